"""URDFs refused before Pinocchio quietly drops or mangles them: malformed numbers, broken trees, zero axes.

Also the yourdfpy round trip of :mod:`robodyn.model.urdf` that ``robodyn params --write`` uses.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.cli import main
from robodyn.errors import ModelError
from robodyn.model.sources import sources
from robodyn.model.urdf import read_document, validate_urdf, write_document

from . import _urdf

ROOT = Path(__file__).resolve().parents[1]
# yourdfpy writes numbers with repr (exact) but rpy back from the rotation matrix: a rounding or two.
ROUND_TRIP_RTOL = 1e-12
ROUND_TRIP_ATOL = 1e-15  # [m, kg m^2] for entries that are zero in the source


@pytest.mark.parametrize("name", ["geared_arm", "cart_pole", "pendubot"])
def test_builtin_models_are_valid(name):
    validate_urdf(ET.parse(ROOT / "models" / f"{name}.urdf").getroot(), Path(name))


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('ixx="4.0e-4"', 'ixx="abc"', r"link 'link1': <inertia ixx='abc'> is not a finite number"),
        ('<mass value="0.5"/>', '<mass value="nan"/>', r"link 'link2': <mass value='nan'> is not a finite number"),
        (
            '<origin xyz="0.15 -0.02 0"',
            '<origin xyz="0.15 -0.02"',
            r"joint 'joint2': <origin xyz='0.15 -0.02'> is not 3 finite numbers",
        ),
        ('<axis xyz="0 -1 0"/>', '<axis xyz="0 -1 zero"/>', r"<axis xyz='0 -1 zero'> is not 3 finite numbers"),
        ('type="revolute"', 'type="hinge"', r"type='hinge', expected one of revolute"),
        ('<mass value="0.5"/>', "<mass/>", r"link 'link2': <mass> has no value="),
        ('ixy="0" ixz="0" iyz="0"/>', 'ixz="0" iyz="0"/>', r"<inertia> has no ixy= \(expected a number: urdfdom drops"),
        ('<mass value="0.5"/>', "", r"link 'link2': <inertial> has no <mass>"),
        ('<mass value="0.5"/>', '<mass value="0.5"/><mass value="0.5"/>', r"link 'link2': 2 <mass> elements"),
        ('<box size="0.252 0.02 0.01"/>', '<mesh filename="m.stl" scale="1 1"/>', r"<mesh scale='1 1'> is not 3 fin"),
        (
            '<robot name="pendubot">',
            '<robot name="pendubot"><material name="red"><color rgba="1 0 0"/></material>',
            r"material 'red': <color rgba='1 0 0'> is not 4 finite numbers",
        ),
        ("</joint>", '<calibration rising="1_0"/></joint>', r"joint 'joint1': <calibration rising='1_0'> is not a"),
    ],
)
def test_malformed_numbers_are_named(old, new, message):
    text = (ROOT / "models" / "pendubot.urdf").read_text()
    assert old in text
    root = ET.fromstring(text.replace(old, new, 1))
    with pytest.raises(ModelError, match=message):
        validate_urdf(root, Path("p.urdf"))


# --------------------------------------------------------------------------- structure

_LINK = (
    '<link name="{}"><inertial><mass value="0.1"/>'
    '<inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>'
)
_FIXED = '<joint name="{}" type="fixed"><parent link="{}"/><child link="{}"/></joint>'


def _append(text: str, extra: str) -> str:
    return text.replace("</robot>", extra + "</robot>")


# A Pendubot: links base, l1, l2; joints j1 (base -> l1) and j2 (l1 -> l2), both axis 0 -1 0.
STRUCTURE = [
    (
        "detached cycle",
        lambda t: _append(
            t, _LINK.format("a") + _LINK.format("b") + _FIXED.format("ja", "a", "b") + _FIXED.format("jb", "b", "a")
        ),
        "joints 'ja', 'jb' form a cycle, cut off from the root link 'base' (expected a tree)",
    ),
    (
        "cycle through the root",
        lambda t: _append(t, _FIXED.format("j0", "l2", "base")),
        "joints 'j1', 'j2', 'j0' form a cycle that leaves no link without a parent",
    ),
    (
        "self-loop",
        lambda t: t.replace('<child link="l2"/>', '<child link="l1"/>'),
        "joint 'j2': parent and child are both link 'l1' (expected two different links)",
    ),
    (
        "two parents",
        lambda t: _append(t, _FIXED.format("j3", "base", "l2")),
        "link 'l2' is the child of two joints, 'j2' and 'j3' (expected one parent joint per link",
    ),
    (
        "missing parent link",
        lambda t: t.replace('<parent link="l1"/>', '<parent link="l1x"/>'),
        "joint 'j2': parent link 'l1x' is not a <link> of this robot (expected one of its 3 links); did you mean 'l1'?",
    ),
    (
        "missing child element",
        lambda t: t.replace('<child link="l2"/>', ""),
        "joint 'j2' has no <child link=...> (expected the name of its child link)",
    ),
    (
        "two roots",
        lambda t: _append(t, _LINK.format("loose")),
        "2 links have no parent joint: 'base', 'loose' (expected exactly one root link",
    ),
    (
        "duplicate link",
        lambda t: _append(t, _LINK.format("l1")),
        "two <link> elements are named 'l1' (expected unique link names)",
    ),
    (
        "zero axis",
        lambda t: t.replace('<axis xyz="0 -1 0"/>', '<axis xyz="0 0 0"/>', 1),
        "joint 'j1': <axis xyz='0 0 0'> is zero (expected a direction, a non-zero vector)",
    ),
    (
        "NaN axis",
        lambda t: t.replace('<axis xyz="0 -1 0"/>', '<axis xyz="0 nan 0"/>', 1),
        "joint 'j1': <axis xyz='0 nan 0'> is not 3 finite numbers",
    ),
]


@pytest.mark.parametrize(("case", "edit", "message"), STRUCTURE, ids=[c[0] for c in STRUCTURE])
def test_structure_refusals_are_one_line_exit_2(tmp_path, capsys, case, edit, message):
    path = _urdf.pendubot(tmp_path / "p.urdf")
    text = path.read_text()
    broken = edit(text)
    assert broken != text
    path.write_text(broken)
    assert main(["params", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith(f"robodyn params: error: {path}: "), err
    assert message in err, err


def test_zero_axis_on_a_fixed_joint_is_ignored_as_urdfdom_does(tmp_path):
    text = _append(_urdf.pendubot(tmp_path / "p.urdf").read_text(), _LINK.format("tip"))
    text = _append(
        text, '<joint name="t" type="fixed"><parent link="l2"/><child link="tip"/><axis xyz="0 0 0"/></joint>'
    )
    validate_urdf(ET.fromstring(text), Path("p.urdf"))


def test_every_example_robot_data_model_is_a_valid_tree():
    """A false refusal would stop a robot from loading: every library URDF must pass."""
    checked = set()
    for source in sources().values():
        if source.urdf in checked or not source.urdf.is_file():
            continue
        checked.add(source.urdf)
        validate_urdf(ET.parse(source.urdf).getroot(), source.urdf)
    assert len(checked) > 50


def test_yourdfpy_round_trip_keeps_the_dynamics_and_what_it_does_not_write(tmp_path):
    """Talos through yourdfpy: mimic, transmissions and gazebo blocks kept; Pinocchio model unchanged."""
    source = robodyn.load("talos")
    document = read_document(source.urdf_path)
    out = tmp_path / "talos.urdf"
    write_document(document, out)
    before, after = ET.parse(source.urdf_path).getroot(), ET.parse(out).getroot()
    for tag in ("transmission", "gazebo", "mimic", "link", "joint"):
        assert len(after.findall(f".//{tag}")) == len(before.findall(f".//{tag}")), tag
    written = robodyn.load(out)
    assert written.joint_names == source.joint_names
    for j in range(1, source.model.njoints):
        a, b = source.model.inertias[j], written.model.inertias[j]
        np.testing.assert_allclose(b.mass, a.mass, rtol=ROUND_TRIP_RTOL)
        np.testing.assert_allclose(b.lever, a.lever, rtol=ROUND_TRIP_RTOL, atol=ROUND_TRIP_ATOL)
        np.testing.assert_allclose(b.inertia, a.inertia, rtol=ROUND_TRIP_RTOL, atol=ROUND_TRIP_ATOL)
        placement_a, placement_b = source.model.jointPlacements[j], written.model.jointPlacements[j]
        np.testing.assert_allclose(
            placement_b.homogeneous, placement_a.homogeneous, rtol=ROUND_TRIP_RTOL, atol=ROUND_TRIP_ATOL
        )
