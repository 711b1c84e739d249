"""Grade one submission: run robodyn's check on it in the sandbox, then score it by quantity and by entry.

Each asked quantity's points are split evenly over its entries (M: the upper triangle, n (n + 1) / 2;
C: n^2, or C v: n when the Christoffel form is not required; G: n; V: one), and an entry that
mismatches Pinocchio at any sampled state loses its share. A submission that cannot be run (a
syntax error, a missing function, a loop past the time limit, an exit, a refused operation, a NaN,
a wrong shape) gets 0 with the check's one-line reason.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from robodyn import __version__
from robodyn.errors import RobodynError
from robodyn.grade.assignment import Assignment

GUARD = Path(__file__).with_name("_guard")
ROW = {"M": "M", "C": "C", "G": "G", "V": "V - V(q0)", "nle": "nle = C v + G"}
POINTS_DIGITS = 6  # scores are rounded to this many decimals: shares like 4/3 print and add up cleanly
ONE_THREAD = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")  # a submission's process: one BLAS thread


@dataclass(frozen=True)
class QuantityScore:
    """One asked quantity: its points, what the submission earned, and its wrong entries (``M[0,1]``)."""

    name: str  # "M", "C", "Cv", "G", "V"
    score: float
    max_score: float
    wrong: tuple[str, ...] = ()
    reason: str = ""  # why the whole quantity got 0, if it did for a reason other than wrong entries


@dataclass(frozen=True)
class SubmissionResult:
    """A graded submission, JSON round-trippable (``as_dict`` / ``from_dict``) for resuming."""

    student: str
    source: str  # the graded file, relative to the submissions folder
    digest: str  # sha256 of the submission, the assignment and robodyn's version: the resume key
    score: float
    max_score: float
    quantities: tuple[QuantityScore, ...]
    feedback: str
    error: str = ""  # the one-line reason a submission could not be run
    verdict: str = ""  # the check's verdict ("PASS", "EQUATIONS AGREE", "FAIL") or "ERROR"
    terms: tuple[str, ...] = ()  # named mistakes, "M[0,1]: formula - Pinocchio = -m2*l1*lc2*cos(q2)"
    # the same in the model's joint coordinates, "M[0,1]: formula - Pinocchio = -m2*l1*lc2*cos(elbow)": the class
    # report counts these, so one slip written in two coordinate conventions is one mistake
    model_terms: tuple[str, ...] = ()
    wall_time_s: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> SubmissionResult:
        """The inverse of :meth:`as_dict`."""
        quantities = tuple(QuantityScore(**{**q, "wrong": tuple(q["wrong"])}) for q in d["quantities"])
        return cls(
            **{
                **d,
                "quantities": quantities,
                "terms": tuple(d["terms"]),
                "model_terms": tuple(d.get("model_terms", ())),
            }
        )


def digest(assignment: Assignment, submission: Path) -> str:
    """The resume key: the submission's bytes, the assignment's and robodyn's version."""
    h = hashlib.sha256()
    for part in (submission.read_bytes(), assignment.path.read_bytes(), __version__.encode()):
        h.update(hashlib.sha256(part).digest())
    return h.hexdigest()


@functools.lru_cache(maxsize=4)
def _robot(model: str) -> Any:
    import robodyn

    return robodyn.load(model)


@contextlib.contextmanager
def _guarded(path: Path, memory_mb: int) -> Iterator[None]:
    """Environment for the formula process the check starts: the guard's audit hook, RLIMIT_AS, one BLAS thread."""
    saved = {k: os.environ.get(k) for k in ("PYTHONPATH", "ROBODYN_GRADE_GUARD", "ROBODYN_GRADE_MEMORY", *ONE_THREAD)}
    paths = [str(GUARD), *filter(None, [saved["PYTHONPATH"]])]
    os.environ.update(
        PYTHONPATH=os.pathsep.join(paths),
        ROBODYN_GRADE_GUARD=str(path),
        ROBODYN_GRADE_MEMORY=str(memory_mb << 20),
        **dict.fromkeys(ONE_THREAD, "1"),
    )
    try:
        yield
    finally:
        for k, value in saved.items():
            if value is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = value


def _entries(name: str, n: int) -> list[tuple[int, ...]]:
    if name == "M":
        return [(i, j) for i in range(n) for j in range(i, n)]
    if name == "C":
        return [(i, j) for i in range(n) for j in range(n)]
    return [()] if name == "V" else [(i,) for i in range(n)]


def _label(name: str, entry: tuple[int, ...]) -> str:
    return name if not entry else f"{name}[{','.join(map(str, entry))}]"


def _wrong(row: Any) -> set[tuple[int, ...]]:
    return set() if row.passed else {tuple(m.entry) for m in row.mismatches} or {tuple(row.entry)}


def score_report(assignment: Assignment, report: Any) -> tuple[QuantityScore, ...]:
    """Score a :class:`robodyn.CheckReport` by quantity and by entry, as the assignment asks."""
    rows = {r.quantity: r for r in report.rows if r.group == "formula" and r.applicable}
    n = len(rows["M"].worst_v) if "M" in rows else 0
    out = []
    for name, points in assignment.points.items():
        shown, reason, wrong = name, "", set()
        if name == "C" and not assignment.christoffel:
            shown = "Cv"
            wrong = _wrong_cv(rows, n)
        elif ROW[name] not in rows:
            reason = _missing(name, rows)
        else:
            wrong = _wrong(rows[ROW[name]])
        entries = _entries("V" if shown == "V" else ("G" if shown == "Cv" else shown), n)
        share = points / len(entries)
        lost = [e for e in entries if e in wrong]
        earned = 0.0 if reason else points - share * len(lost)
        labels = tuple(_label(shown, e) for e in lost)
        out.append(QuantityScore(shown, round(earned, POINTS_DIGITS), points, labels, reason))
    return tuple(out)


def _wrong_cv(rows: Mapping[str, Any], n: int) -> set[tuple[int, ...]]:
    """C v's wrong entries: (C v + G)[i] mismatching while G[i] agrees (a wrong G[i] is charged to G only)."""
    if ROW["nle"] not in rows:
        return {(i,) for i in range(n)}
    nle = _wrong(rows[ROW["nle"]])
    g = _wrong(rows[ROW["G"]]) if ROW["G"] in rows else set()
    return {e for e in nle if e not in g}


def _missing(name: str, rows: Mapping[str, Any]) -> str:
    if name == "C":
        return "the Christoffel C is asked: define coriolis_matrix(q, v, p) (the file gives C v only)"
    if name == "V":
        return "V is asked: define potential_energy(q, p)"
    return f"{name} was not checked"


def named_terms(explained: Any) -> tuple[str, ...]:
    """The mistakes ``--explain`` named, one line each: ``M[0,1]: formula - Pinocchio = -m2*l1*lc2*cos(q2)``.

    ``explained``: a report's ``explain_terms`` (the student's coordinates) or ``joint_terms`` (the model's).
    """
    out = []
    for t in explained:
        if t.get("status") != "named" or not t.get("terms"):
            continue
        ordered = sorted(t["terms"], key=lambda x: x["basis"])  # one mistake reads the same in every file
        parts = [f"{x['name']}*{x['basis']}" if x["basis"] != "1" else x["name"] for x in ordered]
        out.append(f"{t['label']}: formula - Pinocchio = {' + '.join(parts)}".replace("+ -", "- "))
    return tuple(out)


def feedback_text(
    assignment: Assignment, result_score: float, quantities: tuple[QuantityScore, ...], report: Any
) -> str:
    """The student's feedback at the assignment's level: verdict, entries or terms."""
    lines = [f"score: {result_score:g} / {assignment.max_score:g}"]
    if assignment.feedback == "verdict":
        return "\n".join(lines) + "\n"
    for q in quantities:
        why = q.reason or (f"wrong: {', '.join(q.wrong)}" if q.wrong else "right")
        lines.append(f"{q.name}: {q.score:g} / {q.max_score:g}  ({why})")
    if assignment.feedback == "terms" and report is not None:
        lines += [f"hint: {h}" if not h.startswith("hint") else h for h in report.hints]
        lines += [
            line for line in report.explanation if not line.startswith("explain:") and " follows from " not in line
        ]
    return "\n".join(lines) + "\n"


def prepared(assignment: Assignment, submission: Path, folder: Path) -> Path:
    """A copy of ``submission`` in ``folder`` (same name: messages read the same), teacher coordinates added."""
    target = folder / submission.name
    shutil.copyfile(submission, target)
    extra = assignment.coordinate_lines()
    if extra:
        with target.open("a", encoding="utf-8") as f:
            f.write(extra)
    return target.resolve()


def grade_file(
    assignment: Assignment, submission: str | Path, *, student: str = "", source: str = ""
) -> SubmissionResult:
    """Grade one formula file; never raises for what the file does (its error is the result's one line)."""
    import time

    import robodyn

    start = time.perf_counter()
    submission = Path(submission)
    key = digest(assignment, submission)
    student = student or submission.stem
    source = source or submission.name
    robot = _robot(assignment.model)
    with tempfile.TemporaryDirectory(prefix="robodyn-grade-") as tmp:
        path = prepared(assignment, submission, Path(tmp))
        try:
            with _guarded(path, assignment.memory_mb):
                report = robodyn.check(
                    robot,
                    str(path),
                    samples=assignment.samples,
                    seed=assignment.seed,
                    rtol=assignment.tolerance,
                    formula_timeout=assignment.time_limit,
                    explain=True,
                )
        except RobodynError as exc:
            return error_result(assignment, student, source, key, str(exc).replace(tmp + os.sep, ""), start)
    quantities = score_report(assignment, report)
    score = round(sum(q.score for q in quantities), POINTS_DIGITS)
    return SubmissionResult(
        student=student,
        source=source,
        digest=key,
        score=score,
        max_score=assignment.max_score,
        quantities=quantities,
        feedback=feedback_text(assignment, score, quantities, report),
        verdict=report.verdict,
        terms=named_terms(report.explain_terms),
        model_terms=named_terms(report.joint_terms),
        wall_time_s=time.perf_counter() - start,
    )


def error_result(
    assignment: Assignment, student: str, source: str, key: str, why: str, start: float
) -> SubmissionResult:
    """0 for everything asked, with the one line that says why."""
    import time

    line = " ".join(why.split())
    quantities = tuple(
        QuantityScore("Cv" if q == "C" and not assignment.christoffel else q, 0.0, p, (), line)
        for q, p in assignment.points.items()
    )
    feedback = f"score: 0 / {assignment.max_score:g}\nerror: {line}\n"
    return SubmissionResult(
        student, source, key, 0.0, assignment.max_score, quantities, feedback, line, "ERROR",
        wall_time_s=time.perf_counter() - start,
    )  # fmt: skip
