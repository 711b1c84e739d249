"""device="cuda": the built-in kinds' closed form compiled by numba.cuda, run here in numba's CUDA simulator.

numba reads NUMBA_ENABLE_CUDASIM when it is first imported, and this test process has imported
numba already (other tests), so the simulator checks run in a subprocess of their own with the
variable set; the refusals without a GPU run here, with the simulator off.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.cli import main
from robodyn.engine.cuda import batch as cuda_batch
from robodyn.errors import InputError, UnavailableError
from robodyn.sim import batch

SRC = Path(__file__).resolve().parents[1] / "src"
# The CUDA kernel does the CPU kernel's arithmetic term for term; in the simulator both are numba-free
# float64 operations in the same order, so they agree to the bit; 1e-12 is the bound for a real GPU
# (whose fused multiply-adds round differently).
CUDA_VS_CPU_ATOL = 1e-12
# The simulator runs a Python thread per state: small batches keep each test well under a minute.
STATES = 12
DURATION = 0.2  # [s]: 200 steps of dt
DT = 1e-3
SIMULATOR = os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"


def _gpu_here() -> bool:
    """True where numba's CUDA target finds a GPU (or runs its simulator): the refusals cannot be seen there."""
    if SIMULATOR:
        return True
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            from numba import cuda

            return bool(cuda.is_available())
        except Exception:  # no CUDA target at all: no GPU either
            return False


NO_GPU_REASON = "this machine has a CUDA GPU (or runs numba's simulator): the no-GPU refusal cannot happen"


def _simulated(code: str) -> dict:
    """Run ``code`` (which prints one JSON line last) in a subprocess under numba's CUDA simulator."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1", "PYTHONPATH": str(SRC)}
    run = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], env=env, capture_output=True, text=True, timeout=600
    )
    assert run.returncode == 0, run.stderr[-3000:]
    return json.loads(run.stdout.strip().splitlines()[-1])


def bench_gpu(folder: Path, *run_args: str, command: tuple[str, ...] = ()) -> subprocess.CompletedProcess:
    """``bench_gpu.py --prepare folder`` here, then ``--run folder run_args`` in numba's CUDA simulator.

    ``command`` replaces ``python bench_gpu.py --run folder`` (``benchmarks/gpu_session.sh run folder``).
    """
    script = SRC.parent / "benchmarks" / "bench_gpu.py"
    env = {**os.environ, "PYTHONPATH": str(SRC), "PYTHON": sys.executable}
    prepared = subprocess.run(
        [sys.executable, str(script), "--prepare", str(folder)], env=env, capture_output=True, text=True
    )
    assert prepared.returncode == 0, prepared.stderr
    ran = subprocess.run(
        [*(command or (sys.executable, str(script), "--run", str(folder))), *run_args],
        env={**env, "NUMBA_ENABLE_CUDASIM": "1"},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert ran.returncode == 0, ran.stdout[-2000:] + ran.stderr[-2000:]
    return ran


def test_cuda_rollout_equals_cpu_rollout_for_every_built_in_kind():
    out = _simulated(
        f"""
        import json
        import numpy as np
        import robodyn
        from robodyn.sim import batch

        out = {{}}
        for kind in ("pendubot", "cart_pole", "geared_arm"):
            robot = robodyn.load(kind)
            rng = np.random.default_rng(11)
            Q = rng.uniform(-3.0, 3.0, ({STATES}, robot.nv))
            V = rng.uniform(-2.0, 2.0, ({STATES}, robot.nv))
            cpu = batch.rollout(robot, Q, V, duration={DURATION}, dt={DT}, threads=1)
            gpu = batch.rollout(robot, Q, V, duration={DURATION}, dt={DT}, device="cuda")
            out[kind] = {{
                "dq": float(np.max(np.abs(gpu.q - cpu.q))),
                "dv": float(np.max(np.abs(gpu.v - cpu.v))),
                "moved": float(np.max(np.abs(gpu.q - Q))),
                "device": gpu.device, "path": gpu.path, "steps": gpu.steps, "n": int(gpu.q.shape[0]),
            }}
        print(json.dumps(out))
        """
    )
    for kind, got in out.items():
        assert got["device"] == "cuda" and got["path"] == "closed_form", kind
        assert got["n"] == STATES and got["steps"] == round(DURATION / DT), kind
        assert got["moved"] > 1e-3, kind  # the states did move: the comparison is not of two copies of Q
        assert got["dq"] <= CUDA_VS_CPU_ATOL and got["dv"] <= CUDA_VS_CPU_ATOL, (kind, got)


# The GPU kernel (closed form, engine/rk4.py's step) against simulate's Python RK4 on Pinocchio's ABA:
# two exact formulas for the same accelerations in float64, 50 steps from states inside the limits.
CUDA_VS_ABA_RTOL = 1e-10


def test_cuda_rollout_follows_simulate_on_aba_for_every_built_in_kind():
    """An oracle that shares no code with the GPU path: a wrong RK4 step fails here though GPU and CPU agree."""
    out = _simulated(
        """
        import json
        import numpy as np
        import robodyn
        from robodyn.sim import batch

        out = {}
        for kind in ("pendubot", "cart_pole", "geared_arm"):
            robot = robodyn.load(kind)
            rng = np.random.default_rng(7)
            Q = rng.uniform(-0.3, 0.3, (3, robot.nv))
            V = rng.uniform(-0.5, 0.5, (3, robot.nv))
            gpu = batch.rollout(robot, Q, V, duration=0.05, dt=1e-3, device="cuda")
            worst = 0.0
            for q0, v0, q, v in zip(Q, V, gpu.q, gpu.v):
                ref = robodyn.simulate(robot, q0, v0, duration=0.05, dt=1e-3, integrator="rk4", backend="aba")
                scale = max(1.0, float(np.max(np.abs(ref.v[-1]))))
                worst = max(worst, float(np.max(np.abs(q - ref.q[-1])) / scale), float(np.max(np.abs(v - ref.v[-1])) / scale))
            out[kind] = {"worst": worst, "moved": float(np.max(np.abs(gpu.v - V)))}
        print(json.dumps(out))
        """
    )
    for kind, got in out.items():
        assert got["moved"] > 1e-3, kind
        assert got["worst"] <= CUDA_VS_ABA_RTOL, (kind, got)


def test_a_batch_one_block_and_a_bit_long_steps_every_state():
    """130 states need 2 blocks of 128 threads: a grid rounded down to 1 would leave the last 2 unstepped."""
    n = cuda_batch.THREADS_PER_BLOCK + 2
    assert [cuda_batch.blocks_for(k) for k in (0, 1, 128, 129, n, 256, 257)] == [1, 1, 1, 2, 2, 2, 3]
    out = _simulated(
        f"""
        import json
        import numpy as np
        import robodyn
        from robodyn.sim import batch

        robot = robodyn.load("pendubot")
        rng = np.random.default_rng(5)
        Q = rng.uniform(-3.0, 3.0, ({n}, robot.nv))
        V = rng.uniform(-2.0, 2.0, ({n}, robot.nv))
        cpu = batch.rollout(robot, Q, V, duration=0.005, dt={DT}, threads=1)
        gpu = batch.rollout(robot, Q, V, duration=0.005, dt={DT}, device="cuda")
        moved = np.max(np.abs(gpu.q - Q), axis=1)
        print(json.dumps({{"dq": float(np.max(np.abs(gpu.q - cpu.q))), "still": int(np.sum(moved == 0.0)),
                           "n": int(gpu.q.shape[0])}}))
        """
    )
    assert out["n"] == n and out["still"] == 0, out  # every state was stepped
    assert out["dq"] <= CUDA_VS_CPU_ATOL, out


def test_cuda_coordinate_range_is_the_trajectory_range():
    """The kernel's (q_min, q_max) per run are those of the CPU fast path's whole trajectory."""
    out = _simulated(
        f"""
        import json
        import numpy as np
        import robodyn
        from robodyn.engine.cuda import batch as cuda_batch
        from robodyn.sim.fast import FastDynamics

        robot = robodyn.load("cart_pole")
        fast = FastDynamics.from_robot(robot)
        rng = np.random.default_rng(3)
        Q, V = rng.uniform(-2.0, 2.0, (8, 2)), rng.uniform(-3.0, 3.0, (8, 2))
        q, v, lo, hi, wall = cuda_batch.rollout(
            "cart_pole", fast.param_vector, fast.damping, Q, V, dt={DT}, steps={round(DURATION / DT)}
        )
        worst = 0.0
        for k in range(8):
            t = fast.simulate(Q[k], V[k], duration={DURATION}, dt={DT})
            worst = max(worst, float(np.max(np.abs(lo[k] - t.q.min(axis=0)))), float(np.max(np.abs(hi[k] - t.q.max(axis=0)))))
        print(json.dumps({{"worst": worst, "spread": float(np.min(hi - lo)), "wall": wall >= 0.0}}))
        """
    )
    assert out["spread"] > 0.0 and out["wall"]
    assert out["worst"] <= CUDA_VS_CPU_ATOL, out


def test_cuda_sweep_equals_cpu_sweep_with_stops():
    """A cart-pole sweep on the cuda path gives the CPU path's rows; runs that reach the rail's stops go to simulate."""
    out = _simulated(
        """
        import dataclasses, json, tempfile
        import numpy as np
        import robodyn.sweep as sweep
        from robodyn.sweep.chunk import execute

        spec = {
            "model": "cart_pole", "duration": 0.3, "dt": 1e-3, "device": "cuda", "chunk": 6,
            "measure": ["final_state", "energy_drift"],
            "q0": {"slider": [-2.3, 0.0, 2.3], "hinge": [0.5, 3.0]}, "v0": {"slider": [0.0, 4.0]},
        }
        prepared = sweep.prepare(spec, tempfile.mkdtemp())
        cpu_job = dataclasses.replace(prepared.job, device="cpu")
        paths, cpu_paths, worst = [], [], 0.0
        for chunk in prepared.plan.chunks:
            gpu, cpu = execute(chunk, prepared.job), execute(chunk, cpu_job)
            paths += gpu["path"]
            cpu_paths += cpu["path"]
            for key, value in gpu.items():
                if isinstance(value, np.ndarray) and value.dtype.kind == "f":
                    worst = max(worst, float(np.max(np.abs(value - cpu[key]))))
        print(json.dumps({"paths": paths, "cpu_paths": cpu_paths, "worst": worst}))
        """
    )
    assert out["worst"] <= CUDA_VS_CPU_ATOL, out
    assert "simulate" in out["paths"] and "cuda" in out["paths"], out["paths"]  # both kinds of run are here
    assert [p == "simulate" for p in out["paths"]] == [p == "simulate" for p in out["cpu_paths"]]


def test_cuda_module_imports_no_pinocchio():
    code = "import sys, robodyn.engine.cuda.batch; print('pinocchio' in sys.modules, 'numba' in sys.modules)"
    run = subprocess.run(
        [sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": str(SRC)}, capture_output=True, text=True
    )
    assert run.stdout.split() == ["False", "False"], run.stderr


@pytest.mark.skipif(_gpu_here(), reason=NO_GPU_REASON)
def test_no_gpu_is_one_line_unavailable():
    robot = robodyn.load("pendubot")
    with pytest.raises(UnavailableError, match=r"^device cuda: no CUDA GPU found \(numba.cuda.is_available\(\)"):
        batch.rollout(robot, np.zeros((2, 2)), np.zeros((2, 2)), duration=0.01, dt=1e-3, device="cuda")


def test_bad_device_is_an_input_error():
    # (a robot neither the closed form nor the tree path takes: tests/test_cuda_tree.py)
    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match="device 'gpu': expected one of cpu, cuda"):
        batch.rollout(robot, np.zeros((2, 2)), np.zeros((2, 2)), duration=0.01, dt=1e-3, device="gpu")


@pytest.mark.skipif(_gpu_here(), reason=NO_GPU_REASON)
def test_sweep_device_cuda_without_gpu_exits_5_in_one_line(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text('model = "pendubot"\nduration = 0.01\n[q0]\njoint1 = [0.1, 0.2]\n')
    code = main(["sweep", str(path), "--out", str(tmp_path / "out"), "--device", "cuda", "--quiet"])
    err = capsys.readouterr().err
    assert code == 5
    assert err.strip().splitlines() == [
        "robodyn sweep: error: device cuda: no CUDA GPU found (numba.cuda.is_available() is False); "
        "run without --device cuda or on a machine with an NVIDIA GPU"
    ]


def test_cuda_sweep_lyapunov_equals_cpu_sweep():
    """Benettin's twins stepped on the GPU give each run the CPU path's estimate (seeded per run)."""
    out = _simulated(
        """
        import dataclasses, json, tempfile
        import numpy as np
        import robodyn.sweep as sweep
        from robodyn.sweep.chunk import execute

        spec = {
            "model": "pendubot", "duration": 0.3, "dt": 1e-3, "device": "cuda", "chunk": 3, "seed": 5,
            "measure": ["lyapunov", "final_state"], "q0": {"joint1": [0.5, 2.0, 3.0], "joint2": [0.1, -1.0]},
        }
        prepared = sweep.prepare(spec, tempfile.mkdtemp())
        cpu_job = dataclasses.replace(prepared.job, device="cpu")
        gpu, cpu = [], []
        for chunk in prepared.plan.chunks:
            gpu += execute(chunk, prepared.job)["lyapunov"].tolist()
            cpu += execute(chunk, cpu_job)["lyapunov"].tolist()
        print(json.dumps({"gpu": gpu, "cpu": cpu}))
        """
    )
    assert len(out["gpu"]) == 6 and len(set(out["gpu"])) == 6  # six runs, six different exponents
    np.testing.assert_allclose(out["gpu"], out["cpu"], rtol=0, atol=CUDA_VS_CPU_ATOL)


TINY = (
    "--states",
    "4",
    "--steps",
    "20",
    "--chaos-seconds",
    "0.2",
    "--basin-seconds",
    "0.05",
)  # bench_gpu.py --run, in the simulator


LOWER_EVERY_KERNEL = """
import types as pytypes, warnings
warnings.simplefilter("ignore")
from numba import cuda, types
try:
    from numba.cuda import compiler, dispatcher
    compile_cuda = compiler.compile_cuda
except (ImportError, AttributeError):
    print("SKIP")
    raise SystemExit(0)
from robodyn.engine.cuda import batch as cuda_batch
from robodyn.engine.cuda import closed_loop as cuda_closed
from robodyn.engine.cuda import sweep as cuda_sweep
from robodyn.engine.cuda import tree as cuda_tree
# no GPU: a compute capability for the device functions, and numba.cuda without is_available()
dispatcher.get_current_device = lambda: pytypes.SimpleNamespace(compute_capability=(8, 0))
cuda_batch.cuda_module = lambda: cuda
for module in (cuda_batch, cuda_closed, cuda_sweep, cuda_tree):
    module.cuda = cuda
    # numba 0.68's own CUDA target cannot type min/max's *args overload (numba-cuda can): stand-ins here only
    module.min = cuda.jit(device=True)(lambda a, b: a if a < b else b)
    module.max = cuda.jit(device=True)(lambda a, b: a if a > b else b)
f8, f4, i8, u8, i1 = types.float64, types.float32, types.int64, types.uint64, types.int8
A = lambda t, nd: types.Array(t, nd, "C")
kernels = []
for kind in cuda_batch.CUDA_KINDS:
    for name, t in (("float64", f8), ("float32", f4)):
        kernels.append((f"rk4 {kind} {name}", cuda_batch.rk4_kernel(kind, name),
                        (A(t, 1), A(t, 1), i8, A(t, 2), A(t, 2), A(t, 2), A(t, 2), t, i8)))
        kernels.append((f"measures {kind} {name}", cuda_sweep.measures_kernel(kind, name),
                        (A(t, 1), A(f8, 1), A(t, 1), i8, A(f8, 1), A(t, 2), A(t, 2), A(f8, 1), A(i1, 1), t, i8)))
    kernels.append((f"benettin {kind}", cuda_batch.benettin_kernel(kind),
                    (A(f8, 1), A(f8, 1), i8, A(f8, 2), A(f8, 2), A(u8, 1), f8, f8, i8, i8, f8, A(f8, 1))))
    kernels.append((f"twin {kind}", cuda_sweep.twin_kernel(kind),
                    (A(f8, 1), A(f8, 1), i8, A(f8, 1), A(f8, 2), A(f8, 2), A(u8, 1), A(f8, 1), A(i1, 1), A(f8, 1),
                     f8, i8, i8, f8, f8)))
for kind, law in (("pendubot", "lqr"), ("pendubot", "pendubot_energy"), ("cart_pole", "lqr"),
                  ("cart_pole", "cart_pole_energy")):
    kernels.append((f"closed {kind} {law}", cuda_closed.closed_kernel(kind, law),
                    (A(f8, 1), A(f8, 1), A(f8, 1), A(f8, 1), A(f8, 1), f8, A(f8, 2), A(f8, 2), A(f8, 1), f8, f8, i8,
                     A(f8, 2), A(f8, 2), A(f8, 2))))
a2, a3 = A(f8, 2), A(f8, 3)  # the compiled tree's kernel (any robot): itree, ftree, grav, method, tab, ...
kernels.append(("tree", cuda_tree.rollout_kernel(),
                (A(i8, 2), a2, A(f8, 1), i8, a2, f8, i8, a2, a2, a2, a2, a3, a3, a3, i8)))
for name, kernel, args in kernels:
    try:
        size = len(compile_cuda(kernel.py_func, types.void, args, cc=(8, 0)).library.get_llvm_str())
        print(f"{name}: OK {size}")
    except Exception as exc:
        print(f"{name}: FAIL {type(exc).__name__}: {str(exc)[:300]!r}")
"""


def test_every_kernel_types_and_lowers_for_the_real_cuda_target():
    """Every CUDA kernel (each kind's, float64 and float32, Benettin's, the measures', the closed loops', the
    compiled tree's) is typed by numba's real CUDA target and lowered to LLVM IR, with no GPU here.

    The simulator runs kernels as Python, so a construct CUDA cannot compile (an allocation, object mode,
    a type that does not unify) would pass it; this is what a GPU would compile, short of NVVM.
    """
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}
    run = subprocess.run(
        [sys.executable, "-c", LOWER_EVERY_KERNEL],
        env={**env, "PYTHONPATH": str(SRC)},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    if run.stdout.split()[0] == "SKIP":
        pytest.skip("this numba has no numba.cuda.compiler.compile_cuda to type the kernels with")
    lines = run.stdout.strip().splitlines()
    assert len(lines) == 6 * 3 + 4 + 1, lines
    failed = [line for line in lines if ": OK " not in line]
    assert not failed, failed


def test_bench_gpu_prepares_here_and_runs_without_pinocchio(tmp_path):
    """benchmarks/bench_gpu.py: --prepare with robodyn, --run from the arrays alone (in the simulator, a tiny batch)."""
    bench_gpu(tmp_path, "--no-mjx", *TINY)
    result = json.loads((tmp_path / "gpu.json").read_text())
    assert result["pinocchio_imported"] is False
    assert result["run"]["gpu"] == "numba CUDA simulator" and result["run"]["steps"] == 20
    for kind in ("pendubot", "cart_pole"):
        (row,) = result["kinds"][kind]["batches"]
        assert row["states"] == 4 and row["gpu_state_steps_per_s"] > 0
        assert row["gpu_vs_cpu_max_abs_diff"] <= CUDA_VS_CPU_ATOL
    chaos = result["kinds"]["pendubot"]["chaos_map"]
    assert chaos["runs"] == 4 and chaos["nan_runs"] == 0 and chaos["median_exponent_per_s"] > 0
    assert chaos["gpu_vs_cpu_max_abs_diff_per_s"] <= CUDA_VS_CPU_ATOL


def test_bench_gpu_past_its_budget_names_the_sections_it_skipped(tmp_path):
    """--budget 0: the first section runs, every later one is named in gpu.json's "skipped", and gpu.json is written."""
    bench_gpu(tmp_path, "--no-mjx", *TINY, "--budget", "0")
    result = json.loads((tmp_path / "gpu.json").read_text())
    assert [row["states"] for row in result["kinds"]["pendubot"]["batches"]] == [4]
    skipped = [line.split(":")[0] for line in result["skipped"]]
    assert skipped == ["pendubot chaos map", "panda", "cart_pole batches", "pendubot basin map", "cart_pole basin map"]
    assert "panda" not in result and "chaos_map" not in result["kinds"]["pendubot"]


def test_gpu_session_run_leaves_gpu_json_and_its_log_in_out(tmp_path, monkeypatch):
    """benchmarks/gpu_session.sh run: bench_gpu --run with the arguments given, gpu.json and the log copied into $OUT."""
    folder, out = tmp_path / "gpu", tmp_path / "out"
    out.mkdir()
    session = ("bash", str(SRC.parent / "benchmarks" / "gpu_session.sh"), "run", str(folder))
    monkeypatch.setenv("OUT", str(out))  # the device tool's folder that comes back
    bench_gpu(folder, "--no-mjx", *TINY, "--budget", "0", command=session)
    result = json.loads((out / "gpu.json").read_text())
    assert result["run"]["steps"] == 20 and "pendubot chaos map" in result["skipped"][0]
    assert "wrote" in (out / "bench_gpu.log").read_text()


def test_cli_sweep_device_cuda_runs_in_process_into_parquet(tmp_path):
    """robodyn sweep --device cuda end to end in the simulator: no cluster, every chunk written, path cuda."""
    path = tmp_path / "s.toml"
    path.write_text(
        'model = "pendubot"\nduration = 0.05\nchunk = 2\nmeasure = ["final_state", "energy_drift"]\n'
        "[q0]\njoint1 = [0.1, 0.2, 0.3]\n"
    )
    out = tmp_path / "out"
    code = (
        "import sys; from robodyn.cli import main; "
        f"code = main(['sweep', {str(path)!r}, '--out', {str(out)!r}, '--device', 'cuda', '--quiet']); "
        "print('distributed imported:', 'distributed' in sys.modules); sys.exit(code)"
    )
    run = subprocess.run(
        [sys.executable, "-c", code],
        env={**os.environ, "NUMBA_ENABLE_CUDASIM": "1", "PYTHONPATH": str(SRC)},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip().splitlines() == [
        f"3 runs in 2 chunks (2 computed, 0 already written) -> {out / 'results'}",
        "distributed imported: False",  # no Dask cluster: the chunks ran in this process
    ]
    import pyarrow.parquet as pq

    table = pq.read_table(out / "results").sort_by("run").to_pydict()
    assert table["path"] == ["cuda"] * 3 and table["run"] == [0, 1, 2]
    assert all(abs(x) < 1e-6 for x in table["energy_drift"])  # 50 RK4 steps of 1 ms conserve energy closely


@pytest.mark.parametrize("value", ["3", '["cuda"]', '"gpu"'])
def test_sweep_file_device_must_be_cpu_or_cuda(value, tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(f'model = "pendubot"\nduration = 0.01\ndevice = {value}\n')
    assert main(["sweep", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "device must be one of 'cpu', 'cuda', got" in err[0]


def test_device_functions_type_check_in_numbas_cpu_compiler():
    """The simulator runs the kernels as Python; numba's CPU compiler types the same device functions as the GPU's.

    Benettin's device function, compiled by numba.njit here, gives the estimate of
    robodyn.integrators.stability.lyapunov over the CPU fast path's runs.
    """
    import numba

    from robodyn.engine.cuda import batch as cuda_batch
    from robodyn.integrators import twins
    from robodyn.integrators.stability import lyapunov
    from robodyn.sim.fast import FastDynamics

    fast = FastDynamics.from_robot(robodyn.load("pendubot"))
    benettin = cuda_batch._benettin(numba.njit, "pendubot")
    q0, v0, d0, dt, interval, count = np.array([0.5, -1.0]), np.array([0.2, 0.0]), 1e-8, DT, 0.05, 4
    e = twins.direction(9, 4, d0)  # the twin of lyapunov(seed=9)
    got = benettin(
        fast.param_vector, np.zeros(2), 2, *q0, *v0, *e, d0, dt, round(interval / dt), count, count * interval
    )

    def step_run(q, v, T):
        t = fast.simulate(q, v, duration=T, dt=dt)
        return t.q[-1].copy(), t.v[-1].copy()

    want = lyapunov(step_run, q0, v0, duration=count * interval, interval=interval, seed=9).exponent
    assert abs(got - want) <= CUDA_VS_CPU_ATOL, (got, want)
