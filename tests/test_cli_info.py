"""robodyn info: text and JSON, reduction options, findings, bad input."""

from __future__ import annotations

import json
import subprocess
import sys

from robodyn.cli import main
from robodyn.errors import EXIT_BAD_INPUT


def test_info_geared_arm_text(capsys):
    assert main(["info", "geared_arm"]) == 0
    out = capsys.readouterr().out
    assert "geared_arm: nq = 1, nv = 1, total mass = 0.243 kg" in out
    assert "0.0027" in out and "1.08e-06" in out  # armature J_m n^2 and rotor inertia J_m
    assert "Physical consistency: no findings" in out


def test_info_json_matches_the_model(capsys):
    assert main(["info", "cart_pole", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["nq"] == 2 and data["nv"] == 2
    joints = {j["name"]: j for j in data["joints"]}
    assert joints["slider"]["type"] == "prismatic" and joints["slider"]["actuated"]
    assert joints["hinge"]["type"] == "revolute" and not joints["hinge"]["actuated"]
    assert joints["hinge"]["axis"] == [0.0, 1.0, 0.0]
    assert data["total_mass"] == 1.1
    assert data["findings"] == [] and data["n_errors"] == 0


def test_info_talos_reports_armature_and_free_flyer_hint(capsys):
    assert main(["info", "talos", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["nv"] == 32 and data["free_flyer_hint"] and not data["free_flyer"]
    assert sum(1 for j in data["joints"] if j["armature"] == [0.1]) == 30
    assert "gripper_left_motor_single_joint" in data["skipped_passive"]
    assert main(["info", "talos", "--free-flyer", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["nv"] == 38


def test_info_keep_reduces(capsys):
    assert main(["info", "panda", "--keep", "panda_joint2,panda_joint4", "--reference", "default", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["nv"] == 2 and [j["name"] for j in data["joints"]] == ["panda_joint2", "panda_joint4"]
    assert data["reduced_from"]["keep"] == "panda_joint2,panda_joint4"


def test_info_reports_impossible_inertia_instead_of_refusing(capsys):
    assert main(["info", "romeo_small"]) == 0
    out = capsys.readouterr().out
    assert "triangle" in out and "RShoulderYawLink" in out


def test_info_geometry_finds_every_mesh_of_talos_full(capsys):
    # talos_full's URIs read package:///example-robot-data/...: all 93 files exist, none is "missing".
    assert main(["info", "talos_full", "--geometry", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["geometry_checked"] and [f for f in data["findings"] if f["code"] == "mesh_missing"] == []


def test_info_geometry_reports_a_missing_mesh(tmp_path, capsys):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(
        '<robot name="arm"><link name="base"/><link name="a"><inertial><mass value="1"/>'
        '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'
        '<visual><geometry><mesh filename="package:///nowhere/a.stl"/></geometry></visual></link>'
        '<joint name="j" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
    )
    assert main(["info", str(urdf), "--geometry"]) == 0
    out = capsys.readouterr().out
    assert "warning mesh_missing" in out and "'package:///nowhere/a.stl' not found" in out


def test_info_bad_inputs(capsys):
    assert main(["info", "no_such_robot"]) == EXIT_BAD_INPUT
    assert "unknown model 'no_such_robot'" in capsys.readouterr().err
    assert main(["info", "panda", "--lock", "panda_joint1"]) == EXIT_BAD_INPUT
    assert "name=value" in capsys.readouterr().err
    assert main(["info", "panda", "--keep", "elbow"]) == EXIT_BAD_INPUT
    assert "panda_joint1" in capsys.readouterr().err


def test_info_talos_subprocess():
    result = subprocess.run(
        [sys.executable, "-m", "robodyn", "info", "talos"], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    assert "talos: nq = 32, nv = 32" in result.stdout and "arm_left_1_joint" in result.stdout


def _gripper_with_a_mimic_finger(folder):
    """my/mimic.urdf: <robot name="gripper">, finger_b mimics finger_a x 0.5."""
    link = (
        '<link name="{}"><inertial><mass value="0.1"/>'
        '<inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>'
    )
    joint = (
        '<joint name="{}" type="prismatic"><parent link="palm"/><child link="{}"/><axis xyz="1 0 0"/>'
        '<limit lower="0" upper="0.04" effort="20" velocity="0.2"/>{}</joint>'
    )
    urdf = folder / "my" / "mimic.urdf"
    urdf.parent.mkdir()
    urdf.write_text(
        '<robot name="gripper">'
        + link.format("palm")
        + link.format("a")
        + link.format("b")
        + joint.format("finger_a", "a", "")
        + joint.format("finger_b", "b", '<mimic joint="finger_a" multiplier="0.5" offset="0"/>')
        + "</robot>"
    )
    return urdf


def test_info_mimic_joint_shows_its_coupling_not_empty_columns(tmp_path, capsys):
    urdf = _gripper_with_a_mimic_finger(tmp_path)
    assert main(["info", str(urdf), "--mimic"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("gripper: nq = 1, nv = 1")  # the URDF's robot name, not the file stem "mimic"
    row = next(line for line in out.splitlines() if line.strip().startswith("finger_b"))
    assert "[]" not in out
    assert row.rstrip().endswith("mimics finger_a x 0.5")
    assert row.split()[5:13] == ["-"] * 8  # limits, vel, effort, armature, rotor J, gear, damping, friction
    assert main(["info", str(urdf)]) == 0  # without --mimic: an independent joint, its URDF coupling named
    row = next(line for line in capsys.readouterr().out.splitlines() if line.strip().startswith("finger_b"))
    assert "0.2" in row and "URDF mimic of finger_a x 0.5" in row


def test_info_unknown_model_suggests_close_names_and_list(capsys):
    assert main(["info", "pandaa"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "unknown model 'pandaa'; did you mean panda" in err and "robodyn info --list" in err
    assert len(err.splitlines()) == 1 and "ur10_limited" not in err  # not the 100 names


def test_info_list_names_every_model(capsys):
    from robodyn.model.sources import model_sources

    assert main(["info", "--list"]) == 0
    out = capsys.readouterr().out
    names = [line.split()[0] for line in out.splitlines()[:-1]]
    assert sorted(names) == sorted(model_sources().names()) and {"pendubot", "panda", "talos"} <= set(names)
    assert main(["info", "--list", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["pendubot"]["description"].startswith("two-link")
    assert main(["info"]) == EXIT_BAD_INPUT
    assert "--list" in capsys.readouterr().err


def test_info_refuses_a_urdf_given_as_srdf(capsys):
    from robodyn.model.sources import resolve

    urdf = resolve("pendubot").urdf
    assert main(["info", "pendubot", "--srdf", str(urdf)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "this is a URDF" in err and "not an SRDF" in err and len(err.splitlines()) == 1
