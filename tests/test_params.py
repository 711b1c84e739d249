"""Parameter extraction: numbers read from URDFs, rotated inertial frames, refused assumptions."""

from __future__ import annotations

import numpy as np
import pytest

import robodyn
from robodyn.errors import AssumptionError
from robodyn.kinds.params import detect_kind, extract

from . import _urdf

EXACT = 1e-12  # numbers copied from the URDF: only rpy rotations add round-off


def test_builtin_parameters_are_the_documented_ones():
    p = extract(robodyn.load("pendubot"), "pendubot")
    expected = dict(m1=1.336, m2=0.5, l1=0.15, lc1=0.10, lc2=0.126, I1=6.19e-3, I2=2.6502e-3, g=9.81)
    for k, v in expected.items():
        assert p[k] == pytest.approx(v, rel=EXACT), k
    # The lumped parameters of Spong and Block's Pendubot, within 1 %:
    lumped = (
        p["m1"] * p["lc1"] ** 2 + p["m2"] * p["l1"] ** 2 + p["I1"],
        p["m2"] * p["lc2"] ** 2 + p["I2"],
        p["m2"] * p["l1"] * p["lc2"],
        p["m1"] * p["lc1"] + p["m2"] * p["l1"],
        p["m2"] * p["lc2"],
    )
    np.testing.assert_allclose(lumped, (0.0308, 0.0106, 0.0095, 0.2086, 0.0630), rtol=0.01)
    arm = extract(robodyn.load("geared_arm"), "geared_arm")
    assert (arm["J_m"], arm["n"], arm["m"], arm["l"]) == (1.08e-6, 50.0, 0.243, 0.15)
    assert arm["J_l"] == pytest.approx(1.840725e-3 + 0.243 * 0.15**2, rel=EXACT)
    cp = extract(robodyn.load("cart_pole"), "cart_pole")
    assert (cp["m_cart"], cp["m"], cp["l"]) == (1.0, 0.1, 0.5)
    assert cp["I"] == pytest.approx(0.1 * 1.0**2 / 12, rel=1e-7)  # URDF prints 8 digits


def test_rotated_inertial_frame_gives_the_axis_inertia(tmp_path):
    principal = np.diag([1e-4, 2.5e-3, 2.55e-3])  # a real body: 1e-4 + 2.5e-3 >= 2.55e-3
    rpy = (0.4, -0.3, 0.9)
    path = _urdf.pendubot(tmp_path / "p.urdf", inertia1=principal, rpy1=rpy)
    p = extract(robodyn.load(path), "pendubot")
    R = _urdf.rpy_matrix(*rpy)
    axis = np.array([0.0, -1.0, 0.0])
    assert p["I1"] == pytest.approx(axis @ R @ principal @ R.T @ axis, rel=EXACT)
    assert p["I2"] == pytest.approx(1.5e-3, rel=EXACT)


@pytest.mark.parametrize("kind", ["pendubot", "cart_pole", "geared_arm"])
def test_detect_kind_on_builtins(kind):
    assert detect_kind(robodyn.load(kind)) == kind


@pytest.mark.parametrize(
    ("make", "kind", "message"),
    [
        (
            lambda d: _urdf.pendubot(d / "a.urdf", axis=(0, 0, 1)),
            "pendubot",
            r"axis is \(0 0 1\) in world, expected \(0 -1 0\)",
        ),
        (
            lambda d: _urdf.pendubot(d / "b.urdf", com_offset_z=0.01),
            "pendubot",
            "centre of mass of link 1 .* is off the line",
        ),
        (lambda d: _urdf.pendubot(d / "c.urdf", extra_joint=True), "pendubot", "expected 2 moving joint"),
        (lambda d: _urdf.pendubot(d / "d.urdf", continuous=True), "pendubot", "nq = 2.*not continuous"),
        (lambda d: _urdf.pendubot(d / "e.urdf"), "cart_pole", "must be prismatic"),
        (lambda d: _urdf.cart_pole(d / "f.urdf", slide_axis=(0, 1, 0)), "cart_pole", r"axis is \(0 1 0\)"),
        (lambda d: _urdf.geared_arm(d / "g.urdf", axis=(0, 0, 1)), "geared_arm", "must be horizontal"),
    ],
)
def test_broken_assumptions_are_named(tmp_path, make, kind, message):
    robot = robodyn.load(make(tmp_path))
    with pytest.raises(AssumptionError, match=message):
        extract(robot, kind)


def test_armature_is_refused_where_the_formula_has_none(tmp_path):
    path = _urdf.pendubot(tmp_path / "p.urdf")
    path.with_suffix(".srdf").write_text(
        '<robot name="x"><rotor_params><joint name="j2" mass="1e-5" gear_ratio="3"/></rotor_params></robot>'
    )
    with pytest.raises(AssumptionError, match="joint j2 has armature 9e-05 kg m.2; the pendubot formula has no rotor"):
        extract(robodyn.load(path), "pendubot")
