"""Joint stops: impacts against an independent oracle, restitution, holding and letting go, the books, the Panda.

The oracle for an impact is SciPy's DOP853 with event location on the smooth dynamics of
Robot.forward_dynamics (no robodyn integrator, no robodyn event code), and the textbook loss
1/2 (J v)^2 / (J M^-1 J^T) (1 - e^2) evaluated there with numpy's own inverse of M.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import robodyn
from robodyn.errors import InputError
from robodyn.sim.simulation import simulate

# The cart-pole's rail end and a start that reaches it in ~0.41 s.
RAIL = 2.4  # [m]
CART_START = ([2.0, 0.1], [1.0, 0.0])
# Impact time and loss against DOP853 at rtol = atol = 1e-12: both integrate the same ODE to
# ~1e-11; the event is located to round-off by both.
IMPACT_TIME_TOL = 1e-9  # [s]
IMPACT_LOSS_RTOL = 1e-8
# Rebound speed -e v: the impulse is solved exactly (a 1-row Delassus solve).
REBOUND_RTOL = 1e-12
# The books with stops, RK4 at dt = 1e-3 over 2 s: the smooth pieces carry RK4's error
# (measured 3e-12 J on a 1 J scale); a dropped impact loss is ~0.5 J.
LEDGER_RTOL = 1e-9
# A held joint sits exactly on its bound, and a located impact puts it there: past a bound
# by at most round-off.
VIOLATION_TOL = 1e-12  # [rad | m]

STOP = 0.5  # [rad], the pendulum's lower stop
PENDULUM_URDF = """<?xml version="1.0"?>
<robot name="stopped_pendulum">
  <link name="base"/>
  <link name="bob">
    <inertial><origin xyz="0 0 -0.5"/><mass value="1.0"/>
      <inertia ixx="1e-3" iyy="1e-3" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="swing" type="revolute">
    <parent link="base"/><child link="bob"/><axis xyz="0 1 0"/>
    <limit lower="0.5" upper="3.0" effort="{effort}" velocity="100"/>
  </joint>
</robot>
"""


def pendulum(tmp_path: Path, effort: float = 5.0) -> robodyn.Robot:
    """A 1 kg bob 0.5 m from its pivot, hanging at 0 rad, with a stop at 0.5 rad: gravity holds it on the stop."""
    path = tmp_path / "stopped_pendulum.urdf"
    path.write_text(PENDULUM_URDF.format(effort=effort))
    return robodyn.load(path)


def oracle_impact(robot: robodyn.Robot, q0: list[float], v0: list[float]) -> tuple[float, np.ndarray, np.ndarray]:
    """(time, q, v) at which the slider first reaches +RAIL: DOP853 with event location."""
    n = robot.nq
    tau = np.zeros(robot.nv)

    def fun(_: float, y: np.ndarray) -> np.ndarray:
        return np.concatenate([y[n:], robot.forward_dynamics(y[:n], y[n:], tau)])

    def hit(_: float, y: np.ndarray) -> float:
        return float(y[0] - RAIL)

    hit.terminal = True  # type: ignore[attr-defined]
    sol = solve_ivp(fun, (0.0, 2.0), np.concatenate([q0, v0]), method="DOP853", rtol=1e-12, atol=1e-12, events=hit)
    assert sol.status == 1, "the oracle never reached the rail's end"
    y = sol.y_events[0][0]
    return float(sol.t_events[0][0]), y[:n], y[n:]


def analytic_loss(robot: robodyn.Robot, q: np.ndarray, v: np.ndarray, row: np.ndarray, e: float) -> float:
    """1/2 (J v)^2 / (J M^-1 J^T) (1 - e^2) [J], with numpy's inverse of M."""
    Minv = np.linalg.inv(robot.M(q))
    return 0.5 * float(row @ v) ** 2 / float(row @ Minv @ row) * (1.0 - e**2)


@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_rail_end_impact_matches_the_oracle_and_the_textbook_loss(e: float) -> None:
    robot = robodyn.load("cart_pole")
    traj = simulate(robot, *CART_START, duration=1.0, dt=1e-3, restitution=e)
    first = traj.meta["impact_log"][0]
    t_hit, q_hit, v_hit = oracle_impact(robot, *CART_START)
    assert first["joint"] == "slider" and first["side"] == "upper"
    assert abs(first["time"] - t_hit) < IMPACT_TIME_TOL
    row = np.array([-1.0, 0.0])  # the upper stop pushes towards -x
    expected = analytic_loss(robot, q_hit, v_hit, row, e)
    assert -first["energy_change"] == pytest.approx(expected, rel=IMPACT_LOSS_RTOL, abs=1e-15)
    assert first["speed_after"] == pytest.approx(-e * first["speed_before"], rel=REBOUND_RTOL, abs=1e-15)
    k = int(np.searchsorted(traj.t, first["time"]))  # the first sample after the impact
    assert traj.work_limits[k - 1] == 0.0 and traj.work_limits[k] == pytest.approx(first["energy_change"])
    assert traj.max_ledger_residual < LEDGER_RTOL * traj.meta["energy_scale"]
    assert traj.meta["limit_violation"] <= VIOLATION_TOL


def test_an_inelastic_stop_holds_the_cart_until_the_pole_pulls_it_off() -> None:
    robot = robodyn.load("cart_pole")
    traj = simulate(robot, *CART_START, duration=2.0, dt=1e-3)
    assert traj.meta["impacts"] >= 1 and traj.meta["releases"] >= 1
    at_stop = np.flatnonzero(traj.q[:, 0] == RAIL)
    assert at_stop.size > 10  # held for a while, exactly on the bound, at rest
    assert np.all(traj.v[at_stop, 0] == 0.0)
    assert traj.q[-1, 0] < RAIL  # let go again
    assert np.max(traj.q[:, 0]) <= RAIL
    assert traj.max_ledger_residual < LEDGER_RTOL * traj.meta["energy_scale"]


def test_without_limits_the_cart_runs_off_the_rail() -> None:
    robot = robodyn.load("cart_pole")
    traj = simulate(robot, *CART_START, duration=1.0, dt=1e-3, limits=False)
    assert traj.q[-1, 0] > RAIL and traj.meta["impacts"] == 0 and np.all(traj.work_limits == 0)
    assert traj.meta["stops"] == {}


# The impact time of each method against RK4's: its own error over 0.4 s at dt = 1e-3
# (first order for symplectic Euler: measured 2e-5 s; 2nd and 5th order: below 1e-7 s).
EVENT_TIME_TOL = {"dopri5": 1e-7, "symplectic_euler": 1e-4, "implicit_midpoint": 1e-6}
# Their books with the cart held and let go: within this factor of the same method's
# residual on the free motion over the same time (measured 2.2x symplectic Euler, 2.8x the
# implicit midpoint rule, 1.8x dopri5: the held motion is another motion, not a worse one).
METHOD_LEDGER_FACTOR = 5.0


@pytest.mark.parametrize("integrator", sorted(EVENT_TIME_TOL))
def test_stops_work_with_adaptive_and_symplectic_methods(integrator: str) -> None:
    robot = robodyn.load("cart_pole")
    traj = simulate(robot, *CART_START, duration=1.0, dt=1e-3, integrator=integrator)
    rk4 = simulate(robot, *CART_START, duration=1.0, dt=1e-3)
    assert traj.meta["impacts"] == rk4.meta["impacts"] and traj.meta["releases"] >= 1
    t_rk4 = rk4.meta["impact_log"][0]["time"]
    assert traj.meta["impact_log"][0]["time"] == pytest.approx(t_rk4, abs=EVENT_TIME_TOL[integrator])
    held = (traj.q[:-1, 0] == RAIL) & (traj.q[1:, 0] == RAIL)  # on the stop at both ends of a step
    assert held.sum() > 10 and np.all(traj.v[:-1][held, 0] == 0.0)  # the momentum form holds it still too
    assert np.max(traj.q[:, 0]) <= RAIL + VIOLATION_TOL
    free = simulate(robot, *CART_START, duration=1.0, dt=1e-3, integrator=integrator, limits=False)
    bound = METHOD_LEDGER_FACTOR * free.max_ledger_residual + 1e-12 * traj.meta["energy_scale"]
    assert traj.max_ledger_residual < bound


def test_a_bouncing_pendulum_comes_to_rest_on_its_stop(tmp_path: Path) -> None:
    robot = pendulum(tmp_path)
    traj = simulate(robot, [1.0], [0.0], duration=4.0, dt=1e-3, restitution=0.8)
    assert traj.meta["impacts"] > 5  # it bounced, with shrinking rebounds...
    speeds = [abs(r["speed_before"]) for r in traj.meta["impact_log"]]
    assert all(b < a for a, b in itertools.pairwise(speeds))
    assert traj.meta["held_at_end"] == ["swing"] and traj.q[-1, 0] == STOP  # ...and rests on the stop
    # Everything above the stop's height went into the stop's book.
    assert traj.work_limits[-1] == pytest.approx(traj.energy[-1] - traj.energy[0], rel=1e-9)
    assert traj.max_ledger_residual < LEDGER_RTOL * traj.meta["energy_scale"]


def test_a_start_on_the_stop_moving_into_it_hits_it_at_once(tmp_path: Path) -> None:
    robot = pendulum(tmp_path)
    traj = simulate(robot, [STOP], [-2.0], duration=0.1, dt=1e-3)
    first = traj.meta["impact_log"][0]
    assert first["time"] == 0.0 and first["speed_after"] == 0.0
    assert traj.work_limits[1] == pytest.approx(-0.5 * robot.M([STOP])[0, 0] * 2.0**2, rel=1e-12)
    assert np.all(traj.q[1:, 0] == STOP)


def test_q0_outside_a_stop_is_moved_onto_it_and_said() -> None:
    robot = robodyn.load("cart_pole")
    traj = simulate(robot, [3.0, 0.0], [0.0, 0.0], duration=0.01, dt=1e-3)
    assert traj.q[0, 0] == RAIL and traj.meta["q0_clamped"] == {"slider": [3.0, RAIL]}


def test_free_joints_say_why_they_have_no_stop(tmp_path: Path) -> None:
    urdf = tmp_path / "wheel.urdf"
    urdf.write_text(PENDULUM_URDF.format(effort=1.0).replace('type="revolute"', 'type="continuous"'))
    meta = simulate(robodyn.load(urdf), [0.3], [0.0], duration=0.01, dt=1e-3).meta
    assert meta["stops"] == {} and "continuous" in meta["free_joints"]["swing"]
    # The built-in models: the rail has ends; the pole turns freely (no stop within reach).
    meta = simulate(robodyn.load("cart_pole"), [0.0, 0.1], [0.0, 0.0], duration=0.01, dt=1e-3).meta
    assert meta["stops"]["slider"] == [-RAIL, RAIL] and meta["stops"]["hinge"] == [-1000.0, 1000.0]


@pytest.mark.slow
def test_panda_torque_free_keeps_every_joint_inside_its_limits() -> None:
    robot = robodyn.load("panda")
    lower, upper = np.array(robot.model.lowerPositionLimit), np.array(robot.model.upperPositionLimit)
    traj = simulate(robot, robot.neutral(), np.zeros(robot.nv), duration=2.0, dt=1e-3)
    past = np.maximum(lower - traj.q, traj.q - upper).max()
    assert past <= VIOLATION_TOL and traj.meta["limit_violation"] <= VIOLATION_TOL
    fingers = traj.q[:, 7:]
    assert fingers.min() >= 0.0 and fingers.max() <= 0.04  # 4 cm slides (7.7 m apart without stops)
    assert traj.meta["impacts"] > 0 and traj.work_limits[-1] < 0
    assert traj.max_ledger_residual < 1e-7 * traj.meta["energy_scale"]  # RK4 at 1 ms through the impacts
    free = simulate(robot, robot.neutral(), np.zeros(robot.nv), duration=2.0, dt=1e-3, limits=False)
    assert np.abs(free.q[-1, 7:]).max() > 1.0  # the fingers fly off without their stops


# ----------------------------------------------------------------------------- effort limits
def test_constant_torque_beyond_the_effort_is_clamped_and_counted() -> None:
    robot = robodyn.load("cart_pole")  # slider effort 20 N
    traj = simulate(robot, [0.0, 0.0], [0.0, 0.0], duration=0.2, dt=1e-3, torque=[30.0])
    np.testing.assert_array_equal(traj.tau[:, 0], 20.0)
    assert traj.meta["effort_clamped_samples"] == traj.t.size
    assert traj.meta["effort_limits"] == {"slider": 20.0}
    loose = simulate(robot, [0.0, 0.0], [0.0, 0.0], duration=0.2, dt=1e-3, torque=[30.0], effort_limits=False)
    np.testing.assert_array_equal(loose.tau[:, 0], 30.0)
    assert loose.meta["effort_clamped_samples"] == 0 and loose.q[-1, 0] > traj.q[-1, 0]
    # The work booked is the clamped force's: 20 N times the displacement.
    np.testing.assert_allclose(traj.work_input, 20.0 * traj.q[:, 0], rtol=0, atol=1e-10)
    # A controller that asks for 30 N is clamped inside the dynamics too: the same motion.
    controller = simulate(robot, [0.0, 0.0], [0.0, 0.0], duration=0.2, dt=1e-3, torque=lambda t, q, v: [30.0])
    np.testing.assert_array_equal(controller.q, traj.q)
    assert controller.meta["effort_clamped_samples"] == traj.t.size


def test_an_effort_of_zero_declares_no_limit(tmp_path: Path) -> None:
    robot = pendulum(tmp_path, effort=0.0)
    traj = simulate(robot, [1.0], [0.0], duration=0.05, dt=1e-3, torque=[50.0])
    np.testing.assert_array_equal(traj.tau[:, 0], 50.0)
    assert traj.meta["effort_clamped_samples"] == 0 and traj.meta["effort_limits"] == {}


def test_restitution_outside_0_1_is_one_line() -> None:
    robot = robodyn.load("cart_pole")
    for e in (-0.1, 1.5, float("nan")):
        with pytest.raises(InputError) as info:
            simulate(robot, [0.0, 0.0], [0.0, 0.0], duration=0.01, dt=1e-3, restitution=e)
        assert "restitution" in str(info.value) and "\n" not in str(info.value)
