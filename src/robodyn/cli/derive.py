"""``robodyn derive``: the Lagrangian of a tree robot derived symbolically, checked against Pinocchio, then printed.

The derivation (:mod:`robodyn.lagrange`) reads robodyn's per-link table; sympy writes it out.
Before anything is printed or written, the printed expressions are evaluated at seeded random
states beside Pinocchio's M, C and G: exit 1 naming the entry if they differ. ``--out`` is
written atomically (a Ctrl-C leaves no half-written file; exit 130).
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import time
from typing import Any

from robodyn.cli._common import (
    add_physics_argument,
    file_path,
    model_argument,
    physics_checked,
    positive_float,
    positive_int,
    seed_number,
    warn_unchecked,
)
from robodyn.errors import EXIT_MISMATCH, EXIT_OK
from robodyn.kinds import catalog

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
        help=f"built-in model ({catalog.listed()}), an example-robot-data robot (ur5, ...) or a .urdf path",
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
    add_physics_argument(p)
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
    """Derive, check against Pinocchio, print or write; exit 1 on a disagreement; exit 2 past ``--time-limit``."""
    if args.steps and args.format != "text":
        from robodyn.errors import InputError

        raise InputError(f"--steps shows the derivation as text; it does not go with --format {args.format}")
    deadline = _Deadline(args.time_limit)
    try:
        try:
            deadline.arm()
            return _run(args, deadline)
        finally:
            deadline.disarm()
    except _OutOfTime:  # the alarm, wherever it came (the timer is one-shot: it cannot come twice)
        deadline.disarm()
        raise deadline.error() from None


def _run(args: argparse.Namespace, deadline: _Deadline) -> int:
    from robodyn import __version__
    from robodyn.cli._output import refuse_clobbering, writable_path

    deadline.stage("importing sympy")
    from robodyn.lagrange import render
    from robodyn.lagrange.selfcheck import self_check
    from robodyn.lagrange.symbolic import symbolic, sympy

    started = deadline.start
    sympy()  # a missing sympy is said before any work (exit 4)
    if args.out is not None:
        refuse_clobbering([("--out", args.out)], [("the coordinates file", args.coordinates)])
        writable_path(args.out)
    deadline.stage("loading the model")
    robot, table, coordinates, locked = _model(args)
    if args.out is not None:
        refuse_clobbering([("--out", args.out)], [("the model's URDF", robot.urdf_path), ("its SRDF", robot.srdf_path)])
    from robodyn.lagrange.derivation import derive

    deadline.stage("the derivation")
    derivation = derive(table, coordinates, time_limit=max(deadline.left(), 1e-9))
    deadline.stage("writing it out with sympy")
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
    deadline.stage("the self-check")
    check = self_check(
        expressions, robot, samples=args.samples, seed=args.seed, formula=formula, text=args.format == "text"
    )
    deadline.finish()  # what is left (printing, writing --out) is not cut off
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
    robot = load(args.model, srdf=args.srdf, check_physics=physics_checked(args))
    if not physics_checked(args):
        warn_unchecked(robot, command="derive")
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


class _OutOfTime(BaseException):
    """Raised by SIGALRM at the time limit; a BaseException, so that sympy's ``except Exception`` lets it by."""


class _Deadline:
    """``--time-limit`` over the whole command: its stages named, the running one cut off at the limit.

    Where SIGALRM exists (POSIX, the main thread) an alarm interrupts whatever runs at the limit (sympy's
    simplification and code generation are pure Python, so they stop within a bytecode); each new stage
    also checks the clock, which is all a platform without the alarm gets. Either way the command ends
    with one line naming the stage that was cut off (exit 2).
    """

    def __init__(self, limit: float) -> None:
        self.limit, self.start, self.running = limit, time.monotonic(), "the start"
        self.previous: Any = None
        self.armed = False

    def arm(self) -> None:
        """Start the alarm (where SIGALRM exists, in the main thread)."""
        if hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGALRM, self._alarm)
            self.armed = True
            signal.setitimer(signal.ITIMER_REAL, max(self.left(), 1e-6))

    def disarm(self) -> None:
        """Stop the alarm and give SIGALRM back its handler (again: nothing)."""
        if self.armed:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, self.previous)
            self.armed = False

    def _alarm(self, signum: int, frame: Any) -> None:
        raise _OutOfTime

    def left(self) -> float:
        """Seconds left [s]."""
        return self.limit - (time.monotonic() - self.start)

    def stage(self, name: str) -> None:
        """``name`` starts now; past the limit already, the command stops here (exit 2)."""
        if self.left() < 0:
            raise self.error()
        self.running = name

    def finish(self) -> None:
        """The limited work is done: stop the alarm (past the limit already, stop here)."""
        self.stage("the end")
        self.disarm()

    def error(self) -> Exception:
        """The one line: the limit, the stage cut off, when."""
        from robodyn.errors import InputError

        return InputError(
            f"the derivation took longer than its limit of {self.limit:g} s (at {self.running}: cut off after "
            f"{time.monotonic() - self.start:.1f} s); lock joints with --coordinates or raise --time-limit"
        )


def _vector(x: Any) -> str:
    return "[" + ", ".join(f"{v:.4g}" for v in x) + "]"
