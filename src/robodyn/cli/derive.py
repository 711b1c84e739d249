"""``robodyn derive``: the Lagrangian of a tree robot derived symbolically, checked against Pinocchio, then printed.

The derivation (:mod:`robodyn.lagrange`) reads robodyn's per-link table; sympy writes it out.
Before anything is printed or written, the printed expressions are evaluated at seeded random
states beside Pinocchio's M, C and G: exit 1 naming the entry if they differ. ``--out`` is
written atomically (a Ctrl-C leaves no half-written file; exit 130).
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from robodyn.cli._common import file_path, model_argument, positive_float, positive_int, seed_number
from robodyn.errors import EXIT_MISMATCH, EXIT_OK

FORMATS = ("text", "latex", "python")
MAX_SAMPLES = 1000  # the self-check's states: 20 by default, ~0.1 s each on a 6-joint arm
MAX_TIME_LIMIT = 3600.0


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    from robodyn.lagrange.derivation import DEFAULT_TIME_LIMIT, MAX_JOINTS

    p = sub.add_parser(
        "derive",
        help="derive M, C, G symbolically from the URDF (sympy), checked against Pinocchio",
        description=f"Derive the Lagrangian of a tree robot of revolute, continuous and prismatic joints (at most "
        f"{MAX_JOINTS} moving, fixed base) symbolically: T, V, M(q), the Christoffel C(q, v) and G(q), with "
        "parameters named per link (m1, lc1, l1, I1, ...). The printed expressions are checked against Pinocchio at "
        "seeded random states first: exit 1 naming the entry if they differ. Needs sympy (the derive extra).",
    )
    p.add_argument(
        "model",
        type=model_argument,
        metavar="URDF_OR_NAME",
        help="built-in model (pendubot, cart_pole, geared_arm), an example-robot-data robot (ur5, ...) or a .urdf path",
    )
    p.add_argument("--srdf", type=file_path, default=None, help="SRDF file (default: same stem as the URDF)")
    p.add_argument(
        "--coordinates",
        type=file_path,
        metavar="FILE.py",
        help="a formula file whose JOINTS (the joints q1, q2, ... stand for; the others are locked at the neutral "
        "pose) and COORDINATES ({joint: (sign, offset)}: q = sign * q_urdf + offset; or a matrix A over JOINTS with "
        "OFFSETS b: q = A q_urdf + b) set the coordinates; the file is parsed, not run",
    )
    p.add_argument("--format", choices=FORMATS, default="text", help="text (default), latex, or python: a formula file")
    p.add_argument(
        "--out", type=file_path, metavar="FILE", help="write the output to FILE (atomically) instead of stdout"
    )
    p.add_argument(
        "--steps",
        action="store_true",
        help="show the derivation step by step: centres of mass, velocities, T, V, Christoffel symbols (text)",
    )
    p.add_argument("--samples", type=_samples, default=20, help="random states of the self-check (default 20)")
    p.add_argument("--seed", type=seed_number, default=0, help="seed of the self-check's states (default 0)")
    p.add_argument(
        "--time-limit",
        type=_time_limit,
        default=DEFAULT_TIME_LIMIT,
        metavar="SECONDS",
        help=f"stop when the derivation, its writing out and its self-check take longer, exit 2 (default "
        f"{DEFAULT_TIME_LIMIT:g} s)",
    )
    p.set_defaults(handler=run)


def _samples(text: str) -> int:
    value = positive_int(text)
    if value > MAX_SAMPLES:
        raise argparse.ArgumentTypeError(f"expected a whole number from 1 to {MAX_SAMPLES}, got {text!r}")
    return value


def _time_limit(text: str) -> float:
    value = positive_float(text)
    if value > MAX_TIME_LIMIT:
        raise argparse.ArgumentTypeError(f"expected at most {MAX_TIME_LIMIT:g} seconds, got {text!r}")
    return value


def run(args: argparse.Namespace) -> int:
    """Derive, check against Pinocchio, print or write; exit 1 on a disagreement."""
    from robodyn import __version__
    from robodyn.cli._output import refuse_clobbering, writable_path
    from robodyn.lagrange import render
    from robodyn.lagrange.selfcheck import self_check
    from robodyn.lagrange.symbolic import symbolic, sympy

    started = time.monotonic()
    sympy()  # a missing sympy is said before any work (exit 4)
    if args.steps and args.format != "text":
        from robodyn.errors import InputError

        raise InputError(f"--steps shows the derivation as text; it does not go with --format {args.format}")
    if args.out is not None:
        refuse_clobbering([("--out", args.out)], [("the coordinates file", args.coordinates)])
        writable_path(args.out)
    robot, table, coordinates, locked = _model(args)
    if args.out is not None:
        refuse_clobbering([("--out", args.out)], [("the model's URDF", robot.urdf_path), ("its SRDF", robot.srdf_path)])
    from robodyn.lagrange.derivation import derive

    begun = time.monotonic()  # the time limit covers the derivation, its writing out and its self-check
    derivation = derive(table, coordinates, time_limit=args.time_limit)
    expressions = symbolic(derivation)
    source, formula = None, None
    if args.format == "python":  # the file is checked itself, and printed once
        source = render.python(
            expressions,
            model=args.model,
            out=str(args.out) if args.out is not None else "FILE.py",
            coordinates_file=str(args.coordinates) if args.coordinates else None,
            version=__version__,
            locked=locked,
        )
        formula = {"table": table}
        exec(compile(source, "<robodyn derive --format python>", "exec"), formula)  # our own output, not a user's
    _within(args.time_limit, begun, "writing it out with sympy")
    check = self_check(
        expressions, robot, samples=args.samples, seed=args.seed, formula=formula, text=args.format == "text"
    )
    _within(args.time_limit, begun, "the self-check")
    elapsed = time.monotonic() - started
    if not check.passed:
        for d in check.failures():
            print(
                f"robodyn derive: error: the derivation disagrees with Pinocchio: {d.entry} derived {d.derived:.10g}, "
                f"Pinocchio {d.pinocchio:.10g} (relative {d.relative:.2e} > {check.rtol:g}) at "
                f"q = {_vector(d.q)}, v = {_vector(d.v)}",
                file=sys.stderr,
            )
        return EXIT_MISMATCH
    if source is not None:
        text = source
    elif args.format == "latex":
        text = render.latex(expressions) + "\n"
    else:
        body = render.steps(expressions) if args.steps else render.text(expressions)
        verdict = (
            f"self-check: M, C, C v and G agree with Pinocchio at {check.samples} seeded states "
            f"(seed {check.seed}; largest relative difference {check.max_relative:.1e}, tolerance {check.rtol:g})"
        )
        text = f"{body}\n\n{verdict}\nderived and checked in {elapsed:.2f} s\n"
    if args.out is None:
        sys.stdout.write(text)
        return EXIT_OK
    from robodyn.fileio import write_text_atomically

    write_text_atomically(args.out, text)
    print(
        f"wrote {args.out}: {derivation.robot}, {derivation.n} joints, {len(derivation.params)} parameters "
        f"(checked against Pinocchio at {check.samples} states; derived and checked in {elapsed:.2f} s)"
    )
    return EXIT_OK


def _model(args: argparse.Namespace) -> tuple[Any, Any, Any, dict[str, float]]:
    """(robot the derivation describes, its link table, the coordinates): joints outside JOINTS locked at neutral."""
    from robodyn.errors import InputError
    from robodyn.lagrange.coordinates import read_coordinates
    from robodyn.lagrange.derivation import MAX_JOINTS
    from robodyn.model.links import link_table
    from robodyn.model.load import load

    joints, cmap, locked = read_coordinates(args.coordinates) if args.coordinates is not None else (None, None, {})
    robot = load(args.model, srdf=args.srdf)
    if joints is None and len(robot.joints) > MAX_JOINTS:
        raise InputError(
            f"{robot.name} has {len(robot.joints)} moving joints; robodyn derive takes at most {MAX_JOINTS}: name at "
            f"most {MAX_JOINTS} in the JOINTS of a --coordinates FILE (the others are locked at the neutral pose)"
        )
    if joints is not None:
        unknown = [j for j in joints if j not in robot.joint_names]
        if unknown:
            from robodyn.errors import UnknownNameError

            raise UnknownNameError(f"joint of {robot.name} (in {args.coordinates})", unknown[0], robot.joint_names)
        if len(joints) > MAX_JOINTS:
            raise InputError(
                f"{args.coordinates}: JOINTS names {len(joints)} joints; robodyn derive takes at most {MAX_JOINTS}"
            )
        if set(joints) != set(robot.joint_names):
            from robodyn.model.reduce import reduce

            robot = reduce(robot, keep=joints, lock=locked).reduced
    table = link_table(robot)
    if cmap is not None:
        kinds = {link.joint: link.joint_type for link in table.links}
        cmap.check_units([kinds[j] == "prismatic" for j in cmap.joints], str(args.coordinates))
    return robot, table, cmap, locked


def _within(limit: float, started: float, stage: str) -> None:
    """Stop (exit 2) once ``limit`` seconds have passed since ``started``, naming the stage that ran past it."""
    from robodyn.errors import InputError

    if time.monotonic() - started > limit:
        raise InputError(
            f"the derivation took longer than its limit of {limit:g} s (at {stage}); "
            "lock joints with --coordinates or raise --time-limit"
        )


def _vector(x: Any) -> str:
    return "[" + ", ".join(f"{v:.4g}" for v in x) + "]"
