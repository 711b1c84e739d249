"""Trajectory: the ledger arithmetic, .npz and CSV round trips, refusing what is not one."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.errors import InputError
from robodyn.sim.simulation import simulate
from robodyn.sim.trajectory import Trajectory


def hand_made() -> Trajectory:
    t = np.array([0.0, 0.5, 1.0])
    z = np.zeros((3, 1))
    return Trajectory(
        t=t,
        q=np.array([[0.0], [0.1], [0.3]]),
        v=np.array([[0.0], [0.4], [0.4]]),
        a=z,
        tau=np.ones((3, 1)),
        kinetic=np.array([0.0, 1.0, 2.0]),
        potential=np.array([5.0, 4.5, 4.5]),
        work_input=np.array([0.0, 1.0, 2.5]),
        work_damping=np.array([0.0, -0.5, -1.0]),
        meta={"model": "hand", "urdf": None, "integrator": "none", "dt": 0.5},
    )


def test_ledger_arithmetic() -> None:
    traj = hand_made()
    np.testing.assert_array_equal(traj.energy, [5.0, 5.5, 6.5])
    # E - E0 - W_in - W_d: 0; 0.5 - 1 + 0.5 = 0; 1.5 - 2.5 + 1 = 0
    np.testing.assert_array_equal(traj.ledger_residual, [0.0, 0.0, 0.0])
    assert traj.energy_drift == 1.5 and traj.max_ledger_residual == 0.0
    assert traj.n_steps == 2 and not traj.diverged


def test_npz_round_trip_keeps_arrays_and_metadata(tmp_path: Path) -> None:
    robot = robodyn.load("pendubot")
    traj = simulate(robot, [0.3, -0.2], [0.1, 0.0], duration=0.2, dt=1e-3, torque=[0.2])
    path = traj.save(tmp_path / "traj.npz")
    with np.load(path) as npz:
        for name in ("t", "q", "v", "tau", "energy"):
            assert name in npz.files
        np.testing.assert_array_equal(npz["energy"], traj.energy)
        meta = json.loads(str(npz["metadata"]))["meta"]
    assert meta["model"] == "pendubot" and meta["integrator"] == "rk4" and meta["dt"] == 1e-3
    assert meta["urdf"].endswith("pendubot.urdf")
    back = Trajectory.load(path)
    for name in ("t", "q", "v", "a", "tau", "kinetic", "potential", "work_input", "work_damping"):
        np.testing.assert_array_equal(getattr(back, name), getattr(traj, name))
    assert back.meta == traj.meta and back.evaluations == traj.evaluations and back.status == "ok"
    assert robodyn.Trajectory.load(path).n_steps == 200


def test_csv_has_one_row_per_sample(tmp_path: Path) -> None:
    traj = hand_made()
    path = traj.save_csv(tmp_path / "traj.csv")
    lines = path.read_text().splitlines()
    assert lines[0].split(",")[:4] == ["t", "q0", "v0", "tau0"]
    assert lines[0].endswith("ledger_residual") and len(lines) == 4
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(table[:, 0], traj.t)


def test_load_refuses_what_is_not_a_trajectory(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no such trajectory"):
        Trajectory.load(tmp_path / "missing.npz")
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip")
    with pytest.raises(InputError, match="not a robodyn trajectory"):
        Trajectory.load(junk)
    other = tmp_path / "other.npz"
    np.savez(other, t=np.arange(3.0))
    with pytest.raises(InputError, match="not a robodyn trajectory"):
        Trajectory.load(other)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"", "the file is empty"),
        (b"t,q0\n0,1\n", "not an .npz (zip) archive"),
        (b"PK\x03\x04 truncated", "the archive is damaged"),
    ],
)
def test_load_of_an_empty_or_garbage_file_is_one_line(tmp_path: Path, content: bytes, message: str) -> None:
    path = tmp_path / "bad.npz"
    path.write_bytes(content)
    with pytest.raises(InputError, match="not a robodyn trajectory") as info:
        Trajectory.load(path)
    text = str(info.value)
    assert message in text and "\n" not in text and "pickle" not in text
    with pytest.raises(InputError, match="is a folder"):
        Trajectory.load(tmp_path)


def test_save_wants_an_npz_name_and_leaves_no_partial_file(tmp_path: Path) -> None:
    traj = hand_made()
    with pytest.raises(InputError, match=r"expected a \.npz path"):
        traj.save(tmp_path / "traj.txt")
    assert not (tmp_path / "traj.txt").exists()
    traj.save(tmp_path / "traj.npz")
    traj.save_csv(tmp_path / "traj.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["traj.csv", "traj.npz"]  # no temporary left over


def test_summary_names_the_figures_the_cli_prints() -> None:
    s = hand_made().summary()
    assert s["steps"] == 2 and s["energy_final"] == 6.5 and s["work_damping"] == -1.0
    assert s["q_final"] == [0.3] and s["max_ledger_residual"] == 0.0


def test_stop_work_and_power_are_saved_and_loaded(tmp_path: Path) -> None:
    robot = robodyn.load("cart_pole")
    traj = simulate(robot, [2.0, 0.1], [1.0, 0.0], duration=0.6, dt=1e-3, torque=[0.5], restitution=0.3)
    assert traj.work_limits[-1] < 0 and traj.meta["impacts"] == 1
    path = traj.save(tmp_path / "traj.npz")
    with np.load(path) as npz:
        np.testing.assert_array_equal(npz["power"], traj.power)
        assert json.loads(str(npz["metadata"]))["format_version"] == 2
    back = Trajectory.load(path)
    np.testing.assert_array_equal(back.work_limits, traj.work_limits)
    np.testing.assert_array_equal(back.ledger_residual, traj.ledger_residual)
    assert back.summary()["work_limits"] == traj.work_limits[-1]
    header = traj.save_csv(tmp_path / "traj.csv").read_text().splitlines()[0].split(",")
    assert header[-4:] == ["work_damping", "work_limits", "power", "ledger_residual"]


def test_a_version_1_file_loads_with_no_stop_work(tmp_path: Path) -> None:
    traj = hand_made()
    path = tmp_path / "old.npz"
    arrays = {name: getattr(traj, name) for name in Trajectory._ARRAYS}
    info = {"format_version": 1, "wall_time_s": 0.0, "evaluations": 0, "status": "ok", "message": "", "meta": traj.meta}
    np.savez_compressed(path, energy=traj.energy, metadata=np.array(json.dumps(info)), **arrays)
    back = Trajectory.load(path)
    np.testing.assert_array_equal(back.work_limits, np.zeros(3))
    assert back.max_ledger_residual == 0.0


def test_the_ledger_books_the_stops() -> None:
    traj = hand_made()
    with_stop = Trajectory(
        **{**{f: getattr(traj, f) for f in Trajectory._ARRAYS}, "work_limits": np.array([0.0, 0.0, -0.5])}
    )
    np.testing.assert_array_equal(with_stop.ledger_residual, [0.0, 0.0, 0.5])  # E - E0 - W_in - W_d - W_lim
