"""robodyn against MuJoCo on the Pendubot: one trajectory, and a batch of 1000.

Run from the repository root (MuJoCo is a benchmark-only dependency: pip install mujoco):

    python benchmarks/bench_mujoco.py --out docs/figures

1. MuJoCo loads the same URDF (models/pendubot.urdf) with <compiler discardvisual fusestatic=false
   balanceinertia=false>, contacts disabled, armature and damping copied from the robodyn model; its
   mass matrix (mj_fullM) and bias forces (qfrc_bias) are confirmed equal to Pinocchio's first.
2. One trajectory: torque-free, RK4, dt = 1 ms, 10 s, from robodyn's bench start state. MuJoCo's
   RK4 steps in its own C loop (mj_step with nstep); robodyn runs its compiled fast path, and its
   Python loop over Pinocchio ABA for scale. Errors at t = 2 s against a DOP853 reference.
3. A batch of 1000 seeded initial states, 1 s of RK4 at 1 ms: robodyn's Pinocchio path
   (abaInParallel inside the integrators' RK4) against mujoco.rollout, both on every CPU.

Prints ratios; writes bench_mujoco.json and bench_mujoco.png/.svg into --out.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

import robodyn
from robodyn import charts
from robodyn.sim import batch
from robodyn.sim.fast import FastDynamics
from robodyn.studies import bench
from robodyn.studies.report import speed_phrase

# MuJoCo's M and bias against Pinocchio's: the same rigid-body algorithms in float64.
MODEL_MATCH_RTOL = 1e-12
N_CHECK_STATES = 20
DT = 1e-3
DURATION = 10.0
ERROR_AT = 2.0
BATCH = 1000
BATCH_STEPS = 1000
REPEATS = 5


def mujoco_model(robot: robodyn.Robot):
    import mujoco

    text = Path(robot.urdf_path).read_text()
    tag = f'<robot name="{robot.name}">'
    compiler = (
        '<mujoco><compiler discardvisual="true" fusestatic="false" balanceinertia="false" angle="radian"/></mujoco>'
    )
    if tag not in text:
        sys.exit(f"cannot find {tag} in {robot.urdf_path}")
    m = mujoco.MjModel.from_xml_string(text.replace(tag, tag + compiler, 1))
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    m.opt.timestep = DT
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    m.dof_armature[:] = robot.armature
    m.dof_damping[:] = robot.damping
    return m


def confirm_same_model(robot: robodyn.Robot, m) -> dict:
    import mujoco

    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    worst_M = worst_bias = 0.0
    for _ in range(N_CHECK_STATES):
        q, v = robot.random_state(rng)
        d.qpos[:], d.qvel[:] = q, v
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        M_pin, b_pin = robot.M(q), robot.nle(q, v)
        worst_M = max(worst_M, float(np.max(np.abs(M - M_pin)) / np.max(np.abs(M_pin))))
        worst_bias = max(worst_bias, float(np.max(np.abs(d.qfrc_bias - b_pin)) / max(np.max(np.abs(b_pin)), 1.0)))
    gravity_ok = np.allclose(m.opt.gravity, np.array(robot.model.gravity.linear), rtol=0, atol=0)
    if worst_M > MODEL_MATCH_RTOL or worst_bias > MODEL_MATCH_RTOL or not gravity_ok:
        sys.exit(f"MuJoCo and Pinocchio disagree: M {worst_M:.3g}, bias {worst_bias:.3g}, gravity equal {gravity_ok}")
    return {"mass_matrix_rel_diff": worst_M, "bias_rel_diff": worst_bias, "states": N_CHECK_STATES}


def state_error(q, v, ref: bench.Reference, t: float) -> float:
    k = round(t / (ref.t[1] - ref.t[0]))
    x, x_ref = np.concatenate([q, v]), np.concatenate([ref.q[k], ref.v[k]])
    return float(np.max(np.abs(x - x_ref)) / np.max(np.abs(x_ref)))


def single(robot: robodyn.Robot, m) -> dict:
    import mujoco

    q0, v0 = bench.start_state(robot)
    ref = bench.reference(robot, q0, v0, duration=ERROR_AT, sample_interval=0.02)
    steps = round(DURATION / DT)
    d = mujoco.MjData(m)
    times = []
    for _ in range(REPEATS):
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:] = q0, v0
        start = time.perf_counter()
        mujoco.mj_step(m, d, nstep=steps)
        times.append(time.perf_counter() - start)
    mujoco.mj_resetData(m, d)
    d.qpos[:], d.qvel[:] = q0, v0
    mujoco.mj_step(m, d, nstep=round(ERROR_AT / DT))
    mj = {"us_per_step": 1e6 * min(times) / steps, "error_at_2s": state_error(d.qpos, d.qvel, ref, ERROR_AT)}

    fast = FastDynamics.from_robot(robot)
    fast_runs = [fast.simulate(q0, v0, duration=DURATION, dt=DT) for _ in range(REPEATS)]
    k = round(ERROR_AT / DT)
    tr = fast_runs[0]
    fast_res = {
        "us_per_step": 1e6 * min(r.wall_time_s for r in fast_runs) / steps,
        "error_at_2s": state_error(tr.q[k], tr.v[k], ref, ERROR_AT),
    }
    paths = {"mujoco_rk4_c_loop": mj, "robodyn_fast_rk4": fast_res}
    for backend in ("aba", "formula"):
        tr = robodyn.simulate(robot, q0, v0, duration=DURATION, dt=DT, integrator="rk4", backend=backend)
        paths[f"robodyn_simulate_rk4_{backend}"] = {
            "us_per_step": 1e6 * tr.wall_time_s / steps,
            "error_at_2s": state_error(tr.q[k], tr.v[k], ref, ERROR_AT),
        }
    return {
        "q0": q0.tolist(),
        "v0": v0.tolist(),
        "dt": DT,
        "duration": DURATION,
        "reference_self_error": ref.self_error,
        "paths": paths,
        "speedup_fast_vs_mujoco": mj["us_per_step"] / fast_res["us_per_step"],
    }


def batched(robot: robodyn.Robot, m) -> dict:
    import mujoco
    from mujoco import rollout

    rng = np.random.default_rng(42)
    Q = rng.uniform(-np.pi, np.pi, (BATCH, robot.nq))
    V = rng.uniform(-1.0, 1.0, (BATCH, robot.nv))
    threads = os.cpu_count() or 1
    ours = [batch.rollout(robot, Q, V, duration=BATCH_STEPS * DT, dt=DT, threads=threads) for _ in range(3)]
    best = min(ours, key=lambda r: r.wall_time_s)
    size = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    state0 = np.zeros((BATCH, size))
    state0[:, 1 : 1 + m.nq] = Q
    state0[:, 1 + m.nq : 1 + m.nq + m.nv] = V
    datas = [mujoco.MjData(m) for _ in range(threads)]
    mj_times = []
    for _ in range(3):
        start = time.perf_counter()
        states, _ = rollout.rollout(m, datas, state0, nstep=BATCH_STEPS)
        mj_times.append(time.perf_counter() - start)
    final = states[:, -1, :]
    q_mj, v_mj = final[:, 1 : 1 + m.nq], final[:, 1 + m.nq : 1 + m.nq + m.nv]
    agree = float(max(np.max(np.abs(q_mj - best.q)), np.max(np.abs(v_mj - best.v))))
    fast = FastDynamics.from_robot(robot)
    start = time.perf_counter()
    for i in range(BATCH):
        fast.simulate(Q[i], V[i], duration=BATCH_STEPS * DT, dt=DT)
    fast_wall = time.perf_counter() - start
    work = BATCH * BATCH_STEPS
    return {
        "states": BATCH,
        "steps": BATCH_STEPS,
        "threads": threads,
        "robodyn_pinocchio_abaInParallel_rk4_us_per_state_step": 1e6 * best.wall_time_s / work,
        "mujoco_rollout_us_per_state_step": 1e6 * min(mj_times) / work,
        "robodyn_fast_loop_us_per_state_step": 1e6 * fast_wall / work,
        "throughput_ratio_pinocchio_vs_mujoco": min(mj_times) / best.wall_time_s,
        "max_final_state_difference_vs_mujoco": agree,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/figures"), help="folder for the JSON and chart")
    args = parser.parse_args()
    import mujoco

    robot = robodyn.load("pendubot")
    m = mujoco_model(robot)
    check = confirm_same_model(robot, m)
    print(
        f"MuJoCo vs Pinocchio on {N_CHECK_STATES} states: M rel diff {check['mass_matrix_rel_diff']:.2g}, "
        f"bias rel diff {check['bias_rel_diff']:.2g}"
    )
    one = single(robot, m)
    for name, p in one["paths"].items():
        print(f"  {name:32s} {p['us_per_step']:9.3f} us/step   error at t = 2 s {p['error_at_2s']:.3g}")
    print(f"fast path vs MuJoCo RK4 (mj_step C loop): {speed_phrase(one['speedup_fast_vs_mujoco'])}")
    many = batched(robot, m)
    print(f"batch of {BATCH}, {BATCH_STEPS} RK4 steps, {many['threads']} threads:")
    ours = many["robodyn_pinocchio_abaInParallel_rk4_us_per_state_step"]
    print(f"  robodyn Pinocchio (abaInParallel + RK4) {ours:.3f} us/state-step")
    print(f"  mujoco.rollout                          {many['mujoco_rollout_us_per_state_step']:.3f} us/state-step")
    print(f"  robodyn fast path, one state at a time  {many['robodyn_fast_loop_us_per_state_step']:.3f} us/state-step")
    print(
        f"  throughput ratio Pinocchio / MuJoCo: {many['throughput_ratio_pinocchio_vs_mujoco']:.2f}x; "
        f"max final state difference {many['max_final_state_difference_vs_mujoco']:.2g}"
    )
    result = {
        "machine": {
            "cpus": os.cpu_count(),
            "platform": platform.platform(),
            "python": platform.python_version(),
            "mujoco": mujoco.__version__,
            "robodyn": robodyn.__version__,
        },
        "model_check": check,
        "single": one,
        "batch": many,
        "command": "python benchmarks/bench_mujoco.py --out docs/figures",
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench_mujoco.json").write_text(json.dumps(result, indent=1) + "\n")
    labels = [f"single: {k}" for k in one["paths"]] + [
        "batch: robodyn Pinocchio abaInParallel",
        "batch: mujoco.rollout",
        "batch: robodyn fast, per state",
    ]
    values = [p["us_per_step"] for p in one["paths"].values()] + [
        many["robodyn_pinocchio_abaInParallel_rk4_us_per_state_step"],
        many["mujoco_rollout_us_per_state_step"],
        many["robodyn_fast_loop_us_per_state_step"],
    ]
    charts.speed_bars(
        labels,
        values,
        args.out / "bench_mujoco",
        unit="microseconds per (state-)step, log scale",
        title="Pendubot, RK4, dt = 1 ms: robodyn against MuJoCo",
    )
    print(f"wrote {args.out / 'bench_mujoco.json'} and bench_mujoco.png/.svg")
    return 0


if __name__ == "__main__":
    sys.exit(main())
