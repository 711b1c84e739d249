"""Joint stops in the compiled loop: held joints locked in the compiled ABA, events taken inside the loop.

The compiled loop steps with the held joints locked, and takes the step with an impact, a
hold or a release with the event stepper's arithmetic, compiled (engine/tree/events.py,
sim/whole_run.py). These tests
check the locked ABA and its stop force against the Python pipeline's hold solve, and whole
runs with impacts, holds and releases against the Python pipeline (``backend="aba"``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.cli import main
from robodyn.errors import AssumptionError, DivergenceError, SimulationInterrupted
from robodyn.sim import tree, whole_run
from robodyn.sim.system import robot_system
from tests.test_limits import PENDULUM_URDF

# Locked ABA and its stop force against the Pinocchio hold solve, relative to the largest entry
# (two float64 implementations: world-frame ABA vs a Cholesky solve of M's free block).
LOCKED_RTOL = 1e-12
# Whole runs with events, compiled loop + event stepper vs the Python pipeline: the same
# method and steps, accelerations differing by round-off, events located to round-off;
# measured 8.6e-14 rad on the Panda over 2 s (27 impacts, 37 releases).
TRAJECTORY_ATOL = 1e-10


def _pendulum(tmp_path: Path) -> robodyn.Robot:
    path = tmp_path / "stopped_pendulum.urdf"  # a 1 kg bob 0.5 m from its pivot, a stop at 0.5 rad
    path.write_text(PENDULUM_URDF.format(effort=5.0))
    return robodyn.load(path)


def _compiled_rates(robot: robodyn.Robot, held: dict[str, int], q: np.ndarray, v: np.ndarray):  # type: ignore[no-untyped-def]
    """(a, lambda by index in v) of the compiled ABA with the joints of ``held`` (name -> side) locked."""
    k = tree.kernels()
    tr = tree.compiled_of(robot).tree
    nv = robot.nv
    rows = {int(tr.itree[i, 3]): i for i in range(tr.itree.shape[0])}
    index_v = {j.name: int(j.idx_v) for j in robot.joints}
    hv = [index_v[name] for name in held]
    locked = np.array([[float(rows[i]) for i in hv], [float(s) for s in held.values()]]).reshape(2, -1)
    ws = np.zeros((tr.itree.shape[0], k.WCOLS))
    k.lock(ws, locked)
    forces = np.zeros((4, nv))
    forces[3, 0] = 1e-3
    out = np.empty(nv + 2)
    u = np.concatenate([v, [0.0, 0.0]])
    k.rates(tr.itree, tr.ftree, tr.grav, tr.flyer, 0.0, q, u, forces, np.zeros((4, 0)), -1, ws, np.empty(nv), out)
    lam = np.zeros(nv)
    for i in hv:
        lam[i] = ws[rows[i], k.W_LAMBDA]
    return out[:nv], lam


@pytest.mark.parametrize("held", [{"panda_joint4": -1}, {"panda_joint2": 1, "panda_finger_joint1": -1}])
def test_locked_aba_and_its_stop_force_match_the_hold_solve(held: dict[str, int]) -> None:
    robot = robodyn.load("panda")
    robot.model.friction[:] = 0.0
    robot.model.damping[:] = 0.0
    system = robot_system(robot)
    stops = system.stops
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, v = robot.random_state(rng)
        for name in held:
            v[list(robot.joint_names).index(name)] = 0.0  # a held joint does not move
        system.hold({list(stops.names).index(name): side for name, side in held.items()}, q)
        u = np.concatenate([v, np.zeros(system.nw)])
        a_ref = system.rates(0.0, q, u)[: robot.nv]
        lam_ref = system.stop_forces(0.0, q, u)
        a, lam = _compiled_rates(robot, held, q, v)
        scale = max(float(np.max(np.abs(a_ref))), 1.0)
        assert np.max(np.abs(a - a_ref)) / scale < LOCKED_RTOL
        assert all(a[list(robot.joint_names).index(name)] == 0.0 for name in held)
        lam_scale = max(float(np.max(np.abs(lam_ref))), 1.0)
        assert np.max(np.abs(lam - lam_ref)) / lam_scale < LOCKED_RTOL, (lam, lam_ref)
        assert np.max(np.abs(lam_ref)) > 1e-3  # the stops do push: the comparison is not of zeros


def _both(robot: robodyn.Robot, q0, v0, **kw):  # type: ignore[no-untyped-def]
    got = robodyn.simulate(robot, q0, v0, **kw)
    ref = robodyn.simulate(robot, q0, v0, backend="aba", **kw)
    return got, ref


def _same_events(got: robodyn.Trajectory, ref: robodyn.Trajectory) -> None:
    for key in ("impacts", "releases", "held_at_end"):
        assert got.meta[key] == ref.meta[key], key
    assert np.max(np.abs(got.q - ref.q)) < TRAJECTORY_ATOL
    assert np.max(np.abs(got.v - ref.v)) < 1e2 * TRAJECTORY_ATOL
    assert np.max(np.abs(got.work_limits - ref.work_limits)) < TRAJECTORY_ATOL * max(1.0, abs(ref.work_limits[-1]))
    ledger = got.kinetic + got.potential - got.kinetic[0] - got.potential[0]
    ledger -= got.work_input + got.work_damping + got.work_limits
    ledger_ref = ref.kinetic + ref.potential - ref.kinetic[0] - ref.potential[0]
    ledger_ref -= ref.work_input + ref.work_damping + ref.work_limits
    assert np.max(np.abs(ledger - ledger_ref)) < TRAJECTORY_ATOL * max(1.0, float(np.max(np.abs(ref.kinetic))))


def test_a_slider_striking_its_stop_runs_compiled() -> None:
    robot = robodyn.load("cart_pole")  # rail +-2.4 m
    got, ref = _both(robot, [2.3, 0.0], [1.0, 0.0], duration=0.5, dt=1e-3)
    assert got.meta["loop"] == "compiled" and got.meta["compiled_loop"] == "ran"
    assert 1 <= got.meta["event_steps"] <= 5
    assert got.meta["impacts"] >= 1
    _same_events(got, ref)


def test_the_panda_from_its_neutral_pose_on_a_stop_runs_compiled() -> None:
    # panda_joint4's range excludes 0: q0 is clamped onto its upper stop, held from step 0;
    # the arm then falls onto other stops (27 impacts, 37 releases in 2 s at 1 ms).
    robot = robodyn.load("panda")
    got, ref = _both(robot, robot.neutral(), np.zeros(robot.nv), duration=1.0, dt=1e-3)
    assert got.meta["loop"] == "compiled"
    assert got.meta["impacts"] > 5 and got.meta["releases"] > 5
    assert got.meta["event_steps"] < 100  # of 1000 steps: the compiled loop takes the rest
    _same_events(got, ref)
    # the evaluations counted: 4 per compiled step, plus the event steps' own
    assert got.evaluations >= 4 * (1000 - got.meta["event_steps"])


def test_a_held_joint_lets_go_where_its_stop_force_crosses_zero(tmp_path: Path) -> None:
    # The bob rests on its stop at 0.5 rad, pressed by gravity (m g l sin 0.5 = 2.3517 N m);
    # a torque rising as 10 t N m lifts it off at t* = 0.23517 s exactly, and not before.
    robot = _pendulum(tmp_path)
    g_torque = 1.0 * 9.81 * 0.5 * np.sin(0.5)
    t_star = g_torque / 10.0

    def ramp(t: float, q: np.ndarray, v: np.ndarray) -> list[float]:
        return [10.0 * t]

    got, ref = _both(robot, [0.5], [0.0], duration=0.4, dt=1e-3, torque=ramp)
    assert got.meta["loop"] == "compiled" and got.meta["releases"] == ref.meta["releases"] == 1
    assert got.meta["event_steps"] <= 3
    _same_events(got, ref)
    on_stop = got.t[got.q[:, 0] == 0.5]
    assert on_stop.max() == pytest.approx(t_star, abs=1e-3)  # the last sample on the stop is the step before t*
    assert np.all(got.q[got.t > t_star + 1e-3, 0] > 0.5)


def test_a_run_that_diverges_after_events_gets_the_python_report(tmp_path: Path) -> None:
    # explicit Euler at 20 ms with an elastic stop: five impacts, then the energy bound at step 142
    robot = _pendulum(tmp_path)
    kw = {"duration": 20.0, "dt": 0.02, "integrator": "euler", "restitution": 1.0}
    with pytest.raises(DivergenceError) as got:
        robodyn.simulate(robot, [1.0], [0.0], **kw)  # type: ignore[arg-type]
    with pytest.raises(DivergenceError) as ref:
        robodyn.simulate(robot, [1.0], [0.0], backend="aba", **kw)  # type: ignore[arg-type]
    assert str(got.value) == str(ref.value)
    a, b = got.value.trajectory, ref.value.trajectory
    assert a.meta["loop"] == "python" and "energy error" in a.meta["compiled_loop"]
    assert a.meta["impacts"] == b.meta["impacts"] == 5
    np.testing.assert_array_equal(a.q, b.q)  # the Python pipeline from the start, held set reset


def test_a_run_handed_back_while_a_joint_is_held_restarts_free(tmp_path: Path) -> None:
    # The bob falls from 1 rad onto its plastic stop and is held there; at t = 0.5 s the torque
    # callable turns NaN, the compiled loop hands the run back, and the Python pipeline runs
    # it again from q0, where the joint is free (not still held from the compiled attempt).
    robot = _pendulum(tmp_path)

    def spoiled(t: float, q: np.ndarray, v: np.ndarray) -> list[float]:
        return [np.nan if t > 0.5 else 0.0]

    kw = {"duration": 1.0, "dt": 1e-3, "torque": spoiled}
    with pytest.raises(DivergenceError) as got:
        robodyn.simulate(robot, [1.0], [0.0], **kw)  # type: ignore[arg-type]
    with pytest.raises(DivergenceError) as ref:
        robodyn.simulate(robot, [1.0], [0.0], backend="aba", **kw)  # type: ignore[arg-type]
    a, b = got.value.trajectory, ref.value.trajectory
    assert "not finite at step 501" in a.meta["compiled_loop"]
    assert str(got.value) == str(ref.value)
    assert a.meta["impacts"] == b.meta["impacts"] == 1 and a.meta["held_at_end"] == ["swing"]
    np.testing.assert_array_equal(a.q, b.q)
    assert a.evaluations == b.evaluations  # the abandoned attempt's event steps are not counted


ARM_URDF = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0.25 0 0"/><mass value="1.0"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial></link>
  <link name="l2"><inertial><origin xyz="0.2 0 0"/><mass value="0.5"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 1 0"/>
    <limit lower="-0.05" upper="0.05" effort="50" velocity="10"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.5 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-3.0" upper="3.0" effort="50" velocity="10"/></joint>
</robot>
"""


def _push_then_pull(tmp_path: Path, switch: float, duration: float):  # type: ignore[no-untyped-def]
    """j1 pressed onto its stop by -20 N m, then pulled off by +20 N m from ``switch`` [s]: compiled, ABA."""
    path = tmp_path / "arm.urdf"
    path.write_text(ARM_URDF)
    robot = robodyn.load(path)

    def torque(t: float, q: np.ndarray, v: np.ndarray) -> list[float]:
        return [-20.0 if t < switch else 20.0, 0.0]

    return _both(robot, [0.0, 0.3], [0.0, 0.0], duration=duration, dt=1e-3, torque=torque)


@pytest.mark.parametrize("block", [1, 2, 3, 5])
def test_a_release_at_the_end_of_a_compiled_block_is_taken_in_its_step(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, block: int
) -> None:
    # blocks of a few steps: the stop starts to pull at the last sample of some block, whose
    # step must be taken again by the event stepper (not the step after it)
    monkeypatch.setattr(whole_run, "BLOCK", block)
    for switch in (0.1205, 0.1237):
        got, ref = _push_then_pull(tmp_path, switch, 0.2)
        assert got.meta["releases"] == ref.meta["releases"] == 1
        _same_events(got, ref)


def test_a_release_in_the_last_step_is_taken(tmp_path: Path) -> None:
    # the pull starts inside the last step: the run ends with the joint let go, as in the Python pipeline
    got, ref = _push_then_pull(tmp_path, 0.1995, 0.2)
    assert got.meta["releases"] == ref.meta["releases"] == 1 and got.meta["held_at_end"] == []
    _same_events(got, ref)
    np.testing.assert_allclose(got.a[-1], ref.a[-1], rtol=1e-9, atol=1e-9)


def test_a_ctrl_c_in_the_torque_callable_keeps_the_stops_work(tmp_path: Path) -> None:
    # j1 strikes its stop (W_limits < 0) and is held; a Ctrl-C inside the controller at t = 0.2 s
    # stops the run: the samples kept carry the stop's work, and the books close as in the Python run
    path = tmp_path / "arm.urdf"
    path.write_text(ARM_URDF)
    robot = robodyn.load(path)
    runs = []
    for backend in (None, "aba"):
        fired = [False]

        def torque(t: float, q: np.ndarray, v: np.ndarray, fired: list[bool] = fired) -> list[float]:
            if t >= 0.2 and not fired[0]:
                fired[0] = True
                raise KeyboardInterrupt
            return [-20.0, 0.0]

        with pytest.raises(SimulationInterrupted) as info:
            robodyn.simulate(robot, [0.0, 0.3], [0.0, 0.0], duration=0.5, dt=1e-3, torque=torque, backend=backend)
        runs.append(info.value.trajectory)
    got, ref = runs
    assert got.meta["loop"] == "compiled" and got.n_steps == ref.n_steps
    assert ref.work_limits[-1] < -0.1  # the impact took energy
    np.testing.assert_allclose(got.work_limits, ref.work_limits, rtol=0, atol=1e-12)
    assert got.max_ledger_residual < 1e-9


def test_a_joint_resting_on_a_stop_unpressed_stays_in_the_compiled_loop() -> None:
    # the free-falling Panda: panda_finger_joint1 sits on its lower stop (0 m) and nothing presses it
    # there, so it is neither held nor struck; its steps are ordinary steps, not events
    robot = robodyn.load("panda", free_flyer=True)
    got, ref = _both(robot, robot.neutral(), np.zeros(robot.nv), duration=0.5, dt=1e-3)
    assert got.meta["loop"] == "compiled" and got.meta["event_steps"] <= 5
    # joints touch their stops at round-off speeds (1e-18 m/s) either way: which of them count as an
    # impact is decided by round-off, at no energy; the motion is the same
    assert np.max(np.abs(got.q - ref.q)) < TRAJECTORY_ATOL
    assert abs(got.work_limits[-1]) < 1e-15 and abs(ref.work_limits[-1]) < 1e-15
    assert got.max_ledger_residual < 1e-9


def test_the_steps_clear_of_the_stops_hand_over_to_the_events_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    # run_steps takes the steps clear of the stops, run_events the rest from the first that meets
    # one: the same arithmetic and counts as run_events taking every step (identical -> exact)
    robot = robodyn.load("cart_pole")  # rail +-2.4 m, struck near t = 0.1 s
    kw = {"duration": 0.3, "dt": 1e-3}
    got = robodyn.simulate(robot, [2.3, 0.0], [1.0, 0.0], **kw)  # type: ignore[arg-type]
    ev = tree.step_kernels()
    monkeypatch.setattr(ev, "run_steps", lambda *args: (ev.EVENTS, args[7]))  # hand every step over at once
    ref = robodyn.simulate(robot, [2.3, 0.0], [1.0, 0.0], **kw)  # type: ignore[arg-type]
    assert got.meta["compiled_loop"] == ref.meta["compiled_loop"] == "ran" and got.meta["impacts"] >= 1
    for name in ("q", "v", "a", "kinetic", "potential", "work_input", "work_damping", "work_limits"):
        np.testing.assert_array_equal(getattr(got, name), getattr(ref, name), err_msg=name)
    assert (got.evaluations, got.meta["event_steps"]) == (ref.evaluations, ref.meta["event_steps"])


def test_a_run_that_meets_no_stop_never_compiles_the_stop_events(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def refuse() -> None:
        raise AssertionError("the stop events were loaded for a run that meets no stop")

    monkeypatch.setattr(tree, "event_kernels", refuse)
    assert main(["simulate", "pendubot", "--duration", "0.2"]) == 0  # the README's first run
    assert "compiled loop" in capsys.readouterr().out


def test_a_run_that_meets_a_stop_checks_the_compiled_crba_first(monkeypatch: pytest.MonkeyPatch) -> None:
    """The stop events solve with the compiled CRBA: it is compared with Pinocchio's before the first stop is taken,
    and a CRBA that differs hands the run back to the Python loop (here: planted by a failing check)."""
    robot = robodyn.load("cart_pole")  # rail +-2.4 m
    got = robodyn.simulate(robot, [2.3, 0.0], [1.0, 0.0], duration=0.2, dt=1e-3)
    assert got.meta["loop"] == "compiled" and got.meta["impacts"] >= 1
    assert "crba" in tree.compiled_of(robot).check

    def differs(self: tree.CompiledDynamics, part: str) -> None:
        raise AssumptionError(f"{robot.name}: the compiled tree algorithms differ from Pinocchio's ({part} by 1)")

    monkeypatch.setattr(tree.CompiledDynamics, "ensure_checked", differs)
    handed = robodyn.simulate(robot, [2.3, 0.0], [1.0, 0.0], duration=0.2, dt=1e-3)
    assert handed.meta["loop"] == "python" and "crba by 1" in handed.meta["compiled_loop"]
    assert handed.meta["impacts"] == got.meta["impacts"]


def test_a_free_flying_robot_loads_only_the_free_flyer_kernels(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each variant is compiled apart (tens of seconds): a free-flying robot must not ask for the fixed-base one."""
    asked: list[bool] = []
    kernels = tree.kernels

    def recorded(flyer: bool = False):  # type: ignore[no-untyped-def]
        asked.append(flyer)
        return kernels(flyer)

    monkeypatch.setattr(tree, "kernels", recorded)
    robot = robodyn.load("panda", free_flyer=True)
    compiled = tree.compiled_of(robot)
    q, v = robot.random_state(np.random.default_rng(3))
    compiled.acceleration(q, v, np.zeros(robot.nv))
    compiled.energies(q, v)
    assert asked and all(asked), asked


def test_compiled_dynamics_kept_across_an_edit_of_the_model_say_so() -> None:
    """RNEA and CRBA are checked at first use: on an edited model the refusal names the edit, not a disagreement."""
    robot = robodyn.load("pendubot")
    compiled = tree.compiled_of(robot)
    robot.model.inertias[2].mass = 2.0 * robot.model.inertias[2].mass
    with pytest.raises(AssumptionError, match="was edited after its compiled dynamics were made"):
        compiled.mass_matrix(robot.neutral())
    assert tree.compiled_of(robot).mass_matrix(robot.neutral()).shape == (2, 2)  # made again: checked and served
