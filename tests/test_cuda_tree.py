"""device="cuda" for any robot the compiled tree path takes (engine/cuda/tree.py), run here in numba's CUDA simulator.

The CUDA kernel is the CPU batch path's kernels (tree_kernels, tree_flyer, tree_body, tree_steps)
rebuilt over their device versions; in the simulator both are float64 operations in the same order,
so the two paths agree to the bit, and CUDA_VS_CPU_ATOL (1e-12) is the issue's bound for a real GPU.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numba
import numpy as np
import pytest

import robodyn
from robodyn.engine.cuda import tree as cuda_tree
from robodyn.errors import AssumptionError, InputError
from robodyn.sim import batch, tree
from tests.test_cuda_batch import CUDA_VS_CPU_ATOL, SRC, _simulated

# The simulator runs every kernel as Python, a thread a state: a few states and steps keep each test
# under a minute here (the Panda's ABA is a few ms of Python; Talos's 32 joints about four times that).
DT = 1e-3


def test_no_rebuilt_kernel_still_calls_a_cpu_kernel():
    """Every callee of every rebuilt function is its device version: none is a numba CPU dispatcher."""
    made = cuda_tree.device_functions(lambda f: f)  # the identity: the plain rebuilt Python functions
    called = set()
    for name, function in made.items():
        for callee in function.__code__.co_names:
            value = function.__globals__.get(callee)
            assert not isinstance(value, numba.core.dispatcher.Dispatcher), f"{name} calls the CPU kernel {callee}"
            if callee in made:
                assert value is made[callee], f"{name} calls another {callee} than the one built here"
                called.add(callee)
    # the whole chain under step is reached: each kernel is called by another one (step by the CUDA kernel)
    assert called == set(made) - {"step"}


def _compare(robot_code: str, integrator: str, states: int, steps: int) -> dict:
    return _simulated(
        f"""
        import json
        import numpy as np
        import robodyn
        from robodyn.sim import batch

        robot = {robot_code}
        robot.model.damping[:] = 0.0  # the batch path is lossless
        robot.model.friction[:] = 0.0
        rng = np.random.default_rng(7)
        lo, hi = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
        Q = lo + (hi - lo) * rng.uniform(0.2, 0.8, ({states}, robot.nq))  # inside the limits: no stop in the way
        V = rng.uniform(-1.0, 1.0, ({states}, robot.nv))
        kw = dict(duration={steps} * {DT}, dt={DT}, integrator="{integrator}")
        cpu = batch.rollout(robot, Q, V, threads=1, **kw)
        gpu = batch.rollout(robot, Q, V, device="cuda", **kw)
        moved = float(np.max(np.abs(cpu.q - Q)))
        dq, dv = float(np.max(np.abs(gpu.q - cpu.q))), float(np.max(np.abs(gpu.v - cpu.v)))
        print(json.dumps({{"dq": dq, "dv": dv, "moved": moved, "path": gpu.path, "device": gpu.device,
                          "evaluations": [cpu.evaluations, gpu.evaluations]}}))
        """
    )


@pytest.mark.parametrize(("integrator", "states", "steps"), [("rk4", 4, 100), ("heun", 2, 50)])
def test_panda_on_cuda_equals_the_cpu_batch_path(integrator, states, steps):
    out = _compare('robodyn.load("panda")', integrator, states, steps)
    assert out["path"] == "tree" and out["device"] == "cuda"
    assert out["moved"] > 1e-3  # the arm fell: the comparison is about motion, not a state at rest
    assert out["dq"] <= CUDA_VS_CPU_ATOL and out["dv"] <= CUDA_VS_CPU_ATOL
    assert out["evaluations"][0] == out["evaluations"][1]


def test_talos_with_a_fixed_base_on_cuda_equals_the_cpu_batch_path():
    out = _compare('robodyn.load("talos")', "rk4", 2, 50)
    assert out["path"] == "tree" and out["moved"] > 1e-4
    assert out["dq"] <= CUDA_VS_CPU_ATOL and out["dv"] <= CUDA_VS_CPU_ATOL


@pytest.mark.parametrize("passes", ["world axes", "joint axes"])
def test_a_free_flyer_on_cuda_equals_the_cpu_kernel_and_its_range_is_the_steps_range(passes):
    """The Panda on a free-flyer base (q 16, v 15) through cuda_tree.rollout against tree_steps.batch_rollout.

    batch.rollout takes nq == nv only; the kernels take the free flyer, so the module is compared with
    the CPU kernel itself, stepped one step a call to record each coordinate's range on the way. With
    the ABA's passes in each joint's axes (the model's choice where world axes fail the check) too.
    """
    out = _simulated(
        f"""
        import json
        import numpy as np
        import robodyn
        from robodyn.sim import tree
        from robodyn.engine.cuda import tree as cuda_tree

        robot = robodyn.load("panda", free_flyer=True)
        t = tree.compiled_of(robot).tree
        if "{passes}" == "joint axes":
            t = t.with_local_passes()
        assert t.local == ("{passes}" == "joint axes")
        k = tree.kernels()
        rng = np.random.default_rng(3)
        n, steps = 2, 60
        Q = np.tile(robot.neutral(), (n, 1))
        Q[:, 3:7] = rng.normal(size=(n, 4))
        Q[:, 3:7] /= np.linalg.norm(Q[:, 3:7], axis=1, keepdims=True)
        Q[:, 7:14] += rng.uniform(-0.5, 0.5, (n, 7))
        V = rng.uniform(-1.0, 1.0, (n, robot.nv))
        forces, springs = np.zeros((4, robot.nv)), np.zeros((4, 0))
        forces[3, 0] = 1.0
        q, v = Q.copy(), V.copy()
        lo, hi = Q.copy(), Q.copy()
        for _ in range(steps):
            k.batch_rollout(t.itree, t.ftree, t.grav, t.flyer, 1, np.zeros((6, 4)), {DT}, 1, q, v, forces, springs,
                            np.array([0, n]))
            lo, hi = np.minimum(lo, q), np.maximum(hi, q)
        other = t.ftree.copy()  # the other passes' run on the CPU: the GPU must follow the model's choice
        other[:, -1] = 1.0 - other[:, -1]
        qo, vo = Q.copy(), V.copy()
        k.batch_rollout(t.itree, other, t.grav, t.flyer, 1, np.zeros((6, 4)), {DT}, steps, qo, vo, forces, springs,
                        np.array([0, n]))
        gq, gv, glo, ghi, wall = cuda_tree.rollout(t.itree, t.ftree, t.grav, Q, V, dt={DT}, steps=steps)
        print(json.dumps({{
            "shape": list(gq.shape) + list(gv.shape),
            "dq": float(np.max(np.abs(gq - q))), "dv": float(np.max(np.abs(gv - v))),
            "dlo": float(np.max(np.abs(glo - lo))), "dhi": float(np.max(np.abs(ghi - hi))),
            "other": float(max(np.max(np.abs(qo - q)), np.max(np.abs(vo - v)))),
            "fell": float(q[0, 2] - Q[0, 2]), "wall": wall,
        }}))
        """
    )
    assert out["shape"] == [2, 16, 2, 15]
    assert out["fell"] < -1e-3  # the base fell under gravity
    for key in ("dq", "dv", "dlo", "dhi"):
        assert out[key] <= CUDA_VS_CPU_ATOL, key
    # the other passes round otherwise (by less than CUDA_VS_CPU_ATOL on the Panda); the simulator is exact
    assert out["other"] > 0 and max(out["dq"], out["dv"]) < out["other"]
    assert out["wall"] > 0


def test_a_batch_split_into_launches_equals_one_launch_and_the_cpu_batch_path():
    """With the workspace bound shrunk to one block of threads, 300 states run in three launches over one workspace."""
    out = _simulated(
        f"""
        import json
        import numpy as np
        import robodyn
        from robodyn.sim import tree
        from robodyn.engine.cuda import tree as cuda_tree

        robot = robodyn.load("double_pendulum")
        t = tree.compiled_of(robot).tree
        k = tree.kernels()
        rng = np.random.default_rng(5)
        n, steps = 300, 3
        Q, V = rng.uniform(-3.0, 3.0, (n, 2)), rng.uniform(-1.0, 1.0, (n, 2))
        forces, springs = np.zeros((4, 2)), np.zeros((4, 0))
        forces[3, 0] = 1.0
        q, v = Q.copy(), V.copy()
        k.batch_rollout(t.itree, t.ftree, t.grav, t.flyer, 1, np.zeros((6, 4)), {DT}, steps, q, v, forces, springs,
                        np.array([0, n]))
        cuda_tree.WORKSPACE_BYTES = cuda_tree.bytes_per_state(2, 2, 2)  # one state fits: a block a launch
        size = cuda_tree.launch_size(n, 2, 2, 2)
        gq, gv, lo, hi, wall = cuda_tree.rollout(t.itree, t.ftree, t.grav, Q, V, dt={DT}, steps=steps)
        print(json.dumps({{"size": size, "dq": float(np.max(np.abs(gq - q))), "dv": float(np.max(np.abs(gv - v))),
                          "inside": bool(np.all(lo <= gq) and np.all(gq <= hi) and np.all(lo <= Q) and np.all(Q <= hi))}}))
        """
    )
    assert out["size"] == 128  # three launches: 128, 128, 44 states
    assert out["dq"] <= CUDA_VS_CPU_ATOL and out["dv"] <= CUDA_VS_CPU_ATOL and out["inside"]


def test_a_launch_holds_whole_blocks_of_threads_within_the_workspace_bound():
    per_state = cuda_tree.bytes_per_state(7, 9, 9)
    assert per_state == 8 * (7 * 139 + 17 * 11 + 8 * 11)
    assert cuda_tree.launch_size(10, 7, 9, 9) == 10  # a small batch: one launch of all of it
    size = cuda_tree.launch_size(2**20, 7, 9, 9)
    assert size % cuda_tree.THREADS_PER_BLOCK == 0 and size * per_state <= cuda_tree.WORKSPACE_BYTES


def test_a_robot_neither_path_takes_is_one_input_error(monkeypatch):
    robot = robodyn.load("double_pendulum")  # no built-in kind: the tree path, refused here by a failing check
    robot.model.damping[:] = 0.0
    robot.model.friction[:] = 0.0

    def refuse(_robot):
        raise AssumptionError("the compiled ABA differs from Pinocchio's by 1e-3")

    monkeypatch.setattr(tree, "compiled_of", refuse)
    with pytest.raises(InputError, match=r"device cuda takes the built-in kinds .* this one is neither: the compiled"):
        batch.rollout(robot, np.zeros((2, 2)), np.zeros((2, 2)), duration=0.01, dt=1e-3, device="cuda")


# A slider carrying a two-link arm: no built-in kind, lossless, the slider's travel limited to +-0.3 m.
SLIDER_ARM_URDF = """<?xml version="1.0"?>
<robot name="slider_arm">
  <link name="base"/>
  <link name="carriage"><inertial><origin xyz="0 0 0"/><mass value="2.0"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="upper"><inertial><origin xyz="0 0 -0.2"/><mass value="0.7"/>
    <inertia ixx="0.005" iyy="0.005" izz="0.001" ixy="0.0002" ixz="0" iyz="0"/></inertial></link>
  <link name="lower"><inertial><origin xyz="0.01 0 -0.15"/><mass value="0.4"/>
    <inertia ixx="0.003" iyy="0.003" izz="0.0008" ixy="0" ixz="0.0001" iyz="0"/></inertial></link>
  <joint name="slider" type="prismatic"><parent link="base"/><child link="carriage"/>
    <axis xyz="1 0 0"/><limit lower="-0.3" upper="0.3" effort="10" velocity="10"/></joint>
  <joint name="shoulder" type="revolute"><parent link="carriage"/><child link="upper"/>
    <axis xyz="0 1 0"/><limit lower="-100" upper="100" effort="10" velocity="10"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/>
    <origin xyz="0 0 -0.4"/><axis xyz="0.3 0.9 0.1"/><limit lower="-100" upper="100" effort="10" velocity="10"/></joint>
</robot>
"""


def test_a_tree_robot_sweep_on_cuda_gives_the_cpu_rows_and_hands_stopped_runs_to_simulate(tmp_path):
    """device = "cuda" for a robot of no built-in kind: final states and energy drifts as the CPU's rows.

    The CPU sweep runs this robot (finite limits) through simulate, run by run; on cuda the runs whose
    slider reached its stop within 0.2 s are handed to simulate too, the others stay on the GPU's rows.
    """
    urdf = tmp_path / "slider_arm.urdf"
    urdf.write_text(SLIDER_ARM_URDF)
    out = _simulated(
        f"""
        import dataclasses, json, tempfile
        import numpy as np
        import robodyn.sweep as sweep
        from robodyn.sweep.chunk import execute

        spec = {{
            "model": {str(urdf)!r}, "duration": 0.2, "dt": {DT}, "device": "cuda", "chunk": 4,
            "measure": ["final_state", "energy_drift"],
            "q0": {{"slider": [-0.28, 0.0], "shoulder": [0.5, 2.0]}}, "v0": {{"slider": [-1.0, 0.5]}},
        }}
        prepared = sweep.prepare(spec, tempfile.mkdtemp())
        cpu_job = dataclasses.replace(prepared.job, device="cpu")
        paths, worst = [], 0.0
        for chunk in prepared.plan.chunks:
            gpu, cpu = execute(chunk, prepared.job), execute(chunk, cpu_job)
            paths += gpu["path"]
            for key, value in gpu.items():
                if isinstance(value, np.ndarray) and value.dtype.kind == "f":
                    worst = max(worst, float(np.max(np.abs(value - cpu[key]))))
        print(json.dumps({{"paths": paths, "worst": worst}}))
        """
    )
    assert out["worst"] <= CUDA_VS_CPU_ATOL, out
    assert len(out["paths"]) == 8
    assert "simulate" in out["paths"] and "cuda" in out["paths"], out["paths"]  # both kinds of run are here


def test_the_cuda_sweep_refuses_what_the_tree_path_cannot_compute(tmp_path):
    from robodyn.sweep.cuda_chunk import refusal as cuda_refusal

    lossy = "double_pendulum"  # no built-in kind, with joint damping
    assert cuda_refusal(lossy, "rk4", None, ("final_state",)) == (
        "lossless runs only; the model has joint damping or friction"
    )
    assert cuda_refusal(lossy, "rk45", None, ("final_state",)).startswith("integrator rk4, heun, euler only")
    urdf = tmp_path / "slider_arm.urdf"
    urdf.write_text(SLIDER_ARM_URDF)
    assert cuda_refusal(str(urdf), "heun", None, ("final_state", "energy_drift")) == ""
    assert cuda_refusal(str(urdf), "rk4", None, ("lyapunov",)) == (
        "measures energy_drift, final_state, wall_time only (lyapunov: kinds, rk4), got lyapunov"
    )
    assert cuda_refusal("pendubot", "heun", None, ("final_state",)) == ""  # a kind with heun: the tree path


def test_bench_gpu_panda_prepares_the_tree_arrays_and_runs_them_without_pinocchio(tmp_path):
    """benchmarks/_gpu_panda.py (bench_gpu.py's Panda): --prepare's arrays, then a tiny run in the simulator."""
    bench = SRC.parent / "benchmarks"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), str(bench)])}
    env.pop("NUMBA_ENABLE_CUDASIM", None)
    prepare = f"import pathlib, _gpu_panda; print(_gpu_panda.prepare(pathlib.Path({str(tmp_path)!r})))"
    made = subprocess.run([sys.executable, "-c", prepare], env=env, capture_output=True, text=True, timeout=300)
    assert made.returncode == 0, made.stderr[-3000:]
    assert "7 joints, fingers fixed" in made.stdout
    run = textwrap.dedent(
        f"""
        import json, pathlib, sys
        import _gpu_panda
        entry = _gpu_panda.run(pathlib.Path({str(tmp_path)!r}), sizes=(3,), steps=15, mjx=False)
        print(json.dumps({{"entry": entry, "pinocchio": "pinocchio" in sys.modules}}))
        """
    )
    ran = subprocess.run(
        [sys.executable, "-c", run],
        env={**env, "NUMBA_ENABLE_CUDASIM": "1"},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert ran.returncode == 0, ran.stderr[-3000:]
    out = json.loads(ran.stdout.strip().splitlines()[-1])
    assert out["pinocchio"] is False
    entry = out["entry"]
    assert entry["joints"] == [f"panda_joint{k}" for k in range(1, 8)] and entry["steps"] == 15
    (row,) = entry["batches"]
    assert row["states"] == 3 and row["gpu_state_steps_per_s"] > 0 and row["cpu_state_steps_per_s"] > 0
    assert row["gpu_vs_cpu_max_abs_diff"] <= CUDA_VS_CPU_ATOL


def test_tree_arrays_of_another_layout_are_one_input_error():
    """An ftree saved by a robodyn whose layout had fewer columns (bench_gpu's panda.npz) is refused, not read past."""
    t = tree.extract(robodyn.load("panda"))
    q = np.zeros((2, t.nq))
    with pytest.raises(InputError, match=r"ftree has shape \(\d+, 57\), expected \(bodies, 58\)"):
        cuda_tree.rollout(t.itree, t.ftree[:, :-1], t.grav, q, np.zeros((2, t.nv)), dt=1e-3, steps=1)
