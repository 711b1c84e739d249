"""robodyn info: text and JSON, reduction options, findings, bad input."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

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
    # the description is the opening line of the built-in URDF's comment
    described = json.loads(capsys.readouterr().out)["pendubot"]["description"]
    assert described == "a two-link planar arm, joint 1 actuated (shoulder), joint 2 passive (elbow)"
    assert main(["info"]) == EXIT_BAD_INPUT
    assert "--list" in capsys.readouterr().err


def test_info_refuses_a_urdf_given_as_srdf(capsys):
    from robodyn.model.sources import resolve

    urdf = resolve("pendubot").urdf
    assert main(["info", "pendubot", "--srdf", str(urdf)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "this is a URDF" in err and "not an SRDF" in err and len(err.splitlines()) == 1


# --------------------------------------------------------------- inertia against the link's one primitive
def _one_link(folder, inertial, geometry, name="thing.urdf"):
    """A URDF with one moving link carrying ``inertial`` and ``geometry`` (raw XML)."""
    urdf = folder / name
    urdf.write_text(
        f'<robot name="thing"><link name="base"/><link name="a">{inertial}{geometry}</link>'
        '<joint name="j" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
    )
    return urdf


def _inertial(I, xyz="0 0 0", rpy="0 0 0", mass=2.0):
    return (
        f'<inertial><origin xyz="{xyz}" rpy="{rpy}"/><mass value="{mass!r}"/>'
        f'<inertia ixx="{I[0][0]!r}" ixy="{I[0][1]!r}" ixz="{I[0][2]!r}" iyy="{I[1][1]!r}" '
        f'iyz="{I[1][2]!r}" izz="{I[2][2]!r}"/></inertial>'
    )


def _primitives(capsys, urdf):
    assert main(["info", str(urdf), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    return data["primitives"], [f for f in data["findings"] if f["code"] == "inertia_vs_shape"]


def test_info_built_in_models_agree_with_their_primitives(capsys):
    for name, links in (("cart_pole", ["cart"]), ("geared_arm", ["link"]), ("pendubot", ["link2"])):
        primitives, findings = _primitives(capsys, name)
        assert [c["link"] for c in primitives] == links and findings == []
        # the URDFs print these inertias to 5 significant digits (pendubot's iyy = 2.6502e-3): 1e-4 covers it
        assert all(c["relative_difference"] < 1e-4 and not c["differs"] for c in primitives)


def test_info_motorcycle_wheels_differ_from_a_uniform_disk(capsys):
    from pathlib import Path

    urdf = Path(__file__).resolve().parents[1] / "examples" / "textbook" / "motorcycle" / "motorcycle.urdf"
    primitives, findings = _primitives(capsys, urdf)
    by_link = {c["link"]: c for c in primitives}
    assert not by_link["body"]["differs"]
    rear = by_link["rear"]
    uniform_axle = 9.0 * 0.33**2 / 2  # a uniform disk about its axle, 0.49005 kg m^2, against the URDF's 0.8
    assert rear["differs"] and rear["element"] == "Iyy" and rear["source"] == "visual"
    assert rear["uniform_inertia"][1][1] == pytest.approx(uniform_axle, rel=1e-12)
    assert rear["relative_difference"] == pytest.approx((0.8 - uniform_axle) / uniform_axle, rel=1e-12)
    assert [f["where"] for f in findings] == ["rear", "front"] and all(f["severity"] == "note" for f in findings)
    assert "Iyy = 0.8 kg m^2 in the URDF, 0.49005 for the uniform cylinder" in findings[0]["message"]
    assert main(["info", str(urdf)]) == 0
    out = capsys.readouterr().out
    assert "3 link(s), 2 differ by more than 1 %" in out
    assert "DIFFERS by 63.2 % (Iyy)" in out and "note    inertia_vs_shape  rear:" in out
    assert "Physical consistency: 0 error(s), 0 warning(s), 2 note(s)" in out


def test_info_primitive_moved_and_turned_is_compared_in_the_inertial_frame(tmp_path, capsys):
    from robodyn import inertia
    from robodyn.model.summary import rotation_rpy

    mass, r, length = 2.0, 0.05, 0.4
    rpy_g = (0.3, -0.7, 1.1)  # the cylinder's pose in the link
    rpy_i = (-0.4, 0.2, 0.9)  # the inertial frame's, at the cylinder's centre
    R_g, R_i = rotation_rpy(*rpy_g), rotation_rpy(*rpy_i)
    I_link = R_g @ inertia.cylinder(mass, r, length) @ R_g.T
    I_inertial = (R_i.T @ I_link @ R_i).tolist()
    geometry = (
        f'<collision><origin xyz="0.1 0.2 0.3" rpy="{" ".join(map(repr, rpy_g))}"/>'
        f'<geometry><cylinder radius="{r}" length="{length}"/></geometry></collision>'
        '<visual><geometry><box size="9 9 9"/></geometry></visual>'  # collision first: this is not compared
    )
    inertial = _inertial(I_inertial, xyz="0.1 0.2 0.3", rpy=" ".join(map(repr, rpy_i)), mass=mass)
    primitives, findings = _primitives(capsys, _one_link(tmp_path, inertial, geometry))
    assert [(c["link"], c["shape"], c["source"]) for c in primitives] == [("a", "cylinder", "collision")]
    assert primitives[0]["relative_difference"] < 1e-12 and findings == []
    # The same inertia with its centre of mass 5 cm off the cylinder's: the parallel-axis term shows.
    moved = _inertial(I_inertial, xyz="0.15 0.2 0.3", rpy=" ".join(map(repr, rpy_i)), mass=mass)
    primitives, findings = _primitives(capsys, _one_link(tmp_path, moved, geometry, "moved.urdf"))
    assert primitives[0]["differs"] and [f["where"] for f in findings] == ["a"]


def test_info_box_about_its_centre_in_the_urdf_agrees_and_the_corner_tensor_does_not(tmp_path, capsys):
    from robodyn import inertia

    size, mass = (0.2, 0.3, 0.4), 3.0
    geometry = '<visual><origin xyz="0.1 0.15 0.2"/><geometry><box size="0.2 0.3 0.4"/></geometry></visual>'
    centre = _inertial(inertia.box(mass, size).tolist(), xyz="0.1 0.15 0.2", mass=mass)
    primitives, findings = _primitives(capsys, _one_link(tmp_path, centre, geometry))
    assert not primitives[0]["differs"] and findings == []
    # A URDF's inertia is about the centre of mass: the corner tensor (6.24) written there is reported.
    corner = _inertial(inertia.box(mass, size, about="corner").tolist(), xyz="0.1 0.15 0.2", mass=mass)
    primitives, findings = _primitives(capsys, _one_link(tmp_path, corner, geometry, "corner.urdf"))
    assert primitives[0]["differs"] and len(findings) == 1
    # So are the book's scalar products of inertia (+integral x y dm) typed in as ixy, ixz, iyz.
    signs = _inertial(inertia.box(mass, size, about=(0.05, -0.1, 0.02), convention="products").tolist(), mass=mass)
    shifted = _inertial(inertia.box(mass, size, about=(0.05, -0.1, 0.02)).tolist(), mass=mass)
    geometry = '<visual><origin xyz="-0.05 0.1 -0.02"/><geometry><box size="0.2 0.3 0.4"/></geometry></visual>'
    assert not _primitives(capsys, _one_link(tmp_path, shifted, geometry, "s.urdf"))[0][0]["differs"]
    assert _primitives(capsys, _one_link(tmp_path, signs, geometry, "p.urdf"))[0][0]["differs"]


def test_info_skips_links_that_are_not_exactly_one_primitive(tmp_path, capsys):
    I = [[1e-3, 0, 0], [0, 1e-3, 0], [0, 0, 1e-3]]
    two = '<visual><geometry><sphere radius="0.1"/></geometry></visual>' * 2
    mesh = '<collision><geometry><mesh filename="a.stl"/></geometry></collision>'
    mesh_over_sphere = mesh + '<visual><geometry><sphere radius="0.1"/></geometry></visual>'
    for i, geometry in enumerate((two, mesh_over_sphere, "")):
        primitives, _ = _primitives(capsys, _one_link(tmp_path, _inertial(I), geometry, f"{i}.urdf"))
        assert primitives == []
    massless = '<inertial><mass value="0"/><inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial>'
    sphere = '<visual><geometry><sphere radius="0.1"/></geometry></visual>'
    assert _primitives(capsys, _one_link(tmp_path, massless, sphere, "m.urdf"))[0] == []
