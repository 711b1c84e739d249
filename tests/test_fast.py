"""The compiled fast path against Pinocchio's ABA path: same method, same steps, same answer."""

from __future__ import annotations

import numpy as np
import pytest

import robodyn
from robodyn.errors import AssumptionError, InputError, UnknownNameError
from robodyn.sim.fast import VERIFY_RTOL, FastDynamics
from robodyn.studies.stability import variant_path

# Closed form vs ABA, same integrator and steps: round-off only, amplified at most ~e^(2.2 * 1 s)
# by the Pendubot's chaos over the 1 s horizon.
TRAJECTORY_RTOL = 1e-12
# Accelerations of one state: a few ulps of the largest entry.
ACCEL_RTOL = 1e-13
# Energies of one state from closed forms vs Pinocchio: round-off.
ENERGY_ATOL = 1e-12
# The fast path books the damping work by the trapezoid rule on the samples (second order),
# so its ledger closes to ~(dt / tau)^2 of that work, not to RK4's accuracy.
LEDGER_RTOL = 1e-4

SEED_KINDS = ("pendubot", "cart_pole", "geared_arm")


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.fixture(scope="module", params=SEED_KINDS)
def robot_and_fast(request: pytest.FixtureRequest) -> tuple[robodyn.Robot, FastDynamics]:
    robot = robodyn.load(request.param)
    return robot, FastDynamics.from_robot(robot)


@pytest.mark.parametrize("method", ["rk4", "semi_implicit_euler"])
def test_trajectory_matches_pinocchio_path_to_round_off(robot_and_fast, method):
    robot, fast = robot_and_fast
    rng = np.random.default_rng(3)
    q0, v0 = robot.random_state(rng, speed=1.0)
    # The compiled path has no joint stops, and a random state puts the cart anywhere in
    # [-pi, pi] m, past the rail's ends: the reference runs without stops too.
    ref = robodyn.simulate(robot, q0, v0, duration=1.0, dt=1e-3, integrator=method, backend="aba", limits=False)
    got = fast.simulate(q0, v0, duration=1.0, dt=1e-3, method=method)
    assert got.status == "ok"
    assert got.t.shape == ref.t.shape
    assert _relative(got.q, ref.q) < TRAJECTORY_RTOL
    assert _relative(got.v, ref.v) < TRAJECTORY_RTOL
    assert got.evaluations == (4 if method == "rk4" else 1) * 1000 + 1


def test_accelerations_and_energies_match_pinocchio(robot_and_fast):
    robot, fast = robot_and_fast
    rng = np.random.default_rng(11)
    for _ in range(20):
        q, v = robot.random_state(rng)
        tau = rng.uniform(-1, 1, robot.nv) * robot.actuated
        a = fast.acceleration(q, v, tau)
        ref = robot.forward_dynamics(q, v, tau - robot.damping * v)
        assert np.max(np.abs(a - ref)) <= ACCEL_RTOL * max(1.0, np.max(np.abs(ref)))
        kin, pot = fast.energies(q, v)
        assert kin == pytest.approx(robot.kinetic_energy(q, v), abs=ENERGY_ATOL)
        assert pot == pytest.approx(robot.potential_energy(q), abs=ENERGY_ATOL)
    assert fast.verify(robot) <= VERIFY_RTOL


def test_batch_acceleration_equals_single_states():
    robot = robodyn.load("pendubot")
    fast = FastDynamics.from_robot(robot)
    rng = np.random.default_rng(5)
    Q, V = rng.normal(size=(7, 2)), rng.normal(size=(7, 2))
    A = fast.acceleration(Q, V)
    for k in range(7):
        np.testing.assert_array_equal(A[k], fast.acceleration(Q[k], V[k]))  # identical arithmetic: exact


def test_damping_is_applied_like_simulate():
    robot = robodyn.load(variant_path("geared_arm_stiff"))
    fast = FastDynamics.from_robot(robot)
    assert fast.damping[0] == 10.0
    ref = robodyn.simulate(robot, [0.5], [0.0], duration=0.05, dt=1e-4, integrator="rk4")
    got = fast.simulate([0.5], [0.0], duration=0.05, dt=1e-4)
    assert _relative(got.v, ref.v) < TRAJECTORY_RTOL
    # the damping work is booked: the ledger closes to the work quadrature's accuracy
    assert got.work_damping[-1] < 0
    assert np.max(np.abs(got.ledger_residual)) < LEDGER_RTOL * abs(got.work_damping[-1])


def test_blow_up_is_reported_not_raised():
    robot = robodyn.load(variant_path("geared_arm_stiff"))
    fast = FastDynamics.from_robot(robot)
    traj = fast.simulate([0.5], [0.0], duration=10.0, dt=5e-3)  # 2.5x explicit RK4's limit of 2 ms
    assert traj.status == "diverged"
    assert traj.t.size < 2001


def test_wrong_kind_and_bad_input_are_refused():
    robot = robodyn.load("pendubot")
    with pytest.raises(AssumptionError):
        FastDynamics.from_robot(robot, "cart_pole")
    with pytest.raises(UnknownNameError, match="pendubot"):
        FastDynamics.from_robot(robot, "double_pendulum")
    fast = FastDynamics.from_robot(robot)
    with pytest.raises(InputError, match="dt"):
        fast.simulate([0, 0], [0, 0], duration=1.0, dt=-1e-3)
    with pytest.raises(InputError, match="q0"):
        fast.simulate([0, 0, 0], [0, 0], duration=1.0, dt=1e-3)
    with pytest.raises(UnknownNameError):
        fast.simulate([0, 0], [0, 0], duration=1.0, dt=1e-3, method="leapfrog")


# The batch kernel runs the arithmetic of the single-state kernel on each state: identical numbers.
BATCH_VS_ONE_TOL = 1e-12  # [rad | rad/s] (asserted to round-off margin; measured 0)


@pytest.mark.parametrize("kind", ["pendubot", "geared_arm"])
def test_the_batch_kernel_steps_each_state_once_across_many_blocks(kind):
    """40 states in 6 uneven blocks (the batch tests of 5-6 states fit in one): every state steps exactly n times."""
    from robodyn.sim.fast import batch_rk4

    robot = robodyn.load(kind)
    fast = FastDynamics.from_robot(robot)
    rng = np.random.default_rng(40)
    n_states, dt, steps = 40, 1e-3, 200
    q0 = rng.uniform(-1.0, 1.0, (n_states, robot.nv))
    v0 = rng.uniform(-1.0, 1.0, (n_states, robot.nv))
    Q, V = np.zeros((n_states, 2)), np.zeros((n_states, 2))
    Q[:, : robot.nv], V[:, : robot.nv] = q0, v0
    blocks = np.array([0, 7, 13, 20, 27, 33, 40], dtype=np.int64)
    batch_rk4(fast, Q, V, dt=dt, steps=steps, blocks=blocks)
    for k in range(n_states):
        one = fast.simulate(q0[k], v0[k], duration=steps * dt, dt=dt)
        np.testing.assert_allclose(Q[k, : robot.nv], one.q[-1], rtol=0, atol=BATCH_VS_ONE_TOL, err_msg=f"state {k}")
        np.testing.assert_allclose(V[k, : robot.nv], one.v[-1], rtol=0, atol=BATCH_VS_ONE_TOL, err_msg=f"state {k}")
