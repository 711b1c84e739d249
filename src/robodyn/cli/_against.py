"""``robodyn check MODEL --against ENGINE[,ENGINE...]``: another engine's reading of the same URDF.

Exit 0: every engine agrees with robodyn within ``--rtol``; 1: one differs (the causes are printed);
2: an engine refuses the file (its own message, on one line) or bad input; 4: an engine is not installed.
"""

from __future__ import annotations

import argparse
from typing import Any

from robodyn.cli._common import load_robot, print_json
from robodyn.errors import EXIT_BAD_INPUT, EXIT_MISMATCH, EXIT_OK, InputError

ENGINE_NAMES = ("mujoco", "pybullet", "drake")  # robodyn.other_engines.ENGINES, without importing the package here
_IGNORED = ("formula", "params", "explain", "mimic")


def engine_list(text: str) -> tuple[str, ...]:
    """Argparse type: comma-separated engine names, each one of mujoco, pybullet, drake."""
    names = tuple(part.strip() for part in text.split(",") if part.strip())
    wrong = [n for n in names if n not in ENGINE_NAMES]
    if not names or wrong:
        got = repr(wrong[0]) if wrong else repr(text)
        raise argparse.ArgumentTypeError(
            f"expected one or more of {', '.join(ENGINE_NAMES)} (comma-separated), got {got}"
        )
    return tuple(dict.fromkeys(names))


def add_against_argument(parser: Any) -> None:
    """Register ``--against``."""
    parser.add_argument(
        "--against",
        type=engine_list,
        metavar="ENGINE",
        help="compare robodyn's reading of the URDF with another engine's (mujoco, pybullet, drake; several "
        "comma-separated), with its defaults and with the option that makes it trust the file, and name the "
        "cause of each difference. Exit 0: agree; 1: differ; 2: an engine refuses the file; 4: not installed",
    )


def run_against(args: argparse.Namespace) -> int:
    """Compare each model with each engine; print the causes (or JSON); pick the exit code."""
    from robodyn.other_engines import against, format_report

    given = [f"--{name}" for name in _IGNORED if getattr(args, name, None) not in (None, False)]
    if given:
        raise InputError(f"--against compares engines' readings of the file; {given[0]} belongs to a formula check")
    reports = []
    for name in args.models:
        robot = load_robot(args, name)
        reports.append(against(robot, args.against, samples=args.samples, seed=args.seed, rtol=args.rtol))
        if not args.json:
            print(format_report(reports[-1]))
    if args.json:
        print_json(reports[0].as_dict() if len(reports) == 1 else [r.as_dict() for r in reports])
    statuses = {r.status for r in reports}
    return EXIT_BAD_INPUT if "refused" in statuses else EXIT_MISMATCH if "differ" in statuses else EXIT_OK
