"""Hostile command lines, scene files and output paths: one line, no traceback, no lost file.

Every refusal is exit 2 with exactly one stderr line naming the argument or the file and what
was expected, and leaves every file in the folder as it was (hashed before and after). A run
that stops early keeps what it computed under ``x.partial.npz``, beside a good ``x.npz``.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

from robodyn.cli import main
from robodyn.errors import EXIT_BAD_INPUT, EXIT_DIVERGED, InputError

from ._ctrl_c import press_ctrl_c_during_step

ROBODYN = Path(sys.executable).parent / "robodyn"
INTERRUPTED = 130

# A pendubot run that explicit Euler blows up at step 7 (t = 0.35 s): exit 3, partial trajectory.
DIVERGING = ["pendubot", "--q0", "0.3,-0.2", "--duration", "5", "--dt", "0.05", "--integrator", "euler"]


def run_cli(argv: Sequence[str]) -> int:
    """``main(argv)``'s exit code, also when argparse refuses the command line (SystemExit)."""
    try:
        return main(list(argv))
    except SystemExit as exc:
        return int(exc.code or 0)


def one_line(capsys: pytest.CaptureFixture[str]) -> str:
    """The only stderr line (asserting there is exactly one, and no traceback)."""
    err = capsys.readouterr().err
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err and lines[0].startswith("robodyn ")
    return lines[0]


def snapshot(folder: Path) -> dict[str, str]:
    """Every entry under ``folder``: a file's sha256, a link's target (links are not followed)."""
    out = {}
    for path in sorted(folder.rglob("*")):
        name = str(path.relative_to(folder))
        if path.is_symlink():
            out[name] = "-> " + os.readlink(path)
        elif path.is_file():
            out[name] = hashlib.sha256(path.read_bytes()).hexdigest()
        else:
            out[name] = "folder"
    return out


def refused(argv: Sequence[str], folder: Path, capsys: pytest.CaptureFixture[str]) -> str:
    """Run ``argv``; assert exit 2, one stderr line and no file changed in ``folder``; return the line."""
    before = snapshot(folder)
    assert run_cli(argv) == EXIT_BAD_INPUT
    line = one_line(capsys)
    assert snapshot(folder) == before, line
    return line


@pytest.fixture
def trajectory(tmp_path: Path) -> Path:
    """A short pendubot trajectory, written by robodyn simulate."""
    path = tmp_path / "t.npz"
    assert main(["simulate", "pendubot", "--duration", "0.1", "--out", str(path)]) == 0
    return path


# --------------------------------------------------------------------------- numeric options


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["check", "pendubot", "--seed", "-1"], "argument --seed: expected a seed from 0 to 9223372036854775807"),
        (["check", "pendubot", "--seed", "1.5"], "argument --seed: expected a seed"),
        (["view", "pendubot", "--port", "70000"], "argument --port: expected a port number from 1 to 65535"),
        (["view", "pendubot", "--fps", "nan"], "argument --fps: expected a positive number (> 0)"),
        (["view", "pendubot", "--speed", "-1"], "argument --speed: expected a positive number (> 0)"),
        (["simulate", "pendubot", "--duration", "inf"], "argument --duration: expected a positive number (> 0)"),
        (["simulate", "pendubot", "--dt", "-1e-3"], "argument --dt: expected a positive number (> 0)"),
        (["simulate", "pendubot", "--rtol", "5"], "argument --rtol: expected a relative tolerance > 0 and <= 1"),
        (["simulate", "pendubot", "--atol", "0"], "argument --atol: expected a positive number (> 0)"),
        (["simulate", "pendubot", "--max-energy-growth", "-2"], "argument --max-energy-growth: expected a positive"),
        (["simulate", "pendubot", "--dt", "1" * 5000], "(5000 characters)"),  # the value is cut short
    ],
)
def test_a_number_out_of_range_is_one_line_stating_the_range(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    line = refused(argv, tmp_path, capsys)
    assert message in line and len(line) < 300


def test_too_many_steps_is_refused_before_the_model_is_loaded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    line = refused(["simulate", "pendubot", "--duration", "1e6", "--dt", "1e-3"], tmp_path, capsys)
    assert "duration / dt = 1e+09 steps; at most 5e+07" in line


# --------------------------------------------------------------------------- view: frames and outputs


# Just over the bound, so that a missing bound costs the test little: 0.1 s at 2e6 frames per second
# is 200,001 frames; at speed 2e-5 and 30 frames per second, 150,001.
@pytest.mark.parametrize(("option", "value"), [("--fps", "2e6"), ("--speed", "2e-5")])
def test_view_bounds_the_rendered_frames(
    option: str, value: str, trajectory: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    html = tmp_path / "v.html"
    line = refused(["view", "pendubot", str(trajectory), option, value, "--html", str(html)], tmp_path, capsys)
    assert f"{trajectory}: 0.1 s of motion" in line and "at most 100,000" in line


def test_view_within_the_frame_bound_writes_the_page(trajectory: Path, tmp_path: Path) -> None:
    html = tmp_path / "v.html"  # 0.1 s at 999,990 frames per second: 100,000 frames, just at the bound
    assert main(["view", "pendubot", str(trajectory), "--fps", "999990", "--html", str(html)]) == 0
    assert html.read_text().startswith("<!DOCTYPE html>")


@pytest.mark.parametrize("how", ["same", "symlink", "hardlink"])
def test_view_never_writes_the_page_over_its_trajectory(
    how: str, trajectory: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    html = trajectory if how == "same" else tmp_path / "alias.npz"
    if how == "symlink":
        html.symlink_to(trajectory)
    elif how == "hardlink":
        os.link(trajectory, html)
    line = refused(["view", "pendubot", str(trajectory), "--html", str(html)], tmp_path, capsys)
    assert f"cannot write --html {html}: it is a trajectory {trajectory}, an input" in line


def test_view_never_writes_the_page_over_the_model(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    urdf = tmp_path / "arm.urdf"
    urdf.write_text((Path(__file__).parents[1] / "models" / "pendubot.urdf").read_text())
    line = refused(["view", str(urdf), "--html", str(urdf)], tmp_path, capsys)
    assert f"cannot write --html {urdf}: it is the model {urdf}" in line


def test_view_notes_come_only_after_the_input_is_known_good(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # a cart-pole trajectory shown on the pendubot (both nq = 2) is worth a note, but not beside a refusal
    cart = tmp_path / "cart.npz"
    assert main(["simulate", "cart_pole", "--duration", "0.1", "--out", str(cart)]) == 0
    capsys.readouterr()
    html = tmp_path / "v.html"
    line = refused(["view", "pendubot", str(cart), "--trace", "no_such_frame", "--html", str(html)], tmp_path, capsys)
    assert "unknown frame 'no_such_frame'" in line
    assert main(["view", "pendubot", str(cart), "--html", str(html)]) == 0
    assert "simulated with model 'cart_pole'" in capsys.readouterr().err


# --------------------------------------------------------------------------- simulate: outputs


def test_simulate_csv_ends_in_csv_so_never_lands_on_the_npz(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "x.npz"
    line = refused(["simulate", "pendubot", "--out", str(out), "--csv", str(out)], tmp_path, capsys)
    assert f"cannot write {out}: expected a .csv path (got .npz)" in line


def test_simulate_never_writes_over_its_model(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    urdf = tmp_path / "arm.urdf"
    urdf.write_text((Path(__file__).parents[1] / "models" / "pendubot.urdf").read_text())
    csv = tmp_path / "arm.csv"
    csv.symlink_to(urdf)  # the link's name ends in .csv, the file it names is the model
    line = refused(["simulate", str(urdf), "--csv", str(csv)], tmp_path, capsys)
    assert f"cannot write --csv {csv}: it is the model {urdf}" in line


def test_mimic_warning_never_joins_a_refusal(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    urdf = Path(__file__).parents[1] / "models" / "variants" / "geared_arm_rotor.urdf"
    line = refused(["simulate", str(urdf), "--q0", "1"], tmp_path, capsys)  # 2 coordinates without --mimic
    assert "q0 must have 2 entries" in line


def test_divergence_keeps_the_good_file_and_writes_the_partial_beside_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out, csv = tmp_path / "x.npz", tmp_path / "x.csv"
    assert main(["simulate", "pendubot", "--duration", "0.1", "--out", str(out), "--csv", str(csv)]) == 0
    capsys.readouterr()
    before = snapshot(tmp_path)
    assert main(["simulate", *DIVERGING, "--out", str(out), "--csv", str(csv)]) == EXIT_DIVERGED
    line = one_line(capsys)
    partial, partial_csv = tmp_path / "x.partial.npz", tmp_path / "x.partial.csv"
    assert f"partial trajectory written to {partial} and {partial_csv} ({out} and {csv} left as they were)" in line
    after = snapshot(tmp_path)
    assert {k: after[k] for k in before} == before and set(after) - set(before) == {partial.name, partial_csv.name}
    from robodyn.sim.trajectory import Trajectory

    assert Trajectory.load(partial).status == "diverged" and Trajectory.load(out).status != "diverged"


def test_ctrl_c_keeps_the_good_file_and_writes_the_partial_beside_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "x.npz"
    out.write_bytes(b"a good run")
    press_ctrl_c_during_step(monkeypatch, 301)
    assert main(["simulate", "pendubot", "--duration", "10", "--out", str(out)]) == INTERRUPTED
    line = one_line(capsys)
    assert f"partial trajectory written to {tmp_path / 'x.partial.npz'} ({out} left as it was)" in line
    assert out.read_bytes() == b"a good run"


# --------------------------------------------------------------------------- writes never follow links


def plant_links(target: Path, victim: Path) -> list[Path]:
    """Symbolic links to ``victim`` at ``target`` and at the old, predictable temporary names."""
    pid = os.getpid()
    links = [target, target.with_name(f".{target.name}.{pid}.part"), target.with_name(f".{target.name}.part")]
    for link in links:
        link.symlink_to(victim)
    return links


def test_writers_follow_no_planted_link(tmp_path: Path) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    out, csv, html = tmp_path / "x.npz", tmp_path / "x.csv", tmp_path / "x.html"
    scene = tmp_path / "scene.toml"
    scene.write_text("[model]\nname = 'pendubot'\n[simulate]\nduration = 0.05\n")
    results = tmp_path / "results"
    results.mkdir()
    runs = [
        (["simulate", "pendubot", "--duration", "0.1", "--out", str(out), "--csv", str(csv)], [out, csv]),
        (["view", "pendubot", str(out), "--html", str(html)], [html]),
        (["run", str(scene), "--out", str(results)], [results / "summary.json", results / "scene.npz"]),
    ]
    for argv, written in runs:
        for path in written:
            plant_links(path, victim)
        assert main(argv) == 0, argv
        assert victim.read_text() == "precious", argv
        for path in written:
            assert path.is_file() and not path.is_symlink(), path


# --------------------------------------------------------------------------- scene files


def write_scene(tmp_path: Path, text: str, name: str = "scene.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


BASE = "[model]\nname = 'pendubot'\n"
SIM = "[simulate]\nduration = 0.05\n"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (BASE + "[check]\nseed = -1\n", "[check] seed: expected a whole number from 0 to 9223372036854775807, got -1"),
        (BASE + "[check]\nsamples = 100000000\n", "[check] samples: expected a whole number from 1 to 100000"),
        (BASE + "[bench]\nrepeat = 1000000000\n", "[bench] repeat: expected a whole number from 1 to 100000"),
        (BASE + SIM + "[view]\nport = 70000\n", "[view] port: expected a whole number from 1 to 65535, got 70000"),
        (BASE + SIM + "[view]\nport = 0\n", "[view] port: expected a whole number from 1 to 65535, got 0"),
        (BASE + "[control]\nkind = 'pd'\nkp = -1.0\n", "[control] kp: expected a number >= 0, got -1.0"),
        (BASE + "[simulate]\nduration = 1e6\ndt = 1e-3\n", "[simulate] duration: 1000000.0 s in steps of 0.001 s"),
        (BASE + "[simulate]\nduration = 4000.0\ndt = 0.01\n[view]\n", "[simulate] duration (played back by [view])"),
        (
            BASE + "[initial]\nq = [" + "[" * 200 + "]" * 200 + "]\n",
            "[initial] q: expected a number, got [[[[[[[...]]]]]]]",
        ),
        (BASE + "[initial]\nq = " + "[" * 10_000 + "]" * 10_000 + "\n", "nested too deeply to read"),
    ],
)
def test_a_bad_scene_is_one_line_naming_file_table_and_key(
    text: str, message: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from robodyn.scene import Scene

    def no_work(self: Scene) -> None:  # the scene is refused before the model is built: nothing runs
        raise AssertionError("the scene was accepted and its model built")

    monkeypatch.setattr(Scene, "build", no_work)
    scene = write_scene(tmp_path, text)
    line = refused(["run", str(scene), "--out", str(tmp_path / "out")], tmp_path, capsys)
    assert message in line and str(scene) in line
    assert not (tmp_path / "out").exists()


def test_a_model_name_with_a_newline_stays_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = write_scene(tmp_path, BASE.replace("'pendubot'", '"pen\\ndubot"'))
    line = refused(["run", str(scene), "--out", str(tmp_path / "out")], tmp_path, capsys)
    assert f"{scene}: [model] name: unknown model 'pen\\ndubot'" in line


def test_a_non_utf8_or_huge_scene_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = tmp_path / "latin1.toml"
    scene.write_bytes(b"[model]\nname = 'pendubot'\n# caf\xe9\n")
    line = refused(["run", str(scene)], tmp_path, capsys)
    assert f"{scene}: not UTF-8 text: byte 0xe9 on line 3" in line
    huge = tmp_path / "huge.toml"
    huge.write_text(BASE + "# " + "x" * 2_000_000 + "\n")
    assert f"{huge}: larger than 1024 KiB" in refused(["run", str(huge)], tmp_path, capsys)


def test_a_file_name_with_a_newline_stays_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    line = refused(["run", str(tmp_path / "two\nlines.toml")], tmp_path, capsys)
    assert "two\\nlines.toml: no such scene file" in line


@pytest.mark.parametrize(
    ("extra", "output", "message"),
    [
        (SIM + "[view]\nhtml = 'scene.toml'\n", None, "cannot write [view] html {d}/scene.toml: it is the scene"),
        (SIM + "[view]\nhtml = 'arm.urdf'\n", None, "cannot write [view] html {d}/arm.urdf: it is the model's URDF"),
        (
            SIM + "[view]\nhtml = 'out/../out/summary.json'\n",
            "out",
            "cannot write [view] html {d}/out/../out/summary.json: the summary {d}/out/summary.json is the same file",
        ),
    ],
)
def test_run_never_writes_over_its_inputs_or_another_output(
    extra: str, output: str | None, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    urdf = tmp_path / "arm.urdf"
    urdf.write_text((Path(__file__).parents[1] / "models" / "pendubot.urdf").read_text())
    scene = write_scene(tmp_path, "[model]\nurdf = 'arm.urdf'\n" + extra)
    line = refused(["run", str(scene), "--out", str(tmp_path / (output or "elsewhere"))], tmp_path, capsys)
    assert message.format(d=tmp_path) in line


def test_run_divergence_keeps_the_good_trajectory(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = write_scene(tmp_path, BASE + "[initial]\nq = [0.3, -0.2]\n[simulate]\nduration = 0.1\n")
    out = tmp_path / "out"
    assert main(["run", str(good), "--out", str(out)]) == 0
    kept = (out / "scene.npz").read_bytes()
    capsys.readouterr()
    bad = "[simulate]\nduration = 5.0\ndt = 0.05\nintegrator = 'euler'\n"
    write_scene(tmp_path, BASE + "[initial]\nq = [0.3, -0.2]\n" + bad)
    assert main(["run", str(good), "--out", str(out)]) == EXIT_DIVERGED
    line = one_line(capsys)
    partial = out / "scene.partial.npz"
    assert f"partial trajectory written to {partial} ({out / 'scene.npz'} left as it was)" in line
    assert (out / "scene.npz").read_bytes() == kept
    assert json.loads((out / "summary.json").read_text())["simulate"]["trajectory"] == str(partial)


def test_run_ctrl_c_keeps_the_partial_trajectory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    press_ctrl_c_during_step(monkeypatch, 301)
    scene = write_scene(tmp_path, BASE + "[simulate]\nduration = 10.0\n")
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out)]) == INTERRUPTED
    line = one_line(capsys)
    assert line.startswith("robodyn run: interrupted after step 300")
    assert f"partial trajectory written to {out / 'scene.partial.npz'}" in line
    summary = json.loads((out / "summary.json").read_text())
    assert summary["simulate"]["interrupted"] is True and (out / "scene.partial.npz").is_file()


# --------------------------------------------------------------------------- bench: the folder agrees


def test_an_interrupted_bench_leaves_the_old_folder_as_it_was(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from robodyn.studies import bench

    out = tmp_path / "bench"
    out.mkdir()
    (out / "report.md").write_text("# the report of an earlier run\n")
    (out / "bench.json").write_text("[]\n")
    before = snapshot(out)
    original = bench.sweep
    done: list[str] = []

    def sweep_then_ctrl_c(robot: object, **options: object) -> object:
        if done:  # Ctrl-C during the second model, once the first one's results are written
            raise KeyboardInterrupt
        done.append("first")
        return original(robot, **options)  # type: ignore[arg-type]

    monkeypatch.setattr(bench, "sweep", sweep_then_ctrl_c)
    argv = ["bench", "geared_arm", "cart_pole", "--quick", "--no-stability", "--no-progress", "--out", str(out)]
    assert main(argv) == INTERRUPTED
    line = one_line(capsys)
    (partial,) = out.glob("bench.partial.*")
    assert line == f"robodyn bench: interrupted; the results so far are in {partial} ({out} is left as it was)"
    assert {k: v for k, v in snapshot(out).items() if not k.startswith("bench.partial.")} == before
    assert {r["model"] for r in json.loads((partial / "bench.json").read_text())} == {"geared_arm"}
    assert not (partial / "report.md").exists()


def test_a_bench_interrupted_before_any_result_leaves_no_partial_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from robodyn.studies import bench

    def ctrl_c(robot: object, **options: object) -> object:
        raise KeyboardInterrupt

    monkeypatch.setattr(bench, "sweep", ctrl_c)
    out = tmp_path / "bench"
    assert main(["bench", "geared_arm", "--quick", "--no-progress", "--out", str(out)]) == INTERRUPTED
    assert one_line(capsys) == f"robodyn bench: interrupted before any result; {out} is left as it was"
    assert list(out.iterdir()) == []


def test_a_finished_bench_replaces_the_old_report_and_drops_what_it_did_not_write(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "bench"
    out.mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    (out / "report.md").symlink_to(victim)
    (out / "stability.json").write_text('{"from": "an earlier run"}\n')
    (out / "notes.txt").write_text("the user's own file\n")
    argv = ["bench", "geared_arm", "--quick", "--no-stability", "--no-progress", "--out", str(out)]
    assert main(argv) == 0
    assert victim.read_text() == "precious" and not (out / "report.md").is_symlink()
    assert "geared_arm" in (out / "report.md").read_text()
    assert not (out / "stability.json").exists()  # --no-stability: an old one would describe another run
    assert (out / "notes.txt").read_text() == "the user's own file\n"
    assert not list(out.glob("bench.partial.*"))


# --------------------------------------------------------------------------- numpy warnings


def test_numpy_warnings_are_counted_in_one_note(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import robodyn.cli.simulate as simulate_cli

    report = simulate_cli._report

    def overflowing_report(*args: object, **options: object) -> None:
        big = np.full(3, 1e308)
        for _ in range(4):
            big * 10.0
        report(*args, **options)  # type: ignore[arg-type]

    monkeypatch.setattr(simulate_cli, "_report", overflowing_report)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # what main does not catch would fail the test
        assert main(["simulate", "pendubot", "--duration", "0.01"]) == 0
    assert one_line(capsys) == (
        "robodyn simulate: note: numpy reported 4 floating-point warnings during the run: "
        "overflow encountered in multiply (4)"
    )


def test_numpy_warnings_never_join_a_refusal(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import robodyn.cli.simulate as simulate_cli

    def overflow_then_refuse(*args: object, **options: object) -> None:
        np.full(2, 1e308) * 10.0
        raise InputError("refused after the overflow")

    monkeypatch.setattr(simulate_cli, "_report", overflow_then_refuse)
    assert main(["simulate", "pendubot", "--duration", "0.01"]) == EXIT_BAD_INPUT
    assert one_line(capsys) == "robodyn simulate: error: refused after the overflow"


# --------------------------------------------------------------------------- real processes


def real(argv: Sequence[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(ROBODYN), *argv], capture_output=True, text=True, cwd=cwd, timeout=300, check=False)


def test_real_processes_refuse_in_one_line(tmp_path: Path) -> None:
    assert real(["simulate", "pendubot", "--duration", "0.1", "--out", "t.npz"], tmp_path).returncode == 0
    (tmp_path / "deep.toml").write_text(BASE + "[initial]\nq = " + "[" * 10_000 + "]" * 10_000 + "\n")
    (tmp_path / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    cases = [
        (["check", "pendubot", "--seed", "-1"], "argument --seed"),
        (["view", "pendubot", "t.npz", "--html", "t.npz"], "cannot write --html t.npz: it is a trajectory"),
        (["view", "pendubot", "t.npz", "--fps", "1e9", "--html", "v.html"], "at most 100,000"),
        (["run", "deep.toml"], "deep.toml: arrays or tables nested too deeply"),
        (["check", "pendubot", "--formula", "pendubot", "--params", "deep.json"], "nested too deeply"),
    ]
    for argv, message in cases:
        before = snapshot(tmp_path)
        proc = real(argv, tmp_path)
        lines = proc.stderr.splitlines()
        assert proc.returncode == EXIT_BAD_INPUT and len(lines) == 1 and message in lines[0], (argv, proc.stderr)
        assert snapshot(tmp_path) == before, argv


def test_a_real_overflowing_run_is_one_line(tmp_path: Path) -> None:
    # v0 = 1e150 rad/s: a finite energy (3e298 J) that the first step overflows; numpy warns in several
    # places, robodyn says it once
    proc = real(["simulate", "pendubot", "--v0", "1e150,0", "--duration", "0.01", "--out", "w.npz"], tmp_path)
    lines = proc.stderr.splitlines()
    assert proc.returncode == EXIT_DIVERGED and len(lines) == 1, proc.stderr
    assert "diverged at step 1" in lines[0] and "overflowed float64" in lines[0]
    assert "partial trajectory written to w.partial.npz" in lines[0]


def test_an_initial_state_whose_energy_overflows_is_bad_input(tmp_path: Path) -> None:
    # v0 = 1e200 rad/s: the kinetic energy is inf before any step; not a divergence
    proc = real(["simulate", "pendubot", "--v0", "1e200,0", "--duration", "0.01", "--out", "w.npz"], tmp_path)
    lines = proc.stderr.splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert "the initial energy is not finite (T0 = inf J" in lines[0]
    assert not (tmp_path / "w.npz").exists() and not (tmp_path / "w.partial.npz").exists()


# --------------------------------------------------------------------------- check --params files

PENDUBOT_PARAMS = {
    "m1": 1.336,
    "m2": 0.5,
    "l1": 0.15,
    "lc1": 0.1,
    "lc2": 0.126,
    "I1": 6.19e-3,
    "I2": 2.65e-3,
    "g": 9.81,
}


def params_file(folder: Path, name: str, content: str | bytes) -> Path:
    path = folder / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return path


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (
            json.dumps(dict.fromkeys(PENDUBOT_PARAMS, 0)),
            "with the given pendubot parameters m1 = 0, m2 = 0, l1 = 0, lc1 = 0, lc2 = 0, I1 = 0, I2 = 0, g = 0 "
            "the formula's mass matrix M(q) is singular at sample 0",
        ),
        (
            json.dumps(PENDUBOT_PARAMS | {"m2": 0, "I2": 0}),
            "the formula's mass matrix M(q) is singular at sample 0",
        ),
        (json.dumps(PENDUBOT_PARAMS | {"I1": -1.0}), "given pendubot parameters I1 = -1 (expected masses and inertias"),
        (
            json.dumps(PENDUBOT_PARAMS | {"m1": 1e300, "l1": 1e300}),
            "the formula's mass matrix M(q) is not finite at sample 0",
        ),
        (json.dumps(PENDUBOT_PARAMS | {"m1": "1.3"}), "parameter m1 must be a finite number, got '1.3'"),
        ('{"m1": 1e999}', "pendubot parameters must be exactly"),
        ("[" * 100_000 + "]" * 100_000, "arrays or objects nested too deeply to read"),
        ('{"params": ' + "{" * 0 + '{"m1": ' + "[" * 5_000 + "]" * 5_000 + "}}", "nested too deeply to read"),
        ('{"m1": 1' + "0" * 5_000 + "}", "a value cannot be read: Exceeds the limit (4300 digits)"),
        (b'{"m1": "\xff"}', "not UTF-8 text: byte 0xff at offset 8"),
        (" " * (2**20 + 1), "larger than 1 MiB"),
    ],
    ids=[
        "all zero",
        "second body massless",
        "negative",
        "overflow",
        "string",
        "1e999",
        "deep",
        "deep inside",
        "long integer",
        "latin-1",
        "huge",
    ],
)
def test_a_bad_params_file_is_one_line_naming_it(
    content: str | bytes, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = params_file(tmp_path, "p.json", content)
    line = refused(
        ["check", "pendubot", "--formula", "pendubot", "--params", str(path), "--samples", "3"], tmp_path, capsys
    )
    assert line.startswith(f"robodyn check: error: {path}: "), line
    assert message in line, line


def test_params_with_massless_bodies_but_inertia_are_a_real_mismatch(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # m1 = m2 = 0 with I1, I2 > 0 keeps M positive definite: the check runs, and disagrees (exit 1)
    path = params_file(tmp_path, "p.json", json.dumps(PENDUBOT_PARAMS | {"m1": 0, "m2": 0}))
    assert main(["check", "pendubot", "--formula", "pendubot", "--params", str(path), "--samples", "3"]) == 1
    assert "FAIL" in capsys.readouterr().out


def test_a_formula_file_with_a_singular_mass_matrix_is_a_mismatch_not_a_traceback(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    formula = tmp_path / "flat.py"
    formula.write_text(
        "import numpy as np\nKIND = 'pendubot'\n"
        "def mass_matrix(q, p): return np.zeros((2, 2))\n"
        "def coriolis_matrix(q, v, p): return np.zeros((2, 2))\n"
        "def gravity(q, p): return np.zeros(2)\n"
    )
    assert main(["check", "pendubot", "--formula", str(formula), "--samples", "3"]) == 1
    out = capsys.readouterr().out
    assert "a (forward dynamics)" in out and "FAIL" in out


# --------------------------------------------------------------------------- more writers, more links


def test_charts_follow_no_planted_link(tmp_path: Path) -> None:
    from robodyn import charts

    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    stem = tmp_path / "bars"
    written = [stem.with_suffix(".png"), stem.with_suffix(".svg")]
    for path in written:
        path.symlink_to(victim)
    assert charts.speed_bars(["a", "b"], [1.0, 10.0], stem, unit="us", title="t") == tuple(written)
    assert victim.read_text() == "precious"
    for path in written:
        assert path.is_file() and not path.is_symlink(), path
    assert written[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and b"<svg" in written[1].read_bytes()[:1000]


def test_params_write_follows_no_link_planted_at_the_srdf_temporary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import tempfile
    import types

    from robodyn.kinds import edit

    victim = tmp_path / "victim.txt"
    victim.write_text("precious")

    def mkstemp_and_plant(**options: object) -> tuple[int, str]:
        fd, name = tempfile.mkstemp(**options)  # type: ignore[call-overload]
        Path(name).with_suffix(".srdf").symlink_to(victim)  # the SRDF's temporary name is derived from it
        return fd, name

    monkeypatch.setattr(edit, "tempfile", types.SimpleNamespace(mkstemp=mkstemp_and_plant))
    out = tmp_path / "arm.urdf"
    assert main(["params", "geared_arm", "--set", "J_m=2e-5", "--write", str(out)]) == 0, capsys.readouterr().err
    assert victim.read_text() == "precious"
    srdf = out.with_suffix(".srdf")
    assert srdf.is_file() and not srdf.is_symlink() and 'mass="2e-05"' in srdf.read_text()


def test_info_and_check_read_the_urdf_only_through_robodyns_reader(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # ET.parse feeds expat in 64 KiB pieces (quadratic on a long token) and reads a DTD: never used
    import xml.etree.ElementTree as ET

    def forbidden(*args: object, **kwargs: object) -> None:
        raise AssertionError("ET.parse used: read URDFs with robodyn.model.files.read_xml")

    monkeypatch.setattr(ET, "parse", forbidden)
    assert main(["info", "pendubot"]) == 0
    assert main(["check", "pendubot", "--samples", "2"]) == 0
    capsys.readouterr()


def test_a_singular_mass_matrix_is_a_mismatch_in_the_table_not_a_traceback(capsys: pytest.CaptureFixture[str]) -> None:
    # the cart-pole's thin pole carries no inertia about its own axis: on a free flyer, M(q) is singular
    assert main(["check", "cart_pole", "--free-flyer", "--samples", "3"]) == 1
    out = capsys.readouterr().out
    assert "M(q) is not positive definite at sample 0" in out and "FAIL" in out


@pytest.mark.parametrize(
    "argv",
    [
        ["view", "a" * 300, "t.npz", "--html", "v.html"],
        ["check", "pendubot", "--formula", "pendubot", "--params", "p" * 300 + ".json"],
        ["params", "b" * 256 + ".urdf"],
        ["check", "pendubot", "--srdf", "x/" + "s" * 256 + "/y.srdf"],
    ],
    ids=["view model", "check --params", "params model", "check --srdf"],
)
def test_a_path_part_longer_than_a_file_name_is_one_line(
    argv: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    line = refused(argv, tmp_path, capsys)
    assert "expected a path whose every part is at most 255 bytes (a file name)" in line, line


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["check", "pendubot", "--seed", "9" * 400], "argument --seed: expected a seed from 0 to 9223372036854775807"),
        (["check", "pendubot", "--samples", "9" * 400], "argument --samples: expected a whole number from 1 to 100000"),
        (["check", ""], "argument URDF_OR_NAME: expected a model name or a path to a .urdf file, got an empty string"),
        (["check", "pendubot", "--params", ""], "argument --params: expected a path, got an empty string"),
    ],
    ids=["seed past a float", "samples past a float", "empty model", "empty path"],
)
def test_a_whole_number_past_any_float_or_an_empty_name_is_one_line(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert message in refused(argv, tmp_path, capsys)
