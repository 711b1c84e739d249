"""Phase portraits (robodyn.studies.portrait, charts.portrait, ``robodyn portrait``): the physics of the plane."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

import robodyn
from robodyn.cli import main
from robodyn.errors import InputError, UnknownNameError
from robodyn.studies import portrait

ROOT_TOL = 1e-10  # [rad]: Brent's method refines each equilibrium to 1e-14; round-off of G near its zero
ENERGY_RTOL = 1e-12  # the grid is 1/2 M_jj v^2 + V from the same CRBA and potential: identical arithmetic up to order


@pytest.fixture(scope="module")
def arm():
    return robodyn.load("geared_arm")


def test_a_pendulum_has_its_bottom_stable_its_top_unstable_and_the_separatrix_through_the_top(arm) -> None:
    p = portrait.compute(arm, resolution=41)
    stable = [e.q for e in p.equilibria if e.stable]
    unstable = [e.q for e in p.equilibria if not e.stable]
    assert stable == pytest.approx([0.0], abs=ROOT_TOL)
    assert unstable == pytest.approx([-np.pi, np.pi], abs=ROOT_TOL)
    assert p.separatrix_energy == pytest.approx(arm.potential_energy([np.pi]), rel=ENERGY_RTOL)
    # the energy of the top is the largest the potential reaches: m g l above the bottom's -m g l
    assert p.separatrix_energy - arm.potential_energy([0.0]) == pytest.approx(2 * arm.G([np.pi / 2])[0], rel=1e-9)


def test_the_grid_is_the_one_joint_energy(arm) -> None:
    p = portrait.compute(arm, resolution=31)
    i, j = 7, 19
    q, v = p.q[j], p.v[i]
    expected = 0.5 * arm.M([q])[0, 0] * v**2 + arm.potential_energy([q])
    assert p.energy[i, j] == pytest.approx(expected, rel=ENERGY_RTOL)
    assert p.energy.shape == (31, 31) and p.q_unit == "rad" and p.v_unit == "rad/s"


def test_other_joints_are_held_at_the_reference() -> None:
    robot = robodyn.load("pendubot")
    reference = np.array([np.pi / 2, 0.0])
    p = portrait.compute(robot, joint="joint2", reference=reference, resolution=21)
    q = reference.copy()
    q[1] = p.q[4]
    assert p.energy[10, 4] == pytest.approx(
        0.5 * robot.M(q)[1, 1] * p.v[10] ** 2 + robot.potential_energy(q), rel=1e-12
    )
    # link 1 upright: the elbow's top (q2 = 0) is unstable, hanging back down (q2 = +-pi) stable
    assert [e.stable for e in p.equilibria] == [True, False, True]


def test_a_prismatic_joint_spans_its_limits_in_metres() -> None:
    robot = robodyn.load("cart_pole")
    p = portrait.compute(robot, joint="slider", resolution=21)
    assert (p.q[0], p.q[-1]) == (-2.4, 2.4) and p.q_unit == "m" and p.v_unit == "m/s"
    assert p.equilibria == ()  # no gravity along the rail: no isolated rest point


def test_the_region_slice_is_the_lqr_ellipse_by_the_plane() -> None:
    robot = robodyn.load("cart_pole")
    lqr = robodyn.control.design(robot)
    rho = 2.5
    p = portrait.compute(robot, reference=lqr.q_eq, region=(lqr.q_eq, lqr.P, rho), resolution=21)
    q, v = p.region.outline(50)
    for qi, vi in zip(q, v, strict=True):
        e = np.zeros(2 * robot.nv)
        e[1], e[robot.nv + 1] = qi - lqr.q_eq[1], vi
        assert e @ lqr.P @ e == pytest.approx(rho, rel=1e-9)


def test_bad_requests_are_named(arm) -> None:
    with pytest.raises(UnknownNameError, match="no_such_joint"):
        portrait.compute(arm, joint="no_such_joint")
    with pytest.raises(InputError, match="reference must be 1 finite"):
        portrait.compute(arm, reference=[0.0, 1.0])
    with pytest.raises(InputError, match="resolution"):
        portrait.compute(arm, resolution=3)


def test_the_command_writes_the_chart_and_its_numbers(tmp_path, capsys) -> None:
    out = tmp_path / "portrait"
    assert main(["portrait", "pendubot", "--lqr", "--resolution", "21", "--out", str(out)]) == 0
    for name in ("portrait.png", "portrait.svg", "portrait.csv", "portrait.json"):
        assert (out / name).stat().st_size > 0
    with (out / "portrait.csv").open() as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["joint2 [rad]", "joint2 velocity [rad/s]", "energy [J]"] and len(rows) == 1 + 21 * 21
    record = json.loads((out / "portrait.json").read_text())
    assert record["region"]["rho"] > 0 and record["units"]["energy"] == "J"
    assert "separatrix energy" in capsys.readouterr().out


def test_the_command_refuses_an_unknown_joint_in_one_line(tmp_path, capsys) -> None:
    assert main(["portrait", "geared_arm", "--joint", "elbow", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "elbow" in err and not (tmp_path / "x" / "portrait.png").exists()


# portrait.csv writes q, v and the energy to 10 significant digits (%.10g): q rounded by up to 5e-10 rad moves the
# Pendubot's energy by ~1e-9 J (|dE/dq| ~ 2 N m); 1e-8 J keeps a factor 10, and q and v crossed are 0.77 J off.
CSV_ENERGY_TOL = 1e-8  # [J]


def test_the_lqr_portrait_is_centred_on_its_equilibrium_and_its_csv_rows_are_their_states_energies(
    tmp_path, capsys
) -> None:
    """issue 39 item 10: q and v crossed in the CSV (0.77 J off) and a portrait off the LQR's q_eq both passed."""
    robot = robodyn.load("pendubot")
    q_eq = robodyn.control.design(robot).q_eq
    assert q_eq[0] != robot.neutral()[0]  # joint1's upright differs from its neutral angle: the centre tells
    out = tmp_path / "portrait"
    assert main(["portrait", "pendubot", "--lqr", "--joint", "joint1", "--resolution", "21", "--out", str(out)]) == 0
    capsys.readouterr()
    record = json.loads((out / "portrait.json").read_text())
    assert record["reference_q"] == q_eq.tolist()
    assert record["region"]["q0"] == q_eq[0]
    assert sum(record["q_range"]) / 2 == pytest.approx(q_eq[0], rel=1e-15)  # one turn and a bit about it
    with (out / "portrait.csv").open() as fh:
        rows = np.array(list(csv.reader(fh))[1:], dtype=np.float64)
    rng = np.random.default_rng(0)
    for q1, v1, energy in rows[rng.choice(len(rows), 25, replace=False)]:
        q = q_eq.copy()
        q[0] = q1
        expected = 0.5 * robot.M(q)[0, 0] * v1**2 + robot.potential_energy(q)
        assert energy == pytest.approx(expected, rel=0, abs=CSV_ENERGY_TOL)
