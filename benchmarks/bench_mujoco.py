"""robodyn against MuJoCo: single trajectories and batches, seed kinds, the Panda and Talos (fixed base).

Run from the repository root (MuJoCo is a benchmark-only dependency: pip install mujoco):

    python benchmarks/bench_mujoco.py                   # writes into bench-out/
    python benchmarks/bench_mujoco.py --busy            # with a CPU-bound process competing
    python benchmarks/bench_mujoco.py --systems pendubot,panda --out /tmp/b

1. Every system is loaded by robodyn and by MuJoCo from the same URDF (geometry stripped,
   <compiler fusestatic=false balanceinertia=false autolimits=true>, so that MuJoCo limits the
   joints whose URDF <limit> gives a range, as robodyn's stops do: the two sets are compared;
   contacts off, armature and damping copied; Coulomb friction off in both, as MuJoCo's
   frictionloss is a constraint, not robodyn's regularised torque). MuJoCo's mass matrix and
   bias forces are compared with Pinocchio's on seeded states first.
2. Single trajectory, measured twice: with the joint stops on (each engine's default handling of
   the URDF's limits: robodyn's exact impacts and holds, MuJoCo's soft limit constraints) and
   with them off in both. Torque-free RK4 at dt = 1 ms from robodyn's bench start state. MuJoCo
   steps in its own C loop (mj_step with nstep); robodyn runs robodyn.simulate (the compiled
   loop, ledger and energies included) and, for the seed kinds with the stops off, the
   closed-form fast path. Stops off: errors at t = 2 s (or the end) against robodyn's compiled
   RK4 at dt / 20 (RK4's error then 20^4 = 1.6e5 times smaller): equal method, equal step, errors
   printed side by side. Stops on: the number of impacts of robodyn's run, its steps with an
   event, and MuJoCo's limit activations (a joint's limit constraint becoming active, counted
   in a separate step-by-step pass), no error (the two engines model a stop differently). Also:
   robodyn.simulate's whole call against its own compiled loop's wall time (stops off).
3. Batches of 1000 seeded states (lossless: damping set to 0 in both), RK4 at 1 ms: robodyn's
   batch.rollout against mujoco.rollout, on 1 and on 2 threads; the final states compared.

--busy runs one CPU-bound process (a spinning loop) for the whole measurement. Prints every
figure and the ratios, and writes bench_mujoco.json and bench_mujoco.png/.svg (with --busy:
bench_mujoco_busy.*) into --out (default bench-out/; a folder holding committed files only with
--overwrite-committed).
"""

from __future__ import annotations

import json
import multiprocessing
import re
import sys
import time
from pathlib import Path

import numpy as np

import robodyn
from robodyn import charts
from robodyn.sim import batch
from robodyn.sim.fast import FastDynamics
from robodyn.studies import bench

from _common import argument_parser, output_folder, run_facts, write_json

MODEL_MATCH_RTOL = 1e-9  # MuJoCo's M and bias against Pinocchio's (relative to the largest entry)
N_CHECK_STATES = 10
DT = 1e-3
REF_DIVISOR = 20
ERROR_AT = 2.0  # [s]: errors are taken here (the Pendubot's chaos would swamp them by 10 s)
REPEATS = 3
BATCH = 1000
SYSTEMS = ("pendubot", "cart_pole", "geared_arm", "panda", "talos")
SEED_KINDS = ("pendubot", "cart_pole", "geared_arm")
# Simulated time [s] of a single trajectory and steps of a batch, per system (kept short on the big ones).
DURATION = {"pendubot": 10.0, "cart_pole": 10.0, "geared_arm": 10.0, "panda": 2.0, "talos": 1.0}
BATCH_STEPS = {"pendubot": 1000, "cart_pole": 1000, "geared_arm": 1000, "panda": 200, "talos": 50}


def _spin(stop: multiprocessing.synchronize.Event) -> None:  # type: ignore[name-defined]
    x = 0
    while not stop.is_set():
        for _ in range(100_000):
            x += 1


def prepare(name: str) -> robodyn.Robot:
    robot = robodyn.load(name)
    robot.model.friction[:] = 0.0  # MuJoCo's frictionloss is another model
    return robot


def mujoco_model(robot: robodyn.Robot):
    import mujoco

    text = Path(robot.urdf_path).read_text()
    text = re.sub(r"<(visual|collision)\b.*?</\1>", "", text, flags=re.S)
    start = re.search(r"<robot\b[^>]*>", text)
    if start is None:
        sys.exit(f"no <robot> tag in {robot.urdf_path}")
    compiler = (
        '<mujoco><compiler discardvisual="true" fusestatic="false" balanceinertia="false" angle="radian" '
        'autolimits="true"/></mujoco>'
    )
    text = text[: start.end()] + compiler + text[start.end() :]
    m = mujoco.MjModel.from_xml_string(text)
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    m.opt.timestep = DT
    off = mujoco.mjtDisableBit
    m.opt.disableflags |= off.mjDSBL_CONTACT | off.mjDSBL_EQUALITY  # a <mimic> is an equality; limits: see set_limits
    if m.nv != robot.nv or m.nq != robot.nq:
        sys.exit(f"{robot.name}: MuJoCo has {m.nv} degrees of freedom, robodyn {robot.nv}")
    # MuJoCo orders the joints its own way (Talos: torso first); idx[i] = MuJoCo's index of robodyn's joint i
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)]
    idx = np.array([int(m.jnt_dofadr[names.index(n)]) for n in robot.joint_names])
    m.dof_armature[idx] = robot.armature
    m.dof_damping[idx] = robot.damping
    m.dof_frictionloss[:] = 0.0
    return m, idx


def set_limits(m, on: bool) -> None:
    """Honour MuJoCo's joint limits (the URDF's ranges), or disable them."""
    import mujoco

    if on:
        m.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_LIMIT)
    else:
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_LIMIT)


def same_limits(robot: robodyn.Robot, m) -> dict:
    """The joints MuJoCo limits against robodyn's stops: counts, and the joints whose ranges differ."""
    import mujoco

    from robodyn.sim.system import robot_system

    stops = robot_system(robot).stops
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)]
    mj = {names[j]: (float(m.jnt_range[j, 0]), float(m.jnt_range[j, 1])) for j in range(m.njnt) if m.jnt_limited[j]}
    ours = {n: (float(lo), float(hi)) for n, lo, hi in zip(stops.names, stops.lower, stops.upper, strict=True)}
    differ = sorted(
        n for n in set(mj) | set(ours) if n not in mj or n not in ours or not np.allclose(mj[n], ours[n], rtol=1e-12)
    )
    if differ:
        sys.exit(f"{robot.name}: MuJoCo and robodyn limit different joints or ranges: {', '.join(differ)}")
    return {"mujoco_limited_joints": len(mj), "robodyn_stops": len(ours)}


def limit_activations(m, idx, q0, v0, steps: int) -> int:
    """How many times a joint's limit constraint becomes active in MuJoCo's run (a step-by-step pass)."""
    import mujoco

    d = mujoco.MjData(m)
    d.qpos[idx], d.qvel[idx] = q0, v0
    limit = int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT)
    active: set[int] = set()
    onsets = 0
    for _ in range(steps):
        mujoco.mj_step(m, d)
        now = {int(d.efc_id[i]) for i in range(d.nefc) if int(d.efc_type[i]) == limit}
        onsets += len(now - active)
        active = now
    return onsets


def confirm_same_model(robot: robodyn.Robot, m, idx) -> dict:
    import mujoco

    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    worst_M = worst_bias = 0.0
    for _ in range(N_CHECK_STATES):
        q, v = robot.random_state(rng)
        d.qpos[idx], d.qvel[idx] = q, v
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        M, bias = M[np.ix_(idx, idx)], d.qfrc_bias[idx]
        M_pin, b_pin = robot.M(q), robot.nle(q, v)
        worst_M = max(worst_M, float(np.max(np.abs(M - M_pin)) / np.max(np.abs(M_pin))))
        worst_bias = max(worst_bias, float(np.max(np.abs(bias - b_pin)) / max(np.max(np.abs(b_pin)), 1.0)))
    if worst_M > MODEL_MATCH_RTOL or worst_bias > MODEL_MATCH_RTOL:
        sys.exit(f"{robot.name}: MuJoCo and Pinocchio disagree: M {worst_M:.3g}, bias {worst_bias:.3g}")
    return {"mass_matrix_rel_diff": worst_M, "bias_rel_diff": worst_bias, "states": N_CHECK_STATES}


def _error(q, v, q_ref, v_ref) -> float:
    x, x_ref = np.concatenate([q, v]), np.concatenate([q_ref, v_ref])
    return float(np.max(np.abs(x - x_ref)) / max(np.max(np.abs(x_ref)), 1.0))


def _mujoco_time(m, idx, q0, v0, steps: int) -> float:
    """Best wall time [s] of MuJoCo's C loop over ``steps`` steps from (q0, v0)."""
    import mujoco

    d = mujoco.MjData(m)
    times = []
    for _ in range(REPEATS):
        mujoco.mj_resetData(m, d)
        d.qpos[idx], d.qvel[idx] = q0, v0
        start = time.perf_counter()
        mujoco.mj_step(m, d, nstep=steps)
        times.append(time.perf_counter() - start)
    return min(times)


def _simulate_runs(robot: robodyn.Robot, q0, v0, duration: float, opts: dict) -> tuple[list, list[float]]:
    runs, calls = [], []
    for _ in range(REPEATS):
        start = time.perf_counter()
        runs.append(robodyn.simulate(robot, q0, v0, duration=duration, dt=DT, **opts))
        calls.append(time.perf_counter() - start)
    return runs, calls


def single(robot: robodyn.Robot, m, idx) -> dict:
    """Stops off: MuJoCo's RK4 loop against robodyn's paths at equal method, step and (measured) error."""
    import mujoco

    set_limits(m, False)
    duration = DURATION[robot.name]
    steps = round(duration / DT)
    q0, v0 = bench.start_state(robot)
    opts = {"limits": False, "max_energy_growth": None}
    t_err = min(ERROR_AT, duration)
    k = round(t_err / DT)
    ref = robodyn.simulate(robot, q0, v0, duration=t_err, dt=DT / REF_DIVISOR, **opts)
    q_ref, v_ref = ref.q[-1], ref.v[-1]
    mj_time = _mujoco_time(m, idx, q0, v0, steps)
    d = mujoco.MjData(m)
    d.qpos[idx], d.qvel[idx] = q0, v0
    mujoco.mj_step(m, d, nstep=k)
    mj_err = _error(d.qpos[idx], d.qvel[idx], q_ref, v_ref)
    paths = {"mujoco_rk4_c_loop": {"us_per_step": 1e6 * mj_time / steps, "error": mj_err}}
    runs, calls = _simulate_runs(robot, q0, v0, duration, opts)
    tr = runs[0]
    loop_wall = min(r.wall_time_s for r in runs)
    paths["robodyn_simulate_compiled"] = {
        "us_per_step": 1e6 * loop_wall / steps,
        "error": _error(tr.q[k], tr.v[k], q_ref, v_ref),
        "backend": tr.meta["backend"],
        "loop": tr.meta["loop"],
    }
    if robot.name in SEED_KINDS:
        fast = FastDynamics.from_robot(robot)
        fr = [fast.simulate(q0, v0, duration=duration, dt=DT) for _ in range(REPEATS)]
        paths["robodyn_fast_closed_form"] = {
            "us_per_step": 1e6 * min(r.wall_time_s for r in fr) / steps,
            "error": _error(fr[0].q[k], fr[0].v[k], q_ref, v_ref),
        }
    python = robodyn.simulate(robot, q0, v0, duration=min(duration, 1.0), dt=DT, backend="aba", **opts)
    paths["robodyn_simulate_python_aba"] = {"us_per_step": 1e6 * python.wall_time_s / (python.t.size - 1)}
    best = min(p["us_per_step"] for k, p in paths.items() if k.startswith("robodyn") and "error" in p)
    return {
        "stops": "off",
        "duration": duration,
        "dt": DT,
        "steps": steps,
        "error_at_s": t_err,
        "reference": f"robodyn compiled RK4 at dt / {REF_DIVISOR}",
        "paths": paths,
        "speedup_vs_mujoco_rk4": paths["mujoco_rk4_c_loop"]["us_per_step"] / best,
        "simulate_call_over_compiled_loop": min(calls) / loop_wall,
    }


def single_with_stops(robot: robodyn.Robot, m, idx) -> dict:
    """Stops on: MuJoCo's RK4 loop with its limits against robodyn.simulate with its stops (robodyn's default)."""
    set_limits(m, True)
    try:
        duration = DURATION[robot.name]
        steps = round(duration / DT)
        q0, v0 = bench.start_state(robot)
        mj_time = _mujoco_time(m, idx, q0, v0, steps)
        activations = limit_activations(m, idx, q0, v0, steps)
    finally:
        set_limits(m, False)
    runs, calls = _simulate_runs(robot, q0, v0, duration, {"max_energy_growth": None})
    tr = runs[0]
    loop_wall = min(r.wall_time_s for r in runs)
    paths = {
        "mujoco_rk4_c_loop": {"us_per_step": 1e6 * mj_time / steps, "limit_activations": activations},
        "robodyn_simulate_compiled": {
            "us_per_step": 1e6 * loop_wall / steps,
            "backend": tr.meta["backend"],
            "loop": tr.meta["loop"],
            "impacts": tr.meta["impacts"],
            "releases": tr.meta["releases"],
            "event_steps": tr.meta.get("event_steps"),
        },
    }
    return {
        "stops": "on",
        "duration": duration,
        "dt": DT,
        "steps": steps,
        "paths": paths,
        "impacts": tr.meta["impacts"],
        "mujoco_limit_activations": activations,
        "speedup_vs_mujoco_rk4": paths["mujoco_rk4_c_loop"]["us_per_step"]
        / paths["robodyn_simulate_compiled"]["us_per_step"],
        "simulate_call_over_compiled_loop": min(calls) / loop_wall,
    }


def batched(robot: robodyn.Robot, m, idx) -> dict:
    import mujoco
    from mujoco import rollout

    steps = BATCH_STEPS[robot.name]
    robot.model.damping[:] = 0.0  # the batch path is lossless
    m.dof_damping[:] = 0.0
    rng = np.random.default_rng(42)
    Q = (
        rng.uniform(-np.pi, np.pi, (BATCH, robot.nq))
        if robot.nv <= 2
        else robot.neutral() + rng.uniform(-1, 1, (BATCH, robot.nq))
    )
    V = rng.uniform(-1.0, 1.0, (BATCH, robot.nv))
    size = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    state0 = np.zeros((BATCH, size))
    state0[:, 1 + idx] = Q
    state0[:, 1 + m.nq + idx] = V
    out: dict = {"states": BATCH, "steps": steps, "threads": {}}
    for threads in (1, 2):
        ours = [batch.rollout(robot, Q, V, duration=steps * DT, dt=DT, threads=threads) for _ in range(REPEATS)]
        best = min(ours, key=lambda r: r.wall_time_s)
        datas = [mujoco.MjData(m) for _ in range(threads)]
        mj_times = []
        for _ in range(REPEATS):
            start = time.perf_counter()
            states, _ = rollout.rollout(m, datas, state0, nstep=steps)
            mj_times.append(time.perf_counter() - start)
        final = states[:, -1, :]
        q_mj, v_mj = final[:, 1 + idx], final[:, 1 + m.nq + idx]
        work = BATCH * steps
        out["threads"][str(threads)] = {
            "robodyn_us_per_state_step": 1e6 * best.wall_time_s / work,
            "robodyn_path": best.path,
            "mujoco_rollout_us_per_state_step": 1e6 * min(mj_times) / work,
            "ratio_mujoco_over_robodyn": min(mj_times) / best.wall_time_s,
            "max_final_state_difference": float(max(np.max(np.abs(q_mj - best.q)), np.max(np.abs(v_mj - best.v)))),
        }
    out["default_threads_now"] = batch.default_threads()
    return out


def main() -> int:
    parser = argument_parser(__doc__)
    parser.add_argument("--busy", action="store_true", help="run a CPU-bound process during the measurement")
    parser.add_argument("--systems", default=",".join(SYSTEMS), help=f"comma-separated, from {', '.join(SYSTEMS)}")
    args = parser.parse_args()
    import mujoco

    names = [s for s in args.systems.split(",") if s]
    unknown = [s for s in names if s not in SYSTEMS]
    if unknown:
        parser.error(f"unknown system(s) {', '.join(unknown)}; expected some of {', '.join(SYSTEMS)}")
    out = output_folder(args.out, overwrite_committed=args.overwrite_committed)
    stem = "bench_mujoco_busy" if args.busy else "bench_mujoco"
    facts = run_facts()
    facts["mujoco"] = mujoco.__version__
    stop = multiprocessing.Event()
    spinner = multiprocessing.Process(target=_spin, args=(stop,), daemon=True) if args.busy else None
    if spinner is not None:
        spinner.start()
        time.sleep(1.0)
    results: dict = {}
    try:
        for name in names:
            robot = prepare(name)
            m, idx = mujoco_model(robot)
            check = confirm_same_model(robot, m, idx) | same_limits(robot, m)
            stopped = single_with_stops(robot, m, idx)
            one = single(robot, m, idx)
            print(
                f"{name} (nv = {robot.nv}): MuJoCo vs Pinocchio M {check['mass_matrix_rel_diff']:.1e}, "
                f"bias {check['bias_rel_diff']:.1e}; single RK4 trajectory, dt = 1 ms, {one['duration']:g} s"
            )
            print(
                f"  stops on: robodyn {stopped['impacts']} impacts "
                f"({stopped['paths']['robodyn_simulate_compiled']['event_steps']} event steps), "
                f"MuJoCo {stopped['mujoco_limit_activations']} limit activations"
            )
            for path, p in stopped["paths"].items():
                print(f"  {path + ', stops on':40s} {p['us_per_step']:9.3f} us/step")
            print(f"  robodyn.simulate vs MuJoCo RK4, stops on: {stopped['speedup_vs_mujoco_rk4']:.2f}x")
            for path, p in one["paths"].items():
                err = f"error at t = {one['error_at_s']:g} s {p['error']:.2e}" if "error" in p else ""
                print(f"  {path + ', stops off':40s} {p['us_per_step']:9.3f} us/step   {err}")
            print(
                f"  robodyn's best vs MuJoCo RK4, stops off: {one['speedup_vs_mujoco_rk4']:.2f}x; robodyn.simulate's "
                f"whole call over its compiled loop: {one['simulate_call_over_compiled_loop']:.2f}x"
            )
            many = batched(robot, m, idx)
            for threads, b in many["threads"].items():
                print(
                    f"  batch of {BATCH}, {many['steps']} RK4 steps, {threads} thread(s): "
                    f"robodyn ({b['robodyn_path']}) "
                    f"{b['robodyn_us_per_state_step']:.3f}, mujoco.rollout {b['mujoco_rollout_us_per_state_step']:.3f} "
                    f"us/state-step: {b['ratio_mujoco_over_robodyn']:.2f}x; final states differ by "
                    f"{b['max_final_state_difference']:.1e}"
                )
            results[name] = {
                "nv": robot.nv,
                "model_check": check,
                "single": one,
                "single_stops_on": stopped,
                "batch": many,
            }
    finally:
        if spinner is not None:
            stop.set()
            spinner.join(5)
    target = write_json(out, stem, {"busy": args.busy, "systems": results}, facts)
    run = json.loads(target.read_text())["run"]
    print(f"load average (1, 5, 15 min) before {run['load_before']}, after {run['load_after']}; busy mode {args.busy}")
    labels, values = [], []
    for name, r in results.items():
        for key, stops in (("single_stops_on", "stops on"), ("single", "stops off")):
            for path, p in r[key]["paths"].items():
                labels.append(f"{name} single, {stops}: {path}")
                values.append(p["us_per_step"])
        for threads, b in r["batch"]["threads"].items():
            labels += [f"{name} batch {threads} thr: robodyn", f"{name} batch {threads} thr: mujoco.rollout"]
            values += [b["robodyn_us_per_state_step"], b["mujoco_rollout_us_per_state_step"]]
    charts.speed_bars(
        labels,
        values,
        out / stem,
        unit="microseconds per (state-)step, log scale",
        title=f"RK4, dt = 1 ms: robodyn against MuJoCo{' (busy)' if args.busy else ''}",
    )
    print(f"wrote {target} and {stem}.png/.svg")
    return 0


if __name__ == "__main__":
    sys.exit(main())
