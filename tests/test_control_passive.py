"""Controllers on robots robodyn did not build: another lab's Pendubot, a UR5, two pendulums on one base.

``swing_up`` drives the one joint its law is written for and refuses, naming the joint to declare
passive, a robot read with more actuators; its Pendubot gains come from the model's own energy and
inertia. ``lqr`` linearises any robot at any equilibrium it is given, and refuses a point that is not
one (naming each joint's missing torque) and a pair (A, B) that no gain stabilises (PBH).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn import control
from robodyn.control.acrobot import AcrobotEnergy
from robodyn.control.plant import wrap
from robodyn.errors import InputError
from robodyn.kinds.edit import write_params

FIXTURES = Path(__file__).resolve().parent / "fixtures"
OTHER = FIXTURES / "pendubot_other.urdf"  # Spong-Block's Pendubot as another lab wrote it: no SRDF
OTHER_EFFORT = 2.5  # [N m] the effort limit written on both of its joints
UPRIGHT = np.array([np.pi / 2, 0.0])
HANGING = [-1.5708, 0.0]  # the q0: 3.7e-6 rad off hanging, so the swing-up has a side to start

# "Balanced" at the end of the 20 s swing-up: both angles within 1e-3 rad of upright and both speeds
# within 1e-3 rad/s. Measured: the LQR takes over at t = 16.4 s and leaves 2.3e-6 rad and 7.9e-6 rad/s
# at 20 s; 1e-3 fails any run that is still swinging or has fallen.
BALANCED_RAD = 1e-3
# The gains scale exactly with the model (a product of the same numbers): round-off only.
SCALING_RTOL = 1e-9
# A UR5 held by LQR at a seeded pose from ~0.02 rad off: the slowest closed-loop pole is -0.74 /s
# (measured), so after 10 s the error is ~0.02 e^-7.4 ~ 1e-5 rad (times the modes' mixing, measured
# 1.3e-3 rad after 5 s); 1e-3 leaves that room and fails a loop that does not converge.
UR5_SETTLED_RAD = 1e-3
UR5_HOLD_S = 10.0

TWIN = """<?xml version="1.0"?>
<robot name="twin_pendulums">
  <link name="base"/>
  <link name="pole_a"><inertial><origin xyz="0 0 0.5"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="pole_b"><inertial><origin xyz="0 0 0.3"/><mass value="0.5"/>
    <inertia ixx="0.004" iyy="0.004" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="joint_a" type="revolute"><parent link="base"/><child link="pole_a"/><origin xyz="0 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-10" upper="10" effort="20" velocity="10"/></joint>
  <joint name="joint_b" type="revolute"><parent link="base"/><child link="pole_b"/><origin xyz="0 0.2 0"/>
    <axis xyz="0 1 0"/><limit lower="-10" upper="10" effort="20" velocity="10"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def other():
    """The other lab's Pendubot with its elbow declared passive, as ``--passive joint2`` loads it."""
    return robodyn.load(str(OTHER), passive=["joint2"])


# ------------------------------------------------------------------------------------------- swing_up
def test_swing_up_refuses_a_pendubot_whose_elbow_is_actuated_naming_the_joint_to_declare():
    robot = robodyn.load(str(OTHER))  # no SRDF: both joints count as actuated
    with pytest.raises(InputError, match=r"also actuates joint2: declare it passive \(--passive joint2, "):
        control.make("swing_up", robot)


def test_swing_up_of_a_pendubot_whose_shoulder_is_passive_is_the_acrobot_law():
    robot = robodyn.load(str(OTHER), passive=["joint1"])
    controller = control.make("swing_up", robot)
    assert isinstance(controller.swing_up, AcrobotEnergy)  # the elbow driven (tests/test_acrobot.py swings it)
    assert controller.swing_up.plant.effort.tolist() == [OTHER_EFFORT]


@pytest.mark.slow
def test_the_other_labs_pendubot_swings_up_and_balances_within_its_effort(other):
    """The issue's run: robodyn simulate pendubot_other.urdf --passive joint2 --controller swing_up ..."""
    controller = control.make("swing_up", other)
    trajectory = robodyn.simulate(other, HANGING, [0.0, 0.0], duration=20.0, dt=1e-3, torque=controller)
    assert np.max(np.abs(wrap(trajectory.q[-1] - UPRIGHT))) < BALANCED_RAD
    assert np.max(np.abs(trajectory.v[-1])) < BALANCED_RAD
    assert np.max(np.abs(trajectory.tau[:, 0])) <= OTHER_EFFORT
    assert np.all(trajectory.tau[:, 1] == 0.0)  # the elbow is passive


def test_pendubot_swing_up_gains_scale_with_the_model(other, tmp_path):
    """Masses times a, lengths times b: the law is the same law in time scaled by sqrt(b) iff
    k_p ~ 1/b, k_d ~ b^-1/2, accel_max ~ 1/b, kick ~ b^-1/2 and k_energy ~ a^-1 b^-1/2
    (link 2's weight moment ~ a b, its inertia ~ a b^2, w2 ~ b^-1/2)."""
    a, b = 3.0, 2.0
    p = robodyn.kinds.params.extract(other, "pendubot")
    scaled = {k: p[k] * a for k in ("m1", "m2")}
    scaled.update({k: p[k] * b for k in ("l1", "lc1", "lc2")})
    scaled.update({k: p[k] * a * b * b for k in ("I1", "I2")})
    path = tmp_path / "big.urdf"
    write_params(robodyn.load(str(OTHER)), "pendubot", scaled, path)
    big = robodyn.load(str(path), passive=["joint2"])
    small_law = control.make("swing_up", other).swing_up
    big_law = control.make("swing_up", big).swing_up
    ratios = {"k_p": 1 / b, "k_d": b**-0.5, "accel_max": 1 / b, "kick": b**-0.5, "k_energy": 1 / (a * b**0.5)}
    for gain, ratio in ratios.items():
        assert getattr(big_law, gain) == pytest.approx(ratio * getattr(small_law, gain), rel=SCALING_RTOL), gain


# ------------------------------------------------------------------------------------------- lqr
def test_lqr_balances_the_other_pendubot_upright(other):
    lqr = control.make("lqr", other)
    assert lqr.B.shape == (4, 1) and np.max(lqr.poles.real) < 0


def test_lqr_serves_the_fully_actuated_double_pendulum():
    robot = robodyn.load(str(OTHER))
    lqr = control.make("lqr", robot)
    assert lqr.B.shape == (4, 2) and np.max(lqr.poles.real) < 0


def test_lqr_at_a_non_trivial_equilibrium_of_an_underactuated_robot(other):
    """Link 2 upright on a link 1 at 1 rad (q1 + q2 = pi/2) is an equilibrium held by the shoulder alone."""
    q_eq = np.array([1.0, np.pi / 2 - 1.0])
    lqr = control.make("lqr", other, q_eq=q_eq.tolist())
    p = robodyn.kinds.params.extract(other, "pendubot")  # G1 from the closed form, not from Pinocchio
    g1 = p["g"] * ((p["m1"] * p["lc1"] + p["m2"] * p["l1"]) * np.cos(1.0) + p["m2"] * p["lc2"] * 0.0)
    assert lqr.u_eq == pytest.approx([g1], rel=1e-9)
    assert np.max(lqr.poles.real) < 0


def test_lqr_names_the_torque_a_point_that_is_no_equilibrium_lacks(other):
    q = [1.0, 0.3]
    p = robodyn.kinds.params.extract(other, "pendubot")
    needed = p["m2"] * p["g"] * p["lc2"] * np.cos(1.3)  # the elbow's gravity torque, which no actuator gives
    with pytest.raises(InputError) as info:
        control.make("lqr", other, q_eq=q)
    message = str(info.value)
    assert "is not an equilibrium" in message
    assert f"needs joint2 {needed:+.6g} N m (passive: no actuator gives it)" in message


def test_lqr_at_a_seeded_ur5_pose_with_gravity_compensation():
    """A fully actuated robot robodyn did not build, at a pose that is no seed state: u_eq = G(q_eq)."""
    robot = robodyn.load("ur5")
    rng = np.random.default_rng(3)
    q_eq = rng.uniform(-1.5, 1.5, robot.nq)
    lqr = control.make("lqr", robot, q_eq=q_eq.tolist())
    assert lqr.u_eq == pytest.approx(robot.G(q_eq), rel=1e-12)
    assert np.max(lqr.poles.real) < 0
    q0 = q_eq + 0.02 * rng.standard_normal(robot.nq)
    trajectory = robodyn.simulate(robot, q0, np.zeros(robot.nv), duration=UR5_HOLD_S, dt=1e-3, torque=lqr)
    assert np.max(np.abs(wrap(trajectory.q[-1] - q_eq))) < UR5_SETTLED_RAD


def test_lqr_refuses_an_unstable_mode_no_actuator_reaches(tmp_path):
    path = tmp_path / "twin.urdf"
    path.write_text(TWIN)
    robot = robodyn.load(str(path), passive=["joint_b"])
    with pytest.raises(
        InputError, match=r"not stabilisable: its unstable mode lambda = 5\.4\d* \+0j \[1/s\] moves joint_b"
    ):
        control.make("lqr", robot, q_eq=[0.0, 0.0])
    assert np.max(control.make("lqr", robodyn.load(str(path)), q_eq=[0.0, 0.0]).poles.real) < 0  # both driven
