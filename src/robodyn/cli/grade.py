"""``robodyn grade``: grade a class's formula files against an assignment, or check the assignment itself.

``robodyn grade ASSIGNMENT SUBMISSIONS --out DIR`` grades every submission (resuming: a submission
whose content hash has a result in DIR is not graded again) and writes the results, feedback, a
gradebook and a class report. ``--gradescope PATH`` grades one student's folder and writes
Gradescope's ``results.json``. ``--check-solution FILE`` grades the teacher's solution and its mutants.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path
from typing import Any

from robodyn.cli._common import file_path, number_in
from robodyn.errors import EXIT_MISMATCH, EXIT_OK, InputError

DEFAULT_MUTANTS = 24
MAX_JOBS = 256


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "grade",
        help="grade a class's formula files against an assignment (TOML): scores, feedback, a class report",
        description="Grade derivations of M, C, G, V by their agreement with Pinocchio, entry by entry, as the "
        "assignment (TOML) says; each submission runs in robodyn's formula sandbox with the assignment's time and "
        "memory limits. Exit 0 when graded; 1 when --check-solution finds the solution short of full marks or a "
        "mutant not caught; 2 on bad input; 4 --scheduler without Dask; 5 no scheduler at --scheduler, or it went "
        "away (the results graded so far are kept: the same command resumes).",
    )
    p.add_argument("assignment", type=file_path, metavar="ASSIGNMENT", help="the assignment file (.toml)")
    p.add_argument(
        "submissions",
        type=file_path,
        nargs="?",
        metavar="SUBMISSIONS",
        help="a folder of formula files, or of folders one a student (Gradescope, nbgrader); with --gradescope, "
        "one student's folder",
    )
    p.add_argument("--out", type=file_path, metavar="DIR", help="where results, feedback, gradebook and report go")
    p.add_argument(
        "--jobs",
        type=number_in(low=1, high=MAX_JOBS, low_open=False, integer=True),
        default=None,
        help="submissions graded at once, each in a process of its own (default 1)",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="grade on a running Dask cluster, one task a submission, as robodyn sweep does (e.g. "
        "tcp://127.0.0.1:8786; its workers need robodyn and the same paths); instead of --jobs; a class, or "
        "--check-solution's mutants",
    )
    p.add_argument(
        "--gradescope",
        type=file_path,
        metavar="RESULTS_JSON",
        help="grade one student's folder (SUBMISSIONS) and write Gradescope's results.json to this path",
    )
    p.add_argument(
        "--visibility",
        choices=("hidden", "after_due_date", "after_published", "visible"),
        default="visible",
        help="Gradescope visibility of the results (default visible)",
    )
    p.add_argument(
        "--check-solution",
        type=file_path,
        metavar="FILE",
        help="grade the teacher's solution (must get full marks) and its mutants (each must lose points)",
    )
    p.add_argument(
        "--mutants",
        type=number_in(low=1, high=1000, low_open=False, integer=True),
        default=DEFAULT_MUTANTS,
        help=f"the most mutants --check-solution grades (default {DEFAULT_MUTANTS})",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Grade, or check the solution; print one line a submission and where the outputs went."""
    from robodyn.grade.assignment import load_assignment

    assignment = load_assignment(args.assignment)
    if args.scheduler is not None:
        from robodyn.sweep.engine import check_cluster

        if args.jobs is not None:
            raise InputError("--jobs and --scheduler: give one (the cluster's workers grade at once)")
        check_cluster(scheduler=args.scheduler, workers=None)  # a malformed address before any grading
    if args.check_solution is not None:
        return _check_solution(assignment, args)
    if args.submissions is None:
        raise InputError("give SUBMISSIONS (a folder) to grade, or --check-solution FILE")
    if not args.submissions.is_dir():
        raise InputError(f"{args.submissions}: SUBMISSIONS must be a folder, of formula files or of students' folders")
    if args.gradescope is not None:
        return _gradescope(assignment, args)
    if args.out is None:
        raise InputError("give --out DIR: where the results, feedback, gradebook and class report go")
    return _grade_class(assignment, args)


def _print_result(result: Any, resumed: bool) -> None:
    tail = f"  {result.error}" if result.error else ""
    done = " (graded before: resumed)" if resumed else ""
    print(f"{result.student}: {result.score:g} / {result.max_score:g}{done}{tail}", flush=True)


def _grade_class(assignment: Any, args: argparse.Namespace) -> int:
    from robodyn.grade.outputs import find_submissions, grade_class, write_gradebook
    from robodyn.grade.report import write_report

    submissions = find_submissions(args.submissions, assignment)
    if not submissions:
        raise InputError(f"{args.submissions}: no submissions (expected .py files, or one folder a student)")
    out: Path = args.out
    results = grade_class(
        assignment, submissions, out, jobs=args.jobs or 1, scheduler=args.scheduler, on_result=_print_result
    )
    write_gradebook(out / "gradebook.csv", results, assignment)
    summary = write_report(out, results, assignment)
    d = summary.as_dict()
    print(
        f"graded {d['students']} submissions: {d['full_marks']} with full marks, mean {d['mean']:.3g} of "
        f"{assignment.max_score:g}; {out / 'gradebook.csv'}, {out / 'report.md'}"
    )
    return EXIT_OK


def _gradescope(assignment: Any, args: argparse.Namespace) -> int:
    from robodyn.grade.outputs import Submission, grade_class, submission_in_folder, write_gradescope

    folder: Path = args.submissions
    picked = submission_in_folder(folder, folder.parent, assignment)
    submission = Submission("submission", picked.path, picked.source, picked.problem)
    with tempfile.TemporaryDirectory(prefix="robodyn-gradescope-") as tmp:
        out = args.out if args.out is not None else Path(tmp)
        (result,) = grade_class(assignment, [submission], out, on_result=_print_result)
    write_gradescope(args.gradescope, result, visibility=args.visibility)
    print(f"wrote {args.gradescope}")
    return EXIT_OK


def _check_solution(assignment: Any, args: argparse.Namespace) -> int:
    from robodyn.grade.mutate import write_mutants
    from robodyn.grade.outputs import Submission, grade_class

    solution: Path = args.check_solution
    if not solution.is_file():
        raise InputError(f"{solution}: --check-solution must be a formula file")
    with tempfile.TemporaryDirectory(prefix="robodyn-mutants-") as tmp:
        planted = write_mutants(solution, Path(tmp) / "mutants", limit=args.mutants)
        subs = [Submission("solution", solution, solution.name)]
        subs += [Submission(p.parent.name, p, f"{p.parent.name}: {what}") for p, what in planted]
        results = grade_class(assignment, subs, Path(tmp) / "out", jobs=args.jobs or 1, scheduler=args.scheduler)
    top = assignment.max_score
    ok = results[0].score == top
    print(f"solution {solution}: {results[0].score:g} / {top:g}" + ("" if ok else f"  {results[0].feedback!r}"))
    missed = [r for r in results[1:] if r.score == top]
    for r in results[1:]:
        status = "NOT CAUGHT" if r.score == top else "caught"
        print(f"{status:>10}  {r.score:g} / {top:g}  {r.source}")
    print(
        f"{len(results) - 1 - len(missed)} of {len(results) - 1} mutants lose points"
        + ("" if ok else "; the solution does not get full marks")
    )
    sys.stdout.flush()
    return EXIT_OK if ok and not missed else EXIT_MISMATCH


__all__ = ["add_parser", "run"]
