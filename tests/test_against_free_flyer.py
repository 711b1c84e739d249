"""robodyn check MODEL --against ENGINE --free-flyer: each engine's floating base mapped to Pinocchio's free flyer.

Engine versions as in tests/test_against.py (mujoco 4.0.0, pybullet 3.2.7, drake 1.51.1).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.cli import main
from robodyn.errors import EXIT_BAD_INPUT, EXIT_OK, InputError
from robodyn.other_engines import against, floating
from tests import _against_urdfs as urdfs

ENGINES = ("mujoco", "drake")  # PyBullet gives no floating base's C v, G: refused (test below)
SAMPLES = 5  # seeded states: a wrong convention moves M, C v or G by O(1) at any state with a turned base
# Engines that agree do so to ~1e-15 (the same sums in other orders and frames); a wrong convention moves them by O(1).
RTOL = 1e-9


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("against_free_flyer")


def _largest(report: robodyn.AgainstReport) -> float:
    return max(max(c.differences.values()) for c in report.comparisons)


@pytest.mark.parametrize("model", ["solo12", "a1"])
def test_example_robot_data_free_flyers_agree(model: str) -> None:
    urdfs.needs(ENGINES)
    report = against(robodyn.load(model, free_flyer=True), ENGINES, samples=SAMPLES, rtol=RTOL)
    assert [c.status for c in report.comparisons] == ["agree"] * 3, report.rows()
    assert _largest(report) < RTOL


def test_a_rotated_off_centre_base_with_a_welded_sensor_agrees(folder: Path) -> None:
    robot = robodyn.load(urdfs.write("floating_base", folder), free_flyer=True)
    urdfs.needs(ENGINES)
    report = against(robot, ENGINES, samples=SAMPLES, rtol=RTOL)
    assert report.status == "agree", report.rows()
    assert _largest(report) < RTOL
    # the base's block is the whole robot's: the comparison covers it (a turned base, non-zero v and w)
    q, v = robot.random_state(np.random.default_rng(0))
    assert abs(q[6]) < 0.99 and np.abs(v[:6]).min() > 0.0


def test_a_root_link_named_world_floats_in_mujoco_at_its_child(folder: Path) -> None:
    # Pinocchio floats the root link `world`; MuJoCo's freejoint is on `trunk`, 0.06 m and a quarter turn away.
    robot = robodyn.load(urdfs.write("world_root", folder), free_flyer=True)
    assert robot.model.frames[robot.model.getFrameId("world")].parentJoint == 1
    urdfs.needs(ENGINES)
    report = against(robot, ENGINES, samples=SAMPLES, rtol=RTOL)
    mujoco = [c for c in report.comparisons if c.engine == "mujoco"]
    assert [c.status for c in mujoco] == ["agree", "agree"], report.rows()
    assert max(max(c.differences.values()) for c in mujoco) < RTOL
    # Drake welds the robot to its world body `world`: nothing floats, and it says so
    (drake,) = [c for c in report.comparisons if c.engine == "drake"]
    assert drake.refused is not None and "takes the root link named world as its world body" in drake.refused


def test_the_base_body_is_compared(folder: Path) -> None:
    # Drake replaces a base link's physically invalid inertia (as it does ANYmal's and Go1's): the difference is in
    # the free flyer's body, and named; MuJoCo refuses the file with its own message.
    robot = robodyn.load(urdfs.write("invalid_base", folder), free_flyer=True, check_physics=False)
    urdfs.needs(ENGINES)
    report = against(robot, ENGINES, samples=SAMPLES, rtol=RTOL)
    by = {(c.engine, c.reading): c for c in report.comparisons}
    assert "inertia must have positive eigenvalues" in str(by["mujoco", "default"].refused)
    drake = by["drake", "default"]
    assert drake.unexplained is None and len(drake.causes) == 1
    (cause,) = drake.causes
    assert cause.where == "trunk (root_joint)"
    assert (
        cause.what.startswith("physically invalid inertia of trunk in the file") and "drake replaces it" in cause.what
    )
    assert cause.effect["M"] > 1e-3


def test_conventions_measured_on_the_engines() -> None:
    # MuJoCo's freejoint: qpos [x y z qw qx qy qz], qvel [world linear; local angular], read back from MuJoCo's own
    # kinematics (mj_objectVelocity in the body's local frame: [angular; linear]).
    import mujoco

    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body name="b"><freejoint/><geom size="0.1" mass="1"/></body></worldbody></mujoco>'
    )
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    quaternion = rng.normal(size=4)
    q = np.concatenate([rng.normal(size=3), quaternion / np.linalg.norm(quaternion)])  # Pinocchio's [.. qx qy qz qw]
    v = rng.normal(size=6)  # Pinocchio's [local linear; local angular]
    data.qpos[:], data.qvel[:], *_ = floating.mujoco_base(q, v)
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.xmat[1].reshape(3, 3), floating.rotation(q[3:]), atol=1e-15)
    local = np.zeros(6)
    mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, 1, local, 1)
    np.testing.assert_allclose(local, np.concatenate([v[3:], v[:3]]), atol=1e-14)


def test_cli_free_flyer_and_pybullet_refused(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", "solo12", "--against", "mujoco", "--free-flyer", "--samples", "3"]) == EXIT_OK
    assert "every engine agrees with robodyn" in capsys.readouterr().out
    assert main(["check", "solo12", "--against", "pybullet", "--free-flyer"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "PyBullet 3.2.7 gives no floating base's C v and G" in err
    with pytest.raises(InputError, match="drop --free-flyer"):
        against(robodyn.load("solo12", free_flyer=True), ("mujoco", "pybullet"))
