"""Physical-consistency findings on hand-made inertials."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from robodyn.model.consistency import all_findings, impossible_inertials, inertial_findings, joint_findings


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
