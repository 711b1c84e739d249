"""Stop events inside the compiled loop (engine/tree/events.py) against the Python event stepper (sim/events.py).

The compiled loop takes every step of a run on a compiled tree, the steps with an impact, a
hold or a release included, with the event stepper's arithmetic; ``backend="aba"`` runs the
Python pipeline and its :class:`~robodyn.sim.events.EventStepper`, the reference. Both must
find the same impacts, in the same order, at the same times, and the same motion and books.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.cli._summary import _loop_phrase
from robodyn.errors import DivergenceError
from robodyn.sim.events import MAX_EVENTS_PER_STEP
from robodyn.studies.bench import start_state

from .test_constraints import LOOP, closed, linkage_urdf
from .test_couplings import chain

# Two float64 implementations of the dynamics (compiled world-frame ABA vs Pinocchio) step the
# same method at the same steps; each event is located to round-off of the step (LOCATE_RTOL
# 1e-15 x 1 ms): impact times agree to 1e-12 s, the motion to 1e-10 rad (measured on the
# Panda's 2 s from the bench start: 6e-14 s and 4e-13 rad).
TIME_ATOL = 1e-12
Q_ATOL = 1e-10
# The stops' work, relative to the largest |W_limits| of the run (measured 1.3e-12 J of 3.9 J).
WORK_RTOL = 1e-10


def _both(robot: robodyn.Robot, q0, v0, **kw):  # type: ignore[no-untyped-def]
    got = robodyn.simulate(robot, q0, v0, **kw)
    ref = robodyn.simulate(robot, q0, v0, backend="aba", **kw)
    assert got.meta["loop"] == "compiled" and ref.meta["loop"] == "python"
    return got, ref


def _same_events(got: robodyn.Trajectory, ref: robodyn.Trajectory) -> None:
    """The same impacts in the same order at the same times, the same releases, motion and stops' work."""
    for key in ("impacts", "releases", "held_at_end"):
        assert got.meta[key] == ref.meta[key], (key, got.meta[key], ref.meta[key])
    a, b = got.meta["impact_log"], ref.meta["impact_log"]
    assert [(r["joint"], r["side"]) for r in a] == [(r["joint"], r["side"]) for r in b]
    assert max(abs(x["time"] - y["time"]) for x, y in zip(a, b, strict=True)) < TIME_ATOL
    assert np.max(np.abs(got.q - ref.q)) < Q_ATOL
    scale = max(1.0, float(np.max(np.abs(ref.work_limits))))
    assert np.max(np.abs(got.work_limits - ref.work_limits)) < WORK_RTOL * scale
    dT = np.array([r["energy_change"] for r in a]) - np.array([r["energy_change"] for r in b])
    assert np.max(np.abs(dT)) < WORK_RTOL * scale


def test_the_panda_falling_onto_its_stops_for_2_s_matches_the_event_stepper() -> None:
    # the bench's start, torque-free, RK4 at 1 ms: 26 impacts and 30 releases, all inside the compiled loop
    robot = robodyn.load("panda")
    q0, v0 = start_state(robot)
    got, ref = _both(robot, q0, v0, duration=2.0, dt=1e-3, integrator="rk4")
    assert ref.meta["impacts"] > 20 and ref.meta["releases"] > 20
    assert got.meta["event_steps"] > 20  # taken by the compiled loop, not handed to Python
    _same_events(got, ref)


def test_talos_with_a_fixed_base_matches_the_event_stepper() -> None:
    # the bench's start: torso_2 then both knees (leg_*_4) strike their lower stops near 0.2 s and are held.
    # At 0.5 ms: at 1 ms RK4 barely holds arm_right_7 (a light wrist), whose round-off then grows by 1e8 in
    # 0.3 s on either path (events or none), and no two implementations agree to 1e-10 rad there.
    robot = robodyn.load("talos")
    q0, v0 = start_state(robot)
    got, ref = _both(robot, q0, v0, duration=0.25, dt=5e-4, integrator="rk4")
    assert ref.meta["impacts"] == 3 and ref.meta["held_at_end"]
    _same_events(got, ref)


@pytest.mark.parametrize("e", [0.0, 0.5])
def test_the_cart_striking_its_rail_end_matches_the_event_stepper(e: float) -> None:
    # the cart runs into the end of its rail (+2.4 m) at 1 m/s: held there (e = 0, then pulled off by the
    # pole: a release), or bouncing back (e = 0.5)
    robot = robodyn.load("cart_pole")
    got, ref = _both(robot, [2.3, 0.0], [1.0, 0.0], duration=0.5, dt=1e-3, restitution=e)
    assert ref.meta["impacts"] >= 1
    assert ref.meta["impact_log"][0]["speed_after"] == pytest.approx(-e * ref.meta["impact_log"][0]["speed_before"])
    _same_events(got, ref)


def test_loops_and_couplings_go_to_the_python_loop_and_say_why(tmp_path: Path) -> None:
    # the compiled loop takes trees only: a closed linkage and a coupled chain run in the Python pipeline,
    # and the metadata and the CLI's summary say why in one line
    linkage = robodyn.load(linkage_urdf(tmp_path / "linkage.urdf"))
    looped = robodyn.simulate(linkage, closed(0.3), [0, 0, 0], duration=0.01, dt=1e-3, loops=LOOP)
    robot = chain(tmp_path)
    coupling = {"joint": "b_follow", "leader": "a_lead", "ratio": 2.0, "offset": 0.5}
    coupled = robodyn.simulate(robot, [0.0], [0.0], duration=0.01, dt=1e-3, couplings=[coupling])
    for traj, why in ((looped, "loop closures are solved by Pinocchio"), (coupled, "couplings are mimic joints")):
        assert traj.meta["loop"] == "python"
        assert traj.meta["compiled_loop"] == f"not used: {why}"
        assert _loop_phrase(traj.meta) == f"Python loop: {why}"


def test_a_joint_chattering_on_its_stop_is_handed_back_with_the_event_steppers_reason() -> None:
    # Talos from its neutral pose at 0.5 ms: the first step has more than MAX_EVENTS_PER_STEP stop events.
    # The compiled loop stops there and hands the run to the Python pipeline, which writes the report.
    robot = robodyn.load("talos")
    kw = {"duration": 0.002, "dt": 5e-4, "integrator": "rk4"}
    with pytest.raises(DivergenceError) as got:
        robodyn.simulate(robot, robot.neutral(), np.zeros(robot.nv), **kw)  # type: ignore[arg-type]
    with pytest.raises(DivergenceError) as ref:
        robodyn.simulate(robot, robot.neutral(), np.zeros(robot.nv), backend="aba", **kw)  # type: ignore[arg-type]
    assert str(got.value) == str(ref.value) and "(chattering)" in str(ref.value)
    meta = got.value.trajectory.meta
    assert meta["loop"] == "python" and meta["compiled_loop"].startswith(f"not used: more than {MAX_EVENTS_PER_STEP}")
    assert meta["compiled_loop"].endswith("(chattering) at step 1 (t = 0.0005 s)")


# The plain numbers the stop kernels may write: halves (a bisection, ½ v M v), doubles and units.
KERNEL_LITERALS = {0.0, 0.5, 1.0, 2.0}


def test_the_stop_kernels_hold_no_constant_of_their_own_they_take_the_python_steppers() -> None:
    """One specification: every tolerance of the compiled stops is sim/events.py's or sim/limits.py's, passed in."""
    import ast

    from robodyn.engine.tree import impacts as k
    from robodyn.sim import events, limits, tree, whole_run
    from robodyn.sim.constraints import Constraints
    from robodyn.sim.system import robot_system

    engine = Path(__file__).resolve().parents[1] / "src" / "robodyn" / "engine" / "tree"
    for name in ("events.py", "impacts.py"):
        module = ast.parse((engine / name).read_text())
        floats = {n.value for n in ast.walk(module) if isinstance(n, ast.Constant) and isinstance(n.value, float)}
        assert floats <= KERNEL_LITERALS, (
            f"engine/tree/{name} writes {sorted(floats - KERNEL_LITERALS)}: pass it in par"
        )
    robot = robodyn.load("cart_pole")
    system = robot_system(robot, constraints=Constraints(restitution=0.5))
    _, par = whole_run._event_arrays(system, tree.extract(robot))
    expected = {
        k.P_LOCATE_RTOL: events.LOCATE_RTOL,
        k.P_LOCATE_FTOL: events.LOCATE_FTOL,
        k.P_NOISE_RTOL: events.FORCE_NOISE_RTOL,
        k.P_RELEASE_TOL: events.RELEASE_TOL,
        k.P_PULL_RTOL: limits.PULL_RTOL,
        k.P_ITERATIONS: events.LOCATE_ITERATIONS,
        k.P_MAX_EVENTS: events.MAX_EVENTS_PER_STEP,
        k.P_RESTITUTION: 0.5,
        k.P_RCOND: limits.IMPACT_RCOND,
    }
    assert len(par) == k.PCOLS
    assert {slot: par[slot] for slot in expected} == expected
