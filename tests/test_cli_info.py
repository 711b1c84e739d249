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
