"""The batch path (Pinocchio's threaded ABA inside the integrators' RK4) against single runs."""

from __future__ import annotations

import numpy as np
import pytest

import robodyn
from robodyn.errors import InputError
from robodyn.sim import batch
from robodyn.studies.stability import variant_path

# Same method, same steps, accelerations from abaInParallel instead of aba: round-off only,
# amplified over 0.2 s of the Pendubot's chaos.
BATCH_RTOL = 1e-11


def test_batch_equals_single_runs():
    robot = robodyn.load("pendubot")
    rng = np.random.default_rng(7)
    Q = rng.uniform(-np.pi, np.pi, (6, 2))
    V = rng.uniform(-1, 1, (6, 2))
    res = batch.rollout(robot, Q, V, duration=0.2, dt=1e-3, threads=2)
    assert res.evaluations == 4 * 200
    for i in range(6):
        ref = robodyn.simulate(robot, Q[i], V[i], duration=0.2, dt=1e-3, integrator="rk4")
        np.testing.assert_allclose(res.q[i], ref.q[-1], rtol=BATCH_RTOL, atol=BATCH_RTOL)
        np.testing.assert_allclose(res.v[i], ref.v[-1], rtol=BATCH_RTOL, atol=BATCH_RTOL)


def test_one_dof_model_does_not_reach_abaInParallel():
    # pin 4.1.0's abaInParallel crashes the process on 1-DoF models: dynamics.aba_batch guards it
    robot = robodyn.load("geared_arm")
    res = batch.rollout(robot, np.full((3, 1), 0.4), np.zeros((3, 1)), duration=0.01, dt=1e-3)
    ref = robodyn.simulate(robot, [0.4], [0.0], duration=0.01, dt=1e-3)
    np.testing.assert_allclose(res.q[:, 0], ref.q[-1, 0], rtol=BATCH_RTOL)


def test_bad_input_is_refused():
    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match="shape"):
        batch.rollout(robot, np.zeros((3, 2)), np.zeros((2, 2)), duration=0.01, dt=1e-3)
    with pytest.raises(InputError, match="explicit fixed-step"):
        batch.rollout(robot, np.zeros((3, 2)), np.zeros((3, 2)), duration=0.01, dt=1e-3, integrator="dopri5")
    with pytest.raises(InputError, match="losses"):
        batch.rollout(
            robodyn.load(variant_path("geared_arm_stiff")),
            np.zeros((2, 1)),
            np.zeros((2, 1)),
            duration=0.01,
            dt=1e-3,
        )


def test_tree_path_equals_single_runs_whatever_the_threads():
    robot = robodyn.load("double_pendulum")  # no built-in kind: the compiled tree algorithms
    robot.model.damping[:] = 0.0  # the batch path is lossless
    rng = np.random.default_rng(11)
    Q = rng.uniform(-np.pi, np.pi, (37, 2))  # not a multiple of the block size
    V = rng.uniform(-1, 1, (37, 2))
    one = batch.rollout(robot, Q, V, duration=0.2, dt=1e-3, integrator="heun", threads=1)
    two = batch.rollout(robot, Q, V, duration=0.2, dt=1e-3, integrator="heun", threads=2)
    assert one.path == two.path == "tree" and one.evaluations == 2 * 200
    np.testing.assert_array_equal(one.q, two.q)  # each state's arithmetic is its own: exact
    np.testing.assert_array_equal(one.v, two.v)
    for i in (0, 17, 36):
        ref = robodyn.simulate(robot, Q[i], V[i], duration=0.2, dt=1e-3, integrator="heun", limits=False)
        assert ref.meta["loop"] == "compiled"
        np.testing.assert_array_equal(one.q[i], ref.q[-1])  # the same compiled step: exact
        np.testing.assert_array_equal(one.v[i], ref.v[-1])


def test_closed_form_path_for_seed_kinds_and_bad_threads():
    robot = robodyn.load("pendubot")
    res = batch.rollout(robot, np.full((5, 2), 0.3), np.zeros((5, 2)), duration=0.01, dt=1e-3, threads=2)
    assert res.path == "closed_form" and res.threads == 2
    with pytest.raises(InputError, match="threads"):
        batch.rollout(robot, np.zeros((3, 2)), np.zeros((3, 2)), duration=0.01, dt=1e-3, threads=0)
