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
