"""``robodyn check --against``: every URDF of example-robot-data and pybullet_data against each engine installed.

    python benchmarks/against.py [--sets erd,pybullet] [--engines mujoco,pybullet,drake] [--limit N]
                                 [--samples 5] [--timeout 300] [--jobs 1] [--free-flyer] [--out bench-out]
    python benchmarks/against.py --merge ERD.json PYBULLET.json --out DIR
    python benchmarks/against.py --only FILE[,FILE...] --out DIR   (those files only, e.g. to re-run rows after a fix)

For each file robodyn loads (fixed base, revolute, continuous and prismatic joints only), each installed
engine reads it with its defaults and trusting the file (``robodyn.against``). The table counts, per engine
and reading: the files compared, those that agree at rtol 1e-9, those that differ (by cause), those the engine
refuses, and any difference no cause explains; with robodyn's time (its load and the comparison, engines
included). Each file is compared in a forked child of this process (``--jobs`` of them at once), killed after
``--timeout`` seconds (a row marked ``timed out``), so one engine that hangs on a file does not end the survey.
It writes ``against.json`` to ``--out`` after each file; the benchmarks page renders its table.

With ``--free-flyer`` each file's root link floats (``robodyn.load(path, free_flyer=True)``), in MuJoCo (a
``<freejoint>``) and Drake (its quaternion floating joint); PyBullet is left out (``--against pybullet`` compares
fixed bases only), and the table is ``against_free_flyer.json``.
"""

from __future__ import annotations

import importlib.util
import json
import os
import signal
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

from world_urdfs import erd_files, label_of, portable, pybullet_files

from _common import argument_parser, output_folder, run_facts, write_json

# The named causes, by the words each line starts with (robodyn.other_engines.causes).
CAUSES = (
    "no <inertial>",
    "zero-mass link",
    "mass read differently",
    "centre of mass read differently",
    "inertia taken from the collision shape",
    "inertia rotation dropped",
    "inertia's off-diagonal terms dropped",
    "a diagonalisation",
    "physically invalid inertia",
    "inertia rotated differently",
    "inertia changed by the URDF compiler",
    "rotational inertia read differently",
    "axis read differently",
    "limits read differently",
    "effort limit read differently",
    "velocity limit read differently",
    "friction read differently",
    "damping read differently",
    "armature",
)
_MODULES = {"mujoco": "mujoco", "pybullet": "pybullet", "drake": "pydrake"}


def cause_of(what: str) -> str:
    """The named cause a cause line starts with."""
    return next((c for c in CAUSES if what.startswith(c)), what.split(":")[0])


def survey_file(path: Path, engines: tuple[str, ...], samples: int, free_flyer: bool = False) -> dict[str, Any]:
    """One file's row: skipped (with why) or, per engine and reading, its status and causes."""
    import robodyn
    from robodyn.errors import RobodynError

    start = time.perf_counter()
    row: dict[str, Any] = {"file": label_of(path)}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            robot = robodyn.load(path, free_flyer=free_flyer)
        if robot.nv == 0 or any(j.nv != 1 for j in robot.joints[1 if free_flyer else 0 :]):
            return {**row, "skipped": "no moving joint" if robot.nv == 0 else "a joint other than 1-DoF"}
        report = robodyn.against(robot, engines, samples=samples)
    except RobodynError as exc:
        return {**row, "skipped": portable(f"robodyn: {' '.join(str(exc).split())[:200]}")}
    except Exception as exc:  # a crash of the comparison itself: a row of its own, counted, not the end of the survey
        return {**row, "crashed": f"{type(exc).__name__}: {' '.join(str(exc).split())[:160]}"}
    row["seconds"] = time.perf_counter() - start
    row["readings"] = [
        {
            "engine": c.engine,
            "reading": c.reading,
            "status": c.status,
            "causes": sorted({cause_of(cause.what) for cause in c.causes}),
            "unexplained": c.unexplained is not None,
            "refused": portable(c.refused) if c.refused is not None else None,
        }
        for c in report.comparisons
    ]
    return row


class Child:
    """One file compared in a forked child of this process; its row comes back through a temporary file."""

    def __init__(self, path: Path, engines: tuple[str, ...], samples: int, free_flyer: bool) -> None:
        self.path, self.start = path, time.perf_counter()
        self.result = tempfile.TemporaryFile()
        sys.stdout.flush()
        sys.stderr.flush()
        self.pid = os.fork()
        if self.pid == 0:  # the child: its row as JSON into the shared file
            try:
                self.result.write(json.dumps(survey_file(path, engines, samples, free_flyer)).encode())
                self.result.flush()
            finally:
                os._exit(0)

    def row(self, timeout: float) -> dict[str, Any] | None:
        """The child's row once it ended (or was killed past ``timeout`` seconds), None while it runs."""
        if not os.waitpid(self.pid, os.WNOHANG)[0]:
            if time.perf_counter() - self.start <= timeout:
                return None
            os.kill(self.pid, signal.SIGKILL)
            os.waitpid(self.pid, 0)
            self.result.close()
            return {"file": label_of(self.path), "crashed": f"timed out after {timeout:g} s"}
        self.result.seek(0)
        text = self.result.read().decode()
        self.result.close()
        if not text:
            return {"file": label_of(self.path), "crashed": "the child died before writing its row"}
        row: dict[str, Any] = json.loads(text)
        return row


def survey(
    files: list[Path], engines: tuple[str, ...], samples: int, timeout: float, jobs: int, free_flyer: bool
) -> Any:
    """Each file's row, ``jobs`` files at once, yielded as each ends (the rows are put back in file order later)."""
    waiting, running = list(files), []
    while waiting or running:
        while waiting and len(running) < jobs:
            running.append(Child(waiting.pop(0), engines, samples, free_flyer))
        for child in list(running):
            row = child.row(timeout)
            if row is not None:
                running.remove(child)
                yield row
        time.sleep(0.05)


def merge(parts: list[Path]) -> dict[str, Any]:
    """Surveys run side by side (e.g. one of both sets, one of ``--sets pybullet``) as one table of both sets.

    A file in several parts keeps its row of the first (a re-run with ``--only`` goes first); the table's
    ``files`` are those of both sets. The run's facts (date, load) are those of the part with the most rows, the
    other parts' kept under ``other_runs``.
    """
    loaded = [json.loads(part.read_text(encoding="utf-8")) for part in parts]
    rows: dict[str, dict[str, Any]] = {}
    for part in loaded:
        for row in part["rows"]:
            rows.setdefault(row["file"], row)
    everything = [label_of(path) for path in erd_files() + pybullet_files(random_only=False)]
    main = max(loaded, key=lambda part: len(part["rows"]))
    run = dict(main["run"])
    run["command"] = " + ".join(part["run"]["command"] for part in loaded)
    run["wall_time_s"] = max(part["run"]["wall_time_s"] for part in loaded)
    run["other_runs"] = main["run"].get("other_runs", []) + [
        {**part["run"], "files": [row["file"] for row in part["rows"]]} for part in loaded if part is not main
    ]
    return {
        "run": run,
        "engines": loaded[0]["engines"],
        "samples": loaded[0]["samples"],
        "files": len(everything),
        "rows": [rows[name] for name in everything if name in rows],
    }


def main() -> None:
    """Run the survey and write ``against.json`` (the benchmarks page renders its table)."""
    parser = argument_parser(__doc__ or "")
    parser.add_argument("--sets", default="erd,pybullet", help="erd (example-robot-data), pybullet (pybullet_data)")
    parser.add_argument("--engines", default="mujoco,pybullet,drake", help="engines, those installed only")
    parser.add_argument("--limit", type=int, default=0, help="at most this many files per set (0: all)")
    parser.add_argument("--samples", type=int, default=5, help="seeded states per comparison (default 5)")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds per file before it is killed")
    parser.add_argument("--jobs", type=int, default=1, help="files compared at once, each in a child (default 1)")
    parser.add_argument("--merge", type=Path, nargs="+", help="write these saved surveys as one against.json, and stop")
    parser.add_argument("--free-flyer", action="store_true", help="float each root link (MuJoCo and Drake only)")
    parser.add_argument("--only", default="", help="these files only (comma-separated, as the table names them)")
    args = parser.parse_args()
    table = "against_free_flyer" if args.free_flyer else "against"
    out = output_folder(args.out, overwrite_committed=args.overwrite_committed)
    if args.merge:
        write_json(out, table, merge(args.merge))
        print(f"wrote {out / table}.json: {len(args.merge)} surveys as one table")
        return
    wanted = [e for e in args.engines.split(",") if not (args.free_flyer and e == "pybullet")]
    engines = tuple(e for e in wanted if importlib.util.find_spec(_MODULES[e]) is not None)
    facts = run_facts()
    import robodyn  # imported once, before the children fork, with each engine's module

    for engine in engines:
        importlib.import_module(_MODULES[engine])
    del robodyn
    files: list[Path] = []
    for name in args.sets.split(","):
        found = erd_files() if name == "erd" else pybullet_files(random_only=False)
        files += found[: args.limit] if args.limit else found
    if args.only:
        wanted_files = set(args.only.split(","))
        files = [path for path in files if label_of(path) in wanted_files]
        unknown = wanted_files - {label_of(path) for path in files}
        if unknown:
            parser.error(f"--only: no such file in --sets {args.sets}: {', '.join(sorted(unknown))}")
    rows: list[dict[str, Any]] = []
    order = {label_of(path): k for k, path in enumerate(files)}
    for row in survey(files, engines, args.samples, args.timeout, args.jobs, args.free_flyer):
        rows.append(row)
        rows.sort(key=lambda r: order[r["file"]])
        partial = {"engines": list(engines), "samples": args.samples, "files": len(files), "rows": rows}
        write_json(out, table, partial, dict(facts))  # after each file: a stopped survey keeps its rows
        shown = (
            row.get("skipped")
            or row.get("crashed")
            or ", ".join(f"{r['engine']}/{r['reading']} {r['status']}" for r in row["readings"])
        )
        print(f"{row['file']}: {shown}", flush=True)
    summary = {"engines": list(engines), "samples": args.samples, "files": len(files), "rows": rows}
    write_json(out, table, summary, facts)
    print(f"wrote {out / table}.json: the benchmarks page renders its table (docs/hooks/robodyn_docs.py)")


if __name__ == "__main__":
    main()
