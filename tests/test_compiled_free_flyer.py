"""The compiled tree kernels (sim/tree.py, engine/tree/algorithms.py) on a free-flyer root, against Pinocchio."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import robodyn
from robodyn.engine.tree import layout as tree_layout
from robodyn.errors import AssumptionError
from robodyn.sim import tree

# Compiled ABA / RNEA / CRBA / energies against Pinocchio, relative to the largest entry: two float64
# implementations of the same recursions (world frame at the free flyer vs local frames).
ALGORITHM_RTOL = 1e-12
# q (+) dq against pin.integrate: the SE(3) exponential written from its formula (Taylor series
# where its terms cancel), against Pinocchio's own; entries are O(1), a few ulps apart.
INTEGRATE_ATOL = 1e-14

ARM_URDF = """<?xml version="1.0"?>
<robot name="box_arm">
  <link name="box">
    <inertial><origin xyz="0.02 -0.01 0.03" rpy="0.1 0.2 0.3"/><mass value="3.0"/>
      <inertia ixx="0.05" iyy="0.07" izz="0.09" ixy="0.001" ixz="-0.002" iyz="0.003"/></inertial>
  </link>
  <link name="upper">
    <inertial><origin xyz="0.15 0 0"/><mass value="0.8"/>
      <inertia ixx="0.001" iyy="0.008" izz="0.008" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="slider">
    <inertial><origin xyz="0.05 0.01 0"/><mass value="0.3"/>
      <inertia ixx="0.0004" iyy="0.0009" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="wheel">
    <inertial><origin xyz="0 0 0.02"/><mass value="0.2"/>
      <inertia ixx="0.0002" iyy="0.0002" izz="0.0003" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="shoulder" type="revolute"><parent link="box"/><child link="upper"/>
    <origin xyz="0.1 0.05 0.2" rpy="0 0.3 0"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
  <joint name="slide" type="prismatic"><parent link="upper"/><child link="slider"/>
    <origin xyz="0.3 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-0.2" upper="0.2" effort="10" velocity="10"/></joint>
  <joint name="spin" type="continuous"><parent link="box"/><child link="wheel"/>
    <origin xyz="-0.1 0 -0.1" rpy="0.4 0 0"/><axis xyz="0 0.6 0.8"/></joint>
</robot>
"""


def _relative(got: np.ndarray, ref: np.ndarray) -> float:
    return float(np.max(np.abs(got - ref)) / max(np.max(np.abs(ref)), 1.0))


def _box_arm(path: Path, *, armature: bool = False) -> robodyn.Robot:
    urdf = path / "box_arm.urdf"
    urdf.write_text(ARM_URDF)
    robot = robodyn.load(urdf, free_flyer=True)
    if not armature:
        return robot
    model = robot.model.copy()
    model.armature[:] = [0.5, 0.6, 0.7, 0.01, 0.02, 0.03, 0.004, 0.2, 0.003]  # [kg | kg m^2]
    return robodyn.Robot.from_model(model, name="box_arm_rotors", urdf_path=urdf)


@pytest.fixture(scope="module")
def talos() -> robodyn.Robot:
    return robodyn.load("talos", free_flyer=True)


def _models(talos: robodyn.Robot, tmp_path: Path) -> list[robodyn.Robot]:
    return [talos, _box_arm(tmp_path), _box_arm(tmp_path, armature=True)]


def test_the_free_flyer_is_read_as_the_root_row(talos: robodyn.Robot) -> None:
    assert tree.unsupported(talos) is None
    t = tree.extract(talos)
    assert (t.nq, t.nv) == (talos.nv + 1, talos.nv)
    assert list(t.itree[0]) == [-1, tree_layout.FREEFLYER, 0, 0]
    assert t.ftree[0, tree_layout.F_TOTAL] == pytest.approx(talos.total_mass, rel=1e-15)


def test_algorithms_match_pinocchio(talos: robodyn.Robot, tmp_path: Path) -> None:
    for robot in _models(talos, tmp_path):
        compiled = tree.compiled_of(robot)
        assert max(compiled.check.values()) <= tree.VERIFY_RTOL, robot.name
        model, data = robot.model, robot.data
        rng = np.random.default_rng(2024)  # other states than the built-in check's
        for _ in range(6):
            q, v = robot.random_state(rng)
            tau, a = rng.normal(size=robot.nv), rng.normal(size=robot.nv)
            assert _relative(compiled.acceleration(q, v, tau), pin.aba(model, data, q, v, tau)) < ALGORITHM_RTOL
            assert _relative(compiled.inverse_dynamics(q, v, a), pin.rnea(model, data, q, v, a)) < ALGORITHM_RTOL
            M = pin.crba(model, data, q)
            M = np.triu(M) + np.triu(M, 1).T
            assert _relative(compiled.mass_matrix(q), M) < ALGORITHM_RTOL
            kin, pot = compiled.energies(q, v)
            ref = np.array([0.5 * v @ M @ v, pin.computePotentialEnergy(model, data, q)])
            assert _relative(np.array([kin, pot]), ref) < ALGORITHM_RTOL, robot.name


def test_far_from_the_world_origin(talos: robodyn.Robot) -> None:
    # world-origin inertias of bodies d away carry m d^2 terms: the kernels work at the free flyer instead
    compiled = tree.compiled_of(talos)
    rng = np.random.default_rng(9)
    for distance in (10.0, 1e3):  # [m]
        q, v = talos.random_state(rng)
        q[:3] *= distance / np.linalg.norm(q[:3])
        tau = rng.normal(size=talos.nv)
        ref = pin.aba(talos.model, talos.data, q, v, tau)
        assert _relative(compiled.acceleration(q, v, tau), ref) < ALGORITHM_RTOL, distance
        _, pot = compiled.energies(q, v)
        assert pot == pytest.approx(pin.computePotentialEnergy(talos.model, talos.data, q), rel=ALGORITHM_RTOL)


def test_integrate_is_pinocchios(talos: robodyn.Robot) -> None:
    kernels = tree.kernels()
    itree = tree.extract(talos).itree
    rng = np.random.default_rng(3)
    out = np.empty(talos.nq)
    for k in range(300):
        q, _ = talos.random_state(rng)
        dq = rng.normal(size=talos.nv) * 10.0 ** rng.uniform(-9, 1)
        if k % 3 == 0:  # a small rotation: the Taylor branches
            dq[3:6] *= 1e-6
        if k % 2 == 0:  # a quaternion drifted off unit length, as a long run leaves it
            q[3:7] *= 1.0 + 1e-9
        kernels.integrate(itree, True, q, dq, out)
        unit = q.copy()
        unit[3:7] /= np.linalg.norm(q[3:7])  # the rotation a drifted quaternion stands for
        assert np.max(np.abs(out - pin.integrate(talos.model, unit, dq))) < INTEGRATE_ATOL
        assert abs(np.linalg.norm(out[3:7]) - 1.0) < INTEGRATE_ATOL


def test_a_free_flyer_is_never_held(tmp_path: Path) -> None:
    robot = _box_arm(tmp_path)
    t = tree.compiled_of(robot).tree
    kernels = tree.kernels()
    rng = np.random.default_rng(5)
    q, v = robot.random_state(rng)
    tau = rng.normal(size=robot.nv)
    free, held = np.empty(robot.nv), np.empty(robot.nv)
    ws = np.zeros((t.itree.shape[0], kernels.WCOLS))
    kernels.aba(t.itree, t.ftree, t.grav, t.flyer, q, v, tau, ws, free)
    ws[0, tree_layout.W_LOCK] = 1.0
    ws[0, tree_layout.W_LAMBDA] = np.nan
    kernels.aba(t.itree, t.ftree, t.grav, t.flyer, q, v, tau, ws, held)
    np.testing.assert_array_equal(held, free)  # the lock flag is ignored on a free flyer
    assert ws[0, tree_layout.W_LAMBDA] == 0.0


def _model_with(joints: list[tuple[int, pin.JointModel]]) -> robodyn.Robot:
    model = pin.Model()
    for k, (parent, joint) in enumerate(joints):
        j = model.addJoint(parent, joint, pin.SE3.Identity(), f"j{k}")
        model.appendBodyToJoint(j, pin.Inertia.FromBox(1.0, 0.1, 0.2, 0.3), pin.SE3.Identity())
    return robodyn.Robot.from_model(model, name="hand_built")


def test_what_stays_refused() -> None:
    below = _model_with([(0, pin.JointModelRZ()), (1, pin.JointModelFreeFlyer())])
    assert "free flyer below joint 'j0'" in str(tree.unsupported(below))
    beside = _model_with([(0, pin.JointModelFreeFlyer()), (0, pin.JointModelRX())])
    assert "free flyer beside the root joint 'j1'" in str(tree.unsupported(beside))
    assert "only as the root of the whole tree" in str(tree.unsupported(beside))
    ball = _model_with([(0, pin.JointModelFreeFlyer()), (1, pin.JointModelSpherical())])
    assert "JointModelSpherical" in str(tree.unsupported(ball))
    with pytest.raises(AssumptionError, match="only as the root"):
        tree.extract(below)


# The free flyer's displacement R V nu against 40-digit arithmetic, for rotations of 1e-4 to 1e-2 rad
# per step (a step's rotation in a run): V's (1 - cos t) / t^2 taken as 2 sin^2(t/2) / t^2 and
# (t - sin t) / t^3 as its series do not cancel. Pinocchio's exp6 there: 6.5e-14 at 1e-3 rad (measured).
EXP_ATOL = 1e-14


def test_the_free_flyers_step_is_exact_to_round_off_where_its_terms_would_cancel() -> None:
    import mpmath  # sympy's dependency, in the test extra

    mpmath.mp.dps = 40
    robot = robodyn.load("panda", free_flyer=True)
    kernels, itree = tree.kernels(), tree.extract(robot).itree
    rng = np.random.default_rng(11)
    out = np.empty(robot.nq)
    for theta in (1e-4, 3e-4, 1e-3, 3e-3, 1e-2):
        q, _ = robot.random_state(rng)
        dq = 3.0 * rng.normal(size=robot.nv)
        axis = rng.normal(size=3)
        dq[3:6] = theta * axis / np.linalg.norm(axis)
        kernels.integrate(itree, True, q, dq, out)
        x, y, z, w = (mpmath.mpf(float(c)) for c in q[3:7])
        R = mpmath.matrix(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
            ]
        )
        om = [mpmath.mpf(float(c)) for c in dq[3:6]]
        t = mpmath.sqrt(sum(c * c for c in om))
        W = mpmath.matrix([[0, -om[2], om[1]], [om[2], 0, -om[0]], [-om[1], om[0], 0]])
        V = mpmath.eye(3) + (1 - mpmath.cos(t)) / t**2 * W + (t - mpmath.sin(t)) / t**3 * W * W
        exact = mpmath.matrix([mpmath.mpf(float(c)) for c in q[:3]]) + R * (
            V * mpmath.matrix([float(c) for c in dq[:3]])
        )
        assert np.max(np.abs(out[:3] - np.array([float(c) for c in exact]))) < EXP_ATOL, theta


@pytest.mark.parametrize("integrator", ["rk4", "semi_implicit_euler"])
def test_a_free_flying_robot_runs_in_the_compiled_loop_and_agrees(integrator: str) -> None:
    # the Panda on a free flyer, falling and tumbling from a spin, its joints striking their stops
    robot = robodyn.load("panda", free_flyer=True)
    v0 = np.zeros(robot.nv)
    v0[:6] = [0.3, -0.2, 1.0, 2.0, -1.0, 0.5]  # [m/s, rad/s] in the base's frame
    kw = {"duration": 0.5, "dt": 1e-3, "integrator": integrator}
    got = robodyn.simulate(robot, robot.neutral(), v0, **kw)  # type: ignore[arg-type]
    ref = robodyn.simulate(robot, robot.neutral(), v0, backend="aba", **kw)  # type: ignore[arg-type]
    assert got.meta["loop"] == "compiled" and got.meta["backend"] == "numba"
    assert got.meta["impacts"] == ref.meta["impacts"]
    assert np.max(np.abs(got.q - ref.q)) < 1e-11
    assert np.max(np.abs(got.v - ref.v)) < 1e-9
    assert abs(got.max_ledger_residual - ref.max_ledger_residual) < 1e-9
    assert np.allclose(np.linalg.norm(got.q[:, 3:7], axis=1), 1.0, atol=1e-14)  # the quaternion stays unit
