"""device="cuda" with a controller: the LQR and the swing-up to LQR on the GPU, run here in numba's CUDA simulator.

numba reads NUMBA_ENABLE_CUDASIM when it is first imported, so the simulator runs in a subprocess of
its own (as in tests/test_cuda_batch.py).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from robodyn.cli import main
from tests.test_cuda_batch import CUDA_VS_CPU_ATOL, SRC, _simulated, bench_gpu

UP = np.pi / 2
# Starts near the upright (some balance within the run, one after leaving the band) and hanging ones
# (the swing-up's energy law): 6 to 8 runs of 0.4 s.
STARTS = {
    "pendubot": {"joint1": [UP - 0.06, UP - 0.04, -UP], "joint2": [0.06, 0.1]},
    "cart_pole": {"slider": [0.0, 0.3], "hinge": [0.08, -0.2, 0.5, np.pi]},
}


def _gpu_and_cpu(spec: dict) -> dict:
    """Every chunk of the sweep ``spec`` on device cuda and device cpu: paths, float columns, worst difference."""
    return _simulated(
        f"""
        import dataclasses, json, math, tempfile
        import numpy as np
        import robodyn.sweep as sweep
        from robodyn.sweep.chunk import execute

        prepared = sweep.prepare({spec!r}, tempfile.mkdtemp())
        cpu_job = dataclasses.replace(prepared.job, device="cpu")
        out = {{"paths": [], "cpu_paths": [], "worst": 0.0, "balance": [], "cpu_balance": []}}
        for chunk in prepared.plan.chunks:
            gpu, cpu = execute(chunk, prepared.job), execute(chunk, cpu_job)
            out["paths"] += gpu["path"]
            out["cpu_paths"] += cpu["path"]
            for key, value in gpu.items():
                if isinstance(value, np.ndarray) and value.dtype.kind == "f" and key not in ("time_to_balance", "wall_time"):
                    assert np.array_equal(np.isnan(value), np.isnan(cpu[key])), key
                    out["worst"] = max(out["worst"], float(np.nanmax(np.abs(value - cpu[key]), initial=0.0)))
            out["balance"] += [None if math.isnan(x) else x for x in gpu["time_to_balance"]]
            out["cpu_balance"] += [None if math.isnan(x) else x for x in cpu["time_to_balance"]]
            out["walls"] = out.get("walls", []) + gpu.get("wall_time", np.zeros(0)).tolist()
        print(json.dumps(out))
        """
    )


@pytest.mark.parametrize("kind", ["pendubot", "cart_pole"])
@pytest.mark.parametrize("controller", ["lqr", "swing_up"])
def test_cuda_closed_loop_equals_the_cpu_closed_loop(kind, controller):
    spec = {"model": kind, "duration": 0.4, "dt": 1e-3, "device": "cuda", "chunk": 8, "controller": controller}
    spec |= {"measure": ["final_state", "energy_drift", "time_to_balance", "wall_time"], "q0": STARTS[kind]}
    out = _gpu_and_cpu(spec)
    assert set(out["paths"]) == {"cuda"} and set(out["cpu_paths"]) == {"closed_loop"}
    assert out["worst"] <= CUDA_VS_CPU_ATOL, out
    assert out["balance"] == out["cpu_balance"]  # counted on the device, to the step
    assert any(x is not None and x > 0 for x in out["balance"]), out["balance"]  # some runs balance on the way
    assert None in out["balance"]  # and some do not by the end
    assert len(out["walls"]) == len(out["paths"]) and min(out["walls"]) > 0  # the kernel's time, shared by its runs


def test_cuda_closed_loop_hands_rail_runs_to_simulate():
    """The cart driven into its +2.4 m stop under the LQR: recomputed by simulate, as on the CPU path."""
    spec = {"model": "cart_pole", "duration": 0.5, "dt": 1e-3, "device": "cuda", "controller": "lqr"}
    spec |= {"measure": ["final_state", "time_to_balance"], "q0": {"slider": [0.0, 2.3]}, "v0": {"slider": 3.0}}
    out = _gpu_and_cpu(spec)
    assert out["paths"] == ["cuda", "simulate"] and out["cpu_paths"] == ["closed_loop", "simulate"]
    assert out["worst"] <= CUDA_VS_CPU_ATOL and out["balance"] == out["cpu_balance"]


def test_cuda_closed_loop_with_joint_damping_equals_the_cpu_closed_loop(tmp_path):
    """A damped Pendubot: the damping's power enters the device's energy ledger and its PFL, as on the CPU."""
    urdf = (SRC.parent / "models" / "pendubot.urdf").read_text()
    assert urdf.count('damping="0"') == 2
    model = tmp_path / "pendubot.urdf"
    model.write_text(urdf.replace('damping="0"', 'damping="0.02"'))
    (tmp_path / "pendubot.srdf").write_text((SRC.parent / "models" / "pendubot.srdf").read_text())  # joint2 passive
    spec = {"model": str(model), "duration": 0.4, "dt": 1e-3, "device": "cuda", "controller": "swing_up"}
    spec |= {"measure": ["final_state", "energy_drift", "time_to_balance"], "q0": STARTS["pendubot"]}
    out = _gpu_and_cpu(spec)
    assert set(out["paths"]) == {"cuda"} and set(out["cpu_paths"]) == {"closed_loop"}
    assert out["worst"] <= CUDA_VS_CPU_ATOL and out["balance"] == out["cpu_balance"], out


def test_cli_sweep_device_cuda_with_swing_up_into_parquet(tmp_path):
    """robodyn sweep --device cuda with controller = "swing_up", end to end in the simulator."""
    path = tmp_path / "s.toml"
    path.write_text(
        'model = "pendubot"\nduration = 0.1\nchunk = 2\ncontroller = "swing_up"\n'
        'measure = ["final_state", "time_to_balance"]\n'
        f"[q0]\njoint1 = [{UP - 0.04}, {-UP}]\njoint2 = [0.06]\n"
    )
    out = tmp_path / "out"
    argv = ["sweep", str(path), "--out", str(out), "--device", "cuda", "--quiet"]
    run = subprocess.run(
        [sys.executable, "-c", f"import sys; from robodyn.cli import main; sys.exit(main({argv!r}))"],
        env={**os.environ, "NUMBA_ENABLE_CUDASIM": "1", "PYTHONPATH": str(SRC)},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    import pyarrow.parquet as pq

    table = pq.read_table(out / "results").sort_by("run").to_pydict()
    assert table["path"] == ["cuda", "cuda"] and table["controller"] == ["swing_up"] * 2
    assert table["time_to_balance"][0] > 0 and np.isnan(table["time_to_balance"][1])


def test_sweep_device_cuda_refuses_a_controller_file_before_any_work(tmp_path, capsys):
    (tmp_path / "pd.py").write_text("def make(robot):\n    return lambda t, q, v: -q[:1]\n")
    path = tmp_path / "s.toml"
    path.write_text(
        'model = "pendubot"\nduration = 0.01\ncontroller = "pd.py"\ndevice = "cuda"\n[q0]\njoint1 = [0.1]\n'
    )
    code = main(["sweep", str(path), "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].endswith(
        "s.toml: device cuda: the controllers lqr and swing_up of the cart-pole and the Pendubot "
        "only (a controller file, a scene's constant torque or PD law runs with device cpu)"
    )
    assert not (tmp_path / "out" / "results").exists()


def test_bench_gpu_basin_map_runs_from_the_arrays_alone(tmp_path):
    """benchmarks/bench_gpu.py's swing-up basin map: --prepare packs the controller, --run needs no Pinocchio."""
    tiny = ["--states", "3", "--steps", "2", "--chaos-seconds", "0.01", "--basin-seconds", "0.2", "--no-mjx"]
    bench_gpu(tmp_path, *tiny)
    result = json.loads((tmp_path / "gpu.json").read_text())
    assert result["pinocchio_imported"] is False
    for kind, law in (("pendubot", "pendubot_energy"), ("cart_pole", "cart_pole_energy")):
        basin = result["kinds"][kind]["basin_map"]
        assert basin["runs"] == basin["cpu_runs"] == 3 and basin["law"] == law and basin["seconds"] == 0.2
        assert basin["gpu_vs_cpu_max_abs_diff"] <= CUDA_VS_CPU_ATOL and basin["gpu_vs_cpu_same_time_to_balance"]
        assert basin["gpu_state_steps_per_s"] > 0 and basin["diverged_runs"] == 0


def test_rollout_closed_loop_backend_cuda_equals_backend_fast():
    """robodyn.control.rollout.closed_loop(controller, backend="cuda") against "fast" with the controller's batch form."""
    out = _simulated(
        """
        import json
        import numpy as np
        import robodyn, robodyn.control
        from robodyn.control import rollout
        from robodyn.sim.fast import FastDynamics
        from robodyn.sweep.policy import batch_policy

        out = {}
        for kind, name in (("pendubot", "swing_up"), ("cart_pole", "lqr")):
            robot = robodyn.load(kind)
            controller = robodyn.control.make(name, robot)
            rng = np.random.default_rng(5)
            q0, v0 = rng.uniform(-1.0, 1.0, (5, 2)), rng.uniform(-1.0, 1.0, (5, 2))
            gpu = rollout.closed_loop(robot, controller, q0, v0, duration=0.2, dt=1e-3, backend="cuda")
            policy = batch_policy(controller, FastDynamics.from_robot(robot))
            cpu = rollout.closed_loop(robot, policy, q0, v0, duration=0.2, dt=1e-3, backend="fast")
            worst = max(float(np.max(np.abs(getattr(gpu, k) - getattr(cpu, k)))) for k in ("q", "v", "q_min", "q_max"))
            spread = float(np.max(np.abs(gpu.q - q0)))
            out[kind] = {"worst": worst, "spread": spread, "backend": gpu.backend, "steps": gpu.steps}
        print(json.dumps(out))
        """
    )
    for kind in ("pendubot", "cart_pole"):
        assert out[kind]["backend"] == "cuda" and out[kind]["steps"] == 200
        assert out[kind]["worst"] <= CUDA_VS_CPU_ATOL and out[kind]["spread"] > 1e-3, out


def test_rollout_backend_cuda_refuses_a_policy_it_has_no_law_for():
    import robodyn
    from robodyn.control import rollout
    from robodyn.errors import InputError

    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match="backend 'cuda' runs the controllers robodyn.control.make"):
        rollout.closed_loop(robot, lambda q, v: np.zeros((q.shape[0], 1)), np.zeros((1, 2)), np.zeros((1, 2)),
                            duration=0.01, dt=1e-3, backend="cuda")  # fmt: skip
