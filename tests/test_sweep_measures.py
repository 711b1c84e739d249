"""The sweep's measures: time_to_balance is the first sample from which the run stays balanced, to the sample."""

from __future__ import annotations

import math

import numpy as np

from robodyn.sweep.measures import balanced_from, inside_upright

DT = 0.01  # [s]


def _oracle(inside: np.ndarray, dt: float) -> float:
    """The slow, obvious answer: the time of the first sample k with every sample from k on inside."""
    for k in range(inside.size):
        if inside[k:].all():
            return k * dt
    return math.nan


def test_time_to_balance_is_the_first_sample_from_which_every_sample_is_inside():
    assert balanced_from(np.array([False, False, True, True, True]), DT) == 2 * DT
    assert balanced_from(np.array([True, False, True]), DT) == 2 * DT
    assert balanced_from(np.array([True, True]), DT) == 0.0
    assert math.isnan(balanced_from(np.array([True, False]), DT))
    assert math.isnan(balanced_from(np.array([], dtype=bool), DT))
    rng = np.random.default_rng(7)
    for _ in range(200):
        inside = rng.random(rng.integers(1, 30)) < 0.7
        got, expected = balanced_from(inside, DT), _oracle(inside, DT)
        assert (math.isnan(got) and math.isnan(expected)) or got == expected, (inside, got, expected)


def test_the_upright_test_wraps_angles_and_leaves_slides_out():
    upright = np.array([0.0, np.pi])
    angular = np.array([False, True])  # a slider, then a hinge
    q = np.array([[5.0, np.pi + 0.04], [5.0, -np.pi + 0.04], [0.0, np.pi + 0.06], [0.0, 3 * np.pi - 0.01]])
    np.testing.assert_array_equal(inside_upright(q, upright, angular), [True, True, False, True])
