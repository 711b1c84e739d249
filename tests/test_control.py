"""robodyn.control: LQR balance, energy swing-up, the hand-over, the names and a user's controller file."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

import robodyn
import robodyn.control as control
from robodyn.control import pfl, region, rollout
from robodyn.control.plant import wrap
from robodyn.errors import InputError, UnknownNameError

DT = 2e-3  # [s] the step the swing-up times below were measured at (benchmarks/bench_control.py)
# Swing-up from hanging at rest, measured by the benchmark (RK4, dt = 2 ms): upright within
# 0.05 rad and staying from then on. The test allows 1.5 times that, then 3 s more to stay.
MEASURED_SWING_UP_S = {"cart_pole": 3.412, "pendubot": 5.768}
SWING_UP_ALLOWANCE = 1.5
HOLD_S = 3.0
UPRIGHT_TOL = 0.05  # [rad]
# The Riccati residual of SciPy's Schur solver: round-off of the largest entry of P A and Q.
RICCATI_RTOL = 1e-9
# PFL: the commanded acceleration comes back from ABA up to round-off.
PFL_RTOL = 1e-9
# The vectorised RK4 against simulate's RK4 on the same states: the same arithmetic in another
# order, round-off only over a stable 2 s run.
ROLLOUT_ATOL = 1e-9
# A small upright perturbation under LQR decays with the slowest pole (~ -1.3 /s): after 8 s
# the error is below e^-10 of 0.1 rad.
BALANCED_ATOL = 1e-4

SYSTEMS = ("cart_pole", "pendubot")


@pytest.fixture(scope="module", params=SYSTEMS)
def robot(request):
    return robodyn.load(request.param)


def _time_upright(t, q, ctl):
    plant = ctl.lqr.plant
    error = np.max(np.abs(wrap(q[:, plant.angular] - ctl.lqr.q_eq[plant.angular])), axis=1)
    bad = np.flatnonzero(error >= UPRIGHT_TOL)
    if bad.size == 0:
        return float(t[0])
    return float(t[bad[-1] + 1]) if bad[-1] + 1 < t.size else None


# ---------------------------------------------------------------------------------------------- LQR
def test_lqr_closed_loop_is_stable_and_solves_riccati(robot):
    lqr = control.make("lqr", robot)
    assert lqr.K.shape == (1, 4)
    assert np.max(lqr.poles.real) < 0
    A, B, Q, R, P = lqr.A, lqr.B, lqr.Q, lqr.R, lqr.P
    residual = A.T @ P + P @ A - P @ B @ np.linalg.solve(R, B.T) @ P + Q
    assert np.max(np.abs(residual)) < RICCATI_RTOL * max(np.max(np.abs(P @ A)), np.max(np.abs(Q)))
    assert np.all(np.linalg.eigvalsh(P) > 0)


def test_lqr_balances_a_small_perturbation(robot):
    lqr = control.make("lqr", robot)
    q0 = lqr.q_eq + np.array([0.05, 0.1])
    traj = robodyn.simulate(robot, q0, [0.0, 0.0], duration=8.0, dt=DT, torque=lqr)
    assert np.max(np.abs(lqr.plant.error(traj.q[-1], traj.v[-1], lqr.q_eq))) < BALANCED_ATOL
    assert np.max(np.abs(traj.tau[:, robot.actuated])) <= lqr.plant.effort[0]


def test_lqr_given_gain_gives_its_lyapunov_matrix(robot):
    designed = control.make("lqr", robot)
    given = control.make("lqr", robot, K=designed.K.ravel().tolist())
    assert np.allclose(given.P, designed.P, rtol=1e-6)  # the Riccati K's Lyapunov matrix is the Riccati P


def test_lqr_gains_of_the_wrong_shape_name_the_shape(robot):
    with pytest.raises(InputError, match=r"K must have shape \(1, 4\) \(one row per actuated joint"):
        control.make("lqr", robot, K=[1.0, 2.0, 3.0])
    with pytest.raises(
        InputError, match=r"Q must be a number, 4 diagonal entries or a \(4, 4\) matrix, got shape \(3,\)"
    ):
        control.make("lqr", robot, Q=[1, 1, 1])
    with pytest.raises(InputError, match=r"R must be a number, 1 diagonal entries or a \(1, 1\) matrix"):
        control.make("lqr", robot, R=[[1, 0], [0, 1]])
    with pytest.raises(InputError, match="does not stabilise"):
        control.make("lqr", robot, K=[[0.0, 0.0, 0.0, 0.0]])


def test_lqr_at_a_state_that_is_no_equilibrium(robot):
    with pytest.raises(InputError, match="is not an equilibrium: residual"):
        control.make("lqr", robot, q_eq=[0.3, 0.4], u_eq=[0.0])


# ---------------------------------------------------------------------------------------------- region
def test_states_in_the_hand_over_region_balance(robot):
    """The sampled region must hold what it claims: seeded states inside it all balance."""
    lqr = control.make("lqr", robot)
    reg = region.estimate(lqr)
    assert reg.rho > 0
    e = region._uniform_in_ellipsoid(lqr.P, 0.99 * reg.rho, 40, np.random.default_rng(7))
    q0, v0 = lqr.q_eq + e[:, :2], e[:, 2:]
    assert np.all(region.contains(lqr, reg, q0, v0))
    run = rollout.closed_loop(robot, lqr.batch, q0, v0, duration=10.0, dt=DT, backend="fast")
    assert np.max(np.abs(lqr.plant.error(run.q, run.v, lqr.q_eq))) < 1e-3
    if lqr.plant.rail_index is not None:
        k = lqr.plant.rail_index
        assert lqr.plant.rail[0] <= run.q_min[:, k].min() and run.q_max[:, k].max() <= lqr.plant.rail[1]


def test_rollout_matches_simulate(robot):
    lqr = control.make("lqr", robot)
    rng = np.random.default_rng(3)
    q0 = lqr.q_eq + rng.uniform(-0.05, 0.05, (3, 2))
    v0 = rng.uniform(-0.1, 0.1, (3, 2))
    fast = rollout.closed_loop(robot, lqr.batch, q0, v0, duration=2.0, dt=DT, backend="fast")
    slow = rollout.closed_loop(robot, lqr.batch, q0, v0, duration=2.0, dt=DT, backend="aba")
    for k in range(3):
        traj = robodyn.simulate(robot, q0[k], v0[k], duration=2.0, dt=DT, torque=lqr)
        assert np.max(np.abs(slow.q[k] - traj.q[-1])) < ROLLOUT_ATOL
        assert np.max(np.abs(fast.q[k] - traj.q[-1])) < ROLLOUT_ATOL


# ---------------------------------------------------------------------------------------------- swing-up
def test_pfl_gives_the_commanded_acceleration(robot):
    law = pfl.collocated(robot)
    rng = np.random.default_rng(11)
    for _ in range(10):
        q, v = robot.random_state(rng)
        accel = rng.uniform(-5, 5, 1)
        u = law.torque(q, v, accel)
        a = robot.forward_dynamics(q, v, robot.input_matrix() @ u - robot.damping * v)
        assert abs(a[robot.actuated][0] - accel[0]) < PFL_RTOL * max(1.0, abs(accel[0]))


def test_swing_up_from_hanging_reaches_upright_and_stays(robot):
    ctl = control.make("swing_up", robot)
    allowed = SWING_UP_ALLOWANCE * MEASURED_SWING_UP_S[robot.name]
    traj = robodyn.simulate(robot, ctl.lqr.plant.hanging(), [0.0, 0.0], duration=allowed + HOLD_S, dt=DT, torque=ctl)
    t_up = _time_upright(traj.t, traj.q, ctl)
    assert t_up is not None and t_up <= allowed, f"upright at {t_up} s, allowed {allowed:.3f} s"
    plant = ctl.lqr.plant
    assert np.max(np.abs(traj.tau[:, robot.actuated])) <= plant.effort[0]
    final_energy = ctl.swing_up.energy(traj.q[-1], traj.v[-1])
    assert abs(final_energy - ctl.swing_up.energy_up) < 1e-3  # at rest upright, the energy is its target
    if plant.rail is not None:
        y = traj.q[:, plant.rail_index]
        assert plant.rail[0] <= y.min() and y.max() <= plant.rail[1]


def test_swing_up_energy_target_is_the_upright_energy(robot):
    ctl = control.make("swing_up", robot)
    up = ctl.lqr.q_eq
    assert ctl.swing_up.energy(up, np.zeros(2)) == pytest.approx(ctl.swing_up.energy_up, abs=1e-12)
    down = ctl.lqr.plant.hanging()
    assert ctl.swing_up.energy(down, np.zeros(2)) < ctl.swing_up.energy_up - 0.1


def test_cart_rail_guard_brakes_before_the_end():
    robot = robodyn.load("cart_pole")
    ctl = control.make("swing_up", robot)
    law = ctl.swing_up
    hi = ctl.lqr.plant.rail[1]
    # 0.1 m from the usable end at 2 m/s: braking at accel_max needs 4 / (2 accel_max) > 0.1 m
    assert law.acceleration(np.array([hi - 0.1, np.pi]), np.array([2.0, 0.0])) <= -law.accel_max
    assert law.acceleration(np.array([-hi + 0.1, np.pi]), np.array([-2.0, 0.0])) >= law.accel_max
    assert (
        law.acceleration(np.array([hi - 0.1, np.pi]), np.array([-2.0, 0.0])) > -law.accel_max
    )  # moving away: no braking


def test_swing_up_gains_are_checked():
    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match="swing_up gain k_d must be a positive number, got -1.0"):
        control.make("swing_up", robot, k_d=-1.0)
    with pytest.raises(InputError, match="swing_up gain kick must be a number >= 0"):
        control.make("swing_up", robot, kick=float("nan"))
    with pytest.raises(
        UnknownNameError, match=r"unknown gain of controller 'swing_up \(pendubot\)' 'kp'; did you mean 'k_p'"
    ):
        control.make("swing_up", robot, kp=1.0)
    with pytest.raises(InputError, match="swing_up gain k_energy must be a positive number"):
        control.make("swing_up", robodyn.load("cart_pole"), k_energy=[1.0, 2.0])


# ---------------------------------------------------------------------------------------------- names and files
def test_unknown_controller_name_suggests_a_close_one():
    with pytest.raises(UnknownNameError, match=r"unknown controller 'swingup'; did you mean 'swing_up'"):
        control.make("swingup", robodyn.load("cart_pole"))
    assert control.names() == ("lqr", "swing_up")


def test_swing_up_refuses_other_robots():
    with pytest.raises(InputError, match="'swing_up' knows the cart_pole and the pendubot; geared_arm is neither"):
        control.make("swing_up", robodyn.load("geared_arm"))


USER_PD = """\
import numpy as np

def make(robot, kp=40.0, kd=8.0):
    def tau(t, q, v):
        return np.array([-kp * (q[0] - np.pi / 2) - kd * v[0]])
    return tau
"""


def test_user_controller_file_runs_in_simulate(tmp_path):
    path = tmp_path / "pd.py"
    path.write_text(USER_PD)
    robot = robodyn.load("pendubot")
    ctl = control.make(str(path), robot, kd=6.0)
    traj = robodyn.simulate(robot, [np.pi / 2, -np.pi / 2 - 0.1], [0, 0], duration=1.0, dt=DT, torque=ctl)
    assert traj.status == "ok"
    assert traj.tau[0, 0] == pytest.approx(0.0, abs=1e-12) and np.any(traj.tau[:, 0])


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        (
            "def make(robot):\n    def tau(t, q, v):\n        return 1.0 / 0.0\n    return tau\n",
            r"c\.py:3: the controller raised ZeroDivisionError: float division by zero at t = 0 s",
        ),
        (
            "def make(robot):\n    raise RuntimeError('no gains')\n",
            r"c\.py:2: make\(robot, \*\*gains\) raised RuntimeError: no gains",
        ),
        ("import sys\nsys.exit(3)\n", r"c\.py: the controller file called sys\.exit\(3\) at import \(line 2\)"),
        ("def make(robot)\n", r"c\.py:1: the controller file has a syntax error"),
        ("x = 1\n", r"c\.py: define make\(robot, \*\*gains\)"),
        (
            "def make(robot):\n    return lambda t, q, v: [1.0, 2.0, 3.0]\n",
            r"returned shape \(3,\) at t = 0 s; expected \(2,\)",
        ),
    ],
)
def test_a_failing_controller_file_is_one_line_with_file_and_line(tmp_path, text, pattern):
    path = tmp_path / "c.py"
    path.write_text(text)
    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match=pattern) as info:
        ctl = control.make(str(path), robot)
        ctl(0.0, np.array([0.1, 0.2]), np.zeros(2))
    assert "\n" not in str(info.value)


def test_a_failing_controller_stops_simulate_with_its_line(tmp_path):
    path = tmp_path / "late.py"
    path.write_text(
        "def make(robot):\n    def tau(t, q, v):\n        if t > 0.01:\n            raise ValueError('late')\n        return [0.0]\n    return tau\n"
    )
    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match=r"late\.py:4: the controller raised ValueError: late"):
        robodyn.simulate(robot, [0.0, 0.0], [0, 0], duration=0.1, dt=DT, torque=control.make(str(path), robot))


def test_solve_continuous_are_is_the_riccati_solver():
    """The gain is SciPy's: K = R^-1 B^T P with P from solve_continuous_are on the linearisation."""
    robot = robodyn.load("cart_pole")
    lqr = control.make("lqr", robot, Q=[1, 20, 1, 2], R=0.5)
    P = scipy.linalg.solve_continuous_are(lqr.A, lqr.B, np.diag([1, 20, 1, 2]), np.array([[0.5]]))
    assert np.allclose(lqr.K, np.linalg.solve(lqr.R, lqr.B.T @ P), rtol=1e-12, atol=0)
