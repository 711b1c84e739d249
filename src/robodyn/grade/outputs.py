"""A class's submissions found, graded (resuming what is done) and written out.

``--out DIR`` receives ``results/<student>.json`` (each submission's result with its content hash,
the resume key), ``feedback/<student>.txt``, ``gradebook.csv`` and, from :mod:`robodyn.grade.report`,
the class report. One submission's Gradescope ``results.json`` is :func:`gradescope_results`.
"""

from __future__ import annotations

import contextlib
import csv
import json
import os
import re
import uuid
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robodyn.grade.assignment import Assignment, load_assignment
from robodyn.grade.grading import SubmissionResult, digest, error_result, grade_file

SKIPPED = ("__pycache__", ".ipynb_checkpoints")
TASK_PREFIX = "robodyn_grade"  # each submission's task on a Dask cluster is named robodyn_grade-...
VISIBILITY = ("hidden", "after_due_date", "after_published", "visible")  # Gradescope's visibility values


@dataclass(frozen=True)
class Submission:
    """One student's work: the file to grade, or the one-line reason there is none."""

    student: str
    path: Path | None  # None: no single formula file could be picked (``problem`` says why)
    source: str
    problem: str = ""


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "student"


def _python_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*.py") if not any(part in SKIPPED for part in p.parts))


def find_submissions(folder: Path, assignment: Assignment) -> list[Submission]:
    """The submissions of ``folder``: each ``*.py`` file in it, and each sub-folder (one a student).

    A student's folder gives the file the assignment names (``file = ...``, found anywhere inside),
    or its one ``.py`` file; several, or none, is that student's one-line problem.
    """
    out = []
    for entry in sorted(folder.iterdir()):
        if entry.name.startswith(".") or entry.name in SKIPPED:
            continue
        if entry.is_file() and entry.suffix == ".py":
            out.append(Submission(entry.stem, entry, entry.name))
        elif entry.is_dir():
            out.append(submission_in_folder(entry, folder, assignment))
    return out


def submission_in_folder(entry: Path, root: Path, assignment: Assignment) -> Submission:
    """The file a student's folder ``entry`` gives (named relative to ``root``), or the one line why none."""
    files = _python_files(entry)
    if assignment.file:
        files = [p for p in files if p.name == assignment.file]
    if len(files) == 1:
        return Submission(entry.name, files[0], str(files[0].relative_to(root)))
    named = f"a file named {assignment.file}" if assignment.file else "a .py file"
    if not files:
        return Submission(entry.name, None, entry.name, f"{entry.name}: no {named} in the submission")
    listed = ", ".join(str(p.relative_to(entry)) for p in files[:5])
    return Submission(
        entry.name,
        None,
        entry.name,
        f"{entry.name}: several .py files ({listed}); the assignment's file = '...' picks one",
    )


def _grade_one(assignment_path: str, submission: Submission) -> dict[str, Any]:
    """Worker entry point (a process of the pool): grade and return a JSON-ready dict."""
    import time

    assignment = load_assignment(assignment_path)
    if submission.path is None:
        result = error_result(
            assignment, submission.student, submission.source, "", submission.problem, time.perf_counter()
        )
    else:
        result = grade_file(assignment, submission.path, student=submission.student, source=submission.source)
    return result.as_dict()


def _cached(out: Path, submission: Submission, assignment: Assignment) -> SubmissionResult | None:
    file = out / "results" / f"{_safe(submission.student)}.json"
    if submission.path is None or not file.is_file():
        return None
    try:
        result = SubmissionResult.from_dict(json.loads(file.read_text(encoding="utf-8")))
    except (ValueError, KeyError, TypeError):
        return None  # a half-written or older file: graded again
    return result if result.digest == digest(assignment, submission.path) else None


def _write_atomic(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def save_result(out: Path, result: SubmissionResult) -> None:
    """The submission's result (the resume record) and its feedback file, each written atomically."""
    name = _safe(result.student)
    _write_atomic(out / "results" / f"{name}.json", json.dumps(result.as_dict(), indent=1))
    _write_atomic(out / "feedback" / f"{name}.txt", result.feedback)


def grade_class(
    assignment: Assignment,
    submissions: Sequence[Submission],
    out: Path,
    *,
    jobs: int = 1,
    scheduler: str | None = None,
    on_result: Callable[[SubmissionResult, bool], None] | None = None,
) -> list[SubmissionResult]:
    """Grade every submission not already graded in ``out`` (same content hash), in ``jobs`` processes.

    With ``scheduler`` (a Dask scheduler's address, ``tcp://host:8786``) each submission is one task of that
    cluster instead, through ``robodyn sweep``'s own client (:func:`robodyn.sweep.engine.client_for`); its
    workers need robodyn and read the assignment and the submissions at the same paths (a shared folder).
    Each result is saved as it arrives, so an interrupted run, or one whose scheduler went away, keeps what
    it finished and the same call resumes from it. ``on_result(result, resumed)`` is called as each one is
    done, in completion order. Results are returned in the order of ``submissions``.

    Raises:
        UnavailableError: no scheduler at ``scheduler``, or it went away (the results saved are kept).
        MissingDependencyError: ``scheduler`` given without Dask installed.
    """
    results: dict[str, SubmissionResult] = {}
    todo = []
    for s in submissions:
        cached = _cached(out, s, assignment)
        if cached is not None:
            results[s.student] = cached
            if on_result:
                on_result(cached, True)
        else:
            todo.append(s)

    def done(d: dict[str, Any]) -> None:
        result = SubmissionResult.from_dict(d)
        save_result(out, result)
        results[result.student] = result
        if on_result:
            on_result(result, False)

    if scheduler is not None and todo:
        _on_cluster(scheduler, assignment, todo, done)
    elif jobs <= 1 or len(todo) <= 1:
        for s in todo:
            done(_grade_one(str(assignment.path), s))
    else:
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            for d in pool.map(_grade_one, [str(assignment.path)] * len(todo), todo):
                done(d)
    return [results[s.student] for s in submissions]


def _on_cluster(
    scheduler: str, assignment: Assignment, todo: Sequence[Submission], done: Callable[[dict[str, Any]], None]
) -> None:
    """Each submission a task of the Dask cluster at ``scheduler``; each result handed to ``done`` as it arrives."""
    from robodyn.errors import UnavailableError
    from robodyn.sweep.engine import client_for, distributed, quiet_dask

    dd = distributed()
    with quiet_dask(), client_for(scheduler=scheduler, workers=None) as client:
        tag = uuid.uuid4().hex  # a key of its own per run: a cancelled earlier task cannot answer for this one
        futures = [
            client.submit(_grade_one, str(assignment.path), s, key=f"{TASK_PREFIX}-{tag}-{i}", pure=False)
            for i, s in enumerate(todo)
        ]
        by_key = {future.key: s for future, s in zip(futures, todo, strict=True)}
        try:
            for future in dd.as_completed(futures):
                done(_from_worker(future, by_key[future.key]))
                future.release()
        except (OSError, TimeoutError, dd.client.FutureCancelledError, dd.CancelledError) as exc:
            raise UnavailableError(
                f"the Dask scheduler went away mid-grading ({type(exc).__name__}); the results graded so far are "
                "saved: run the same command again to resume from them"
            ) from None
        finally:
            for future in futures:
                with contextlib.suppress(Exception):  # a client whose scheduler is gone cannot cancel
                    future.cancel()


def _from_worker(future: Any, submission: Submission) -> dict[str, Any]:
    """A task's result; what its worker raised becomes one line naming the submission (the results so far kept)."""
    from robodyn.errors import RobodynError

    try:
        result: dict[str, Any] = future.result()
    except RobodynError:
        raise
    except FileNotFoundError as exc:
        raise RobodynError(
            f"{submission.source}: a worker of the cluster cannot read {exc.filename}: the workers need the "
            "assignment and the submissions at the same paths (a shared folder); the results graded so far are saved"
        ) from None
    except (OSError, TimeoutError):
        raise  # the scheduler or its connection went away: grade_class says so
    except Exception as exc:  # a worker that died (KilledWorker), or its memory's end: one line, named
        raise RobodynError(
            f"{submission.source}: its worker failed ({type(exc).__name__}: {' '.join(str(exc).split())[:200]}); "
            "the results graded so far are saved, and the same command resumes"
        ) from None
    return result


def write_gradebook(path: Path, results: Iterable[SubmissionResult], assignment: Assignment) -> None:
    """The class's gradebook: student, score, max, the points of each asked quantity, and the one-line error."""
    results = list(results)
    names = [q.name for q in results[0].quantities] if results else list(assignment.points)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["student", "source", "score", "max_score", *names, "error"])
        for r in results:
            w.writerow(
                [
                    r.student,
                    r.source,
                    f"{r.score:g}",
                    f"{r.max_score:g}",
                    *(f"{q.score:g}" for q in r.quantities),
                    r.error,
                ]
            )


def gradescope_results(result: SubmissionResult, *, visibility: str = "visible") -> dict[str, Any]:
    """Gradescope's autograder ``results.json`` for one submission: a test per asked quantity.

    The format is Gradescope's documented one (https://gradescope-autograders.readthedocs.io/en/latest/specs/):
    ``score``, ``output``, ``execution_time`` [s], ``visibility`` and ``tests``, each with ``name``,
    ``score``, ``max_score``, ``status`` and ``output``.
    """
    if visibility not in VISIBILITY:
        raise ValueError(f"visibility must be one of {', '.join(VISIBILITY)}, got {visibility!r}")
    tests = []
    for q in result.quantities:
        why = q.reason or (f"wrong: {', '.join(q.wrong)}" if q.wrong else "right")
        tests.append(
            {
                "name": q.name,
                "score": q.score,
                "max_score": q.max_score,
                "status": "passed" if q.score == q.max_score else "failed",
                "output": why,
                "visibility": visibility,
            }
        )
    return {
        "score": result.score,
        "execution_time": max(1, round(result.wall_time_s)),
        "output": result.feedback,
        "output_format": "text",
        "visibility": visibility,
        "stdout_visibility": "hidden",
        "tests": tests,
        "extra_data": {"robodyn_verdict": result.verdict, "max_score": result.max_score},
    }


def write_gradescope(path: Path, result: SubmissionResult, *, visibility: str = "visible") -> None:
    """Write :func:`gradescope_results` to ``path`` (``/autograder/results/results.json``)."""
    _write_atomic(path, json.dumps(gradescope_results(result, visibility=visibility), indent=1))
