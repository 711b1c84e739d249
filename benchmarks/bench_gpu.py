"""The built-in kinds' and the Panda's batch rollout on a GPU (numba-cuda) against numba on the CPU's cores and MJX.

Two steps, because the GPU machine has no Pinocchio (its wheels are too big to carry there):

    python benchmarks/bench_gpu.py --prepare bench-out/gpu     # where robodyn is installed
    python benchmarks/bench_gpu.py --run bench-out/gpu         # where numpy and numba-cuda are

``--prepare DIR`` writes ``DIR/models.npz``: each kind's closed-form parameter vector (checked
against Pinocchio's ABA by ``FastDynamics.from_robot``), its damping and degrees of freedom, and
the URDF text MuJoCo reads (geometry stripped, as ``bench_mujoco.py``) with its joint names.

``--run DIR`` imports NumPy, numba and ``robodyn.engine.cuda.batch`` (with ``robodyn.kinds``'s closed
forms; no Pinocchio: the run checks that ``pinocchio`` is not in ``sys.modules``). For the Pendubot
and the cart-pole it runs batches of 2^14 to 2^20 seeded states (``--states N`` for one size),
``--steps`` (1,000) torque-free RK4 steps of 1 ms each, on the GPU (float64, one thread a state,
best of 3) and, up to ``CPU_MAX_STATES``, the same step on all CPU cores (numba ``prange``); it
reports state-steps per second and the largest difference of the final states (the same
arithmetic; a GPU's fused multiply-adds round differently). With ``mujoco.mjx`` importable (and
not ``--no-mjx``) it also runs MJX (float32, ``MJX_STATES`` states) from the same starts and
reports its speed and its difference from the float64 kernel. Each batch also runs the float32 kernel
(the same source, its literals float32) and reports its speed and its error against float64. A
Pendubot chaos map follows, end to end as a ``device = "cuda"`` sweep computes one chunk from arrays
alone (``robodyn.engine.cuda.sweep``, the model's ``DeviceModel`` saved by ``--prepare``): the largest
batch's runs over ``--chaos-seconds`` (20 s), timed part by part (starts and twin streams, the
kernel that steps each run and its Benettin twin in one GPU thread, the twin's direction drawn
there, and computes the measures, the columns, the Parquet file where pyarrow imports), against
the same device functions on the CPU's cores for 1,024 of them.
The Panda (fingers fixed, stops off; ``DIR/panda.npz``, the tree's arrays) follows through
``robodyn.engine.cuda.tree`` (the compiled tree algorithms, one thread a state) for the same batch sizes
and ``min(--steps, 200)`` steps, beside the CPU batch kernel on all cores and MJX float32 for one
size (``benchmarks/_gpu_panda.py``). A swing-up basin map of each built-in kind follows: the
largest batch's starts under the swing-up to LQR (the controller's numbers saved by ``--prepare``,
the law of ``robodyn.engine.torque_laws``) for ``--basin-seconds`` (10 s), the time to balance counted
on the GPU, against the same device function on the CPU's cores for 1,024 of them. Everything goes into
``DIR/gpu.json`` with the GPU's name, written after every section. The sections run in the order of
the issue's goals (the Pendubot against MJX, the chaos map, the Panda, then the cart-pole and the
basin maps); once ``--budget`` seconds (240) are spent the rest are skipped and named there.
Without a GPU, ``--run`` stops in one line (exit 5);
``NUMBA_ENABLE_CUDASIM=1`` runs it in numba's CUDA simulator (use a tiny ``--states``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import sys
import time
from pathlib import Path
from typing import Any

import _gpu_mjx  # MJX's column (benchmarks/ is on sys.path when this script runs)
import _gpu_panda  # the Panda's part
import numpy as np

DT = 1e-3  # [s]
STEPS = 1000
SIZES = tuple(2**k for k in range(14, 21))
KINDS = ("pendubot", "cart_pole")
REPEATS = 3
# Numba on the CPU's cores above this many states would take most of the 5-minute budget (~6e7 state-steps/s).
CPU_MAX_STATES = 2**17
MJX_STATES = 2**17
# The chaos map: Benettin's estimate of the free Pendubot over CHAOS_SECONDS, its twins renormalised every
# CHAOS_INTERVAL (the sweep's LYAPUNOV_INTERVAL), d0 as robodyn.integrators.stability.lyapunov; the CPU
# column on CHAOS_CPU_STATES of the runs (all of them would take minutes).
CHAOS_SECONDS = 20.0
CHAOS_INTERVAL = 0.1
CHAOS_D0 = 1e-8
CHAOS_CPU_STATES = 1024
# The basin map: the swing-up to LQR from the batches' starts over BASIN_SECONDS; the CPU column on
# BASIN_CPU_STATES of the runs.
BASIN_SECONDS = 10.0
BASIN_CPU_STATES = 1024
SEED = 0
# The whole --run stays under the 5 minutes: once this many seconds are spent, the sections left
# are skipped and named in gpu.json ("skipped"), which is written after every section.
BUDGET_S = 240.0
# The starting states: angles anywhere, the cart within its rail, speeds up to 1 rad/s | m/s.
START_RANGE = {"pendubot": (np.pi, np.pi), "cart_pole": (2.0, np.pi)}


def prepare(folder: Path) -> int:
    import robodyn
    from robodyn.sim.fast import FastDynamics
    from robodyn.sweep.cuda_chunk import device_model_of

    folder.mkdir(parents=True, exist_ok=True)
    arrays: dict[str, Any] = {}
    for kind in KINDS:
        robot = robodyn.load(kind)
        fast = FastDynamics.from_robot(robot, kind)  # checked against Pinocchio's ABA on seeded states
        arrays[f"{kind}.params"] = fast.param_vector
        arrays[f"{kind}.damping"] = fast.damping
        arrays[f"{kind}.joints"] = np.array(robot.joint_names)
        arrays[f"{kind}.urdf"] = np.array(_mujoco_text(Path(robot.urdf_path).read_text()))
        arrays |= device_model_of(kind).arrays(f"{kind}.device")  # what a sweep ships to a GPU worker
        arrays |= _prepare_basin(robot, kind, fast)
    np.savez(folder / "models.npz", **arrays)
    what = "closed-form parameters, damping, limits, URDF for MuJoCo"
    print(f"wrote {folder / 'models.npz'}: {', '.join(KINDS)} ({what})")
    print(f"wrote {folder / 'panda.npz'}: {_gpu_panda.prepare(folder)}")
    return 0


def _mujoco_text(urdf: str) -> str:
    """The URDF without geometry, with MuJoCo's compiler options (as bench_mujoco.py)."""
    text = re.sub(r"<(visual|collision)\b.*?</\1>", "", urdf, flags=re.S)
    start = re.search(r"<robot\b[^>]*>", text)
    if start is None:
        raise SystemExit("no <robot> tag in the URDF")
    compiler = (
        '<mujoco><compiler discardvisual="true" fusestatic="false" balanceinertia="false" angle="radian"/></mujoco>'
    )
    return text[: start.end()] + compiler + text[start.end() :]


def starts(kind: str, n: int, nv: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(SEED)
    Q = rng.uniform(-1.0, 1.0, (n, nv)) * np.array(START_RANGE[kind][:nv])
    V = rng.uniform(-1.0, 1.0, (n, nv))
    return Q, V


def run(
    folder: Path,
    *,
    sizes: tuple[int, ...],
    steps: int,
    mjx: bool,
    chaos_seconds: float,
    basin_seconds: float,
    budget: float = BUDGET_S,
) -> int:
    from robodyn.engine.cuda import batch as cuda_batch
    from robodyn.errors import RobodynError

    models = np.load(folder / "models.npz")
    try:
        gpu = cuda_batch.device_name()
    except RobodynError as exc:
        print(f"bench_gpu: error: {exc}", file=sys.stderr)
        return exc.exit_code
    import numba

    facts = {
        "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
        "gpu": gpu,
        "cpu_cores": os.cpu_count(),
        "numba_threads": int(numba.config.NUMBA_NUM_THREADS),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "numba": numba.__version__,
        "simulator": os.environ.get("NUMBA_ENABLE_CUDASIM") == "1",
        "dt_s": DT,
        "steps": steps,
        "command": " ".join(sys.argv),
    }
    print(f"GPU: {gpu}; {steps} RK4 steps of {DT * 1e3:g} ms, float64; budget {budget:g} s")
    results: dict[str, Any] = {"run": facts, "kinds": {kind: {} for kind in KINDS}, "skipped": []}
    path = folder / "gpu.json"
    kinds = results["kinds"]

    def batches(kind: str) -> None:
        kinds[kind]["batches"] = _batches(kind, models, sizes, steps)

    def mjx_of(kind: str) -> None:
        p, b = models[f"{kind}.params"], models[f"{kind}.damping"]
        kinds[kind]["mjx"] = _mjx(kind, models, p, b, min(MJX_STATES, max(sizes)), steps)

    def panda() -> None:
        if (folder / "panda.npz").is_file():  # the Panda: robodyn.engine.cuda.tree (benchmarks/_gpu_panda.py)
            results["panda"] = _gpu_panda.run(folder, sizes=sizes, steps=steps, mjx=mjx)
        else:
            print(f"panda: {folder / 'panda.npz'} is missing (written by --prepare): left out")

    # The goals first (the Pendubot against MJX, the chaos map, the Panda), then the rest.
    sections: list[tuple[str, Any]] = [("pendubot batches", lambda: batches("pendubot"))]
    sections += [("pendubot mjx", lambda: mjx_of("pendubot"))] if mjx else []
    sections += [
        (
            "pendubot chaos map",
            lambda: kinds["pendubot"].update(
                chaos_map=_chaos_map(folder, models, "pendubot", max(sizes), chaos_seconds)
            ),
        ),
        ("panda", panda),
        ("cart_pole batches", lambda: batches("cart_pole")),
    ]
    sections += [("cart_pole mjx", lambda: mjx_of("cart_pole"))] if mjx else []
    if basin_seconds > 0:
        sections += [
            (
                f"{kind} basin map",
                lambda kind=kind: kinds[kind].update(basin_map=_basin(kind, models, max(sizes), basin_seconds)),
            )
            for kind in KINDS
        ]
    start = time.perf_counter()
    results["seconds"] = 0.0
    for i, (name, work) in enumerate(sections):
        spent = time.perf_counter() - start
        if (
            i > 0 and spent > budget
        ):  # the first (the Pendubot's batches) always runs  # what is left is named in gpu.json, not silently dropped
            results["skipped"].append(f"{name}: {spent:.0f} s of the {budget:g} s budget spent before it")
            print(f"{name}: skipped, {spent:.0f} s of the {budget:g} s budget spent")
            continue
        work()
        results["seconds"] = time.perf_counter() - start
        _save(path, results)  # after every section: a run cut short keeps what it measured
    results["pinocchio_imported"] = "pinocchio" in sys.modules
    _save(path, results)
    if results["pinocchio_imported"]:
        raise SystemExit("bench_gpu --run imported pinocchio: it must run from the saved arrays alone")
    print(f"wrote {path} ({results['seconds']:.0f} s)")
    return 0


def _save(path: Path, results: dict[str, Any]) -> None:
    path.write_text(json.dumps(results, indent=2) + "\n")


def _batches(kind: str, models: Any, sizes: tuple[int, ...], steps: int) -> list[dict[str, Any]]:
    """The torque-free batches of one kind: GPU float64 and float32, and the CPU's cores up to CPU_MAX_STATES."""
    from robodyn.engine.cuda import batch as cuda_batch

    p, b = models[f"{kind}.params"], models[f"{kind}.damping"]
    nv = b.size
    rows = []
    for n in sizes:
        Q, V = starts(kind, n, nv)
        wall, out = _best(cuda_batch.rollout, kind, p, b, Q, V, steps)
        row: dict[str, Any] = {"states": n, "gpu_s": wall, "gpu_state_steps_per_s": n * steps / wall}
        line = f"{kind:10s} {n:>8,} states  GPU {n * steps / wall:9.3g} state-steps/s"
        row |= _float32(kind, p, b, Q, V, steps, out)
        line += f"  float32 {row['float32_state_steps_per_s']:9.3g} state-steps/s"
        line += f" (max |diff| from float64 {row['float32_vs_float64_max_abs_diff']:.2g})"
        if n <= CPU_MAX_STATES:
            cpu_wall, cpu = _best(cuda_batch.cpu_rollout, kind, p, b, Q, V, steps)
            diff = max(float(np.max(np.abs(out[0] - cpu[0]))), float(np.max(np.abs(out[1] - cpu[1]))))
            row |= {
                "cpu_s": cpu_wall,
                "cpu_state_steps_per_s": n * steps / cpu_wall,
                "gpu_vs_cpu_max_abs_diff": diff,
            }
            line += f"  CPU {n * steps / cpu_wall:9.3g} state-steps/s  GPU/CPU {cpu_wall / wall:7.3g}x"
            line += f"  max |diff| {diff:.2g} rad | m, rad/s | m/s"
        print(line)
        rows.append(row)
    return rows


def _float32(kind: str, p: np.ndarray, b: np.ndarray, Q: np.ndarray, V: np.ndarray, steps: int, ref: Any) -> dict:
    """The float32 kernel (the same source, literals float32) from the same starts: speed and error against float64."""
    from robodyn.engine.cuda import batch as cuda_batch

    wall, out = float("inf"), None
    for _ in range(REPEATS):
        out = cuda_batch.rollout(kind, p, b, Q, V, dt=DT, steps=steps, precision="float32")
        wall = min(wall, out[-1])
    assert out is not None
    error = np.concatenate([np.abs(out[0] - ref[0]).ravel(), np.abs(out[1] - ref[1]).ravel()])
    return {
        "float32_s": wall,
        "float32_state_steps_per_s": Q.shape[0] * steps / wall,
        "float32_speedup_over_float64": ref[-1] / wall,
        "float32_vs_float64_max_abs_diff": float(np.max(error)),
        "float32_vs_float64_median_abs_diff": float(np.median(error)),
    }


def _chaos_map(folder: Path, models: Any, kind: str, n: int, seconds: float) -> dict[str, Any]:
    """A sweep's chaos map on the GPU end to end, from arrays alone: starts, kernels, columns, written result.

    What ``robodyn sweep --device cuda`` does with one chunk of n runs (measures final_state,
    energy_drift, lyapunov), timed part by part: the starts and each twin's stream (host), the
    measures kernel (each run stepped, its drift and flags on the device), Benettin's kernel
    (each run and its twin, the twin's direction drawn in the thread), the columns (host), and
    the Parquet file (where pyarrow imports). The same device functions on the CPU's cores for
    ``CHAOS_CPU_STATES`` of the runs give the agreement.
    """
    from robodyn.engine.cuda import batch as cuda_batch
    from robodyn.engine.cuda import sweep as cuda_sweep

    model = cuda_sweep.DeviceModel.from_arrays(models, f"{kind}.device")
    joints = [str(j) for j in models[f"{kind}.joints"]]
    names = ("final_state", "energy_drift", "lyapunov")
    steps = round(seconds / DT)
    cuda_sweep.compile_measures(kind, lyapunov=True)
    parts: dict[str, float] = {}
    start = time.perf_counter()
    Q, V = starts(kind, n, model.damping.size)
    runs = np.arange(n, dtype=np.int64)
    streams = cuda_batch.streams_of(SEED, runs)
    parts["starts_s"] = time.perf_counter() - start
    mark = time.perf_counter()
    measured = cuda_sweep.measures(
        model, Q, V, dt=DT, steps=steps, streams=streams, lyapunov_interval=CHAOS_INTERVAL, d0=CHAOS_D0
    )
    parts["device_s"] = time.perf_counter() - mark
    parts["measures_kernel_s"], parts["lyapunov_launch_s"] = measured.kernel_s, measured.lyapunov_s
    mark = time.perf_counter()
    columns: dict[str, Any] = {"run": runs, "path": ["cuda"] * n}
    for j, joint in enumerate(joints):
        columns[f"q0.{joint}"], columns[f"v0.{joint}"] = Q[:, j], V[:, j]
    columns |= cuda_sweep.columns(measured, names, tuple(joints))
    again = measured.again
    parts["columns_s"] = time.perf_counter() - mark
    written = _write_parquet(folder / "chaos.parquet", columns)
    if written is not None:
        parts["parquet_s"] = written
    total = time.perf_counter() - start
    gpu = measured.lyapunov
    assert gpu is not None
    m = min(n, CHAOS_CPU_STATES)
    cuda_sweep.compile_measures(kind, lyapunov=True, cpu=True)
    mark = time.perf_counter()
    cpu = cuda_sweep.measures(
        model, Q[:m], V[:m], dt=DT, steps=steps, streams=streams[:m], lyapunov_interval=CHAOS_INTERVAL,
        d0=CHAOS_D0, cpu=True,
    )  # fmt: skip
    cpu_wall = time.perf_counter() - mark
    assert cpu.lyapunov is not None
    fused = measured.lyapunov_s == 0.0  # one launch stepped each run and its twin (else a run again in Benettin's)
    state_steps = (2 if fused else 3) * steps
    finite = np.isfinite(cpu.lyapunov) & np.isfinite(gpu[:m])
    diff = float(np.max(np.abs(gpu[:m] - cpu.lyapunov)[finite])) if finite.any() else float("nan")
    drift_diff = float(np.nanmax(np.abs(measured.drift[:m] - cpu.drift))) if m else float("nan")
    print(
        f"{kind:10s} chaos map {n:,} runs x {seconds:g} s end to end {total:.3g} s "
        f"(starts {parts['starts_s']:.2g} s, device {parts['device_s']:.3g} s: "
        + (f"one kernel, each run with its twin, {parts['measures_kernel_s']:.3g} s" if fused else
           f"measures kernel {parts['measures_kernel_s']:.3g} s + Lyapunov {parts['lyapunov_launch_s']:.3g} s")
        + f", columns "
        f"{parts['columns_s']:.2g} s" + (f", Parquet {parts['parquet_s']:.2g} s" if written is not None else "")
        + f"); {n * state_steps / parts['device_s']:.3g} state-steps/s; CPU cores "
        f"{m * state_steps / cpu_wall:.3g} state-steps/s; max |diff| of the exponents {diff:.2g} 1/s, "
        f"of the drift {drift_diff:.2g} J; {int(np.isnan(gpu).sum())} NaN, {again.size} runs for simulate"
    )  # fmt: skip
    return {
        "runs": n,
        "seconds": seconds,
        "interval_s": min(CHAOS_INTERVAL, seconds),
        "end_to_end_s": total,
        **parts,
        "parquet": written is not None,
        "one_launch": fused,
        "gpu_s": parts["device_s"],
        "gpu_state_steps_per_s": n * state_steps / parts["device_s"],
        "cpu_runs": m,
        "cpu_s": cpu_wall,
        "cpu_state_steps_per_s": m * state_steps / cpu_wall,
        "gpu_vs_cpu_max_abs_diff_per_s": diff,
        "gpu_vs_cpu_drift_max_abs_diff_J": drift_diff,
        "runs_for_simulate": int(again.size),
        "nan_runs": int(np.isnan(gpu).sum()),
        "median_exponent_per_s": float(np.nanmedian(gpu)) if np.isfinite(gpu).any() else float("nan"),
    }


def _write_parquet(path: Path, columns: dict[str, Any]) -> float | None:
    """Seconds to write the columns as one Parquet file (as the sweep's store does), or None without pyarrow."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        print("pyarrow is not installed here: the chaos map's Parquet file is not written")
        return None
    start = time.perf_counter()
    pq.write_table(pa.table(columns), path)
    return time.perf_counter() - start


def _prepare_basin(robot: Any, kind: str, fast: Any) -> dict[str, Any]:
    """The swing-up to LQR's law and numbers for the basin map (robodyn's controller, packed as the sweep packs it)."""
    import robodyn.control
    from robodyn.control.compiled import law_of
    from robodyn.sim.energy import reference_energy
    from robodyn.sim.simulation import DEFAULT_MAX_ENERGY_GROWTH
    from robodyn.sweep.chunk import upright_of
    from robodyn.sweep.measures import BALANCE_TOL

    found = law_of(robodyn.control.make("swing_up", robot), fast)
    upright = upright_of(robot)
    if found is None or upright is None:
        raise SystemExit(f"no GPU swing-up law for {kind}")
    law, c = found
    return {
        f"{kind}.swing_up.law": np.array(law),
        f"{kind}.swing_up.c": c,
        f"{kind}.upright": upright[0],
        f"{kind}.angular": upright[1].astype(np.float64),
        f"{kind}.balance_tol": np.array(BALANCE_TOL),
        f"{kind}.potential_offset": np.array(fast.potential_offset),
        f"{kind}.energy_growth": np.array(DEFAULT_MAX_ENERGY_GROWTH),
        f"{kind}.reference_energy": np.array(reference_energy(robot)),
        f"{kind}.lower": np.asarray(robot.model.lowerPositionLimit, dtype=np.float64),
        f"{kind}.upper": np.asarray(robot.model.upperPositionLimit, dtype=np.float64),
    }


def _basin(kind: str, models: Any, n: int, seconds: float) -> dict[str, Any]:
    """The swing-up basin map of n runs on the GPU (time to balance on the device) against the CPU's cores."""
    from robodyn.engine.cuda import closed_loop as cuda_closed
    from robodyn.kinds.catalog import closed_form

    p, b = models[f"{kind}.params"], np.zeros(2)
    b[: models[f"{kind}.damping"].size] = models[f"{kind}.damping"]
    law, c = str(models[f"{kind}.swing_up.law"]), models[f"{kind}.swing_up.c"]
    offset = float(models[f"{kind}.potential_offset"])
    Q, V = starts(kind, n, 2)
    form = closed_form(kind)
    m11, m12, m22 = form.mass(p, Q[:, 0], Q[:, 1])
    K0 = 0.5 * (m11 * V[:, 0] ** 2 + 2.0 * m12 * V[:, 0] * V[:, 1] + m22 * V[:, 1] ** 2)
    P0 = form.potential(p, Q[:, 0], Q[:, 1]) + offset
    bound = float(models[f"{kind}.energy_growth"]) * np.maximum(
        K0 + np.abs(P0), float(models[f"{kind}.reference_energy"])
    )
    steps = round(seconds / DT)
    args = {"upright": models[f"{kind}.upright"], "angular": models[f"{kind}.angular"], "offset": offset, "dt": DT}
    args["tol"] = float(models[f"{kind}.balance_tol"])
    start = time.perf_counter()
    q, v, q_min, q_max, balance, diverged, wall = cuda_closed.closed_loop(
        kind, law, p, b, c, Q, V, bound=bound, steps=steps, **args
    )
    total = time.perf_counter() - start  # the first call compiles: the kernel's own time is ``wall``
    m = min(n, BASIN_CPU_STATES)
    cpu = cuda_closed.closed_loop(kind, law, p, b, c, Q[:m], V[:m], bound=bound[:m], steps=steps, cpu=True, **args)
    diff = max(
        float(np.nanmax(np.abs(q[:m] - cpu[0]), initial=0.0)), float(np.nanmax(np.abs(v[:m] - cpu[1]), initial=0.0))
    )
    same_balance = bool(np.array_equal(balance[:m], cpu[4], equal_nan=True))
    rail = int(np.sum(np.any((q_min < models[f"{kind}.lower"]) | (q_max > models[f"{kind}.upper"]), axis=1)))
    balanced = np.isfinite(balance) & ~diverged
    print(
        f"{kind:10s} swing-up basin map {n:,} runs x {seconds:g} s: GPU kernel {wall:.3g} s "
        f"({n * steps / wall:.3g} state-steps/s), CPU cores {m * steps / cpu[-1]:.3g} state-steps/s, "
        f"{int(balanced.sum()):,} balanced by the end, {int(diverged.sum())} diverged, "
        f"{rail} reached a position limit, "
        f"max |diff| {diff:.2g} rad | m, rad/s | m/s, time to balance {'equal' if same_balance else 'DIFFERENT'}"
    )
    return {
        "runs": n,
        "seconds": seconds,
        "controller": "swing_up",
        "law": law,
        "gpu_s": wall,
        "gpu_with_copies_and_compile_s": total,
        "gpu_state_steps_per_s": n * steps / wall,
        "cpu_runs": m,
        "cpu_s": cpu[-1],
        "cpu_state_steps_per_s": m * steps / cpu[-1],
        "gpu_vs_cpu_max_abs_diff": diff,
        "gpu_vs_cpu_same_time_to_balance": same_balance,
        "balanced_runs": int(balanced.sum()),
        "median_time_to_balance_s": float(np.median(balance[balanced])) if balanced.any() else float("nan"),
        "diverged_runs": int(diverged.sum()),
        "runs_reaching_a_position_limit": rail,
    }


def _best(rollout: Any, kind: str, p: np.ndarray, b: np.ndarray, Q: np.ndarray, V: np.ndarray, steps: int) -> Any:
    """Best kernel wall time [s] of ``REPEATS`` calls (the rollout's own timing: no copies, no compilation)."""
    best, out = float("inf"), None
    for _ in range(REPEATS):
        out = rollout(kind, p, b, Q, V, dt=DT, steps=steps)
        best = min(best, out[-1])
    return best, out


def _mjx(kind: str, models: Any, p: np.ndarray, b: np.ndarray, n: int, steps: int) -> dict[str, Any]:
    """MJX (float32) from the same starts as the kind's float64 kernel (benchmarks/_gpu_mjx.py)."""
    from robodyn.engine.cuda import batch as cuda_batch

    Q, V = starts(kind, n, b.size)

    def reference(Q: np.ndarray, V: np.ndarray) -> Any:
        return cuda_batch.rollout(kind, p, b, Q, V, dt=DT, steps=steps)

    urdf, joints = str(models[f"{kind}.urdf"]), models[f"{kind}.joints"]
    return _gpu_mjx.run(kind, urdf, joints, Q, V, steps=steps, dt=DT, reference=reference)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--prepare", type=Path, metavar="DIR", help="write DIR/models.npz (needs robodyn installed)")
    what.add_argument("--run", type=Path, metavar="DIR", help="run the batches from DIR/models.npz (no Pinocchio)")
    parser.add_argument("--states", type=int, help="one batch of this many states instead of 2^14 to 2^20")
    parser.add_argument("--steps", type=int, default=STEPS, help=f"RK4 steps of {DT * 1e3:g} ms (default {STEPS})")
    parser.add_argument("--no-mjx", action="store_true", help="leave MJX out even where it imports")
    parser.add_argument(
        "--chaos-seconds",
        type=float,
        default=CHAOS_SECONDS,
        help=f"the chaos map's duration [s] (default {CHAOS_SECONDS:g}; its runs: the largest batch)",
    )
    parser.add_argument(
        "--basin-seconds",
        type=float,
        default=BASIN_SECONDS,
        help=f"the swing-up basin map's duration [s] (default {BASIN_SECONDS:g}; 0 leaves it out)",
    )
    parser.add_argument(
        "--budget",
        type=float,
        default=BUDGET_S,
        help=f"seconds after which the sections left are skipped and named (default {BUDGET_S:g})",
    )
    args = parser.parse_args()
    if args.prepare is not None:
        return prepare(args.prepare)
    if (args.states is not None and args.states < 1) or args.steps < 1 or not args.chaos_seconds >= DT:
        parser.error(f"--states and --steps must be >= 1, --chaos-seconds >= {DT:g}")
    if not args.basin_seconds >= 0:
        parser.error("--basin-seconds must be >= 0")
    if not (args.run / "models.npz").is_file():
        print(
            f"bench_gpu: error: {args.run / 'models.npz'} is missing; run --prepare {args.run} first", file=sys.stderr
        )
        return 2
    sizes = (args.states,) if args.states is not None else SIZES
    return run(
        args.run,
        sizes=sizes,
        steps=args.steps,
        mjx=not args.no_mjx,
        chaos_seconds=args.chaos_seconds,
        basin_seconds=args.basin_seconds,
        budget=args.budget,
    )


if __name__ == "__main__":
    sys.exit(main())
