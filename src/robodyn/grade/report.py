"""The class report: the score distribution and which mistakes how many students made.

Written to ``--out``: ``report.md`` (the numbers and the chart), ``scores.png`` (a histogram of the
scores), ``class.json`` (everything below, for machines) and ``mistakes.csv`` (one row a mistake:
kind ``entry`` or ``term``, what, how many students).
"""

from __future__ import annotations

import csv
import json
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.grade.assignment import Assignment
from robodyn.grade.grading import SubmissionResult


@dataclass(frozen=True)
class ClassSummary:
    """The class's numbers: scores, and mistakes counted once per student."""

    scores: tuple[float, ...]
    max_score: float
    entries: tuple[tuple[str, int], ...]  # ("M[0,1]", students), most frequent first
    terms: tuple[tuple[str, int], ...]  # ("M[0,1]: formula - Pinocchio = ...", students), in the model's coordinates
    errors: tuple[tuple[str, str], ...]  # (student, one-line reason) of submissions that could not run

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict, with the score statistics."""
        s = np.asarray(self.scores, dtype=float)
        stats = {
            "students": len(s),
            "mean": float(s.mean()) if len(s) else 0.0,
            "median": float(np.median(s)) if len(s) else 0.0,
        }
        full = sum(1 for x in self.scores if x == self.max_score)
        return {
            **stats,
            "max_score": self.max_score,
            "full_marks": full,
            "scores": list(self.scores),
            "entries": dict(self.entries),
            "terms": dict(self.terms),
            "errors": dict(self.errors),
        }


def summarize(results: Sequence[SubmissionResult], assignment: Assignment) -> ClassSummary:
    """Count each wrong entry and each named term once per student who made it.

    Terms are counted as the model's joint coordinates name them (:attr:`SubmissionResult.model_terms`): the
    same slip written in two conventions (a sign, an offset, absolute angles) is one mistake of the report.
    """
    entries: Counter[str] = Counter()
    terms: Counter[str] = Counter()
    for r in results:
        entries.update({w for q in r.quantities for w in q.wrong})
        terms.update(set(r.model_terms))
    return ClassSummary(
        scores=tuple(r.score for r in results),
        max_score=assignment.max_score,
        entries=tuple(sorted(entries.items(), key=lambda kv: (-kv[1], kv[0]))),
        terms=tuple(sorted(terms.items(), key=lambda kv: (-kv[1], kv[0]))),
        errors=tuple((r.student, r.error) for r in results if r.error),
    )


def _students(n: int) -> str:
    return f"{n} student" + ("" if n == 1 else "s")


def _chart(path: Path, summary: ClassSummary, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.2))
    top = summary.max_score
    bins = list(np.linspace(0, top, min(20, max(4, int(np.ceil(top)))) + 1)) if top > 0 else 4
    ax.hist(summary.scores, bins=bins, color="tab:blue", edgecolor="white")
    ax.set_xlabel(f"score (of {top:g} points)")
    ax.set_ylabel("students")
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_report(out: Path, results: Sequence[SubmissionResult], assignment: Assignment) -> ClassSummary:
    """Write report.md, scores.png, class.json and mistakes.csv under ``out``; return the summary."""
    summary = summarize(results, assignment)
    d = summary.as_dict()
    out.mkdir(parents=True, exist_ok=True)
    _chart(out / "scores.png", summary, assignment.title)
    (out / "class.json").write_text(json.dumps(d, indent=1), encoding="utf-8")
    with (out / "mistakes.csv").open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["kind", "mistake", "students"])
        w.writerows(("entry", k, n) for k, n in summary.entries)
        w.writerows(("term", k, n) for k, n in summary.terms)
    lines = [
        f"# {assignment.title}: class report",
        "",
        f"{_students(d['students'])}, {d['full_marks']} with full marks; mean {d['mean']:.3g}, median "
        f"{d['median']:.3g} of {summary.max_score:g} points.",
        "",
        "![score distribution](scores.png)",
        "",
        "## Wrong entries",
        "",
        *(f"- {_students(n)}: {k}" for k, n in summary.entries),
        "",
        "## Named terms (formula - Pinocchio in the model's joint coordinates, named by its joints)",
        "",
        *(f"- {_students(n)}: {k}" for k, n in summary.terms),
        "",
        "## Submissions that could not be run",
        "",
        *(f"- {s}: {why}" for s, why in summary.errors),
        "",
    ]
    (out / "report.md").write_text("\n".join(lines), encoding="utf-8")
    return summary
