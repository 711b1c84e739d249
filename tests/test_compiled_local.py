"""The compiled ABA's passes in each joint's own axes (engine/tree/local.py), chosen per model by sim/tree.compiled_of.

The world-axes passes are the faster ones and stay wherever they pass the check against Pinocchio
(every built-in); a model where they fail it (an exact zero of the model only nearly one after
rounding in world axes) is served with the joint-axes passes instead of being refused.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.errors import AssumptionError
from robodyn.sim import tree
from tests._urdf import _inertial
from tests.test_compiled import TRAJECTORY_RTOL, _relative

# The compiled ABA against Pinocchio on one state, relative to the largest entry: the compiled path's
# own gate (tree.VERIFY_RTOL); the joint-axes passes must meet it where the world-axes ones do not.
ALGORITHM_RTOL = 1e-12

# iCub's neck in small, on a torso far from the world origin: a head that is a point mass 0.11 m
# out on the yaw axis's plane, with pitch and roll links of 0.1 kg on their joints' origins, and the
# roll and yaw axes crossing at one point (M's condition number 2e8). Its projected articulated
# inertia has a direction that moves nothing; in each joint's own axes that direction is a
# coordinate axis and its column is exactly 0, in world axes it is only nearly so: the compiled ABA
# in world axes differed from Pinocchio's by 1.2e-9 relative (measured), in joint axes by 2e-14.
NECK_URDF = """<?xml version="1.0"?><robot name="neck"><link name="base"/>
  <link name="torso">{torso}</link><link name="pitch">{small}</link><link name="roll">{small}</link>
  <link name="head">{head}</link>
  <joint name="torso_yaw" type="revolute"><parent link="base"/><child link="torso"/>
    <origin xyz="0.83 -0.61 1.27" rpy="0.37 -0.21 0.9"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="50" velocity="2"/></joint>
  <joint name="neck_pitch" type="revolute"><parent link="torso"/><child link="pitch"/>
    <origin xyz="0.00231 0.1933 -1.18362e-17" rpy="1.5707963 -1.5707927 0"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="5" velocity="2"/></joint>
  <joint name="neck_roll" type="revolute"><parent link="pitch"/><child link="roll"/>
    <origin xyz="0.0095 0 0" rpy="-1.5707963 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="5" velocity="2"/></joint>
  <joint name="neck_yaw" type="revolute"><parent link="roll"/><child link="head"/>
    <origin xyz="0 0 0" rpy="1.5707963 0 0"/><axis xyz="0 -1 0"/>
    <limit lower="-3" upper="3" effort="5" velocity="2"/></joint>
</robot>
"""

# A wheel at rest beside a swinging arm, with Coulomb friction far too stiff for RK4 at 1 ms
# (10 N m over v_f 1e-3 rad/s on 5e-5 kg m^2: rate 2e8 1/s) -- Stretch's right drive wheel, with its
# numbers (rpy -1.5708 with its 1e-16 terms, the centre of mass 27.65 mm along the axis). At rest
# its acceleration is exactly 0 in Pinocchio's ABA: the lever and the axis are parallel in the
# wheel's own axes, so U = IA S has a linear part of exact zeros. Turned into world axes, both carry
# round-off and c x w is not 0: the compiled ABA in world axes gave 9.3e-30 rad/s^2 there, which the
# friction amplified ~1e19-fold a step: the run blew up at step 3 and fell back to the Python loop.
WHEEL_URDF = """<?xml version="1.0"?><robot name="cart"><link name="base"/>
  <link name="wheel">{wheel}</link><link name="arm">{arm}</link>
  <joint name="wheel_joint" type="continuous"><parent link="base"/><child link="wheel"/>
    <origin xyz="0.13 -0.17035 0.0508" rpy="-1.5708 1.2717e-16 4.8006e-17"/><axis xyz="0 0 1"/>
    <dynamics friction="10"/></joint>
  <joint name="arm_joint" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0.31 -0.2 1.1" rpy="0.2 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
</robot>
"""


def _neck(tmp_path: Path) -> robodyn.Robot:
    path = tmp_path / "neck.urdf"
    path.write_text(
        NECK_URDF.format(
            torso=_inertial(4.7, (0.01, 0.02, 0.11), np.diag([0.03, 0.04, 0.02])),
            small=_inertial(0.1, (0.0, 0.0, 0.0), np.diag([1e-9, 1e-9, 1e-9])),
            head=_inertial(1.33687, (0.0185, -0.1108, 0.0), np.diag([1e-8, 1e-8, 1e-8])),
        )
    )
    return robodyn.load(path)


def _wheel(tmp_path: Path) -> robodyn.Robot:
    path = tmp_path / "cart.urdf"
    path.write_text(
        WHEEL_URDF.format(
            wheel=_inertial(0.20773, (0.0, 0.0, 0.02765), np.diag([5.4e-5, 5.4e-5, 5.1e-5])),
            arm=_inertial(1.0, (0.0, 0.0, -0.3), np.diag([0.01, 0.01, 0.001])),
        )
    )
    return robodyn.load(path)


def test_a_point_mass_head_on_crossing_neck_axes_is_served_in_joint_axes(tmp_path: Path) -> None:
    robot = _neck(tmp_path)
    with pytest.raises(AssumptionError, match="differ from Pinocchio"):  # the world axes fail the gate
        tree.CompiledDynamics(tree.extract(robot), {}).verify(robot)
    compiled = tree.compiled_of(robot)  # served, not refused
    assert compiled.passes == "joint axes" and compiled.tree.local
    assert tree.compiled_of(robot) is compiled  # the choice is cached with the check
    rng = np.random.default_rng(5)
    for _ in range(8):
        q, v = robot.random_state(rng)
        tau = rng.uniform(-1.0, 1.0, robot.nv)
        assert np.linalg.cond(robot.M(q)) > 1e7  # ill-conditioned indeed: the test is about round-off
        ref = robot.forward_dynamics(q, v, tau)
        assert _relative(compiled.acceleration(q, v, tau), ref) < ALGORITHM_RTOL
    compiled.verify(robot)  # RNEA, CRBA and the energies too (world axes: the choice is the ABA's)
    compiled.inverse_dynamics(q, v, tau)  # checked at first use: the flag is not taken for an edit


def test_stretchs_wheel_at_rest_runs_compiled_in_joint_axes_as_the_python_loop(tmp_path: Path) -> None:
    robot = _wheel(tmp_path)
    q0 = robot.neutral()
    q0[robot.joint("arm_joint").idx_q] = 0.8
    options = {"duration": 0.2, "dt": 1e-3, "limits": False}
    got = robodyn.simulate(robot, q0, np.zeros(robot.nv), **options)
    ref = robodyn.simulate(robot, q0, np.zeros(robot.nv), backend="aba", **options)
    assert got.meta["stiff_friction"]["joints"] == ["wheel_joint"]  # stiff indeed: said, not hidden
    assert (got.meta["loop"], ref.meta["loop"]) == ("compiled", "python")  # no fall-back
    assert got.meta["aba_passes"] == "joint axes"
    wheel = robot.joint("wheel_joint").idx_v
    assert np.all(got.v[:, wheel] == 0.0) and np.all(ref.v[:, wheel] == 0.0)  # at rest, exactly, in both
    assert _relative(got.q, ref.q) < TRAJECTORY_RTOL and _relative(got.v, ref.v) < TRAJECTORY_RTOL


def test_the_panda_keeps_the_world_axes_passes_to_the_bit() -> None:
    robot = robodyn.load("panda")
    compiled = tree.compiled_of(robot)
    assert compiled.passes == "world axes" and not compiled.tree.local
    world = tree.CompiledDynamics(tree.extract(robot), {})  # the world-axes kernel, as every model had it
    local = tree.CompiledDynamics(tree.extract(robot).with_local_passes(), {})
    rng = np.random.default_rng(11)
    differ = 0
    for _ in range(5):
        q, v = robot.random_state(rng)
        tau = rng.uniform(-1.0, 1.0, robot.nv)
        a = compiled.acceleration(q, v, tau)
        assert np.array_equal(a, world.acceleration(q, v, tau))  # identical arithmetic: exact
        differ += not np.array_equal(a, local.acceleration(q, v, tau))  # the other passes round otherwise
    assert differ > 0
    run = robodyn.simulate(robot, robot.neutral(), np.zeros(robot.nv), duration=0.01, dt=1e-3, backend="numba")
    assert (run.meta["loop"], run.meta["aba_passes"]) == ("compiled", "world axes")


@pytest.mark.parametrize("name", ["panda", "talos", "panda_free_flyer"])
def test_the_joint_axes_passes_match_pinocchio_on_the_built_ins(name: str) -> None:
    """Where the world axes are chosen, the joint-axes passes would pass the check too (a free-flyer root included)."""
    robot = robodyn.load("panda", free_flyer=True) if name == "panda_free_flyer" else robodyn.load(name)
    local = tree.CompiledDynamics(tree.extract(robot).with_local_passes(), {})
    assert local.passes == "joint axes"
    assert local.verify(robot, parts=("aba",))["aba"] <= tree.VERIFY_RTOL


def test_a_model_failing_both_passes_is_refused_naming_the_joint_axes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    robot = _neck(tmp_path)
    monkeypatch.setattr(tree, "VERIFY_RTOL", 1e-300)  # no difference but an exact 0 passes
    monkeypatch.setattr(tree, "VERIFY_SPREAD", 0.0)
    with pytest.raises(AssumptionError, match=r"algorithms \(ABA in joint axes\) differ from Pinocchio"):
        tree.compiled_of(robot)
