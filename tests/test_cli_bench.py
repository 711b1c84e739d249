"""``robodyn bench``: every file of the issue, through main() and one real subprocess run."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from robodyn.cli import main

from ._bench_helpers import RECORD_KEYS

# geared_arm_stiff: inertia about the joint J [kg m^2] and viscous damping b [N m s/rad]
STIFF_J, STIFF_B = 1.0008275e-2, 10.0
CHARTS = ("work_precision_pendubot", "error_vs_dt_pendubot", "energy_pendubot", "stability", "lyapunov")


def test_quick_bench_writes_every_file(tmp_path):
    out = tmp_path / "bench"
    proc = subprocess.run(
        [sys.executable, "-m", "robodyn", "bench", "pendubot", "--quick", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert proc.returncode == 0, proc.stderr
    assert "[####" in proc.stderr  # the progress bar
    records = json.loads((out / "bench.json").read_text())
    assert records and all(RECORD_KEYS <= r.keys() for r in records)
    assert {r["backend"] for r in records} == {"aba", "crba", "formula", "fast"}
    for stem in CHARTS:
        assert (out / f"{stem}.png").stat().st_size > 1000
        assert (out / f"{stem}.svg").stat().st_size > 1000
    stab = json.loads((out / "stability.json").read_text())
    assert {x["case"] for x in stab["limits"]} >= {"geared_arm_stiff", "pendubot"}
    euler = next(x for x in stab["limits"] if x["case"] == "pendubot" and x["integrator"] == "euler")
    assert euler["predicted_dt_max"] == 0.0  # unstable at every dt on an undamped system
    assert stab["chaos"]["lyapunov"]["exponent"] > 0
    # the stiff arm's time constant J / b (models/variants/geared_arm_stiff.urdf), from the linearisation:
    # its fast eigenvalue is -b / J shifted by the slow mode's 0.036 1/s
    assert stab["stiff"]["time_constant_s"] == pytest.approx(STIFF_J / STIFF_B, rel=1e-4)
    report = (out / "report.md").read_text()
    for needle in ("work_precision_pendubot.png", "stability.png", "Lyapunov", "Cheapest run"):
        assert needle in report
    # conclusions are computed from the numbers: on the 1-DoF stiff arm (nearly linear) every row agrees
    assert "time constant 1 ms" in report
    stiff_rows = [line for line in report.splitlines() if line.startswith("| geared_arm_stiff |")]
    assert len(stiff_rows) == sum(x["case"] == "geared_arm_stiff" for x in stab["limits"]) > 0
    assert all(row.split("|")[-2].strip().startswith("agree") for row in stiff_rows), stiff_rows
    assert "compared limits: predicted and measured agree (tolerance 10 %)" in report


def test_unknown_model_is_bad_input_without_traceback(tmp_path, capsys):
    assert main(["bench", "no_such_robot", "--out", str(tmp_path), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "unknown model" in err and "Traceback" not in err


def test_unwritable_out_is_bad_input(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["bench", "pendubot", "--quick", "--out", str(blocker / "sub"), "--no-progress"]) == 2
    assert "cannot write" in capsys.readouterr().err


def test_out_is_required(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["bench", "pendubot"])
    assert exc.value.code == 2


def test_sweep_only_through_main(tmp_path):
    out = tmp_path / "o"
    assert main(["bench", "geared_arm", "--quick", "--no-stability", "--no-progress", "--out", str(out)]) == 0
    assert not (out / "stability.json").exists()
    records = json.loads((out / "bench.json").read_text())
    assert {r["model"] for r in records} == {"geared_arm"}
    assert "geared_arm" in (out / "report.md").read_text()


# --------------------------------------------------------------------------- a tiny plan for what follows
TINY = dict(
    error_horizon=0.2,
    energy_horizon=0.4,
    sample_interval=0.02,
    dts=(0.01, 0.005),
    rtols=(),
    adaptive=(),
    backends=("aba",),
    all_backends_for=(),
)


@pytest.fixture
def tiny_plan(monkeypatch):
    """The bench runs euler and rk4 at two steps on ABA over 0.4 s (a second or two instead of minutes)."""
    from robodyn.studies import bench

    def plan(*, quick: bool = False, fixed: tuple[str, ...] = ("euler", "rk4")) -> bench.SweepPlan:
        return bench.SweepPlan(fixed=fixed, **TINY)

    monkeypatch.setattr(bench, "default_plan", plan)
    return monkeypatch


def _page_info(page):
    import re

    text = page.read_text(encoding="utf-8")
    return json.loads(re.search(r'id="robodyn-info">(.*?)</script>', text, re.S).group(1))


def _pair_from(out, accuracy):
    from robodyn.studies.bench import BenchResult
    from robodyn.studies.replay_pair import pick_pair

    results = [
        BenchResult(**{k: (float("inf") if v is None and k == "error" else v) for k, v in r.items()})
        for r in json.loads((out / "bench.json").read_text())
    ]
    return pick_pair(results[0].model, results, accuracy, horizon=TINY["error_horizon"])


def test_bench_view_replays_the_fastest_hit_beside_the_cheapest_miss(tiny_plan, tmp_path, capsys):
    out, page = tmp_path / "out", tmp_path / "pair.html"
    args = ["bench", "pendubot", "--no-stability", "--no-progress", "--out", str(out), "--view", "--html", str(page)]
    assert main(args) == 0
    captured = capsys.readouterr()
    pair = _pair_from(out, 1e-6)  # the default accuracy, chosen from the runs bench.json records
    assert pair.met is not None and pair.missed is not None
    assert pair.met.integrator == "rk4" and pair.missed.integrator == "euler"  # order 4 meets 1e-6, order 1 not
    assert f"replay of {pair.describe()}" in captured.out  # the accuracy is stated, and both runs
    assert "accuracy 1e-06 (largest relative state error over the first 0.2 s" in captured.out
    assert "measured again" not in captured.err  # the replayed runs reproduce their recorded errors
    info = _page_info(page)
    names = [pair.name(pair.met), pair.name(pair.missed)]
    assert [run["name"] for run in info["panel"]["runs"]] == names
    for name, result in zip(names, pair.runs, strict=True):
        assert f"{result.integrator}/aba dt {result.dt:g} s, error {result.error:.2g}," in name
        assert "per simulated s" in name
    energy = next(c for c in info["panel"]["charts"] if c["key"] == "energy")
    assert {s["run"] for s in energy["series"]} == {0, 1}  # both runs' curves share the chart
    assert f"wrote {page}" in captured.out


@pytest.mark.parametrize(
    ("accuracy", "fixed", "words", "side"),
    [
        ("1e-300", ("euler", "rk4"), "no run meets it; replaying the cheapest alone", "missed"),
        ("1", ("rk4",), "every run meets it; replaying the fastest alone", "met"),
    ],
)
def test_bench_view_with_one_side_empty_says_so_and_replays_one_run(
    tiny_plan, tmp_path, capsys, accuracy, fixed, words, side
):
    from robodyn.studies import bench

    tiny_plan.setattr(bench, "default_plan", lambda *, quick=False: bench.SweepPlan(fixed=fixed, **TINY))
    out, page = tmp_path / "out", tmp_path / "one.html"
    args = ["bench", "pendubot", "--no-stability", "--no-progress", "--out", str(out), "--html", str(page)]
    assert main([*args, "--accuracy", accuracy]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("replay of")]
    assert len(lines) == 1 and words in lines[0]
    pair = _pair_from(out, float(accuracy))
    shown = getattr(pair, side)
    assert [run["name"] for run in _page_info(page)["panel"]["runs"]] == [pair.name(shown)]


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--view"], "--view replays the runs of one model; 2 given"),
        (["--accuracy", "1e-4"], "--accuracy is an option of the replay; add --view"),
        (["--open"], "--open is an option of the replay"),
        (["--ground"], "--ground is an option of the replay; add --view"),
        (["--html", "x.html", "--port", "8123"], "--html writes a file and starts no server"),
    ],
)
def test_bench_view_bad_options_fail_before_any_work(tiny_plan, tmp_path, capsys, extra, words):
    out = tmp_path / "out"
    models = ["pendubot", "geared_arm"] if extra == ["--view"] else ["pendubot"]
    assert main(["bench", *models, "--no-progress", "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err
    assert words in err and len(err.strip().splitlines()) == 1
    assert not out.exists() or not any(out.iterdir())  # nothing ran, nothing was written


def test_bench_view_html_may_not_be_one_of_the_results(tiny_plan, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["bench", "pendubot", "--no-progress", "--out", str(out), "--html", str(out / "report.md")]) == 2
    assert "cannot write" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["bench", "pendubot", "--out", str(out), "--view", "--accuracy", "0"])
    assert exc.value.code == 2


def test_bench_view_without_html_serves_the_pair(tiny_plan, tmp_path, capsys):
    """--view alone hands the two-run playback to the server robodyn view uses (stubbed: no browser here)."""
    from robodyn.cli import view

    served = []

    def serve(playback, *, open_browser, zmq_url, port):
        served.append((playback, open_browser, port))
        return 0

    tiny_plan.setattr(view, "serve_playback", serve)
    out = tmp_path / "out"
    assert main(["bench", "pendubot", "--no-stability", "--no-progress", "--out", str(out), "--view"]) == 0
    ((playback, open_browser, port),) = served
    pair = _pair_from(out, 1e-6)
    assert [run.name for run in playback.runs] == [pair.name(r) for r in pair.runs] and len(playback.runs) == 2
    assert (open_browser, port) == (False, None)
    assert "wrote" not in capsys.readouterr().out.split("replay of")[1]  # no HTML file without --html


# --------------------------------------------------------------------------- a folder whose files agree
def _files(folder):
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


def test_an_interrupted_bench_leaves_the_last_complete_run_untouched(tiny_plan, tmp_path, capsys):
    from robodyn.studies import bench

    out = tmp_path / "out"
    assert main(["bench", "pendubot", "--no-stability", "--no-progress", "--out", str(out)]) == 0
    before = _files(out)
    real = bench.sweep

    def sweep(robot, **options):  # Ctrl-C during the second model's sweep
        if robot.name == "cart_pole":
            raise KeyboardInterrupt
        return real(robot, **options)

    tiny_plan.setattr(bench, "sweep", sweep)
    capsys.readouterr()
    assert main(["bench", "geared_arm", "cart_pole", "--no-stability", "--no-progress", "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert _files(out) == before  # the report and the results it describes, as they were
    (stage,) = [p for p in out.iterdir() if p.is_dir()]
    assert stage.name.startswith("bench.partial.") and f"the results so far are in {stage}" in err
    assert "report.md" not in _files(stage)  # the partial folder has no report to contradict its files
    assert {r["model"] for r in json.loads((stage / "bench.json").read_text())} == {"geared_arm"}


def test_ctrl_c_while_the_results_move_in_undoes_the_moves(tiny_plan, tmp_path, capsys):
    import os
    import signal

    out = tmp_path / "out"
    assert main(["bench", "pendubot", "--no-stability", "--no-progress", "--out", str(out)]) == 0
    before = _files(out)
    real, pressed = os.replace, []

    def replace(src, dst):  # Ctrl-C as the first result moves from the private folder into --out
        if os.path.dirname(os.fspath(dst)) == os.fspath(out) and not pressed:
            pressed.append(dst)
            signal.raise_signal(signal.SIGINT)
        return real(src, dst)

    tiny_plan.setattr(os, "replace", replace)
    assert main(["bench", "cart_pole", "--no-stability", "--no-progress", "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert pressed
    assert _files(out) == before  # --out as it was: the pendubot's report and results
    (stage,) = [p for p in out.iterdir() if p.is_dir()]
    assert err == (
        f"robodyn bench: interrupted while the results were being moved in; they are in {stage} "
        f"({out} is left as it was)\n"
    )
    assert {r["model"] for r in json.loads((stage / "bench.json").read_text())} == {"cart_pole"}
    assert "cart_pole" in (stage / "report.md").read_text()  # the new run whole, report included


def test_a_failed_move_leaves_no_report_beside_results_it_does_not_describe(tiny_plan, tmp_path, capsys):
    import os

    out = tmp_path / "out"
    assert main(["bench", "pendubot", "--no-stability", "--no-progress", "--out", str(out)]) == 0
    real, moves = os.replace, []

    def replace(src, dst):  # the disk fills up on the second move into --out
        if os.path.dirname(os.fspath(dst)) == os.fspath(out):
            moves.append(dst)
            if len(moves) == 2:
                raise OSError(28, "No space left on device", os.fspath(dst))
        return real(src, dst)

    tiny_plan.setattr(os, "replace", replace)
    assert main(["bench", "cart_pole", "--no-stability", "--no-progress", "--out", str(out)]) == 2
    assert not (out / "report.md").exists()  # the old report (of pendubot) went before any new file came in


def test_numeric_warnings_are_folded_into_one_line_not_printed_in_the_progress_bar(tiny_plan, tmp_path, capsys):
    """An overflow inside a run: no raw RuntimeWarning (and its source line) in the middle of the bar."""
    import numpy as np

    from robodyn.studies import bench

    real = bench.run_one

    def run_one(*args, **options):
        np.multiply(np.array([1e308]), 10.0)  # overflow encountered in multiply, as a blown-up state does
        return real(*args, **options)

    tiny_plan.setattr(bench, "run_one", run_one)
    out = tmp_path / "out"
    assert main(["bench", "pendubot", "--no-stability", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "RuntimeWarning" not in err and "np.multiply" not in err
    assert "[####" in err  # the progress bar was drawn
    notes = [line for line in err.splitlines() if "floating-point" in line]
    assert notes == [
        "robodyn bench: note: numpy reported 4 floating-point warnings during the run: "
        "overflow encountered in multiply (4)"
    ]
