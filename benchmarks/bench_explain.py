"""How well ``robodyn check --explain`` names planted mistakes: the explain corpus, scored, with the times.

    python benchmarks/bench_explain.py [--robots scara,arm3] [--cases lc-for] [--repeat 3] [--no-timing]
                                       [--derive ur5] [--label before] [--before OLD.json] [--out bench-out]

For every case of ``benchmarks/explain_corpus`` (hand-written robots, a correct formula file each and
planted single mistakes with their true terms; ``explain_corpus/verify.py`` proves each truth) the
planted file is written to a temporary folder and ``robodyn check URDF --formula FILE --explain --json``
runs on it, as a student runs it (a process of its own). Each true entry is then scored
(``_explain_score.py``): named right, candidates including the truth, an honest "cannot name",
a WRONG NAME (a printed name, or a candidate list, that is not the truth at random parameter
values), or missing; a convention slip's one-line hint right, wrong or missing.

Per robot it also times, as wall clock of the whole command: ``check`` of the correct file, ``check
--explain`` of the robot's first case and ``derive URDF --coordinates correct.py``: the first run, then
the median of ``--repeat`` more; and ``derive`` of each robot of ``--derive`` (UR5 by default). A robot
whose correct file does not pass (a feature the robodyn under test lacks) is reported and its cases are
not scored. ``--before OLD.json`` (a run of an earlier version) puts its summary and per-case outcomes
beside this run's. It prints one line per case and a summary, and writes ``explain[_LABEL].json`` to
``--out``.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

from _explain_score import OUTCOMES, Case, Robot, load_corpus, planted_text, score_case

from _common import argument_parser, output_folder, run_facts, write_json

COMMAND_TIMEOUT = 300  # [s] one robodyn command; past it the run is recorded as timed out
TIMEOUT_EXIT = -1


def robodyn(args: list[str]) -> tuple[int, str, str, float]:
    """``python -m robodyn ARGS`` in a process of its own: exit code, stdout, stderr, wall time [s]."""
    start = time.perf_counter()
    try:
        done = subprocess.run(
            [sys.executable, "-m", "robodyn", *args], capture_output=True, text=True, timeout=COMMAND_TIMEOUT
        )
    except subprocess.TimeoutExpired:
        return TIMEOUT_EXIT, "", f"timed out after {COMMAND_TIMEOUT} s", time.perf_counter() - start
    return done.returncode, done.stdout, done.stderr, time.perf_counter() - start


def first_line(text: str) -> str:
    """The first non-empty line of ``text`` (a refusal's one line)."""
    return next((line for line in text.splitlines() if line.strip()), "")


def timed(args: list[str], repeat: int, first_run: tuple[int, str, float] | None = None) -> dict[str, Any]:
    """The first run's wall time, then the median of ``repeat`` more [s]; the exit code and a refusal's line.

    ``first_run``: (exit, stderr, wall time) of a first run already made.
    """
    code, err, first = first_run if first_run is not None else _run3(args)
    runs = [robodyn(args)[3] for _ in range(repeat)] if code != TIMEOUT_EXIT else []
    out: dict[str, Any] = {"exit": code, "first_s": round(first, 3)}
    if runs:
        out["median_s"] = round(statistics.median(runs), 3)
        out["runs_s"] = [round(t, 3) for t in runs]
    if code not in (0, 1):
        out["error"] = first_line(err)
    return out


def _run3(args: list[str]) -> tuple[int, str, float]:
    code, _, err, wall = robodyn(args)
    return code, err, wall


def robot_times(
    robot: Robot, first_case: Path | None, repeat: int, first_check: tuple[int, str, float]
) -> dict[str, Any]:
    """check (its first run made), check --explain (of the first case) and derive of one robot, timed."""
    urdf, formula = robot.model, str(robot.formula)
    times = {"check": timed(["check", urdf, "--formula", formula], repeat, first_check)}
    if first_case is not None:
        times["check_explain"] = timed(["check", urdf, "--formula", str(first_case), "--explain"], repeat)
    times["derive"] = timed(["derive", urdf, "--coordinates", formula], repeat)
    return times


def run_case(robot: Robot, case: Case, folder: Path) -> dict[str, Any]:
    """Plant, check with --explain --json, score."""
    path = folder / f"{case.id.replace('-', '_')}.py"
    path.write_text(planted_text(robot, case), encoding="utf-8")
    code, out, err, wall = robodyn(["check", robot.model, "--formula", str(path), "--explain", "--json"])
    row: dict[str, Any] = {
        "id": case.id,
        "robot": robot.name,
        "slip": case.slip,
        "truth": dict(case.truth),
        "hint_expected": dict(case.hint) if case.hint else None,
        "exit": code,
        "wall_s": round(wall, 3),
    }
    try:
        report = json.loads(out)
    except json.JSONDecodeError:
        row.update(outcome="not_run", hint="not_run", entries=[], error=first_line(err) or "no JSON on stdout")
        return row
    row.update(score_case(robot, case, report))
    if code != 1:  # a planted mistake must FAIL the check; anything else is the check's fault
        row["outcome"] = "missing" if row["outcome"] != "not_run" else row["outcome"]
    return row


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Counts over the scored cases: term outcomes (cases with a true term), hints (convention cases)."""
    run = [r for r in rows if r["outcome"] != "not_run"]
    terms = [r for r in run if r["truth"]]
    counts = Counter(r["outcome"] for r in terms)
    hint_cases = [r for r in run if r["hint_expected"]]
    hints = Counter(r["hint"] for r in hint_cases)
    wrong_in_conventions = sum(
        any(e["outcome"] == "wrong_name" for e in r["entries"]) for r in run if not r["truth"]
    )  # fmt: skip
    return {
        "cases": len(rows),
        "not_run": len(rows) - len(run),
        "term_cases": len(terms),
        **{k: counts.get(k, 0) for k in OUTCOMES},
        "named_right_pct": round(100.0 * counts.get("named_right", 0) / len(terms), 1) if terms else None,
        "hint_cases": len(hint_cases),
        "hints_right": hints.get("right", 0),
        "hints_wrong": hints.get("wrong", 0),
        "hints_missing": hints.get("missing", 0),
        "spurious_hints": sum(r["hint"] == "spurious" for r in run),
        "wrong_names_in_convention_cases": wrong_in_conventions,
        "entries_wrong_name": sum(e["outcome"] == "wrong_name" for r in run for e in r["entries"]),
    }


def commit() -> str:
    """The short git commit of the robodyn under test (empty outside a repository)."""
    done = subprocess.run(
        ["git", "-C", str(Path(__file__).parent), "rev-parse", "--short", "HEAD"],
        capture_output=True,
        text=True,
        check=False,
    )
    return done.stdout.strip()


def print_case(row: dict[str, Any]) -> None:
    hint = f"  hint {row['hint']}" if row.get("hint_expected") or row.get("hint") == "spurious" else ""
    wrong = [e["label"] for e in row["entries"] if e["outcome"] == "wrong_name"]
    said = f"  wrong: {', '.join(wrong)}" if wrong else ""
    code = "-" if row["exit"] is None else row["exit"]
    print(f"{row['id']:<30} {row['slip']:<30} exit {code:>2}  {row['outcome']:<22}{hint}{said}", flush=True)


def print_summary(summary: dict[str, Any], robots: list[dict[str, Any]]) -> None:
    s = summary
    print(
        f"\n{s['term_cases']} cases with a true term: named right {s['named_right']} ({s['named_right_pct']} %), "
        f"candidates incl. the truth {s['candidates']}, honest cannot-name {s['cannot_name']}, "
        f"WRONG NAME {s['wrong_name']}, missing {s['missing']}"
    )
    print(
        f"{s['hint_cases']} convention cases: hint right {s['hints_right']}, wrong {s['hints_wrong']}, "
        f"missing {s['hints_missing']}; spurious hints {s['spurious_hints']}; cases not run {s['not_run']}"
    )
    print(f"\n{'robot':<26} {'check':>14} {'check --explain':>16} {'derive':>14}   (first / median [s])")
    for r in robots:
        cells = []
        for key in ("check", "check_explain", "derive"):
            t = r["times"].get(key)
            cells.append("-" if t is None else f"{t['first_s']:.2f} / {t.get('median_s', float('nan')):.2f}")
        note = f"   correct file: exit {r['correct_exit']}" if r["correct_exit"] != 0 else ""
        print(f"{r['robot']:<26} {cells[0]:>14} {cells[1]:>16} {cells[2]:>14}{note}")


def main() -> int:
    parser = argument_parser(__doc__)
    parser.add_argument("--robots", default="", help="comma-separated robots of the corpus (default: all)")
    parser.add_argument("--cases", default="", help="only the cases whose id contains this text")
    parser.add_argument("--repeat", type=int, default=3, help="timed runs after the first (default 3)")
    parser.add_argument("--no-timing", action="store_true", help="score the cases only")
    parser.add_argument("--label", default="", help="suffix of the JSON file (explain_LABEL.json)")
    parser.add_argument("--before", type=Path, help="an earlier run's JSON, shown beside this one")
    parser.add_argument(
        "--derive",
        default="ur5",
        help="comma-separated robots (names or URDFs) whose derive is timed too (default ur5; '' for none)",
    )
    args = parser.parse_args()
    out = output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    facts["commit"] = commit()
    wanted = {r for r in args.robots.split(",") if r}
    robots = [r for r in load_corpus() if not wanted or r.name in wanted]
    rows: list[dict[str, Any]] = []
    robot_rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="explain-bench-") as tmp:
        folder = Path(tmp)
        for robot in robots:
            cases = [c for c in robot.cases if args.cases in c.id]
            code, _, err, wall = robodyn(["check", robot.model, "--formula", str(robot.formula)])
            info: dict[str, Any] = {
                "robot": robot.name,
                "note": robot.note,
                "requires": list(robot.requires),
                "cases": len(cases),
                "correct_exit": code,
                "times": {},
            }
            if code != 0:
                info["correct_error"] = first_line(err)
                for case in cases:
                    row = {"id": case.id, "robot": robot.name, "slip": case.slip, "truth": dict(case.truth),
                           "hint_expected": dict(case.hint) if case.hint else None, "exit": None,
                           "outcome": "not_run", "hint": "not_run", "entries": [],
                           "error": f"the correct file does not pass: {info['correct_error']}"}  # fmt: skip
                    rows.append(row)
                    print_case(row)
            else:
                for case in cases:
                    rows.append(run_case(robot, case, folder))
                    print_case(rows[-1])
            if not args.no_timing:
                first = folder / "timing_case.py"
                if cases:
                    first.write_text(planted_text(robot, cases[0]), encoding="utf-8")
                info["times"] = robot_times(robot, first if cases else None, args.repeat, (code, err, wall))
            robot_rows.append(info)
        if not args.no_timing:
            for name in (n for n in args.derive.split(",") if n):
                derive = timed(["derive", name], args.repeat)
                robot_rows.append({"robot": name, "note": "derive only", "requires": [], "cases": 0,
                                   "correct_exit": 0, "times": {"derive": derive}})  # fmt: skip
    summary = summarise(rows)
    result: dict[str, Any] = {"label": args.label or "", "summary": summary, "robots": robot_rows, "cases": rows}
    if args.before is not None:
        old = json.loads(args.before.read_text(encoding="utf-8"))
        result["before"] = {
            "file": args.before.name,
            "commit": old.get("run", {}).get("commit", ""),
            "summary": old["summary"],
            "cases": {r["id"]: {"outcome": r["outcome"], "hint": r["hint"]} for r in old["cases"]},
            "robots": {r["robot"]: r["times"] for r in old["robots"]},
        }
    print_summary(summary, robot_rows)
    stem = f"explain_{args.label}" if args.label else "explain"
    path = write_json(out, stem, result, facts)
    print(f"\nwrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
