"""The Robot API against Pinocchio's own identities, on seeded random states."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import robodyn

RTOL = 1e-10  # same algorithms, different association of sums: round-off only
N_STATES = 25


@pytest.fixture(params=["geared_arm", "cart_pole", "pendubot", "ur5"])
def robot(request):
    return robodyn.load(request.param)


def test_api_matches_pinocchio_identities(robot):
    rng = np.random.default_rng(2024)
    for _ in range(N_STATES):
        q, v = robot.random_state(rng)
        tau = rng.uniform(-1, 1, robot.nv)
        a = rng.uniform(-2, 2, robot.nv)
        M, C, G = robot.M(q), robot.C(q, v), robot.G(q)
        scale = max(1.0, np.abs(robot.nle(q, v)).max())
        np.testing.assert_allclose(
            C @ v + G,
            pin.rnea(robot.model, robot.model.createData(), q, v, np.zeros(robot.nv)),
            rtol=RTOL,
            atol=RTOL * scale,
        )
        np.testing.assert_allclose(
            np.linalg.solve(M, tau - robot.nle(q, v)), robot.forward_dynamics(q, v, tau), rtol=1e-8, atol=1e-9
        )
        np.testing.assert_allclose(
            robot.forward_dynamics(q, v, tau, backend="crba"), robot.forward_dynamics(q, v, tau), rtol=1e-8, atol=1e-9
        )
        np.testing.assert_allclose(robot.inverse_dynamics(q, v, a), M @ a + C @ v + G, rtol=RTOL, atol=RTOL * scale)
        np.testing.assert_array_equal(M, M.T)
        assert robot.kinetic_energy(q, v) == pytest.approx(0.5 * v @ M @ v, rel=1e-14)


def test_returned_arrays_are_fresh_copies(robot):
    rng = np.random.default_rng(1)
    q1, _ = robot.random_state(rng)
    q2, _ = robot.random_state(rng)
    M1 = robot.M(q1)
    kept = M1.copy()
    robot.M(q2)
    np.testing.assert_array_equal(M1, kept)


def test_armature_is_in_M_and_in_the_energy():
    arm = robodyn.load("geared_arm")
    assert arm.armature[0] == pytest.approx(1.08e-6 * 50**2, rel=1e-14)
    J_l = 1.840725e-3 + 0.243 * 0.15**2
    assert arm.M([0.3])[0, 0] == pytest.approx(J_l + 2.7e-3, rel=1e-12)
    assert arm.kinetic_energy([0.3], [2.0]) == pytest.approx(0.5 * (J_l + 2.7e-3) * 4.0, rel=1e-12)


def test_bad_vectors_are_refused_with_the_argument_named():
    r = robodyn.load("pendubot")
    with pytest.raises(robodyn.InputError, match=r"q must have 2 entries, got shape \(3,\)"):
        r.M([0, 0, 0])
    with pytest.raises(robodyn.InputError, match="tau must have 2 entries"):
        r.forward_dynamics([0, 0], [0, 0], [1])
    with pytest.raises(robodyn.InputError, match="v must be finite"):
        r.C([0, 0], [np.nan, 0])
    with pytest.raises(robodyn.UnknownNameError, match="expected one of: aba, crba"):
        r.forward_dynamics([0, 0], [0, 0], [0, 0], backend="featherstone")


def test_passive_joints_come_from_the_srdf():
    assert robodyn.load("pendubot").passive_joints == ("joint2",)
    assert robodyn.load("cart_pole").passive_joints == ("hinge",)
    assert list(robodyn.load("cart_pole").actuated) == [True, False]
    assert robodyn.load("geared_arm").passive_joints == ()
