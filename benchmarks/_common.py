"""What the benchmark scripts share: best-of timing, the --out folder and its guard, run facts, JSON and figures.

Every script writes into the folder ``--out`` names (default ``bench-out/``, which git ignores) and
refuses, in one line and exit code 2, a folder that holds files under version control unless
``--overwrite-committed`` is given: a figure committed to the documentation is replaced only on
purpose. Each JSON file carries ``run``: the date, the machine, its load before and after, the
versions and the command line, so that a figure shown from it says where it came from.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

T = TypeVar("T")

# The benchmarks measure the compiled loop itself: a run compiles its kernels the first time, whatever its
# length (robodyn.sim.compile_choice), rather than take the Python loop while they are not built.
# bench_first_run.py measures the default choice too, in processes of its own.
os.environ.setdefault("ROBODYN_COMPILE", "always")

DEFAULT_OUT = Path("bench-out")


def best_of(fn: Callable[[], T], repeat: int) -> tuple[float, T]:
    """Best wall time [s] of ``repeat`` calls of ``fn()`` (a shared machine is noisy), and the last result."""
    best = float("inf")
    result: Any = None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - start)
    return best, result


def add_out_arguments(parser: argparse.ArgumentParser, default: Path | None = DEFAULT_OUT) -> None:
    """``--out DIR`` (default ``bench-out``) and ``--overwrite-committed``."""
    parser.add_argument(
        "--out",
        type=Path,
        default=default,
        help=f"folder for the JSON and charts (default {default}; created if missing)",
    )
    parser.add_argument(
        "--overwrite-committed",
        action="store_true",
        help="allow --out to be a folder holding files under version control (e.g. to refresh the documentation's)",
    )


def argument_parser(doc: str) -> argparse.ArgumentParser:
    """A parser described by the first line of ``doc``, with ``--out`` and ``--overwrite-committed``."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    add_out_arguments(parser)
    return parser


def tracked_files(folder: Path) -> list[str]:
    """Files inside ``folder`` that git tracks (empty when git or a repository is absent)."""
    probe = folder if folder.is_dir() else folder.parent
    while not probe.is_dir():
        probe = probe.parent
    try:
        listed = subprocess.run(
            ["git", "-C", str(probe), "ls-files", "--", str(folder.resolve())],
            capture_output=True,
            text=True,
            timeout=30,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return []
    return listed.stdout.split() if listed.returncode == 0 else []


def output_folder(out: Path, *, overwrite_committed: bool) -> Path:
    """Create ``out`` and return it; exit 2 with one line when it holds committed files and that was not allowed."""
    tracked = tracked_files(out)
    if tracked and not overwrite_committed:
        shown = ", ".join(tracked[:3]) + (f" and {len(tracked) - 3} more" if len(tracked) > 3 else "")
        print(
            f"{Path(sys.argv[0]).name}: error: --out {out} holds files under version control ({shown}); "
            "expected a folder of your own (default bench-out/), or --overwrite-committed to replace them",
            file=sys.stderr,
        )
        raise SystemExit(2)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        print(f"{Path(sys.argv[0]).name}: error: --out {out}: {exc.strerror}; expected a folder that can be created",
              file=sys.stderr)  # fmt: skip
        raise SystemExit(2) from None
    return out


def _load() -> list[float] | None:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def run_facts() -> dict[str, Any]:
    """Date (UTC), machine, load average (1, 5, 15 min), versions and command line, taken at the start of a run."""
    import numpy

    facts: dict[str, Any] = {
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "machine": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "load_before": _load(),
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "command": " ".join(["python", *sys.argv]),
    }
    try:
        import pinocchio

        facts["pinocchio"] = pinocchio.__version__
    except ImportError:  # pragma: no cover - robodyn needs it
        pass
    try:
        import robodyn

        facts["robodyn"] = robodyn.__version__
    except ImportError:  # pragma: no cover
        pass
    facts["_started"] = time.perf_counter()
    return facts


def finish_facts(facts: dict[str, Any]) -> dict[str, Any]:
    """``facts`` with the load after the run and its wall time [s]."""
    done = {k: v for k, v in facts.items() if not k.startswith("_")}
    done["load_after"] = _load()
    done["wall_time_s"] = round(time.perf_counter() - facts["_started"], 2)
    return done


def write_json(out: Path, stem: str, result: dict[str, Any], facts: dict[str, Any] | None = None) -> Path:
    """``out/<stem>.json``, indented, with ``run`` (see :func:`run_facts`) first when given; returns its path."""
    path = out / f"{stem}.json"
    body = {"run": finish_facts(facts), **result} if facts is not None else result
    path.write_text(json.dumps(body, indent=2) + "\n")
    return path


def pyplot() -> Any:
    """matplotlib.pyplot on the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, out: Path, stem: str) -> None:
    """``out/<stem>.png`` and ``.svg`` at 120 dpi (SVG without a date, so a rerun differs only in its numbers)."""
    for ext in ("png", "svg"):
        metadata = {"Date": None} if ext == "svg" else {"Software": None}
        fig.savefig(out / f"{stem}.{ext}", dpi=120, metadata=metadata)
    pyplot().close(fig)
