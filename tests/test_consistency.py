"""Physical-consistency findings on hand-made inertials."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from robodyn.model.consistency import (
    all_findings,
    impossible_inertials,
    inertial_findings,
    joint_findings,
    link_findings,
    link_inertials,
)


def one_body(mass: float, inertia: np.ndarray, *, armature: float = 0.0) -> pin.Model:
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelRY(), pin.SE3.Identity(), "joint")
    body = pin.Inertia(abs(mass), np.array([0.0, 0.0, -0.1]), np.eye(3))
    body.mass, body.inertia = mass, inertia  # set after construction: pin.Inertia refuses impossible ones
    model.appendBodyToJoint(joint, body, pin.SE3.Identity())
    model.armature = np.array([armature])
    return model


def codes(model: pin.Model) -> set[str]:
    return {f.code for f in all_findings(model)}


def test_a_real_box_has_no_findings():
    assert codes(one_body(1.0, np.diag([1e-3, 2e-3, 2.5e-3]))) == set()


@pytest.mark.parametrize(
    ("mass", "inertia", "code"),
    [
        (-1.0, np.diag([1e-3, 1e-3, 1e-3]), "negative_mass"),
        (1.0, np.diag([1e-3, -1e-3, 1e-3]), "inertia_not_psd"),
        (1.0, np.diag([1e-3, 1e-3, 3e-3]), "triangle"),  # Ixx + Iyy = 2e-3 < Izz
        (1.0, np.diag([0.0, 0.0, 0.0]), "inertia_singular"),  # a point mass
        (0.0, np.diag([1e-3, 1e-3, 1e-3]), "zero_mass"),
        (0.0, np.zeros((3, 3)), "massless_subtree"),
    ],
)
def test_each_finding(mass, inertia, code):
    assert code in codes(one_body(mass, inertia))


def test_rounding_dust_is_not_a_finding():
    # URDF exporters leave 1e-18 kg m^2 of noise on zero inertias (iCub)
    assert "triangle" not in codes(one_body(0.5, np.diag([0.0, 4e-18, 0.0])))


def test_armature_carries_a_massless_joint():
    assert "massless_subtree" not in codes(one_body(0.0, np.zeros((3, 3)), armature=1e-3))


def test_joint_findings():
    model = one_body(1.0, np.diag([1e-3, 1e-3, 1e-3]))
    model.damping = np.array([-0.1])
    model.lowerPositionLimit = np.array([1.0])
    model.upperPositionLimit = np.array([-1.0])
    assert {f.code for f in joint_findings(model)} == {"negative_joint", "limits_reversed"}


def test_impossible_means_errors_only():
    model = one_body(1.0, np.diag([1e-3, 1e-3, 3e-3]))
    assert [f.code for f in impossible_inertials(model)] == ["triangle"]
    assert all(f.severity == "warning" for f in inertial_findings(one_body(1.0, np.zeros((3, 3)))))


def _rotated(principal: list[float], angle: float = np.pi / 4) -> np.ndarray:
    """diag(principal) turned by ``angle`` about x: off-diagonal terms, same principal moments."""
    c, s = np.cos(angle), np.sin(angle)
    R = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    return R @ np.diag(principal) @ R.T


def test_the_triangle_inequality_is_on_the_principal_moments():
    impossible = _rotated([1e-3, 1e-3, 3e-3])  # diagonal (1, 2, 2)e-3: every diagonal triangle holds
    d = np.diag(impossible)
    assert d[0] + d[1] >= d[2] and d[1] + d[2] >= d[0] and d[0] + d[2] >= d[1]
    assert "triangle" in codes(one_body(1.0, impossible))
    assert codes(one_body(1.0, _rotated([1e-3, 2e-3, 2.5e-3]))) == set()  # a real box, turned


def test_link_findings_check_each_link_of_the_file_before_the_merge():
    root = ET.parse(Path(__file__).resolve().parents[1] / "models" / "pendubot.urdf").getroot()
    tip = root.find("link[@name='tip']")
    ET.SubElement(tip, "inertial").extend(
        [
            ET.Element("mass", value="0.01"),
            ET.Element("inertia", ixx="-1e-6", iyy="1e-6", izz="1e-6", ixy="0", ixz="0", iyz="0"),
        ]
    )
    inertials = link_inertials(root)
    assert [i.link for i in inertials] == ["base", "link1", "link2", "tip"]
    assert inertials[1].mass == 1.336 and inertials[1].xyz == (0.10, 0.0, 0.0)
    assert [(f.body, f.code) for f in link_findings(inertials)] == [("tip", "inertia_not_psd")]
