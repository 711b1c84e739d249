"""``robodyn info``, ``check`` and ``simulate`` on the URDFs of example-robot-data, pybullet_data and 8 packages.

    python benchmarks/world_urdfs.py [--sets erd-name,erd-file,pybullet,pybullet-random | corpora | CORPUS,...]
                                     [--random N] [--seed 0] [--timeout 300] [--label after]
                                     [--before OLD.json] [--extra ARGS] [--jnrh2023 DIR] [--out bench-out]

Each command runs as ``robodyn.cli.main([...])`` in a forked child of this process (robodyn and
Pinocchio imported once, before the fork), with file descriptors 1 and 2 sent to files, so that
what urdfdom prints natively is counted too. For each file and command it records the exit code,
the number of lines on stderr (error lines, warning lines and others), whether a Python traceback
escaped (the child prints it and exits 99), the error line (else the first line) of stderr, and for ``check`` the rows
marked FAIL. ``--before OLD.json`` (a run of an earlier version) adds each row's exit codes there.
The sets:

* ``erd-name``: every name robodyn's model sources give an example-robot-data robot (loader names
  with their SRDF and free-flyer hint, then every other file's stem);
* ``erd-file``: every URDF file of example-robot-data, by path;
* ``pybullet``: every URDF of pybullet_data outside ``random_urdfs/`` (95 files);
* ``pybullet-random``: the 1,000 generated files of ``random_urdfs/``; all of them by default
  (both commands together take about a second a file), or a seeded sample of ``--random N``;
* ``corpora``, the world's corpora, one set per package (see ``_world_corpora.py``): icub-models, armar,
  jvrc-description, airo-models, gb-robot-models, hello-robot-stretch-urdf, dexmate-urdf and
  example-robot-data-jnrh2023, every ``.urdf`` of each that is installed (as data, never a robodyn
  dependency); an absent one is named in the JSON with the command that installs it. On these,
  ``robodyn simulate FILE --duration 0.1 --json`` runs too, and each row records the longest
  time the command went without printing (``silent_s``), a kill at ``--timeout`` (a hang), and
  the loop that ran: a finished run that the compiled loop handed to the Python loop for a reason
  other than a structural one (loop closures, mimic couplings, a method it does not take) is a
  fallback, unless its summary gives the stiff joint losses of its warning as the reason (counted
  apart); a physics refusal is followed by the run its way past takes, ``--no-physics-check``.

It prints one line per file and a summary, and writes ``world_urdfs[_LABEL].json`` to ``--out``.
"""

from __future__ import annotations

import os
import random
import signal
import sys
import tempfile
import time
import traceback
from pathlib import Path
from typing import Any

from _world_corpora import NAMES as CORPORA
from _world_corpora import absent, corpus_files

from _common import argument_parser, output_folder, run_facts, write_json

SETS = ("erd-name", "erd-file", "pybullet", "pybullet-random", *CORPORA)
SIMULATE = ["--duration", "0.1", "--json"]  # 100 steps of rk4 at the default dt: every stage of the loop runs
SILENT_LIMIT_S = 60.0  # no command may go longer without printing
STIFF = "the stiff joint losses of the warning"  # a hand-back the summary explains, with the warning's cure
STRUCTURAL = ("loop closures", "couplings are mimic", "not a fixed-step explicit", "no degree of freedom")
PHYSICS = "physically impossible model"  # a refusal whose way past, --no-physics-check, is taken too
UNCHECKED = "simulate --no-physics-check"
COMMANDS = ("info", "check", "simulate", UNCHECKED)
ROOTS: dict[str, Path] = {}  # each installed corpus's folder, for labels and portable text
TRACEBACK_EXIT = 99  # the child's exit code when an exception escaped main()
TIMEOUT_EXIT = -1  # recorded when the child ran past --timeout and was killed


def erd_names() -> list[str]:
    """Every example-robot-data name of robodyn's model sources, sorted."""
    from robodyn.model.sources import sources

    return sorted(sources())


def erd_files() -> list[Path]:
    """Every URDF file of example-robot-data, sorted."""
    from robodyn.model.files import robots_dir

    folder = robots_dir()
    return sorted(folder.glob("**/*.urdf")) if folder is not None else []


def pybullet_files(*, random_only: bool) -> list[Path]:
    """The URDF files of pybullet_data: outside ``random_urdfs/``, or only inside it (empty without pybullet)."""
    try:
        import pybullet_data
    except ImportError:
        return []
    root = Path(pybullet_data.getDataPath())
    files = sorted(root.glob("**/*.urdf"))
    return [f for f in files if ("random_urdfs" in f.relative_to(root).parts) == random_only]


def label_of(path: Path) -> str:
    """A file's name in its data package: ``pybullet_data/r2d2.urdf``, ``hyq_description/robots/hyq.urdf``."""
    for name, root in ROOTS.items():
        if path.is_relative_to(root):
            return f"{name}/{path.relative_to(root)}"
    parts = path.parts
    if "pybullet_data" in parts:
        return "/".join(parts[parts.index("pybullet_data") :])
    if "example-robot-data" in parts:
        return "/".join(parts[parts.index("example-robot-data") + 2 :])  # after example-robot-data/robots/
    return str(path)


def portable(text: str) -> str:
    """``text`` with this machine's data folders written as ``<example-robot-data>`` and ``<pybullet_data>``."""
    from robodyn.model.files import robots_dir

    folders: dict[str, Path | None] = {f"<{name}>": root for name, root in ROOTS.items()}
    folders["<example-robot-data>"] = robots_dir()
    try:
        import pybullet_data

        folders["<pybullet_data>"] = Path(pybullet_data.getDataPath())
    except ImportError:
        pass
    for token, folder in folders.items():
        if folder is not None:
            text = text.replace(str(folder), token)
    return text


def run_child(argv: list[str], timeout: float) -> dict[str, Any]:
    """``robodyn.cli.main(argv)`` in a forked child: exit code, stdout and stderr (native output included)."""
    from robodyn.cli import main

    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        sys.stdout.flush()
        sys.stderr.flush()
        start = time.perf_counter()
        pid = os.fork()
        if pid == 0:  # the child
            code = TRACEBACK_EXIT
            try:
                os.dup2(out.fileno(), 1)
                os.dup2(err.fileno(), 2)
                sys.stdout.reconfigure(line_buffering=True)  # type: ignore[union-attr]  # printed as a terminal sees it
                code = main(argv)
            except SystemExit as exc:  # argparse
                code = exc.code if isinstance(exc.code, int) else 2
            except BaseException:
                traceback.print_exc()
            finally:
                sys.stdout.flush()
                sys.stderr.flush()
                os._exit(code)
        deadline = start + timeout
        status = None
        printed, last, silent = 0, start, 0.0  # bytes written so far, when the last came, the longest gap [s]
        while status is None:
            done, raw = os.waitpid(pid, os.WNOHANG)
            now = time.perf_counter()
            size = os.fstat(out.fileno()).st_size + os.fstat(err.fileno()).st_size
            if size != printed:
                printed, last = size, now
            silent = max(silent, now - last)
            if done:
                status = raw
            elif now > deadline:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
                status = -1
            else:
                time.sleep(0.01)
        wall = time.perf_counter() - start
        code = TIMEOUT_EXIT if status == -1 else os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        stdout = out.read().decode("utf-8", "replace")
        stderr = err.read().decode("utf-8", "replace")
    return {"exit": code, "stdout": stdout, "stderr": stderr, "wall_s": round(wall, 3), "silent_s": round(silent, 1)}


def summarize(command: str, result: dict[str, Any]) -> dict[str, Any]:
    """What is kept of one run: exit code, stderr line count and first line, traceback, FAIL rows."""
    lines = [line for line in result["stderr"].splitlines() if line.strip()]
    mine = f"robodyn {command}: "
    quiet = (mine + "note: ", mine + "t = ")  # the compile notice, the progress of a long run

    def says(line: str) -> bool:
        """An error line: "robodyn X: error: ...", or simulate's "robodyn simulate: diverged ..."."""
        return line.startswith(mine + "error: ") or line.startswith(mine + "diverged ")

    row: dict[str, Any] = {
        "exit": result["exit"],
        "stderr_lines": len(lines),
        # a line that is neither the refusal, nor a one-line warning, nor a note, nor a long run's progress
        "other_lines": sum(not says(x) and ": warning: " not in x and not x.startswith(quiet) for x in lines),
        "error_lines": sum(says(line) for line in lines),
        # the refusal's own line when there is one (one-line warnings may come first), else the first line
        "stderr_first": portable(next((x for x in lines if says(x)), lines[0]))[:240] if lines else "",
        "traceback": result["exit"] == TRACEBACK_EXIT or "Traceback (most recent call last)" in result["stderr"],
        "wall_s": result["wall_s"],
        "silent_s": result["silent_s"],
    }
    if command == "simulate":
        row.update(_loop_of(result["stdout"], result["exit"]))
    if command == "check":
        fails = []
        for line in result["stdout"].splitlines():
            if line.startswith("MISMATCH "):
                fails.append(portable(line)[:240])
        row["fail_rows"] = fails
    return row


def _loop_of(stdout: str, code: int) -> dict[str, Any]:
    """From ``simulate --json``: the loop that ran, why not the compiled one, and what kind of hand-back that was."""
    import json

    start = stdout.find("{")
    try:
        summary = json.loads(stdout[start:]) if start >= 0 else {}
    except json.JSONDecodeError:
        summary = {}
    loop = summary.get("loop")  # None when the run did not finish (a refusal)
    why = str(summary.get("compiled_loop") or "").removeprefix("not used: ") if loop == "python" else ""
    return {"loop": loop, "why_python": portable(why)[:240], **handback(why, code)}


def handback(why: str, code: int) -> dict[str, bool]:
    """A finished run's hand-back to the Python loop: for the stiff losses of its warning, or a fallback.

    A structural reason (loop closures, mimic couplings, a method the compiled loop does not
    take) is no hand-back; nor is a run that diverged (counted as such). One whose summary says
    the stiff joint losses of its warning amplified round-off is stated, with its cure; any other
    is a fallback.
    """
    handed = code == 0 and bool(why) and not any(phrase in why for phrase in STRUCTURAL)
    stiff = handed and STIFF in why
    return {"stiff_handback": stiff, "fallback": handed and not stiff}


def targets(sets: list[str], sample: int | None, seed: int, jnrh2023: Path | None) -> list[tuple[str, str]]:
    """(set, argument) for every file or name of the chosen sets."""
    out: list[tuple[str, str]] = []
    for name in CORPORA:
        if name in sets:
            root, files = corpus_files(name, jnrh2023)
            if root is not None:
                ROOTS[name] = root
                out += [(name, str(p)) for p in files]
    if "erd-name" in sets:
        out += [("erd-name", name) for name in erd_names()]
    if "erd-file" in sets:
        out += [("erd-file", str(p)) for p in erd_files()]
    if "pybullet" in sets:
        out += [("pybullet", str(p)) for p in pybullet_files(random_only=False)]
    if "pybullet-random" in sets:
        files = pybullet_files(random_only=True)
        if sample is not None and sample < len(files):
            files = sorted(random.Random(seed).sample(files, sample))
        out += [("pybullet-random", str(p)) for p in files]
    return out


def main() -> int:
    """Run every file, print a line each and a summary, write the JSON."""
    parser = argument_parser(__doc__)
    parser.add_argument(
        "--sets",
        default=",".join(SETS[:4]),
        help=f"comma-separated sets among {', '.join(SETS)}; 'corpora': the last eight (default: the first four)",
    )
    parser.add_argument("--random", type=int, default=None, help="a seeded sample of random_urdfs (default: all)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random_urdfs sample (default 0)")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds per command before it is killed")
    parser.add_argument("--label", default="", help="suffix of the JSON's name (world_urdfs_LABEL.json)")
    parser.add_argument("--extra", default="", help="extra arguments for every command, e.g. --no-physics-check")
    parser.add_argument(
        "--jnrh2023",
        type=Path,
        default=None,
        help="folder of pip install --target DIR example-robot-data-jnrh2023",
    )
    parser.add_argument(
        "--before",
        type=Path,
        action="append",
        default=[],
        help="a JSON of an earlier run (repeatable): each row gets its exit codes there as 'before'",
    )
    args = parser.parse_args()
    sets = [x for s in args.sets.split(",") if s for x in (CORPORA if s == "corpora" else (s,))]
    unknown = sorted(set(sets) - set(SETS))
    if unknown:
        parser.error(f"unknown set(s) {unknown}; expected some of {list(SETS)}")
    out = output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    # imported once, before the forks
    import robodyn.checker.compare
    import robodyn.cli
    import robodyn.model.load  # noqa: F401

    extra = args.extra.split()
    rows = []
    for which, target in targets(sets, args.random, args.seed, args.jnrh2023):
        row: dict[str, Any] = {"set": which, "target": target if which == "erd-name" else label_of(Path(target))}
        commands = ("info", "check", "simulate") if which in CORPORA else ("info", "check")
        for command in commands:
            more = SIMULATE if command == "simulate" else []
            row[command] = summarize(command, run_child([command, target, *more, *extra], args.timeout))
        if which in CORPORA and PHYSICS in row["simulate"]["stderr_first"]:  # the way past the refusal, taken
            argv = ["simulate", target, *SIMULATE, "--no-physics-check", *extra]
            row[UNCHECKED] = summarize("simulate", run_child(argv, args.timeout))
        rows.append(row)
        print(_line(row), flush=True)
    summary: dict[str, Any] = {}
    for which in sets:
        mine = [r for r in rows if r["set"] == which]
        if which in CORPORA:
            summary[which] = _corpus_summary(mine)
            print(f"{which}: {summary[which]}")
            continue
        summary[which] = {
            "files": len(mine),
            "info_exits": _count(r["info"]["exit"] for r in mine),
            "check_exits": _count(r["check"]["exit"] for r in mine),
            "tracebacks": sum(r["info"]["traceback"] or r["check"]["traceback"] for r in mine),
            "check_fail": sum(r["check"]["exit"] == 1 for r in mine),
            # a refusal is one error line; one-line warnings may come with it, nothing else may
            "refusals_not_one_line": sum(
                (r[c]["exit"] not in (0, 1) and (r[c]["error_lines"] != 1 or r[c]["other_lines"] > 0))
                for r in mine
                for c in ("info", "check")
            ),
        }
        print(f"{which}: {summary[which]}")
    result: dict[str, Any] = {
        "summary": summary,
        "absent": absent(sets, args.jnrh2023),
        "extra": extra,
        "simulate": SIMULATE,
        "rows": rows,
    }
    if args.before:
        result.update(merge_before(rows, args.before, sets))
    stem = "world_urdfs" + (f"_{args.label}" if args.label else "")
    path = write_json(out, stem, result, facts)
    print(f"wrote {path}")
    return 0


def _line(row: dict[str, Any]) -> str:
    """One printed line: the set, the file, each command's exit code, a traceback flag, the first reason."""
    codes = " ".join(f"{c.split()[0][:4]} {row[c]['exit']:3d}" for c in COMMANDS if c in row)
    bad = any(row[c]["traceback"] for c in COMMANDS if c in row)
    sim = row.get(UNCHECKED, row.get("simulate", {}))
    flag = (" TRACEBACK" if bad else "") + (" FALLBACK" if sim.get("fallback") else "")
    why = next((row[c]["stderr_first"] for c in ("check", "info", "simulate") if c in row and row[c]["exit"]), "")
    return f"{row['set'][:15]:15s} {row['target'][:60]:60s} {codes}{flag}  {(why or sim.get('why_python', ''))[:100]}"


def _corpus_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """One corpus: files, tracebacks, hangs, runs silent past the limit, fallbacks, and every refusal's reason."""
    runs = [(r, c) for r in rows for c in COMMANDS if c in r]
    refusals: dict[str, int] = {}  # each distinct reason (file paths cut) with how many files gave it
    for r, c in runs:
        if r[c]["exit"] not in (0, 1, TRACEBACK_EXIT, TIMEOUT_EXIT):
            reason = r[c]["stderr_first"].split(f"robodyn {c.split()[0]}: ", 1)[-1].removeprefix("error: ")
            key = f"{c}: {reason}"
            refusals[key] = refusals.get(key, 0) + 1
    return {
        "files": len(rows),
        "exits": {c: _count(r[c]["exit"] for r in rows if c in r) for c in COMMANDS},
        "tracebacks": sum(r[c]["traceback"] for r, c in runs),
        "hangs": sum(r[c]["exit"] == TIMEOUT_EXIT for r, c in runs),
        "silent_over_limit": sum(r[c]["silent_s"] > SILENT_LIMIT_S for r, c in runs),
        "longest_silence_s": max((r[c]["silent_s"] for r, c in runs), default=0.0),
        "check_fail": sum(r["check"]["exit"] == 1 for r in rows),
        "fallbacks": sum(bool(r[c].get("fallback")) for r, c in runs),
        "stiff_handbacks": sum(bool(r[c].get("stiff_handback")) for r, c in runs),
        "diverged": sum(c.startswith("simulate") and r[c]["exit"] == 3 for r, c in runs),
        "refusals_not_one_line": sum(
            r[c]["exit"] not in (0, 1) and (r[c]["error_lines"] != 1 or r[c]["other_lines"] > 0) for r, c in runs
        ),
        "refusals": dict(sorted(refusals.items(), key=lambda kv: -kv[1])),
    }


def merge_before(rows: list[dict[str, Any]], files: list[Path], sets: list[str]) -> dict[str, Any]:
    """Each row's exit codes in the earlier runs ``files`` (as ``before``), and their summary per set."""
    import json

    earlier: dict[tuple[str, str], dict[str, Any]] = {}
    facts = []
    for file in files:
        data = json.loads(file.read_text())
        facts.append({"file": file.name, **{k: data["run"].get(k) for k in ("date", "command")}})
        for row in data["rows"]:
            earlier[(row["set"], row["target"])] = row
    summary = {}
    for row in rows:
        old = earlier.get((row["set"], row["target"]))
        row["before"] = None if old is None else {c: old[c]["exit"] for c in ("info", "check")}
        if old is not None and old["check"].get("fail_rows"):
            row["before"]["fail_rows"] = [portable(line)[:240] for line in old["check"]["fail_rows"]]
    for which in sets:
        mine = [r["before"] for r in rows if r["set"] == which and r["before"] is not None]
        summary[which] = {
            "files": len(mine),
            "info_exits": _count(b["info"] for b in mine),
            "check_exits": _count(b["check"] for b in mine),
        }
    return {"before": {"runs": facts, "summary": summary}}


def _count(codes: Any) -> dict[str, int]:
    counts: dict[str, int] = {}
    for code in codes:
        counts[str(code)] = counts.get(str(code), 0) + 1
    return dict(sorted(counts.items(), key=lambda kv: int(kv[0])))


if __name__ == "__main__":
    sys.exit(main())
