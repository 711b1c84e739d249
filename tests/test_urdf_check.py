"""Malformed URDF numbers are refused before Pinocchio quietly drops them."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from robodyn.errors import ModelError
from robodyn.model.urdf import validate_urdf

ROOT = Path(__file__).resolve().parents[1]


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
    ],
)
def test_malformed_numbers_are_named(old, new, message):
    text = (ROOT / "models" / "pendubot.urdf").read_text()
    assert old in text
    root = ET.fromstring(text.replace(old, new, 1))
    with pytest.raises(ModelError, match=message):
        validate_urdf(root, Path("p.urdf"))
