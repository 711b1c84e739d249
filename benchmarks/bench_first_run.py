"""The first run on a fresh install: robodyn simulate with an empty numba cache, then the same run cached.

    python benchmarks/bench_first_run.py [--models pendubot,panda] [--duration 0.2] [--out bench-out]

Each model is run as ``robodyn simulate MODEL --duration 0.2`` in fresh processes, three times:

* ``first``: with an empty ``NUMBA_CACHE_DIR`` of its own and robodyn's default choice
  (``ROBODYN_COMPILE=auto``): what a fresh install pays. A short run takes the Python loop while
  the compiled loop's kernels are not built (:mod:`robodyn.sim.compile_choice`);
* ``first_compiled``: with another empty cache and ``ROBODYN_COMPILE=always``: what the compile
  costs, paid by a run long enough to need it (or ``--backend numba``, or ``robodyn warmup``);
* ``cached``: with that second cache, the default choice again: every later run.

The wall time and the child's CPU time (user + system: what a quiet machine's wall time would be,
near enough, since the compile is single-threaded) are measured for each, with the load average
before and after, the loop the summary line names, and the compile note on stderr. The goals (a
quiet 2-core machine: pendubot at most 15 s, panda at most 45 s, for ``first``) are printed beside
the figures; on a busy machine judge by the CPU time. Prints a table and writes first_run.json to --out.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _common import argument_parser, output_folder, run_facts, write_json

GOALS = {"pendubot": 15.0, "panda": 45.0}  # [s] on a fresh install, quiet 2-core machine


def _loadavg() -> list[float]:
    return [float(x) for x in Path("/proc/loadavg").read_text().split()[:3]] if Path("/proc/loadavg").exists() else []


def timed_run(model: str, duration: float, cache: Path, compile_mode: str = "auto") -> dict[str, Any]:
    """One ``robodyn simulate`` in a fresh process: ``cache`` numba's cache folder, ``ROBODYN_COMPILE`` as given."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "ROBODYN_COMPILE": compile_mode}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = _loadavg()
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "robodyn", "simulate", model, "--duration", str(duration)],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    notes = [line for line in done.stderr.splitlines() if "note: compiling" in line]
    summary = next((line for line in done.stdout.splitlines() if " steps to t = " in line), "")
    return {
        "loop": "compiled" if summary.endswith("compiled loop)") or "compiled loop," in summary else "Python",
        "exit_code": done.returncode,
        "wall_s": round(wall, 2),
        "cpu_s": round(cpu, 2),
        "load_before": load,
        "load_after": _loadavg(),
        "compile_note": notes[0] if notes else None,
    }


def main() -> int:
    parser = argument_parser(__doc__ or "")
    parser.add_argument("--models", default="pendubot,panda", help="comma-separated models (default: pendubot,panda)")
    parser.add_argument("--duration", type=float, default=0.2, help="simulated time [s] (default 0.2)")
    args = parser.parse_args()
    out = output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    rows: dict[str, Any] = {}
    for model in [m.strip() for m in args.models.split(",") if m.strip()]:
        with tempfile.TemporaryDirectory(prefix="robodyn-first-run-") as folder:
            first = timed_run(model, args.duration, Path(folder) / "default")
            compiled = timed_run(model, args.duration, Path(folder) / "compiled", "always")
            cached = timed_run(model, args.duration, Path(folder) / "compiled")
        rows[model] = {"goal_s": GOALS.get(model), "first": first, "first_compiled": compiled, "cached": cached}
    result = {"duration_s": args.duration, "runs": rows}
    path = write_json(out, "first_run", result, facts)
    print(f"robodyn simulate MODEL --duration {args.duration:g}, load average before: {facts['load_before']}")
    print(f"{'model':10} {'run':15} {'loop':9} {'wall':>8} {'CPU':>8} {'goal':>7}  load (1 min) before -> after")
    for model, row in rows.items():
        goal = f"{row['goal_s']:.0f} s" if row["goal_s"] else "-"
        for name in ("first", "first_compiled", "cached"):
            r = row[name]
            load = " -> ".join(f"{x[0]:.1f}" for x in (r["load_before"], r["load_after"]) if x)
            print(
                f"{model:10} {name:15} {r['loop']:9} {r['wall_s']:6.1f} s {r['cpu_s']:6.1f} s "
                f"{goal if name == 'first' else '':>7}  {load}"
            )
    print(f"wrote {path}")
    failed = [m for m, row in rows.items() if any(r["exit_code"] for r in row.values() if isinstance(r, dict))]
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
