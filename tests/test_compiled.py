"""The compiled tree path (sim/tree.py, engine/tree/algorithms.py, sim/whole_run.py) against Pinocchio and the ABA run."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.errors import AssumptionError, InputError
from robodyn.sim import tree
from robodyn.studies.stability import variant_path

# Compiled ABA / RNEA / CRBA against Pinocchio on one state, relative to the largest entry:
# two float64 implementations of the same recursions (world frame vs local frames).
ALGORITHM_RTOL = 1e-12
# Whole trajectories, compiled loop vs the Python pipeline with ABA: the same method, steps and
# stages, accelerations differing by round-off, amplified over the run (0.3 s: < 1e3 x).
TRAJECTORY_RTOL = 1e-11
# Talos's Coulomb friction, regularised as F tanh(v / 1e-3 rad/s), is stiff far beyond explicit
# methods' stability on its light joints (round-off grew by 1e10 within 150 Euler steps at dt =
# 10 us, measured): its runs are compared without losses, and friction on the Pendubot below.

MODELS = (
    "pendubot",
    "cart_pole",
    "geared_arm",
    "panda",
    "talos",
    "double_pendulum_continuous",
    *(
        str(variant_path(v))
        for v in ("cart_pole_point_bob", "geared_arm_rotor", "geared_arm_stiff", "pendubot_light_tip")
    ),
)


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1.0))


@pytest.fixture(scope="module", params=MODELS)
def robot(request: pytest.FixtureRequest) -> robodyn.Robot:
    return robodyn.load(request.param)


def test_algorithms_match_pinocchio(robot: robodyn.Robot) -> None:
    compiled = tree.compiled_of(robot)
    assert max(compiled.check.values()) <= tree.VERIFY_RTOL
    rng = np.random.default_rng(1234)  # other states than the built-in check's
    for _ in range(5):
        q, v = robot.random_state(rng)
        tau, a = rng.normal(size=robot.nv), rng.normal(size=robot.nv)
        assert _relative(compiled.acceleration(q, v, tau), robot.forward_dynamics(q, v, tau)) < ALGORITHM_RTOL
        assert _relative(compiled.inverse_dynamics(q, v, a), robot.inverse_dynamics(q, v, a)) < ALGORITHM_RTOL
        assert _relative(compiled.mass_matrix(q), robot.M(q)) < ALGORITHM_RTOL
        kin, pot = compiled.energies(q, v)
        assert kin == pytest.approx(robot.kinetic_energy(q, v), rel=ALGORITHM_RTOL, abs=1e-12)
        assert pot == pytest.approx(robot.potential_energy(q), rel=ALGORITHM_RTOL, abs=1e-12)


# A light hand far from the world origin on unaligned, unnormalised axes (Stretch's wrist, in small):
# taken about the world origin, its inertia carries m d^2 ~ 0.2 kg x (2 m)^2 against 1e-6 kg m^2
# about its own axis, and the compiled ABA lost 4 digits there (2.4e-12 relative, measured); taken at
# each joint's origin, as Pinocchio does, it stays at round-off.
UNALIGNED_URDF = """<?xml version="1.0"?>
<robot name="far_wrist"><link name="base"/>
  <link name="mast">{mast}</link><link name="arm">{arm}</link><link name="hand">{hand}</link>
  <joint name="lift" type="prismatic"><parent link="base"/><child link="mast"/><origin xyz="0.3 -0.2 0.2"/>
    <axis xyz="0 0 1"/><limit lower="0" upper="1" effort="100" velocity="1"/></joint>
  <joint name="reach" type="revolute"><parent link="mast"/><child link="arm"/>
    <origin xyz="1.2 0.4 0.9" rpy="0.3 -0.7 1.1"/><axis xyz="0.3 0.5 0.81"/>
    <limit lower="-3" upper="3" effort="50" velocity="2"/></joint>
  <joint name="wrist_yaw" type="revolute"><parent link="arm"/><child link="hand"/>
    <origin xyz="0.6 -0.3 0.5" rpy="1.0 0.2 -0.4"/><axis xyz="0.81 -0.3 0.5"/>
    <limit lower="-3" upper="3" effort="1" velocity="5"/></joint>
</robot>
"""
ALGORITHM_RTOL_FAR = 1e-12  # the same gate as the compiled path's own check (tree.VERIFY_RTOL)


def test_a_light_hand_on_unaligned_axes_far_from_the_origin_matches_pinocchio(tmp_path: Path) -> None:
    from tests._urdf import _inertial

    path = tmp_path / "far_wrist.urdf"
    path.write_text(
        UNALIGNED_URDF.format(
            mast=_inertial(5.0, (0.1, 0.0, 0.5), np.diag([0.4, 0.4, 0.02])),
            arm=_inertial(1.0, (0.3, -0.1, 0.2), np.diag([0.01, 0.02, 0.02])),
            hand=_inertial(0.2, (0.01, 0.0, 0.02), np.diag([1e-6, 2e-6, 1.5e-6])),
        )
    )
    robot = robodyn.load(path)
    assert [j.kind for j in robot.joints][1:] == ["JointModelRevoluteUnaligned"] * 2
    compiled = tree.CompiledDynamics(tree.extract(robot), {})
    rng = np.random.default_rng(3)
    for _ in range(8):
        q, v = robot.random_state(rng)
        tau = rng.uniform(-1.0, 1.0, robot.nv)
        ref = robot.forward_dynamics(q, v, tau)
        assert _relative(compiled.acceleration(q, v, tau), ref) < ALGORITHM_RTOL_FAR
    compiled.verify(robot)  # and the path's own check takes it


def test_a_wrong_tree_is_refused_by_the_check() -> None:
    robot = robodyn.load("panda")
    good = tree.compiled_of(robot)
    for column in (15, 17, 28):  # a mass, a lever, an armature
        ftree = good.tree.ftree.copy()
        ftree[3, column] += 0.05
        bad = tree.CompiledDynamics(dataclasses.replace(good.tree, ftree=ftree), {})
        with pytest.raises(AssumptionError, match="differ from Pinocchio"):
            bad.verify(robot)


@pytest.mark.parametrize("integrator", ["rk4", "heun", "euler", "semi_implicit_euler"])
def test_whole_run_equals_the_aba_run(robot: robodyn.Robot, integrator: str) -> None:
    rng = np.random.default_rng(7)
    q0, v0 = robot.random_state(rng, speed=0.5)
    rtol = TRAJECTORY_RTOL
    options = {"duration": 0.3, "dt": 1e-3, "integrator": integrator, "limits": False}
    options["losses"] = not np.any(robot.friction)
    if robot.nv <= 2 and robot.nq == robot.nv:  # a spring needs a one-coordinate joint
        options["springs"] = {robot.joint_names[0]: (3.0, 0.1)}
    if np.any(robot.actuated):
        options["torque"] = 0.5 * robot.actuated
    got = robodyn.simulate(robot, q0, v0, **options)
    ref = robodyn.simulate(robot, q0, v0, backend="aba", **options)
    assert (got.meta["backend"], got.meta["loop"]) == ("numba", "compiled")
    assert (ref.meta["backend"], ref.meta["loop"]) == ("aba", "python")
    assert got.t.shape == ref.t.shape and got.evaluations == ref.evaluations
    scale = max(abs(ref.energy[0]), 1.0)
    for name in ("q", "v", "a"):
        assert _relative(getattr(got, name), getattr(ref, name)) < rtol, name
    for name in ("kinetic", "potential", "work_input", "work_damping"):
        assert np.max(np.abs(getattr(got, name) - getattr(ref, name))) < rtol * scale, name
    assert got.max_ledger_residual == pytest.approx(ref.max_ledger_residual, rel=1e-3, abs=rtol * scale)


def test_friction_and_damping_are_the_pipelines() -> None:
    robot = robodyn.load("pendubot")
    robot.model.friction[:] = [0.02, 0.01]  # [N m], regularised over 1e-3 rad/s as in sim/system.py
    robot.model.damping[:] = [0.01, 0.005]  # [N m s/rad]
    got = robodyn.simulate(robot, [0.3, 0.2], [0.0, 0.0], duration=1.0, dt=1e-3)
    ref = robodyn.simulate(robot, [0.3, 0.2], [0.0, 0.0], duration=1.0, dt=1e-3, backend="aba")
    assert got.meta["loop"] == "compiled" and got.meta["friction"] == [0.02, 0.01]
    assert _relative(got.q, ref.q) < TRAJECTORY_RTOL
    assert got.work_damping[-1] < -1e-3  # friction and damping took energy, booked alike
    assert np.max(np.abs(got.work_damping - ref.work_damping)) < TRAJECTORY_RTOL


# A wheel at rest beside a swinging arm, with Coulomb friction far too stiff for RK4 at 1 ms
# (10 N m over v_f 1e-3 rad/s on 4e-4 kg m^2: rate 2.5e7 1/s) -- Stretch's drive wheels in small.
# At rest its acceleration is exactly 0 in Pinocchio's ABA; any round-off there (the compiled ABA
# about the world origin gave 1.7e-13 rad/s^2) is amplified 1e16-fold a step and blew the compiled
# run up at step 3, which then fell back to the Python loop.
WHEEL_URDF = """<?xml version="1.0"?><robot name="cart"><link name="base"/>
  <link name="wheel">{wheel}</link><link name="arm">{arm}</link>
  <joint name="wheel_joint" type="continuous"><parent link="base"/><child link="wheel"/>
    <origin xyz="0.13 0.17 0.05" rpy="0 0 0.4"/><axis xyz="0 1 0"/><dynamics friction="10"/></joint>
  <joint name="arm_joint" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0.31 -0.2 1.1" rpy="0.2 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
</robot>
"""


def test_stiff_friction_on_a_wheel_at_rest_runs_compiled_as_the_python_loop(tmp_path: Path) -> None:
    from tests._urdf import _inertial

    path = tmp_path / "cart.urdf"
    path.write_text(
        WHEEL_URDF.format(
            wheel=_inertial(0.3, (0.0, 0.0, 0.0), np.diag([2e-4, 4e-4, 2e-4])),
            arm=_inertial(1.0, (0.0, 0.0, -0.3), np.diag([0.01, 0.01, 0.001])),
        )
    )
    robot = robodyn.load(path)
    q0 = robot.neutral()
    q0[robot.joint("arm_joint").idx_q] = 0.8
    options = {"duration": 0.2, "dt": 1e-3, "limits": False}
    got = robodyn.simulate(robot, q0, np.zeros(robot.nv), **options)
    ref = robodyn.simulate(robot, q0, np.zeros(robot.nv), backend="aba", **options)
    assert got.meta["stiff_friction"]["joints"] == ["wheel_joint"]  # stiff indeed: said, not hidden
    assert (got.meta["loop"], ref.meta["loop"]) == ("compiled", "python")  # no fall-back
    wheel = robot.joint("wheel_joint").idx_v
    assert np.all(got.v[:, wheel] == 0.0) and np.all(ref.v[:, wheel] == 0.0)  # at rest, exactly, in both
    assert _relative(got.q, ref.q) < TRAJECTORY_RTOL and _relative(got.v, ref.v) < TRAJECTORY_RTOL


def test_torque_callable_runs_compiled_and_agrees() -> None:
    robot = robodyn.load("cart_pole")

    def push(t: float, q: np.ndarray, v: np.ndarray) -> list[float]:
        return [30.0 * np.sin(5.0 * t) - 2.0 * v[0]]  # above the 20 N effort at times: clamped

    got = robodyn.simulate(robot, [0.0, 0.1], [0.0, 0.0], duration=0.5, dt=1e-3, torque=push)
    ref = robodyn.simulate(robot, [0.0, 0.1], [0.0, 0.0], duration=0.5, dt=1e-3, torque=push, backend="aba")
    assert got.meta["loop"] == "compiled"
    assert got.meta["effort_clamped_samples"] == ref.meta["effort_clamped_samples"] > 0
    assert _relative(got.q, ref.q) < TRAJECTORY_RTOL
    assert np.max(np.abs(got.work_input - ref.work_input)) < TRAJECTORY_RTOL


PLANAR_URDF = """<?xml version="1.0"?>
<robot name="puck">
  <link name="floor"/>
  <link name="puck"><inertial><mass value="1.0"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="glide" type="planar"><parent link="floor"/><child link="puck"/><axis xyz="0 0 1"/></joint>
</robot>
"""


def test_where_the_compiled_path_does_not_apply(tmp_path: Path) -> None:
    path = tmp_path / "puck.urdf"
    path.write_text(PLANAR_URDF)
    puck = robodyn.load(path)
    run = robodyn.simulate(puck, puck.neutral(), np.zeros(puck.nv), duration=0.01, dt=1e-3)
    assert run.meta["loop"] == "python" and "JointModelPlanar" in run.meta["compiled_loop"]
    with pytest.raises(InputError, match="backend 'numba' cannot serve"):
        robodyn.simulate(puck, puck.neutral(), np.zeros(puck.nv), duration=0.01, dt=1e-3, backend="numba")
    robot = robodyn.load("pendubot")
    adaptive = robodyn.simulate(robot, [0.3, 0.2], [0, 0], duration=0.01, dt=1e-3, integrator="dopri5")
    assert adaptive.meta["loop"] == "python" and "dopri5" in adaptive.meta["compiled_loop"]
    asked = robodyn.simulate(robot, [0.3, 0.2], [0, 0], duration=0.01, dt=1e-3, backend="crba")
    assert asked.meta["compiled_loop"] == "not used: backend crba asked"


def test_numba_backend_in_the_python_pipeline_agrees() -> None:
    robot = robodyn.load("pendubot")
    # an adaptive method: the compiled ABA serves as the smooth stage of the Python pipeline
    got = robodyn.simulate(robot, [0.3, 0.2], [0, 0], duration=0.2, dt=1e-2, integrator="dopri5", backend="numba")
    ref = robodyn.simulate(robot, [0.3, 0.2], [0, 0], duration=0.2, dt=1e-2, integrator="dopri5", backend="aba")
    assert (got.meta["backend"], got.meta["loop"]) == ("numba", "python")
    assert _relative(got.q, ref.q) < 1e-9  # adaptive step choices see round-off, then converge to rtol


def test_a_refused_numba_backend_gives_its_advice_once(monkeypatch: pytest.MonkeyPatch) -> None:
    robot = robodyn.load("panda")  # a fresh robot: its check runs now
    # every difference but an exact 0 fails the check, in world axes and in joint axes (the ABA's allowance is
    # max(VERIFY_RTOL, VERIFY_SPREAD x Pinocchio's own ABA-CRBA spread): the joint axes' ABA is within that spread
    # on every state of the Panda, so a negative gate alone no longer fails it)
    monkeypatch.setattr(tree, "VERIFY_RTOL", 1e-300)
    monkeypatch.setattr(tree, "VERIFY_SPREAD", 0.0)
    with pytest.raises(InputError) as info:
        robodyn.simulate(robot, robot.neutral(), np.zeros(robot.nv), duration=0.01, dt=1e-3, backend="numba")
    message = str(info.value)
    assert "differ from Pinocchio" in message and message.count("use backend 'aba'") == 1
