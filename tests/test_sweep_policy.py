"""The sweep's vectorised closed loop: batch controllers equal the controllers, chunks follow robodyn.simulate."""

from __future__ import annotations

import numpy as np
import pytest

import robodyn
import robodyn.control
import robodyn.sweep as sweep
from robodyn.sim.fast import FastDynamics
from robodyn.sweep import chunk as chunk_module
from robodyn.sweep.policy import batch_policy

# The batch law evaluates the same formulas as the controller, M, C v and G from the closed form
# instead of Pinocchio's CRBA/RNEA: round-off, a few ulps of the largest torque (2 N m, 20 N).
POLICY_ATOL = 1e-12
# A closed-loop chunk against robodyn.simulate with the same controller over 0.4 s of RK4 at 1 ms:
# the per-stage accelerations differ by round-off (closed form vs ABA); measured 7e-15 after 400
# steps, allowed 1e-11 for its growth; a wrong law or step is off by > 1e-4.
FOLLOW_ATOL = 1e-11
UP = np.pi / 2


def states(kind: str, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """n seeded states, the first quarter near the upright (the LQR's region), the rest anywhere."""
    up = np.array([UP, 0.0]) if kind == "pendubot" else np.zeros(2)
    q = rng.uniform(-3.0, 3.0, (n, 2))
    v = rng.uniform(-3.0, 3.0, (n, 2))
    q[: n // 4] = up + rng.normal(0.0, 0.02, (n // 4, 2))
    v[: n // 4] = rng.normal(0.0, 0.05, (n // 4, 2))
    return q, v


@pytest.mark.parametrize("kind", ["pendubot", "cart_pole"])
def test_batch_swing_up_gives_the_controllers_torque_in_both_modes(kind):
    robot = robodyn.load(kind)
    controller = robodyn.control.make("swing_up", robot)
    policy = batch_policy(controller, FastDynamics.from_robot(robot))
    assert policy is not None
    q, v = states(kind, 400, np.random.default_rng(3))
    got = policy(q, v)
    ref = np.array([controller(0.0, q[k], v[k]) for k in range(q.shape[0])])
    modes = controller.modes(q, v)
    assert 0 < modes.sum() < modes.size  # both the LQR and the energy law are exercised
    assert got.shape == ref.shape == (400, 1)
    np.testing.assert_allclose(got, ref, rtol=0, atol=POLICY_ATOL * max(1.0, float(np.abs(ref).max())))
    alone = np.concatenate([policy(q[k : k + 1], v[k : k + 1]) for k in range(q.shape[0])])
    np.testing.assert_array_equal(alone, got)  # a row's torque does not depend on its batch


def test_batch_lqr_gives_the_controllers_torque():
    robot = robodyn.load("cart_pole")
    controller = robodyn.control.make("lqr", robot)
    policy = batch_policy(controller, FastDynamics.from_robot(robot))
    q, v = states("cart_pole", 40, np.random.default_rng(4))
    ref = np.array([controller(0.0, q[k], v[k]) for k in range(q.shape[0])])
    np.testing.assert_allclose(policy(q, v), ref, rtol=0, atol=POLICY_ATOL * float(np.abs(ref).max()))


def test_opaque_controllers_have_no_batch_form(tmp_path):
    robot = robodyn.load("pendubot")
    assert batch_policy(lambda t, q, v: np.zeros(1), FastDynamics.from_robot(robot)) is None
    assert batch_policy(None, None) is None


@pytest.mark.parametrize("kind", ["pendubot", "cart_pole"])
def test_closed_loop_swing_up_chunk_follows_simulate(kind, tmp_path):
    start = {"pendubot": {"joint1": [-UP, -1.0, UP - 0.02], "joint2": [0.0, 0.3]}}
    start["cart_pole"] = {"slider": [-0.5, 0.5], "hinge": [np.pi, 2.0, 0.02]}
    spec = {
        "model": kind,
        "duration": 0.4,
        "dt": 1e-3,
        "controller": "swing_up",
        "measure": ["final_state", "energy_drift"],
        "chunk": 6,
        "q0": start[kind],
    }
    prepared = sweep.prepare(spec, tmp_path)
    (chunk,) = prepared.plan.chunks
    columns = chunk_module.execute(chunk, prepared.job)
    assert set(columns["path"]) == {"closed_loop"}
    robot = robodyn.load(kind)
    controller = robodyn.control.make("swing_up", robot)
    names = robot.joint_names
    for k in range(chunk.runs.size):
        ref = robodyn.simulate(robot, chunk.q0[k], chunk.v0[k], duration=0.4, dt=1e-3, torque=controller)
        got_q = [columns[f"q.{j}"][k] for j in names]
        got_v = [columns[f"v.{j}"][k] for j in names]
        np.testing.assert_allclose(got_q, ref.q[-1], rtol=0, atol=FOLLOW_ATOL)
        np.testing.assert_allclose(got_v, ref.v[-1], rtol=0, atol=FOLLOW_ATOL)
        energy = ref.kinetic + ref.potential
        assert abs(columns["energy_drift"][k] - (energy[-1] - energy[0])) < FOLLOW_ATOL


@pytest.mark.parametrize(("controller", "path"), [("lqr", "closed_loop"), ("none", "fast")])
def test_run_that_reaches_the_rail_is_recomputed_by_simulate(controller, path, tmp_path):
    """The cart driven into its +2.4 m stop: the vectorised and compiled paths have no stops, simulate redoes it."""
    spec = {
        "model": "cart_pole",
        "duration": 0.5,
        "dt": 1e-3,
        "controller": controller,
        "measure": ["final_state"],
        "q0": {"slider": [0.0, 2.3]},
        "v0": {"slider": 3.0},
    }
    prepared = sweep.prepare(spec, tmp_path)
    (chunk,) = prepared.plan.chunks
    columns = chunk_module.execute(chunk, prepared.job)
    assert columns["path"] == [path, "simulate"]
    robot = robodyn.load("cart_pole")
    torque = robodyn.control.make("lqr", robot) if controller == "lqr" else None
    ref = robodyn.simulate(robot, chunk.q0[1], chunk.v0[1], duration=0.5, dt=1e-3, torque=torque)
    assert ref.q[:, 0].max() <= 2.4 + 1e-12  # simulate stopped the cart at the rail
    assert columns["q.slider"][1] == ref.q[-1, 0] and columns["v.hinge"][1] == ref.v[-1, 1]
