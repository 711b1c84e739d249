"""Actuation: the effort clamp keeps each command's sign, on both sides of zero, one state or a batch."""

from __future__ import annotations

import numpy as np

import robodyn
from robodyn.sim.actuation import EffortLimits, effort_limits
from robodyn.sim.simulation import simulate

EFFORT = 20.0  # [N] the cart-pole slider's URDF effort


def test_the_clamp_is_symmetric_about_zero():
    """A command beyond the limit goes to the limit of its own sign; one within it passes unchanged."""
    limits = EffortLimits(np.array([0, 2], dtype=np.intp), np.array([20.0, 5.0]))
    tau = np.array([-30.0, 7.0, 6.0])
    np.testing.assert_array_equal(limits.clamp(tau), [-20.0, 7.0, 5.0])
    np.testing.assert_array_equal(limits.clamp(-tau), [20.0, -7.0, -5.0])
    np.testing.assert_array_equal(limits.clamp(np.array([-19.5, 0.0, -4.0])), [-19.5, 0.0, -4.0])
    batch = np.array([[-30.0, 1.0, -6.0], [30.0, -1.0, 6.0], [-20.0, 0.0, -5.0], [np.nan, 0.0, -np.inf]])
    clamped = limits.clamp_batch(batch)
    np.testing.assert_array_equal(clamped[:3], [[-20.0, 1.0, -5.0], [20.0, -1.0, 5.0], [-20.0, 0.0, -5.0]])
    assert np.isnan(clamped[3, 0]) and clamped[3, 2] == -np.inf  # non-finite commands pass on, to be blamed
    np.testing.assert_array_equal(limits.clamped(batch[:3]), [True, True, False])


def test_a_negative_command_beyond_the_effort_pushes_the_other_way():
    """The cart-pole pushed at -30 N is held to -20 N: it moves left, as far as a +20 N push moves it right."""
    robot = robodyn.load("cart_pole")
    assert effort_limits(robot).describe(["slider", "hinge"]) == {"slider": EFFORT}
    left = simulate(robot, [0.0, 0.0], [0.0, 0.0], duration=0.2, dt=1e-3, torque=[-30.0])
    right = simulate(robot, [0.0, 0.0], [0.0, 0.0], duration=0.2, dt=1e-3, torque=[30.0])
    np.testing.assert_array_equal(left.tau[:, 0], -EFFORT)
    assert left.meta["effort_clamped_samples"] == left.t.size
    assert left.q[-1, 0] < 0.0
    np.testing.assert_allclose(left.q[:, 0], -right.q[:, 0], rtol=0, atol=1e-12)  # [m] mirror images
    # A controller's command goes through the same clamp.
    pushed = simulate(robot, [0.0, 0.0], [0.0, 0.0], duration=0.2, dt=1e-3, torque=lambda t, q, v: [-30.0])
    np.testing.assert_array_equal(pushed.tau[:, 0], -EFFORT)
    np.testing.assert_array_equal(pushed.q, left.q)
