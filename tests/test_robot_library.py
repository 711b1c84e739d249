"""Every robot of example-robot-data: indexed, loaded, described by info, and checked."""

from __future__ import annotations

import numpy as np
import pytest

from robodyn.checker.compare import DEFAULT_RTOL, check
from robodyn.cli import main
from robodyn.errors import ModelError
from robodyn.model import sources as robot_library
from robodyn.model.consistency import all_findings
from robodyn.model.load import load
from robodyn.model.sources import resolve
from robodyn.model.summary import summarize

# Structural identities through M^-1 lose digits in proportion to cond(M): iCub's point-mass
# links give cond(M) ~ 4e6, so its identity rows are held to 1e-7 instead of 1e-9.
ILL_CONDITIONED_RTOL = 1e-7
ILL_CONDITIONED = {"icub", "icub_reduced"}

# Robots that Pinocchio parses but robodyn refuses, with the finding that refuses them.
REFUSED = {
    "romeo": "massless_subtree",  # 24 finger joints carry no mass: M is singular
    "romeo_laas_small": "inertia_not_psd",  # hip inertias with a negative eigenvalue
    "romeo_small": "triangle",  # shoulder and elbow yaw links break Ixx + Izz >= Iyy
}

# Robots whose mass matrix is singular at the neutral pose (always among check's samples), as simulate says there:
# icub's neck, 6e-18 of its largest eigenvalue at q = 0. That row fails, and only that one.
SINGULAR_AT_NEUTRAL = {"icub"}

ROBOTS = robot_library.distinct_robots()


def test_library_is_installed_and_indexed():
    assert robot_library.robots_dir() is not None
    assert len(ROBOTS) >= 60
    for name in ("panda", "talos", "ur5", "solo12", "tiago_dual"):
        assert name in ROBOTS


def test_talos_pairs_with_talos_srdf_and_gets_its_rotor_armature():
    robot = load("talos")
    assert robot.srdf_path is not None and robot.srdf_path.name == "talos.srdf"
    # talos.srdf: rotor inertia 1e-5 kg m^2 and gear ratio 100 on every arm, leg, torso and
    # head joint -> armature 1e-5 * 100^2 = 0.1 kg m^2; the two grippers have no rotor entry.
    armature = dict(zip(robot.joint_names, robot.armature, strict=True))
    assert armature["gripper_left_joint"] == 0.0 and armature["gripper_right_joint"] == 0.0
    others = [a for n, a in armature.items() if not n.startswith("gripper")]
    assert len(others) == 30
    np.testing.assert_allclose(others, 0.1, rtol=1e-12)
    np.testing.assert_allclose(
        np.diag(robot.M(robot.neutral())) - np.diag(load("talos", srdf=None).M(robot.neutral())), 0.0
    )


def test_ur5_pairs_with_ur5_srdf_and_free_flyer_hints():
    assert resolve("ur5").srdf is not None and resolve("ur5").srdf.name == "ur5.srdf"
    assert resolve("talos").free_flyer_hint and not resolve("panda").free_flyer_hint


def test_not_loadable_reasons_hold():
    reasons = robot_library.not_loadable()
    assert set(reasons) == {"cassie", "ur3.urdf"}
    folder = robot_library.robots_dir()
    assert not list((folder / "cassie_description").glob("**/*.urdf"))
    assert list((folder / "cassie_description" / "robots").glob("*.sdf"))
    with pytest.raises(ModelError, match="no name attribute"):
        load(folder / "ur_description" / "urdf" / "ur3.urdf")


@pytest.mark.parametrize("name", ROBOTS)
def test_every_robot_info_and_check(name):
    source = resolve(name)
    robot = load(name, check_physics=False, free_flyer=False)
    summary = summarize(robot, free_flyer_hint=source.free_flyer_hint)
    assert summary.nv == robot.nv and len(summary.joints) == len(robot.joints)
    assert summary.total_mass > 0
    codes = {f.code for f in all_findings(robot.model) if f.severity == "error"}
    if name in REFUSED:
        assert REFUSED[name] in codes
        with pytest.raises(ModelError, match="physically impossible"):
            load(name)
        return
    assert not codes, codes
    if robot.nv == 0:  # a lone body (hector, iris): only a free flyer moves it
        robot = load(name, free_flyer=True)
        assert robot.nv == 6
    samples = 5 if robot.nv > 20 else 10
    rtol = ILL_CONDITIONED_RTOL if name in ILL_CONDITIONED else DEFAULT_RTOL
    report = check(robot, samples=samples, seed=1, rtol=rtol)
    failures = [(r.quantity, r.max_rel_error) for r in report.failures]
    if name in SINGULAR_AT_NEUTRAL:
        assert [quantity for quantity, _ in failures] == ["M symmetric positive definite"], failures
        return
    assert report.passed, failures


def test_free_flyer_option_adds_six_dof():
    fixed, floating = load("solo12"), load("solo12", free_flyer=True)
    assert floating.nv == fixed.nv + 6 and floating.nq == fixed.nq + 7


def test_info_json_for_a_library_robot(capsys):
    assert main(["info", "ur5", "--json"]) == 0
    import json

    out = json.loads(capsys.readouterr().out)
    assert out["nv"] == 6 and len(out["joints"]) == 6 and out["srdf"].endswith("ur5.srdf")
