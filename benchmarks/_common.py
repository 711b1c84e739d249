"""What the benchmark scripts share: best-of timing, the --out folder, the JSON and figure files."""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

T = TypeVar("T")


def best_of(fn: Callable[[], T], repeat: int) -> tuple[float, T]:
    """Best wall time [s] of ``repeat`` calls of ``fn()`` (a shared machine is noisy), and the last result."""
    best = float("inf")
    result: Any = None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - start)
    return best, result


def argument_parser(doc: str) -> argparse.ArgumentParser:
    """A parser described by the first line of ``doc``, with ``--out`` (default bench-out)."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("bench-out"))
    return parser


def write_json(out: Path, stem: str, result: dict[str, Any]) -> Path:
    """``out/<stem>.json``, indented; returns its path."""
    path = out / f"{stem}.json"
    path.write_text(json.dumps(result, indent=2) + "\n")
    return path


def pyplot() -> Any:
    """matplotlib.pyplot on the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, out: Path, stem: str) -> None:
    """``out/<stem>.png`` and ``.svg`` at 120 dpi; closes the figure."""
    for ext in ("png", "svg"):
        fig.savefig(out / f"{stem}.{ext}", dpi=120)
    pyplot().close(fig)
