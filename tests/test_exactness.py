"""The exactness proof: a reduced model moves as the full model with its locks held, and costs less."""

from __future__ import annotations

import numpy as np
import pytest

from robodyn.errors import InputError
from robodyn.model.load import load
from robodyn.model.reduce import reduce
from robodyn.studies.exactness import ExactnessReport, compare_cost, prove_exact, time_calls

# Reduced (ABA) vs full model with locks (KKT solve): the same integrator on two algorithms;
# they differ by round-off, grown over 1 s of smooth motion to ~1e-13.
EXACT_TOL = 1e-10

PANDA_KEEP = ["panda_joint2", "panda_joint4", "panda_joint6"]
TALOS_KEEP = ["arm_left_1_joint", "arm_left_2_joint", "arm_left_4_joint", "torso_1_joint"]


@pytest.mark.parametrize(
    ("name", "keep", "reference", "q0"),
    [
        ("panda", PANDA_KEEP, "default", [-0.3, -2.0, 1.2]),
        ("talos", TALOS_KEEP, "half_sitting", [0.2, 0.5, -1.0, 0.1]),
        ("pendubot", ["joint2"], None, [1.0]),
    ],
)
def test_trajectory_of_reduced_model_equals_full_model_with_locks(name, keep, reference, q0):
    red = reduce(load(name), keep=keep, reference=reference)
    report = prove_exact(red, q0, np.zeros(len(keep)), duration=1.0, dt=2e-3, method="rk4")
    assert report.q_error < EXACT_TOL
    assert report.v_error < EXACT_TOL
    assert report.lock_drift < EXACT_TOL
    assert report.holds(EXACT_TOL)
    assert report.max_lock_torque > 0.1  # the locks really hold something [N m]
    # and the motion is not trivial: the kept joints move by more than 0.01 rad
    assert np.ptp(report.q_reduced, axis=0).max() > 0.01


def test_exactness_with_a_controller_and_damping():
    red = reduce(load("talos"), keep=TALOS_KEEP, reference="half_sitting")
    assert np.all(red.reduced.damping == 1.0)  # talos arms and torso: damping 1 N m s/rad

    def pd(t, q, v):
        return -20.0 * q - 2.0 * v

    report = prove_exact(red, [0.2, 0.5, -1.0, 0.1], [0.5, 0.0, 0.0, -0.5], duration=0.5, dt=1e-3, tau=pd)
    assert report.q_error < EXACT_TOL and report.v_error < EXACT_TOL


def test_holds_fails_on_any_error_above_tolerance_and_on_nan():
    base = dict(
        t=np.zeros(1),
        q_reduced=np.zeros((1, 1)),
        v_reduced=np.zeros((1, 1)),
        q_full=np.zeros((1, 2)),
        v_full=np.zeros((1, 2)),
        max_lock_torque=1.0,
        method="rk4",
        dt=1e-3,
        wall_time_reduced_s=0.0,
        wall_time_full_s=0.0,
    )
    assert ExactnessReport(q_error=1e-12, v_error=1e-12, lock_drift=0.0, **base).holds(1e-10)
    for bad in ({"q_error": 1e-9}, {"v_error": 1e-9}, {"lock_drift": 1e-9}, {"v_error": float("nan")}):
        errors = {"q_error": 0.0, "v_error": 0.0, "lock_drift": 0.0, **bad}
        assert not ExactnessReport(**errors, **base).holds(1e-10), bad


def test_bad_duration_and_step_are_refused():
    red = reduce(load("pendubot"), keep=["joint2"])
    with pytest.raises(InputError, match="duration"):
        prove_exact(red, [0.1], [0.0], duration=0.0, dt=1e-3)
    with pytest.raises(InputError, match="dt"):
        prove_exact(red, [0.1], [0.0], duration=1.0, dt=float("nan"))


def test_cost_comparison_times_every_call_on_both_models():
    red = reduce(load("panda"), keep=PANDA_KEEP, reference="default")
    cost = compare_cost(red, repeat=3)
    assert (cost.nv_full, cost.nv_reduced, cost.repeat) == (9, 3, 3)
    assert set(cost.full) == set(cost.reduced) == {"M", "C", "G", "ABA"}
    for what in cost.full:
        assert cost.speedup(what) == cost.full[what] / cost.reduced[what]
    with pytest.raises(InputError, match="repeat"):
        time_calls(red.reduced, repeat=0)
