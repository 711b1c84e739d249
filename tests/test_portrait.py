"""Phase portraits (robodyn.studies.portrait, charts.portrait, ``robodyn portrait``): the physics of the plane."""

from __future__ import annotations

import csv
import dataclasses
import json

import numpy as np
import pytest

import robodyn
import robodyn.control
from robodyn.cli import main
from robodyn.control import basin
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


# The flow's a = -(dE/dq) / M_jj comes from central differences on the grid: step h = 2.5 pi / 120 ~ 0.065 rad,
# relative error ~ h^2 / 6 ~ 7e-4 of the pendulum's V''' / V'; 3e-3 keeps a factor 4 and a sign error is 200 % off.
FLOW_RTOL = 3e-3


def test_the_flow_at_rest_is_gravitys_acceleration_of_the_held_system(arm) -> None:
    p = portrait.compute(arm, resolution=121)
    rest = int(np.argmin(np.abs(p.v)))
    assert p.v[rest] == pytest.approx(0.0, abs=1e-12)  # an odd grid puts a row at v = 0
    inner = slice(5, -5)  # np.gradient is one-sided at the edges
    expected = np.array([-arm.G([q])[0] / arm.M([q])[0, 0] for q in p.q[inner]])
    big = np.abs(expected) > 0.1 * np.abs(expected).max()  # away from the equilibria, where both go through 0
    np.testing.assert_allclose(p.acceleration[rest, inner][big], expected[big], rtol=FLOW_RTOL)


def test_a_run_over_several_turns_is_wrapped_into_the_frame_and_broken_where_it_wraps(arm) -> None:
    t = np.linspace(0.0, 1.0, 400)
    q = (6.5 * np.pi * t)[:, None]  # three and a quarter turns: through pi, 3 pi and 5 pi
    v = np.full_like(q, 6.5 * np.pi)
    p = portrait.compute(arm, resolution=21, trajectories=[("spin", q, v)])
    ((_, shown_q, shown_v),) = p.trajectories
    drawn = np.isfinite(shown_q)
    assert np.all((shown_q[drawn] >= p.q[0]) & (shown_q[drawn] <= p.q[-1]))  # nothing leaves the frame
    assert np.sum(~drawn) == 3 and np.array_equal(drawn, np.isfinite(shown_v))  # one break per wrap, in q and v
    np.testing.assert_allclose(np.cos(shown_q[drawn]), np.cos(q[:, 0]), atol=1e-12)  # whole turns only


def test_the_command_says_the_held_pose_names_runs_and_prints_round_off_zero_as_0(tmp_path, capsys) -> None:
    """issue 37: "unstable at 4.441e-16 rad" printed Brent's round-off as a value, and runs were named by file."""
    robot = robodyn.load("pendubot")
    lqr = robodyn.control.make("lqr", robot)
    run = robodyn.simulate(robot, [1.6, 0.05], [0.0, 0.0], duration=0.2, dt=0.01, torque=lqr)
    saved = dataclasses.replace(run, meta={**run.meta, "controller": {"name": "lqr"}}).save(tmp_path / "b.npz")
    out = tmp_path / "portrait"
    assert (
        main(["portrait", "pendubot", "--lqr", "--trajectory", str(saved), "--resolution", "21", "--out", str(out)])
        == 0
    )
    printed = capsys.readouterr().out.splitlines()
    assert (
        printed[0]
        == "pendubot: phase portrait of joint2; equilibria: stable at -3.142 rad, unstable at 0 rad, stable at 3.142 rad"
    )
    assert printed[1] == "other joints held at joint1 = 1.571 rad"
    record = json.loads((out / "portrait.json").read_text())
    assert record["held"] == "joint1 = 1.571 rad" and record["trajectories"] == ["lqr from q(0) = (1.6, 0.05)"]
    assert abs(record["equilibria"][1]["q"]) < 1e-9  # the JSON keeps the computed value; only the print rounds


def test_the_simulated_basin_balances_near_the_upright_and_not_from_hanging() -> None:
    robot = robodyn.load("pendubot")
    lqr = robodyn.control.design(robot)
    near = basin.simulate(robot, lqr=lqr, side=3, q_range=(-0.05, 0.05), v_range=(-0.1, 0.1), duration=2.0)
    assert near.balanced.all() and near.fraction == 1.0 and near.joint == "joint2"
    hanging = basin.simulate(robot, lqr=lqr, side=3, q_range=(2.9, 3.1), v_range=(-0.1, 0.1), duration=2.0)
    assert not hanging.balanced.any()
    # each start of a wider grid, run alone by robodyn.simulate (per-sample RK4, the same law), is the oracle:
    # the map must agree start by start (its orientation: row i at v[i], column k at q[k])
    wide = basin.simulate(robot, lqr=lqr, side=3, q_range=(-0.6, 0.2), v_range=(-1.0, 2.0), duration=2.0)  # no symmetry
    assert 0 < wide.balanced.sum() < wide.balanced.size  # some caught, some not: the test can tell them apart
    for i, v in enumerate(wide.v):
        for k, q in enumerate(wide.q):
            q0 = lqr.q_eq.copy()
            q0[1] = q
            alone = robodyn.simulate(robot, q0, [0.0, v], duration=2.0, dt=wide.dt, torque=lqr)
            error = lqr.plant.error(alone.q[-1], alone.v[-1], lqr.q_eq)[: robot.nq]
            assert bool(np.all(np.abs(error) < wide.tolerance)) == bool(wide.balanced[i, k]), (q, v)
    with pytest.raises(InputError, match="basin side"):
        basin.simulate(robot, side=1)


def test_a_run_is_named_by_the_outcome_simulate_judged_and_saved(tmp_path, capsys) -> None:
    """issue 34: the portrait's runs carry the same outcome as simulate's summary (one decision, saved with the run)."""
    args = ["simulate", "pendubot", "--controller", "swing_up", "--q0", "1.58,0.02", "--duration", "3", "--dt", "0.005"]
    assert main([*args, "--out", str(tmp_path / "b.npz")]) == 0
    said = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("outcome: balanced from"))
    balanced_at = float(said.split("t = ")[1].split(" s")[0])
    saved = robodyn.Trajectory.load(tmp_path / "b.npz").meta["outcome"]
    assert saved["balanced"] and saved["time_to_balance_s"] == pytest.approx(balanced_at, abs=5e-4)
    out = tmp_path / "portrait"
    assert (
        main(["portrait", "pendubot", "--trajectory", str(tmp_path / "b.npz"), "--resolution", "21", "--out", str(out)])
        == 0
    )
    names = json.loads((out / "portrait.json").read_text())["trajectories"]
    assert names == [f"swing_up from q(0) = (1.58, 0.02), balanced from t = {saved['time_to_balance_s']:.3g} s"]
