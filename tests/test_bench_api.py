"""benchmarks/bench_api.py runs, saves each call's cost against Pinocchio's, and guards committed folders.

No timing is asserted: the figures are the benchmark's to print, on a machine of its run's choosing.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "bench_api.py"
CALLS = ("M(q)", "C(q, v)", "G(q)", "nle(q, v)", "inverse_dynamics(q, v, a)", "forward_dynamics(q, v, tau)")


def _run(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *argv], capture_output=True, text=True, timeout=300, cwd=ROOT)


def test_it_saves_every_call_against_pinocchio_with_the_runs_facts(tmp_path: Path) -> None:
    run = _run("--model", "pendubot", "--calls", "3", "--repeat", "2", "--out", str(tmp_path))
    assert run.returncode in (0, 1), run.stderr  # 1: a call over its limit (a short, noisy run may be)
    data = json.loads((tmp_path / "bench_api.json").read_text())
    assert data["run"]["command"].startswith("python ") and data["model"] == "pendubot"
    rows = {row["call"]: row for row in data["rows"]}
    assert set(CALLS) <= set(rows)
    for row in rows.values():
        assert row["robodyn_us"] > 0 and row["pinocchio_us"] > 0
        assert row["limit_us"] == data["ratio_limit"] * row["pinocchio_us"] + data["slack_us"]
        assert row["within_limit"] == (row["robodyn_us"] <= row["limit_us"])
        assert row["call"] in run.stdout
    assert (run.returncode == 1) == any(not row["within_limit"] for row in rows.values())


def test_a_committed_folder_is_refused_in_one_line() -> None:
    run = _run("--calls", "1", "--repeat", "1", "--out", str(ROOT / "docs" / "benchmarks"))
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.count("\n") == 1 and "--overwrite-committed" in run.stderr
