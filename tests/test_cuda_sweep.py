"""The sweep's cuda chunk from arrays: measures on the device, columns without a per-run loop, float32 on request.

The device functions run here through numba's CPU compiler (``cpu=True``: the same functions the
GPU kernel calls) and, where the kernel itself is the point, in numba's CUDA simulator in a
subprocess (see tests/test_cuda_batch.py).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.cli import main
from robodyn.engine.cuda import batch as cuda_batch
from robodyn.engine.cuda import sweep as cuda_sweep
from robodyn.errors import InputError
from robodyn.sim import batch
from robodyn.sim.energy import reference_energy
from robodyn.sim.fast import FastDynamics
from robodyn.sim.simulation import DEFAULT_MAX_ENERGY_GROWTH
from robodyn.sweep.cuda_chunk import device_model_of

from .test_cuda_batch import _simulated

# The device thread and the fast path's loop step with the same float64 operations in the same order, and the
# energies are the same closed form in the same order: the columns agree to the bit.
SAME_BITS = 0.0
DT = 1e-3
STEPS = 300
# float32 against float64 after FLOAT32_STEPS steps: float32 rounds each operation to 2^-24 = 6e-8 relative, so
# the states part by more than 1e-9 (float64 round-off would be ~1e-15) and by less than 1e-4 (no blow-up).
FLOAT32_STEPS = 50
FLOAT32_PARTS_BY = (1e-9, 1e-4)
# numba's float32 and NumPy's float32 both round every operation to float32; their cos and sin may differ by an
# ulp or two (C library vs NumPy's own float32 loops): after FLOAT32_STEPS steps the states agree to 64 ulps
# of float32 (64 * 1.2e-7 relative), far closer than to float64 (above).
NUMPY_FLOAT32_RTOL = 64 * float(np.finfo(np.float32).eps)


def _oracle(robot, fast, Q, V):
    """The old per-run rows, one run at a time: final state, drift, stopped and diverged flags (a slow loop)."""
    lower, upper = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    rows = []
    for k in range(Q.shape[0]):
        t = fast.simulate(Q[k], V[k], duration=STEPS * DT, dt=DT)
        K0, P0 = fast.energies(Q[k], V[k])
        K1, P1 = fast.energies(t.q[-1], t.v[-1])
        drift = (K1 + P1) - (K0 + P0)
        bound = DEFAULT_MAX_ENERGY_GROWTH * max(K0 + abs(P0), reference_energy(robot))
        stopped = bool(np.any(t.q.min(axis=0) < lower) or np.any(t.q.max(axis=0) > upper))
        diverged = not abs(drift) <= bound
        rows.append({"q": t.q[-1], "v": t.v[-1], "drift": drift, "stopped": stopped, "diverged": diverged})
    return rows


@pytest.mark.parametrize("kind", ["cart_pole", "pendubot", "geared_arm"])
def test_device_columns_equal_the_per_run_rows(kind):
    """cuda_sweep.measures + columns (no per-run loop) give each run the old per-run rows' numbers and flags."""
    robot = robodyn.load(kind)
    fast = FastDynamics.from_robot(robot)
    rng = np.random.default_rng(4)
    Q = rng.uniform(-2.3, 2.3, (10, robot.nv))
    V = rng.uniform(-4.0, 4.0, (10, robot.nv))
    measured = cuda_sweep.measures(device_model_of(kind), Q, V, dt=DT, steps=STEPS, cpu=True)
    joints = robot.joint_names
    columns = cuda_sweep.columns(measured, ("final_state", "wall_time", "energy_drift"), joints)
    want = _oracle(robot, fast, Q, V)
    assert list(columns) == ["status", *[f"{x}.{j}" for j in joints for x in ("q", "v")], "wall_time", "energy_drift"]
    assert columns["status"] == ["ok"] * 10
    for j, joint in enumerate(joints):
        np.testing.assert_allclose(columns[f"q.{joint}"], [r["q"][j] for r in want], rtol=0, atol=SAME_BITS)
        np.testing.assert_allclose(columns[f"v.{joint}"], [r["v"][j] for r in want], rtol=0, atol=SAME_BITS)
    np.testing.assert_allclose(columns["energy_drift"], [r["drift"] for r in want], rtol=0, atol=SAME_BITS)
    assert [bool(f & cuda_sweep.LEFT_LIMITS) for f in measured.flags] == [r["stopped"] for r in want]
    assert [bool(f & cuda_sweep.DIVERGED) for f in measured.flags] == [r["diverged"] for r in want]
    if kind == "cart_pole":  # the rail's stops are met by some runs, not all: the flag is exercised both ways
        assert 0 < sum(r["stopped"] for r in want) < 10
    np.testing.assert_array_equal(measured.again, [k for k, r in enumerate(want) if r["stopped"] or r["diverged"]])


def test_a_non_finite_run_is_diverged_and_flagged():
    model = device_model_of("pendubot")
    Q, V = np.array([[0.1, 0.2], [np.nan, 0.0]]), np.zeros((2, 2))
    measured = cuda_sweep.measures(model, Q, V, dt=DT, steps=3, cpu=True)
    columns = cuda_sweep.columns(measured, ("final_state",), ("joint1", "joint2"))
    assert columns["status"] == ["ok", "diverged"]
    assert measured.again.tolist() == [1]


def _advance_pair(kind):
    """(numba float32 advance, the same source as plain Python on NumPy float32 scalars)."""
    import numba

    return cuda_batch._advance(numba.njit, kind, precision="float32"), cuda_batch._advance(
        lambda f: f, kind, precision="float32"
    )


@pytest.mark.parametrize("kind", ["pendubot", "cart_pole", "geared_arm"])
def test_float32_kernel_computes_in_float32(kind):
    """The float32 device function types as float32 throughout, rounds as NumPy's float32, and parts from float64."""
    import numba

    fast = FastDynamics.from_robot(robodyn.load(kind))
    compiled, python = _advance_pair(kind)
    f32, f64 = np.float32, np.float64
    p32, b32 = fast.param_vector.astype(f32), np.zeros(2, f32)
    start = (f32(0.9), f32(-0.7 if fast.nv == 2 else 0.0), f32(1.3), f32(-0.4 if fast.nv == 2 else 0.0))
    got = compiled(p32, b32, fast.nv, *start, f32(DT), FLOAT32_STEPS)
    (signature,) = compiled.nopython_signatures
    assert all(t == numba.float32 for t in signature.return_type), signature  # no float64 slipped in
    numpy_ref = python(p32, b32, fast.nv, *start, f32(DT), FLOAT32_STEPS)
    assert all(type(x) is np.float32 for x in numpy_ref[:4]), [type(x) for x in numpy_ref]
    np.testing.assert_allclose(np.array(got[:4], f64), np.array(numpy_ref[:4], f64), rtol=NUMPY_FLOAT32_RTOL, atol=0)
    double = cuda_batch._advance(numba.njit, kind, precision="float64")(
        fast.param_vector, np.zeros(2), fast.nv, *map(f64, start), DT, FLOAT32_STEPS
    )
    part = np.max(np.abs(np.array(got[:4], f64) - np.array(double[:4])) / np.maximum(np.abs(double[:4]), 1.0))
    assert FLOAT32_PARTS_BY[0] < part < FLOAT32_PARTS_BY[1], part


def test_float32_cuda_rollout_in_the_simulator_is_numpys_float32():
    """batch.rollout(device="cuda", dtype=np.float32) in numba's simulator: float32 states, NumPy float32's numbers."""
    out = _simulated(
        f"""
        import json
        import numpy as np
        import robodyn
        from robodyn.sim import batch
        from robodyn.engine.cuda import batch as cuda_batch
        from robodyn.sim.fast import FastDynamics

        robot = robodyn.load("pendubot")
        fast = FastDynamics.from_robot(robot)
        Q, V = np.array([[0.9, -0.7], [2.0, 0.3]]), np.array([[1.3, -0.4], [0.0, 0.5]])
        r32 = batch.rollout(robot, Q, V, duration={FLOAT32_STEPS * DT}, dt={DT}, device="cuda", dtype=np.float32)
        r64 = batch.rollout(robot, Q, V, duration={FLOAT32_STEPS * DT}, dt={DT}, device="cuda")
        python = cuda_batch._advance(lambda f: f, "pendubot", precision="float32")
        f32 = np.float32
        p32 = fast.param_vector.astype(f32)
        worst = 0.0
        for k in range(2):
            ref = python(p32, np.zeros(2, f32), 2, *map(f32, (*Q[k], *V[k])), f32({DT}), {FLOAT32_STEPS})
            worst = max(worst, float(np.max(np.abs(np.r_[r32.q[k], r32.v[k]] - np.array(ref[:4], np.float64)))))
        part = float(np.max(np.abs(r32.q - r64.q)))
        print(json.dumps({{"dtype": str(r32.q.dtype), "worst": worst, "part": part}}))
        """
    )
    assert out["dtype"] == "float32"
    assert out["worst"] == 0.0, out  # the simulator runs the same Python on NumPy float32 scalars
    assert FLOAT32_PARTS_BY[0] < out["part"] < FLOAT32_PARTS_BY[1], out


def test_float32_on_the_cpu_is_refused_in_one_line(tmp_path, capsys):
    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match="^dtype float32 runs on device cuda only"):
        batch.rollout(robot, np.zeros((1, 2)), np.zeros((1, 2)), duration=0.01, dt=1e-3, dtype=np.float32)
    with pytest.raises(InputError, match="^dtype 'float16': expected float64"):
        batch.rollout(robot, np.zeros((1, 2)), np.zeros((1, 2)), duration=0.01, dt=1e-3, dtype="float16")
    path = tmp_path / "s.toml"
    path.write_text('model = "pendubot"\nduration = 0.01\n[q0]\njoint1 = [0.1]\n')
    assert main(["sweep", str(path), "--out", str(tmp_path / "o"), "--precision", "float32", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "precision float32 runs on device cuda only" in err[0], err


def test_float32_lyapunov_is_refused_before_any_work(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(
        'model = "pendubot"\nduration = 0.01\ndevice = "cuda"\nprecision = "float32"\nmeasure = ["lyapunov"]\n'
        "[q0]\njoint1 = [0.1]\n"
    )
    assert main(["sweep", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "precision float32 has no Lyapunov estimate" in err[0], err
    assert not (tmp_path / "o" / "results").exists()


def test_precision_enters_the_digest_only_when_float32():
    from robodyn.sweep.spec import parse, with_digest

    base = {"model": "pendubot", "duration": 0.1}
    plain = with_digest(parse(base, name="s", base=Path.cwd()), {}).digest
    same = with_digest(parse({**base, "precision": "float64"}, name="s", base=Path.cwd()), {}).digest
    single = with_digest(parse({**base, "precision": "float32"}, name="s", base=Path.cwd()), {}).digest
    assert plain == same != single
    with pytest.raises(InputError, match="precision must be one of 'float64', 'float32', got 'half'"):
        parse({**base, "precision": "half"}, name="s", base=Path.cwd())


def test_streams_are_seed_plus_run():
    np.testing.assert_array_equal(cuda_batch.streams_of(5, np.arange(3)), np.array([5, 6, 7], dtype=np.uint64))
    with pytest.raises(InputError):
        cuda_batch.streams_of(-1, np.arange(3))
    assert math.isfinite(float(cuda_batch.streams_of(2**32 - 1, np.array([10**6]))[0]))


def test_float32_sweep_chunk_steps_in_float32():
    """A cuda sweep with precision float32 (in numba's simulator): its final states part from float64's as float32's."""
    out = _simulated(
        f"""
        import dataclasses, json, tempfile
        import numpy as np
        import robodyn.sweep as sweep
        from robodyn.sweep.chunk import execute

        spec = {{
            "model": "pendubot", "duration": {FLOAT32_STEPS * DT}, "dt": {DT}, "device": "cuda",
            "precision": "float32", "measure": ["final_state", "energy_drift"], "q0": {{"joint1": [0.5, 2.0]}},
        }}
        prepared = sweep.prepare(spec, tempfile.mkdtemp())
        (chunk,) = prepared.plan.chunks
        single = execute(chunk, prepared.job)
        double = execute(chunk, dataclasses.replace(prepared.job, precision="float64"))
        part = max(float(np.max(np.abs(single[k] - double[k]))) for k in ("q.joint1", "q.joint2", "v.joint1"))
        print(json.dumps({{"paths": single["path"], "part": part, "digest": prepared.spec.digest}}))
        """
    )
    assert out["paths"] == ["cuda", "cuda"]
    assert FLOAT32_PARTS_BY[0] < out["part"] < FLOAT32_PARTS_BY[1], out


def test_a_gpu_worker_runs_a_chunk_from_arrays_without_pinocchio(tmp_path):
    """device_task pickled here, run_task in a fresh process (numba's simulator) that never imports Pinocchio."""
    import pickle

    import robodyn.sweep as sweep
    from robodyn.sweep.cuda_chunk import device_task

    spec = {
        "model": "cart_pole", "duration": 0.2, "dt": DT, "device": "cuda", "seed": 3,
        "measure": ["final_state", "energy_drift", "lyapunov"],
        "q0": {"slider": [0.0, 2.3], "hinge": [0.5, 3.0]}, "v0": {"slider": [4.0]},
    }  # fmt: skip
    prepared = sweep.prepare(spec, tmp_path / "out")
    (chunk,) = prepared.plan.chunks
    task = device_task(chunk, prepared.job)
    (tmp_path / "task.pkl").write_bytes(pickle.dumps(task))
    out = _simulated(
        f"""
        import json, pickle, sys
        from robodyn.engine.cuda import sweep as cuda_sweep

        task = pickle.loads(open({str(tmp_path / "task.pkl")!r}, "rb").read())
        measured = cuda_sweep.run_task(task)
        open({str(tmp_path / "measured.pkl")!r}, "wb").write(pickle.dumps(measured))
        print(json.dumps({{"pinocchio": "pinocchio" in sys.modules, "robot": "robodyn.robot" in sys.modules}}))
        """
    )
    assert out == {"pinocchio": False, "robot": False}
    measured = pickle.loads((tmp_path / "measured.pkl").read_bytes())
    here = cuda_sweep.measures(  # the same device functions through numba's CPU compiler
        task.model, task.q0, task.v0, dt=task.dt, steps=task.steps, streams=task.streams,
        lyapunov_interval=task.lyapunov_interval, d0=task.d0, cpu=True,
    )  # fmt: skip
    for name in ("q", "v", "drift", "flags", "lyapunov"):
        np.testing.assert_allclose(getattr(measured, name), getattr(here, name), rtol=0, atol=SAME_BITS)
    assert 0 < measured.again.size < 4  # the cart that starts at 2.3 m moving at 4 m/s meets the rail's stop


def test_a_cuda_sweep_on_dask_equals_the_in_process_one(tmp_path):
    """With a Dask client the workers get device_task's arrays; the written table is the in-process sweep's."""
    out = _simulated(
        f"""
        import json
        import distributed
        import pyarrow.parquet as pq
        import robodyn.sweep as sweep

        spec = {{
            "model": "cart_pole", "duration": 0.2, "dt": {DT}, "device": "cuda", "chunk": 2, "seed": 3,
            "measure": ["final_state", "energy_drift", "lyapunov"],
            "q0": {{"slider": [0.0, 2.3], "hinge": [0.5, 3.0]}}, "v0": {{"slider": [4.0]}},
        }}
        sweep.run(spec, out={str(tmp_path / "here")!r})
        with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as client:
            sweep.run(spec, out={str(tmp_path / "dask")!r}, client=client)
        here = pq.read_table({str(tmp_path / "here" / "results")!r}).sort_by("run").to_pydict()
        dask = pq.read_table({str(tmp_path / "dask" / "results")!r}).sort_by("run").to_pydict()
        print(json.dumps({{"same": here == dask, "paths": dask["path"], "n": len(dask["run"])}}))
        """
    )
    assert out["n"] == 4 and out["same"], out
    assert "simulate" in out["paths"] and "cuda" in out["paths"], out


@pytest.mark.parametrize("kind", ["cart_pole", "geared_arm"])
def test_run_and_twin_in_one_pass_equal_two_launches(kind):
    """The fused thread (run and twin together) gives the measures kernel's and Benettin's numbers to the bit."""
    robot = robodyn.load(kind)
    rng = np.random.default_rng(4)  # the starts of test_device_columns_equal_the_per_run_rows: some meet the rail
    Q, V = rng.uniform(-2.3, 2.3, (10, robot.nv)), rng.uniform(-4.0, 4.0, (10, robot.nv))
    streams = cuda_batch.streams_of(2, np.arange(10))
    args = {"dt": DT, "steps": STEPS, "streams": streams, "lyapunov_interval": 0.1, "cpu": True}
    one = cuda_sweep.measures(device_model_of(kind), Q, V, **args)
    two = cuda_sweep.measures(device_model_of(kind), Q, V, **args, fused=False)
    assert one.lyapunov_s == 0.0 and two.lyapunov_s > 0.0  # one launch, then two
    for name in ("q", "v", "drift", "flags", "lyapunov"):
        np.testing.assert_allclose(getattr(one, name), getattr(two, name), rtol=0, atol=SAME_BITS, err_msg=name)
    assert np.isfinite(one.lyapunov).all()
    if kind == "cart_pole":
        assert 0 < np.count_nonzero(one.flags & cuda_sweep.LEFT_LIMITS) < 10


def test_a_run_past_its_limit_only_at_the_start_is_flagged_on_both_passes():
    """The range a thread keeps covers every interval: a pendulum released beyond a limit, back inside later."""
    import dataclasses

    model = dataclasses.replace(device_model_of("geared_arm"), upper=np.array([0.45]))
    Q, V = np.array([[0.5], [0.1]]), np.zeros((2, 1))
    streams = cuda_batch.streams_of(0, np.arange(2))
    args = {"dt": DT, "steps": STEPS, "streams": streams, "lyapunov_interval": 0.1, "cpu": True}
    for fused in (True, False):
        measured = cuda_sweep.measures(model, Q, V, **args, fused=fused)
        assert measured.q[0, 0] < 0.45  # back inside the limit at the end
        assert measured.flags.tolist() == [cuda_sweep.LEFT_LIMITS, 0], fused
