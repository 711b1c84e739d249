"""The torque laws written once (robodyn.engine.torque_laws): the NumPy batch, numba's scalars and the controllers agree.

No GPU and no simulator here: numba's CPU compiler compiles the body the GPU's ``cuda.jit(device=True)``
compiles, and the closed loop's device function runs on the CPU's cores against the sweep's CPU path.
"""

from __future__ import annotations

import dataclasses

import numba
import numpy as np
import pytest

import robodyn
import robodyn.control
import robodyn.sweep as sweep
from robodyn.control.compiled import law_of
from robodyn.engine import torque_laws as tl
from robodyn.engine.cuda import closed_loop as cuda_closed
from robodyn.errors import InputError
from robodyn.sim.fast import FastDynamics
from robodyn.sweep import chunk as chunk_module
from robodyn.sweep import measures as ms
from robodyn.sweep.policy import batch_policy
from tests.test_sweep_policy import UP, states

# The controller's own __call__ takes M, C v, G from Pinocchio's CRBA/RNEA, the law from the closed
# form: round-off, a few ulps of the largest torque (2 N m, 20 N) (as tests/test_sweep_policy.py).
POLICY_ATOL = 1e-12
# The scalar (numba) and the NumPy forms run the same body, operation for operation: to the bit.
SAME_BITS = 0.0
CONTROLLERS = [(kind, name) for kind in ("pendubot", "cart_pole") for name in ("lqr", "swing_up")]


@pytest.mark.parametrize(("kind", "name"), CONTROLLERS)
def test_scalar_law_equals_numpy_law_and_the_controller(kind, name):
    robot = robodyn.load(kind)
    fast = FastDynamics.from_robot(robot)
    controller = robodyn.control.make(name, robot)
    law, c = law_of(controller, fast)
    scalar = tl.law(kind, law, numba.njit)
    q, v = states(kind, 200, np.random.default_rng(17))
    p, b = fast.param_vector, np.zeros(2)
    got = np.array([scalar(c, p, b, q[k, 0], q[k, 1], v[k, 0], v[k, 1]) for k in range(q.shape[0])])
    batch = batch_policy(controller, fast)(q, v)[:, 0]
    ref = np.array([controller(0.0, q[k], v[k])[0] for k in range(q.shape[0])])
    assert np.max(np.abs(got - batch)) <= SAME_BITS
    np.testing.assert_allclose(got, ref, rtol=0, atol=POLICY_ATOL * max(1.0, float(np.abs(ref).max())))
    if name == "swing_up":
        modes = controller.modes(q, v)
        assert 0 < modes.sum() < modes.size  # the LQR and the energy law both give torques here


def test_cart_pole_rail_guard_brakes_in_the_scalar_law():
    """Near the rail's end and moving out, the cart brakes at accel_max whatever the energy law asks."""
    robot = robodyn.load("cart_pole")
    fast = FastDynamics.from_robot(robot)
    # No centring terms: the energy law alone would push on towards the end, so the guard decides.
    controller = robodyn.control.make("swing_up", robot, k_position=0.0, k_velocity=0.0)
    law, c = law_of(controller, fast)
    unguarded = c.copy()
    unguarded[tl.GAINS + tl.GAIN_NAMES[law].index("rail")] = 0.0
    scalar = tl.law("cart_pole", law, numba.njit)
    q = np.array([[1.9, np.pi - 0.5], [-1.9, np.pi + 0.5]])
    v = np.array([[3.0, 0.0], [-3.0, 0.0]])  # each would stop past the rail's usable end
    got = [scalar(c, fast.param_vector, np.zeros(2), *q[k], *v[k]) for k in range(2)]
    free = [scalar(unguarded, fast.param_vector, np.zeros(2), *q[k], *v[k]) for k in range(2)]
    ref = [controller(0.0, q[k], v[k])[0] for k in range(2)]
    np.testing.assert_allclose(got, ref, rtol=0, atol=POLICY_ATOL * 20.0)
    assert got[0] < free[0] and got[1] > free[1], (got, free)  # braking away from each end


def test_law_of_refuses_what_it_has_no_law_for():
    pendubot = robodyn.load("pendubot")
    fast = FastDynamics.from_robot(pendubot)
    assert law_of(lambda t, q, v: np.zeros(1), fast) is None
    assert law_of(robodyn.control.make("lqr", pendubot), None) is None
    arm = robodyn.load("geared_arm")
    lqr = robodyn.control.make("lqr", arm, q_eq=[0.5])
    assert law_of(lqr, FastDynamics.from_robot(arm)) is None  # one joint: the NumPy LQR of any size serves it
    with pytest.raises(InputError, match="torque law 'cart_pole_energy' for 'pendubot'"):
        tl.law("pendubot", "cart_pole_energy")


@pytest.mark.parametrize(("kind", "name"), CONTROLLERS)
def test_closed_loop_device_function_on_cpu_cores_equals_the_sweeps_cpu_path(kind, name, tmp_path):
    """The GPU's closed-loop device function, compiled by numba.njit, gives the CPU closed loop's rows."""
    start = {"pendubot": {"joint1": [UP - 0.06, -UP], "joint2": [0.06, 0.1]}}
    start["cart_pole"] = {"slider": [0.0, 0.3], "hinge": [0.08, np.pi]}
    spec = {"model": kind, "duration": 0.3, "controller": name, "chunk": 4, "q0": start[kind]}
    spec["measure"] = ["final_state", "energy_drift", "time_to_balance"]
    prepared = sweep.prepare(spec, tmp_path)
    (chunk,) = prepared.plan.chunks
    job = dataclasses.replace(prepared.job, device="cpu")
    cpu = chunk_module.execute(chunk, job)
    assert set(cpu["path"]) == {"closed_loop"}
    robot = robodyn.load(kind)
    fast = FastDynamics.from_robot(robot)
    law, c = law_of(robodyn.control.make(name, robot), fast)
    up, angular = chunk_module.upright_of(robot)
    K0, P0 = fast.energies_batch(chunk.q0, chunk.v0)
    q, v, _, _, balance, diverged, _ = cuda_closed.closed_loop(
        kind,
        law,
        fast.param_vector,
        np.zeros(2),
        c,
        chunk.q0,
        chunk.v0,
        upright=up,
        angular=angular.astype(float),
        tol=ms.BALANCE_TOL,
        bound=chunk_module.energy_bounds(robot, K0, P0),
        offset=fast.potential_offset,
        dt=1e-3,
        steps=300,
        cpu=True,
    )
    assert not diverged.any()
    names = robot.joint_names
    np.testing.assert_array_equal(q, np.column_stack([cpu[f"q.{j}"] for j in names]))
    np.testing.assert_array_equal(v, np.column_stack([cpu[f"v.{j}"] for j in names]))
    np.testing.assert_array_equal(balance, cpu["time_to_balance"])
    assert np.isnan(balance).any() and (balance > 0).any()  # runs that balance on the way, and runs that do not
