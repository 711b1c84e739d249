"""robodyn simulate: summary, files, exit codes 0, 2 and 3, one real subprocess run."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.cli import main


def test_simulate_prints_summary_and_writes_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out, csv = tmp_path / "traj.npz", tmp_path / "traj.csv"
    argv = ["simulate", "pendubot", "--q0", "0.3,-0.2", "--v0", "0,0", "--duration", "0.5", "--dt", "1e-3"]
    code = main([*argv, "--integrator", "rk4", "--out", str(out), "--csv", str(csv)])
    text = capsys.readouterr().out
    assert code == 0
    assert "500 steps" in text and "drift" in text and "residual" in text and "final state" in text
    traj = robodyn.Trajectory.load(out)
    assert traj.n_steps == 500 and traj.meta["integrator"] == "rk4"
    np.testing.assert_array_equal(traj.q[0], [0.3, -0.2])
    assert len(csv.read_text().splitlines()) == 502


def test_integrator_list(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "--integrator", "list"]) == 0
    text = capsys.readouterr().out
    for name in robodyn.integrators.names():
        assert name in text
    assert main(["simulate", "--integrator", "list", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert {r["name"]: r["order"] for r in rows}["rk4"] == 4


def test_json_summary_with_torque_and_backend(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["simulate", "cart_pole", "--torque", "1.0", "--duration", "0.2", "--backend", "crba", "--json"])
    summary = json.loads(capsys.readouterr().out)
    assert code == 0 and summary["steps"] == 200 and summary["work_input"] > 0
    assert summary["max_ledger_residual"] < 1e-9


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["pendubot", "--q0", "0.1"], "q0 must have 2 entries"),
        (["pendubot", "--v0", "1,2,3"], "v0 must have 2 entries"),
        (["pendubot", "--dt", "0"], "dt must be a positive"),
        (["pendubot", "--duration", "-1"], "duration must be a positive"),
        (["pendubot", "--integrator", "rk5"], "unknown integrator 'rk5'"),
        (["pendubot", "--torque", "0,1"], "passive"),
        (["no_such_robot"], "unknown model"),
        ([], "missing URDF_OR_NAME"),
    ],
)
def test_bad_input_exits_2_with_one_line(args: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "Traceback" not in err[0]


def test_unwritable_output_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    assert main(["simulate", "pendubot", "--out", str(blocker / "traj.npz")]) == 2
    assert "cannot write" in capsys.readouterr().err


def test_divergence_exits_3_and_writes_the_partial_trajectory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "blowup.npz"
    argv = ["simulate", "pendubot", "--q0", "0.3,-0.2", "--duration", "5", "--dt", "0.05", "--integrator", "euler"]
    assert main([*argv, "--out", str(out)]) == 3
    err = capsys.readouterr().err
    assert "diverged at step 7 (t = 0.35 s)" in err and "explicit Euler is unstable at dt = 0.05 s" in err
    traj = robodyn.Trajectory.load(out)
    assert traj.status == "diverged" and 0 < traj.n_steps < 100 and traj.meta["diverged_step"] == traj.n_steps


def test_view_plays_the_trajectory(monkeypatch: pytest.MonkeyPatch) -> None:
    import robodyn.cli.view as view

    played = {}

    def fake_serve_and_play(robot: object, trajectory: object, **options: object) -> int:
        played.update(robot=robot, trajectory=trajectory, **options)
        return 0

    monkeypatch.setattr(view, "serve_and_play", fake_serve_and_play)
    assert main(["simulate", "geared_arm", "--duration", "0.1", "--view"]) == 0
    assert played["trajectory"].n_steps == 100 and played["open_browser"] is False  # type: ignore[attr-defined]


def test_real_subprocess_run(tmp_path: Path) -> None:
    out = tmp_path / "traj.npz"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "robodyn",
            "simulate",
            "geared_arm",
            "--q0",
            "1.0",
            "--v0",
            "0",
            "--duration",
            "0.5",
            "--dt",
            "1e-3",
            "--integrator",
            "symplectic_euler",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "symplectic_euler" in proc.stdout and out.is_file()
    bad = subprocess.run(
        [sys.executable, "-m", "robodyn", "simulate", "geared_arm", "--dt", "-1"],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1
