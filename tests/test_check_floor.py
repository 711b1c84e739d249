"""robodyn check's round-off floor: robots whose quantities are zero or tiny by construction pass,
ill-conditioned ones pass their round trips, and an error of 1e-6 relative still fails."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn import dynamics
from robodyn import kinds as formulas
from robodyn.checker.compare import FD_TOL, check
from robodyn.errors import RobodynError

SAMPLES = 100  # the command line's default: the states the reports were made with
PLANTED = 1e-6  # a relative error far above round-off (1e-13) and below any printed digit of a datasheet


def _pybullet(name: str) -> Path:
    data = pytest.importorskip("pybullet_data")
    return Path(data.getDataPath()) / name


def test_a_quantity_zero_by_symmetry_passes_within_its_floor():
    # r2d2's joints feel neither gravity nor each other: C v + G is identically zero, RNEA leaves 1.4e-16 N m
    report = check(robodyn.load(_pybullet("r2d2.urdf")), samples=SAMPLES, seed=0)
    row = report.row("C v + G = RNEA(q, v, 0)")
    assert row.max_rel_error > row.tolerance  # relative to round-off: meaningless, and it was the false FAIL
    assert row.passed and row.within_floor_only
    assert report.passed


def test_a_tiny_gravity_torque_passes_the_finite_difference_row():
    # racecar: G ~ 2e-7 N m, the finite-difference noise of V (~1e-10 N m) is larger than 1e-6 relative
    report = check(robodyn.load(_pybullet("racecar/racecar.urdf")), samples=SAMPLES, seed=0)
    assert report.row("G = dV/dq").passed
    assert report.passed


def test_an_ill_conditioned_mass_matrix_passes_its_round_trips():
    # icub: bodies without inertia make M ill-conditioned; the ABA round trip was 6e-9 against 1e-9 at seed 0.
    # At its neutral pose (always a sample) M is singular, 6e-18 of its largest eigenvalue: that row alone fails.
    report = check(robodyn.load("icub"), samples=SAMPLES, seed=0)
    assert report.row("RNEA(q, v, ABA(q, v, tau)) = tau").passed
    assert [r.quantity for r in report.failures] == ["M symmetric positive definite"]


# Two revolute joints, z then y at 0.3 m along x; link1 has nothing, link2 is a 1 kg point mass 0.3 m back
# along -x (with a 1e-20 kg m^2 speck of inertia): at q2 = 0 it sits on joint 1's axis, which then moves
# nothing (M[0, 0] = 1e-20 kg m^2 against m a^2 = 0.09); anywhere else it swings off the axis.
SINGULAR_AT_ZERO = """<robot name="on_axis">
  <link name="base"/><link name="link1"/>
  <link name="link2"><inertial><origin xyz="-0.3 0 0"/><mass value="1"/>
    <inertia ixx="1e-20" iyy="1e-20" izz="1e-20" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="link1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="5"/></joint>
  <joint name="j2" type="revolute"><parent link="link1"/><child link="link2"/><origin xyz="0.3 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="5"/></joint>
</robot>
"""


def test_a_mass_matrix_singular_only_at_the_neutral_pose_fails_the_check(tmp_path):
    """issue 39 item 8: random poses never hit q2 = 0 exactly, so the check passed where simulate refuses."""
    path = tmp_path / "on_axis.urdf"
    path.write_text(SINGULAR_AT_ZERO)
    robot = robodyn.load(path)
    for samples in (1, 5):
        report = check(robot, samples=samples, seed=0)
        assert "M symmetric positive definite" in {r.quantity for r in report.failures}, samples
    with pytest.raises(RobodynError, match=r"the mass matrix M\(q0\) is singular"):  # what simulate says there
        robodyn.simulate(robot, robot.neutral(), np.zeros(2), duration=0.01, dt=1e-3)


def _scaled(fn, index, relative=PLANTED):
    """``fn`` with the entry ``index`` of its result multiplied by 1 + ``relative``."""

    def wrong(*args):
        out = np.array(fn(*args), dtype=np.float64)
        out[index] *= 1.0 + relative
        return out

    return wrong


@pytest.mark.parametrize(
    ("routine", "index", "relative", "row"),
    [
        ("nonlinear_effects", 0, PLANTED, "C v + G = RNEA(q, v, 0)"),
        ("gravity", 1, 10 * FD_TOL, "G = dV/dq"),  # a finite-difference row: held to FD_TOL, not 1e-9
        ("aba", 0, PLANTED, "M^-1 (tau - nle) = ABA"),
        ("rnea", 0, PLANTED, "CRBA = RNEA columns"),
    ],
)
def test_an_error_of_1e6_relative_in_pinocchio_still_fails(monkeypatch, routine, index, relative, row):
    robot = robodyn.load("panda")  # its G[0] is zero (a vertical first axis): G[1] carries the shoulder's weight
    monkeypatch.setattr(dynamics, routine, _scaled(getattr(dynamics, routine), index, relative))
    report = check(robot, samples=20, seed=0)
    assert row in {r.quantity for r in report.failures}


@pytest.mark.parametrize("robot_name", ["icub", "talos"])
def test_an_error_of_1e6_relative_fails_on_ill_conditioned_robots_too(monkeypatch, robot_name):
    robot = robodyn.load(robot_name)
    monkeypatch.setattr(dynamics, "nonlinear_effects", _scaled(dynamics.nonlinear_effects, slice(None)))
    report = check(robot, samples=10, seed=0)
    assert "C v + G = RNEA(q, v, 0)" in {r.quantity for r in report.failures}


@pytest.mark.parametrize("quantity", ["M", "C", "G"])
def test_a_formula_off_by_1e6_relative_fails(quantity):
    good = formulas.get("pendubot")
    fields = {"M": "mass_matrix", "C": "coriolis_matrix", "G": "gravity"}
    bad = dataclasses.replace(good, **{fields[quantity]: _scaled(getattr(good, fields[quantity]), 0)})
    report = check(robodyn.load("pendubot"), bad, samples=20, seed=0)
    assert quantity in {r.quantity for r in report.failures}
