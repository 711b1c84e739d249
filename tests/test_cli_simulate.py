"""robodyn simulate: summary, files, exit codes 0, 2 and 3, one real subprocess run."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.cli import main

from ._ctrl_c import press_ctrl_c_during_step


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


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--dt", "0"], "argument --dt: expected a positive number (> 0), got '0'"),
        (["--duration", "-1"], "argument --duration: expected a positive number (> 0), got '-1'"),
        (["--rtol", "2"], "argument --rtol: expected a relative tolerance > 0 and <= 1, got '2'"),
    ],
)
def test_bad_numbers_are_refused_by_their_option_in_one_line(
    args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "pendubot", *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert exc.value.code == 2 and len(err) == 1 and message in err[0]


def test_unwritable_output_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    assert main(["simulate", "pendubot", "--out", str(blocker / "traj.npz")]) == 2
    assert f"cannot write {blocker / 'traj.npz'}: {blocker} is a file, not a folder" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("out", "message"),
    [
        ("missing_dir/x.npz", "the folder {tmp}/missing_dir does not exist"),
        ("traj.txt", "expected a .npz path"),
        (".", "is a folder"),
    ],
)
def test_bad_output_paths_are_refused_and_nothing_is_created(
    tmp_path: Path, out: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["simulate", "pendubot", "--duration", "0.01", "--out", str(tmp_path / out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message.format(tmp=tmp_path) in err[0]
    assert list(tmp_path.iterdir()) == []  # no folder made, no file written


def test_bad_input_leaves_no_empty_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out, csv = tmp_path / "z.npz", tmp_path / "z.csv"
    assert main(["simulate", "pendubot", "--q0", "1", "--out", str(out), "--csv", str(csv)]) == 2
    assert "q0 must have 2 entries" in capsys.readouterr().err
    assert not out.exists() and not csv.exists()


def test_ctrl_c_writes_the_partial_trajectory_and_exits_130(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    press_ctrl_c_during_step(monkeypatch, 701)  # the user presses Ctrl-C during step 701, in the second check block
    out, partial = tmp_path / "int.npz", tmp_path / "int.partial.npz"
    assert main(["simulate", "pendubot", "--q0", "0.3,-0.2", "--duration", "100", "--out", str(out)]) == 130
    captured = capsys.readouterr()
    assert "700 steps" in captured.out
    assert f"interrupted after step 700 (t = 0.7 s); partial trajectory written to {partial}" in captured.err
    assert not out.exists()  # the partial run goes beside the name of a complete one, never under it
    traj = robodyn.Trajectory.load(partial)
    assert traj.status == "interrupted" and traj.n_steps == 700 and traj.evaluations == 4 * 700 + 1


def test_euler_blowup_counts_the_work_done(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "blowup.npz"
    argv = ["simulate", "pendubot", "--q0", "0.3,-0.2", "--duration", "5", "--dt", "0.05", "--integrator", "euler"]
    assert main([*argv, "--out", str(out), "--json"]) == 3
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    # 7 Euler steps evaluate a at samples 0..6, and a(t_7) is filled in: 8, not the 100 of the whole block.
    assert summary["steps"] == 7 and summary["evaluations"] == 8
    assert robodyn.Trajectory.load(tmp_path / "blowup.partial.npz").evaluations == 8
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and err[0].count("likely cause") == 1 and err[0].count("try ") == 1


def test_mimic_option_and_the_warning_without_it(capsys: pytest.CaptureFixture[str]) -> None:
    urdf = str(robodyn.model.files.models_dir() / "variants" / "geared_arm_rotor.urdf")
    assert main(["simulate", urdf, "--mimic", "--q0", "1", "--duration", "0.1", "--json"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert summary["steps"] == 100 and summary["max_ledger_residual"] < 1e-10 and captured.err == ""
    assert main(["simulate", urdf, "--q0", "1,0", "--duration", "0.1"]) == 0  # rotor as a free joint
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "warning" in err[0] and "rotor_joint" in err[0] and "--mimic" in err[0]
    assert main(["simulate", urdf, "--mimic", "--q0", "1", "--duration", "0.1", "--backend", "aba"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--backend crba" in err[0]


WHEELS_URDF = """<?xml version="1.0"?>
<robot name="wheels">
  <link name="base"/>
  <link name="a"><inertial><origin xyz="0.2 0 0"/><mass value="0.5"/>
    <inertia ixx="1e-4" iyy="2e-3" izz="2e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="b"><inertial><origin xyz="0.2 0 0"/><mass value="0.5"/>
    <inertia ixx="1e-4" iyy="2e-3" izz="2e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="first" type="continuous"><parent link="base"/><child link="a"/><axis xyz="0 1 0"/></joint>
  <joint name="second" type="continuous"><parent link="a"/><child link="b"/><origin xyz="0.2 0 0"/>
    <axis xyz="0 1 0"/></joint>
</robot>
"""


def test_invalid_states_exit_2_naming_the_cause(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    urdf = tmp_path / "wheels.urdf"
    urdf.write_text(WHEELS_URDF)
    assert main(["simulate", str(urdf), "--q0", "2,0,1,0", "--duration", "0.1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "joint 'first'" in err[0] and "norm 2" in err[0] and "diverged" not in err[0]
    assert main(["simulate", str(urdf), "--q0", "1,0,0.6,0.8", "--duration", "0.1"]) == 0
    capsys.readouterr()
    assert main(["simulate", "pendubot", "--free-flyer", "--duration", "0.5"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "singular" in err[0] and "unstable" not in err[0]


def test_model_with_no_moving_joint_exits_2_and_its_advice_works(capsys: pytest.CaptureFixture[str]) -> None:
    # hector is one body welded to the world: nothing moves until it gets the free flyer the line suggests.
    assert main(["simulate", "hector", "--duration", "0.01"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no moving joint" in err[0] and "--free-flyer" in err[0]
    assert main(["simulate", "hector", "--free-flyer", "--duration", "0.01", "--backend", "aba"]) == 0


def test_summary_prints_units_and_help_states_defaults(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "cart_pole", "--q0", "0.1,0.2", "--duration", "0.01"]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("final state"))
    number = r"-?[0-9.e+-]+"
    assert re.fullmatch(rf"final state: q = \[{number} m, {number} rad\], v = \[{number} m/s, {number} rad/s\]", line)
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "(default: 0.001 s)" in text and "(default: 1e-09)" in text and "(default: 1e-12)" in text
    assert "--mimic" in text


def test_divergence_exits_3_and_writes_the_partial_trajectory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "blowup.npz"
    argv = ["simulate", "pendubot", "--q0", "0.3,-0.2", "--duration", "5", "--dt", "0.05", "--integrator", "euler"]
    assert main([*argv, "--out", str(out)]) == 3
    err = capsys.readouterr().err
    assert "diverged at step 7 (t = 0.35 s)" in err and "explicit Euler is unstable at dt = 0.05 s" in err
    assert f"partial trajectory written to {tmp_path / 'blowup.partial.npz'}" in err and not out.exists()
    traj = robodyn.Trajectory.load(tmp_path / "blowup.partial.npz")
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


def test_a_controlled_run_says_the_controller_saturates_and_measures_accuracy_by_the_ledger(capsys):
    """An LQR started outside its linear range clips its own command: robodyn never clamps, and says who did."""
    code = main(["simulate", "pendubot", "--q0", "1.6708,0.1", "--controller", "lqr", "--duration", "0.2"])
    out = capsys.readouterr().out
    assert code == 0
    efforts = next(line for line in out.splitlines() if line.startswith("efforts:"))
    assert "robodyn never clamped tau" in efforts and "was at its effort limit in" in efforts
    energy = next(line for line in out.splitlines() if line.startswith("energy:"))
    assert "change E(t) - E0" in energy and "ledger's residual" in energy and "drift max" not in energy


def test_a_torque_free_run_reports_its_energy_drift(capsys):
    assert main(["simulate", "pendubot", "--q0", "0.3,-0.2", "--duration", "0.1"]) == 0
    out = capsys.readouterr().out
    assert "drift max|E - E0|" in out and "at its effort limit" not in out


def test_a_one_step_run_says_one_step_in_the_singular(capsys: pytest.CaptureFixture[str]) -> None:
    """'1 step', not '1 steps': the summary's counts agree with their numbers (Euler: 2 evaluations, 2 samples)."""
    assert main(["simulate", "pendubot", "--duration", "0.001", "--dt", "0.001", "--integrator", "euler"]) == 0
    out = capsys.readouterr().out
    assert "1 step to t = 0.001 s" in out and "(2 dynamics evaluations," in out and "; 2 samples)" in out, out
    assert "1 steps" not in out


def test_a_long_run_says_how_far_it_got_every_ten_seconds() -> None:
    """Every PROGRESS_EVERY seconds after the run's first steps; a first compile before them (97 s here) prints none."""
    import io

    from robodyn.cli._progress import PROGRESS_EVERY, ProgressLines

    first = 97.0  # the first steps end after a compile: the documented output of a short run stays as it is
    ticks = iter([first, first + 3.0, first + PROGRESS_EVERY + 0.5, first + PROGRESS_EVERY + 2.0, first + 21.0])
    stream = io.StringIO()
    lines = ProgressLines(stream, 0.5, clock=lambda: next(ticks))
    for t in (0.004, 0.01, 0.1, 0.12, 0.3):  # the clock reads 97, 100, 107.5, 109 and 118 s
        lines(t)
    assert stream.getvalue().splitlines() == [
        "robodyn simulate: t = 0.1 s of 0.5 s (20 %), 10 s after its first steps",
        "robodyn simulate: t = 0.3 s of 0.5 s (60 %), 21 s after its first steps",
    ]


def test_a_step_that_takes_long_is_still_reported() -> None:
    """Between the hook's calls (a step with many stop events, a slow controller) the watch thread prints."""
    import io
    import time

    from robodyn.cli._progress import ProgressLines

    stream = io.StringIO()
    lines = ProgressLines(stream, 0.5, every=0.2)
    lines(0.0)  # the run is about to take its first step...
    time.sleep(0.9)  # ...which takes long: no call comes
    lines.close()
    printed = stream.getvalue().splitlines()
    assert printed and all(line.startswith("robodyn simulate: t = 0 s of 0.5 s (0 %), ") for line in printed), printed
    time.sleep(0.5)
    assert stream.getvalue().splitlines() == printed  # closed: no more lines


def test_a_compile_inside_a_run_is_left_to_its_notes() -> None:
    """While numba compiles (the stop events, met late in a run) the progress lines wait: the compile's notes speak."""
    import io
    import time

    from robodyn.cli._progress import ProgressLines
    from robodyn.engine import jit

    stream = io.StringIO()
    lines = ProgressLines(stream, 0.5, every=0.2)
    lines(0.0)
    jit._COMPILES.begin()  # as numba's compile event would
    time.sleep(0.8)
    assert stream.getvalue() == ""
    jit._COMPILES.end()
    time.sleep(0.8)
    lines.close()
    assert stream.getvalue().startswith("robodyn simulate: t = 0 s of 0.5 s (0 %), ")


@pytest.mark.parametrize("backend", ["aba", None])  # the Python loop (each step), the compiled loop (each block)
def test_simulate_reports_its_progress_to_the_end(backend: str | None) -> None:
    robot = robodyn.load("pendubot")
    seen: list[float] = []
    traj = robodyn.simulate(
        robot, [0.3, -0.2], [0.0, 0.0], duration=0.05, dt=1e-3, backend=backend, progress=seen.append
    )
    assert traj.meta["loop"] == ("python" if backend == "aba" else "compiled")
    assert seen and seen[-1] == pytest.approx(0.05, abs=1e-15) and seen == sorted(seen)
    if backend == "aba":  # before the first step (a first step that takes long is watched too), then after each
        assert seen[0] == 0.0 and len(seen) == traj.n_steps + 1
