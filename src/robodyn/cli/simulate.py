"""``robodyn simulate``: integrate a model, print the energy books, save the trajectory.

The URDF's joint stops and effort limits are enforced unless ``--no-limits`` /
``--no-effort-limits``; ``--restitution`` sets the stops' e in [0, 1]; ``--constraints FILE.json``
adds loops, couplings and springs (the keys of a scene's ``[constraints]`` table, plus
``springs``: the ``[springs]`` table). ``--controller NAME_OR_FILE.py [--gains JSON_OR_FILE]``
closes the loop with a controller of :mod:`robodyn.control` (``lqr``, ``swing_up``, or a user's
file defining ``make(robot, **gains)``); ``--controller list`` names them.

Exit codes: 0 the run finished; 2 bad input (a model with no moving joint, wrong vector lengths, a cos/sin pair or
quaternion off the unit sphere, a singular mass matrix, non-positive dt or duration, an
unknown integrator or backend, an unwritable output path, an output that is an input or
another output, an unknown frame or joint in a constraint, a coupling cycle, a negative
stiffness, a restitution outside [0, 1], a loop whose frames cannot meet, an unknown
controller or gain, gains of the wrong shape, a controller file that raises, an equilibrium
that is not one, --controller with --torque); 3 the run diverged
or its constraint solver failed to converge; 6 ``--controller swing_up`` did not balance by the
end (the summary's ``outcome:`` line and one line on stderr say why, where known); 130 interrupted
by Ctrl-C. A run that stops early writes what it computed as ``x.partial.npz`` (and
``x.partial.csv``), beside and never over the ``x.npz`` of an earlier complete run.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.cli import _control
from robodyn.cli._common import (
    add_passive_argument,
    add_physics_argument,
    file_path,
    float_list,
    load_robot,
    number_in,
    positive_float,
    print_json,
    refuse_uncoupled_sizes,
    warn_ignored_mimic,
)
from robodyn.cli._interrupts import held
from robodyn.cli._output import partial_path, refuse_clobbering, writable_path
from robodyn.cli._progress import ProgressLines
from robodyn.cli._summary import _report, note_clamped_q0
from robodyn.cli.view import add_ground_argument
from robodyn.errors import EXIT_DIVERGED, EXIT_NOT_BALANCED, EXIT_OK, InputError, UnknownNameError
from robodyn.fileio import read_user_file
from robodyn.kinds import catalog
from robodyn.registry import BACKENDS

EXIT_INTERRUPTED = 130

TOLERANCE = number_in(high=1.0, noun="relative tolerance")
"""Argparse type of --rtol: above 1 every step passes, so (0, 1]."""

RESTITUTION = number_in(low=0.0, high=1.0, low_open=False, noun="restitution")
"""Argparse type of --restitution: e in [0, 1] (0 inelastic, 1 elastic)."""

# A constraints file is a few lines of JSON; a larger one is not read (and /dev/zero never ends).
MAX_CONSTRAINTS_BYTES = 2**20


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "simulate",
        help="integrate a model's motion and keep the energy and work books",
        description="Integrate M a + C v + G = tau + tau_damping from (q0, v0), print the steps, wall time, final "
        "state, energy drift and ledger residual E - E0 - W_input - W_damping, and save the trajectory. "
        "Exit 0: done; 2: bad input; 3: diverged; 130: interrupted by Ctrl-C. A run that stops early writes "
        "the trajectory so far as X.partial.npz (X.partial.csv), never over the X.npz of an earlier run.",
    )
    _add_model_arguments(p)
    _add_step_arguments(p)
    _add_input_arguments(p)
    _add_solver_arguments(p)
    _add_constraint_arguments(p)
    _add_output_arguments(p)
    p.set_defaults(handler=run)


def _add_model_arguments(p: argparse.ArgumentParser) -> None:
    """``simulate``'s arguments: the model and its initial state."""
    p.add_argument(
        "model",
        metavar="URDF_OR_NAME",
        nargs="?",
        help=f"built-in model ({catalog.listed()}), an example-robot-data robot (panda, ...) or a path to a .urdf file",
    )
    p.add_argument("--srdf", type=file_path, default=None, help="SRDF file (default: same stem as the URDF)")
    p.add_argument("--free-flyer", action="store_true", help="mount the root on a free-flyer joint")
    add_physics_argument(p)
    p.add_argument(
        "--mimic",
        action="store_true",
        help="keep the URDF's <mimic> couplings (forward dynamics then by CRBA); without it they are ignored",
    )
    add_passive_argument(p)
    p.add_argument(
        "--q0",
        type=float_list,
        help="initial configuration a,b,... [rad | m] (default: neutral); cos/sin pairs and quaternions must "
        "have norm 1 within 1e-9, or give one angle per continuous joint",
    )
    p.add_argument("--v0", type=float_list, help="initial velocity c,d,... [rad/s | m/s] (default: zero)")


def _add_step_arguments(p: argparse.ArgumentParser) -> None:
    """``simulate``'s arguments: how long, in which steps, by which method."""
    p.add_argument("--duration", type=positive_float, default=2.0, help="simulated time [s] (default: %(default)g s)")
    p.add_argument(
        "--dt",
        type=positive_float,
        default=1e-3,
        help="time step, or output interval of adaptive methods [s] (default: %(default)g s)",
    )
    p.add_argument("--integrator", default="rk4", help="integration method (default rk4); 'list' names them and exits")


def _add_input_arguments(p: argparse.ArgumentParser) -> None:
    """``simulate``'s arguments: what drives it: a constant torque or a controller."""
    p.add_argument(
        "--torque",
        type=float_list,
        help="constant input torque x,y,... [N m | N]: one per velocity (0 on passive joints) or one per "
        "actuated joint",
    )
    p.add_argument(
        "--controller",
        metavar="NAME_OR_FILE.py",
        default=None,
        help="close the loop: a built-in controller (lqr, swing_up; 'list' names them and exits) or a Python file "
        "defining make(robot, **gains) that returns tau(t, q, v); not with --torque",
    )
    p.add_argument(
        "--gains",
        metavar="JSON_OR_FILE",
        default=None,
        help='the controller\'s gains as a JSON object, e.g. \'{"Q": [10, 10, 1, 1], "R": 0.1}\', or a file '
        "holding one (default: the controller's own)",
    )


def _add_solver_arguments(p: argparse.ArgumentParser) -> None:
    """``simulate``'s arguments: the forward dynamics and the adaptive methods' tolerances."""
    p.add_argument(
        "--backend",
        choices=BACKENDS.names(),
        default=None,
        help="forward dynamics (default: the whole run in numba's compiled loop where it applies, else aba; "
        "crba on a model loaded with --mimic, which aba refuses; while the compiled kernels are not built, "
        "a run shorter than their compile takes aba's Python loop); the summary says which ran",
    )
    p.add_argument(
        "--rtol",
        type=TOLERANCE,
        default=1e-9,
        help="relative tolerance of the adaptive methods, dimensionless (default: %(default)g)",
    )
    p.add_argument(
        "--atol",
        type=positive_float,
        default=1e-12,
        help="absolute tolerance of the adaptive methods, in the units of each state entry [rad | m | rad/s | m/s | J] "
        "(default: %(default)g)",
    )


def _add_constraint_arguments(p: argparse.ArgumentParser) -> None:
    """``simulate``'s arguments: damping, stops, effort limits, constraints and the divergence bound."""
    p.add_argument("--no-damping", action="store_true", help="ignore the URDF's joint damping and friction")
    p.add_argument(
        "--no-limits", action="store_true", help="let the joints pass through the URDF's position limits (no stops)"
    )
    p.add_argument(
        "--no-effort-limits",
        action="store_true",
        help="apply the commanded torque as given (default: clamped at each joint's URDF effort)",
    )
    p.add_argument(
        "--restitution",
        type=RESTITUTION,
        default=None,
        metavar="E",
        help="coefficient of restitution at the joint stops, 0 (inelastic) to 1 (elastic) (default: 0, or the "
        "--constraints file's)",
    )
    p.add_argument(
        "--constraints",
        type=file_path,
        default=None,
        metavar="FILE.json",
        help="loops, couplings and springs as a JSON object: the keys of a scene's [constraints] table (limits, "
        'restitution, effort_limits, loops, couplings) and "springs" (the [springs] table); the flags above '
        "override it",
    )
    p.add_argument(
        "--max-energy-growth",
        type=positive_float,
        default=1.0,
        help="stop as diverged when |E - E0 - W| exceeds this times the energy scale (default 1)",
    )


def _add_output_arguments(p: argparse.ArgumentParser) -> None:
    """``simulate``'s arguments: what is written and shown."""
    p.add_argument(
        "--out",
        type=file_path,
        metavar="FILE.npz",
        help="write the trajectory to this .npz file (its folder must exist)",
    )
    p.add_argument(
        "--csv", type=file_path, metavar="FILE.csv", help="also write the trajectory as CSV (its folder must exist)"
    )
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--view", action="store_true", help="afterwards, play the motion in the browser (meshcat)")
    add_ground_argument(p)


def run(args: argparse.Namespace) -> int:
    """Simulate, print the summary, write the files; return 0, or 3 if the run diverged."""
    from robodyn import integrators

    if args.integrator == "list":
        _print_integrators(integrators, as_json=args.json)
        return EXIT_OK
    if args.controller == "list":
        _control.print_controllers(as_json=args.json)
        return EXIT_OK
    method, gains, out, csv, constraints = _checked_before_loading(args, integrators)
    outputs = [("--out", out), ("--csv", csv)]
    robot = load_robot(args, mimic=args.mimic)
    refuse_clobbering(outputs, [("the model's URDF", robot.urdf_path), ("the model's SRDF", robot.srdf_path)])
    refuse_uncoupled_sizes(robot, q0=args.q0, v0=args.v0, mimic=args.mimic)
    q0 = args.q0 if args.q0 is not None else robot.neutral()
    v0 = args.v0 if args.v0 is not None else np.zeros(robot.nv)
    from robodyn.errors import SimulationInterrupted

    built: list[Any] = []  # the controller, for its modes after the run (not filled by a forked child)
    trajectory, failure = _simulated(args, robot, q0, v0, method, gains, constraints, built)
    written: list[Path] = []
    with held(abandoned=lambda: _abandoned(written)) as ctrl_c:  # the run is over: a Ctrl-C must not lose it
        if args.controller is not None:  # the file says what closed the loop (and, when switched, in which mode)
            record: dict[str, Any] = {"name": args.controller, "gains": gains}
            if built and hasattr(built[0], "record") and len(trajectory.t):  # switched: modes, regulated energy
                record.update(built[0].record(trajectory.q, trajectory.v))
            trajectory = dataclasses.replace(trajectory, meta={**trajectory.meta, "controller": record})
        # Said after the run, not before it: a refused input stays one line on stderr.
        warn_ignored_mimic(robot, mimic=args.mimic, command="simulate")
        note_clamped_q0(trajectory, command="simulate")
        kept: list[Path] = []
        if failure is not None:  # what was computed goes beside, never over, an earlier complete run
            kept = [p for p in (out, csv) if p is not None and p.exists()]
            out, csv = (None if p is None else partial_path(p) for p in (out, csv))
        verdict = _control.outcome(built[0] if built else None, trajectory) if failure is None else None
        judged = None if verdict is None else verdict.as_record()
        if judged is not None:  # the file carries the verdict: `robodyn portrait` names the run by it
            trajectory = dataclasses.replace(trajectory, meta={**trajectory.meta, "outcome": judged})
        _write(trajectory, out, csv, written)
        _report(trajectory, out, csv, as_json=args.json, effort=robot.model.effortLimit, outcome=judged)
        if verdict is not None and not args.json:
            print(verdict.line())
    if failure is not None:
        print(f"robodyn simulate: {failure}{_partial_note(out, csv, kept)}", file=sys.stderr)
        return EXIT_INTERRUPTED if isinstance(failure, SimulationInterrupted) else EXIT_DIVERGED
    if ctrl_c:  # the whole run is written: say where, and stop there (no --view)
        where = " and ".join(map(str, written))
        said = f"its trajectory is written to {where}" if written else "no --out or --csv, nothing to write"
        print(f"robodyn simulate: interrupted after the run had finished; {said}", file=sys.stderr)
        return EXIT_INTERRUPTED
    if verdict is not None and not verdict.balanced:
        print(f"robodyn simulate: the controller did not reach its goal: {verdict.reason}", file=sys.stderr)
        return EXIT_NOT_BALANCED
    if args.view:
        from robodyn.cli.view import serve_and_play

        return serve_and_play(robot, trajectory, speed=1.0, open_browser=False, zmq_url=None, ground=args.ground)
    return EXIT_OK


def _checked_before_loading(
    args: argparse.Namespace, integrators: Any
) -> tuple[Any, Any, Path | None, Path | None, Any]:
    """(method, gains, out, csv, constraints): every check that needs no model, made before it loads.

    Nothing is created: a run that fails leaves no empty file.
    """
    if args.model is None:
        raise InputError("missing URDF_OR_NAME: a built-in model name or a path to a .urdf file")
    method = integrators.get(args.integrator)  # an unknown name fails before anything is loaded
    if args.controller is not None and args.torque is not None:
        raise InputError("--controller and --torque both give the input: give one (the controller sets the torque)")
    if args.gains is not None and args.controller is None:
        raise InputError("--gains needs --controller NAME_OR_FILE.py (the gains are the controller's)")
    gains = _control.parse_gains(args.gains)
    out = writable_path(args.out, create_parents=False, suffix=".npz") if args.out is not None else None
    csv = writable_path(args.csv, create_parents=False, suffix=".csv") if args.csv is not None else None
    outputs = [("--out", out), ("--csv", csv)]
    given = Path(args.model)
    inputs = [("the model", given if given.is_file() else None), ("--srdf", args.srdf)]
    controller_file = Path(args.controller) if args.controller and args.controller.endswith(".py") else None
    gains_file = Path(args.gains) if args.gains and Path(args.gains).is_file() else None
    refuse_clobbering(
        outputs,
        [*inputs, ("--constraints", args.constraints), ("--controller", controller_file), ("--gains", gains_file)],
    )
    constraints = constraints_from_args(args)
    if args.ground and not args.view:
        raise InputError("--ground draws a plane in the replay; add --view")
    if args.view:
        from robodyn.cli.view import check_frame_count

        hint = "simulate less, or save it with --out and play it with robodyn view --speed"
        check_frame_count(args.duration, speed=1.0, fps=None, what="--view of --duration", hint=hint)
    return method, gains, out, csv, constraints


def _simulated(
    args: argparse.Namespace, robot: Any, q0: Any, v0: Any, method: Any, gains: Any, constraints: Any, built: list[Any]
) -> tuple[Any, BaseException | None]:
    """(trajectory, the DivergenceError or Ctrl-C that ended it early, or None); ``built`` gets the controller."""
    from robodyn.control.user_controller import looks_like_file
    from robodyn.errors import DivergenceError, SimulationInterrupted
    from robodyn.sim.simulation import simulate

    def job() -> Any:
        torque = args.torque if args.controller is None else _control.build(robot, args.controller, gains)
        built.append(torque)
        lines = ProgressLines(sys.stderr, args.duration)
        try:
            return simulate(
                robot,
                q0,
                v0,
                duration=args.duration,
                dt=args.dt,
                integrator=method,
                torque=torque,
                backend=args.backend,
                losses=not args.no_damping,
                rtol=args.rtol,
                atol=args.atol,
                max_energy_growth=args.max_energy_growth,
                constraints=constraints,
                progress=lines,
            )
        finally:
            lines.close()

    trajectory: Any
    try:
        if args.controller is not None and looks_like_file(args.controller):
            from robodyn.control.supervised import run_supervised

            # A controller file runs in a forked child: os._exit or a hang in it cannot fake a finished run.
            trajectory = run_supervised(job, source=args.controller)
        else:
            trajectory = job()
        failure: BaseException | None = None
    except DivergenceError as exc:
        trajectory, failure = exc.trajectory, exc
    except SimulationInterrupted as exc:  # Ctrl-C: no lost work, the trajectory so far is written
        trajectory, failure = exc.trajectory, exc
    except UnknownNameError as exc:  # a frame or joint of a constraint: name the file it came from
        if args.constraints is None:
            raise
        raise InputError(f"--constraints {args.constraints}: {exc}") from None
    return trajectory, failure


def constraints_from_args(args: argparse.Namespace) -> Any:
    """The run's :class:`~robodyn.sim.constraints.Constraints`: the --constraints file, then the flags over it.

    Raises:
        InputError: one line naming the file (or the flag) and what is wrong.
    """
    from robodyn.sim.constraints import Constraints

    spec = Constraints() if args.constraints is None else read_constraints(args.constraints)
    changes: dict[str, Any] = {}
    if args.no_limits:
        changes["limits"] = False
    if args.no_effort_limits:
        changes["effort_limits"] = False
    if args.restitution is not None:
        changes["restitution"] = float(args.restitution)
    return dataclasses.replace(spec, **changes) if changes else spec


def read_constraints(path: Path) -> Any:
    """The constraints of a JSON file: ``{"limits": .., "loops": [..], "couplings": [..], "springs": {..}}``.

    The keys are a scene's ``[constraints]`` table's, with ``springs`` its ``[springs]`` table;
    ``{"constraints": {..}, "springs": {..}}`` (the two tables as they are) is read too.

    Raises:
        InputError: the file cannot be read, is larger than :data:`MAX_CONSTRAINTS_BYTES`, is not
            UTF-8 JSON, or holds a bad entry; one line starting with the file's name.
    """
    from robodyn.sim.constraints import Constraints

    try:
        raw = read_user_file(path, what="constraints", expected="a short JSON object", limit=MAX_CONSTRAINTS_BYTES)
    except InputError as exc:
        raise InputError(f"--constraints {exc}") from None
    try:
        data = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise InputError(
            f"--constraints {path}: not UTF-8 text: byte 0x{raw[exc.start]:02x} at offset {exc.start}"
        ) from None
    except json.JSONDecodeError as exc:
        raise InputError(f"--constraints {path}: not valid JSON ({exc.msg} at line {exc.lineno})") from None
    except (RecursionError, ValueError) as exc:
        raise InputError(
            f"--constraints {path}: cannot be read ({type(exc).__name__}); expected a flat JSON object"
        ) from None
    if not isinstance(data, dict):
        raise InputError(f"--constraints {path}: expected a JSON object of the [constraints] keys, got {_kind(data)}")
    if "constraints" in data:  # the two scene tables, as they are
        unknown = sorted(set(data) - {"constraints", "springs"})
        if unknown:
            raise InputError(f"--constraints {path}: unknown key {unknown[0]!r} beside 'constraints'; expected springs")
        if not isinstance(data["constraints"], dict):
            raise InputError(f"--constraints {path}: 'constraints' must be an object, got {_kind(data['constraints'])}")
        return Constraints.from_mapping(data["constraints"], springs=data.get("springs"), where=f"--constraints {path}")
    return Constraints.from_mapping(data, where=f"--constraints {path}")


def _kind(value: Any) -> str:
    """``a list``, ``a number``: what a JSON value is, for a message."""
    names = {list: "a list", str: "a string", bool: "true or false", type(None): "null", dict: "an object"}
    return names.get(type(value), "a number")


def _partial_note(out: Path | None, csv: Path | None, kept: list[Path]) -> str:
    """``; partial trajectory written to x.partial.npz (x.npz left as it was)``, or nothing without files."""
    written = [p for p in (out, csv) if p is not None]
    if not written:
        return ""
    left = f" ({' and '.join(map(str, kept))} left as {'they were' if len(kept) > 1 else 'it was'})" if kept else ""
    return f"; partial trajectory written to {' and '.join(map(str, written))}{left}"


def _write(trajectory: Any, out: Path | None, csv: Path | None, written: list[Path]) -> None:
    """Write the .npz, then the CSV; ``written`` gets each path once its file is whole."""
    if out is not None:
        written.append(trajectory.save(out))
    if csv is not None:
        written.append(trajectory.save_csv(csv))


def _abandoned(written: list[Path]) -> str:
    """The line of a second Ctrl-C during the writes: what was written before it."""
    done = f"only {' and '.join(map(str, written))} written" if written else "nothing written"
    return f"interrupted twice while the finished run was being written; the writes were abandoned ({done})"


def _print_integrators(integrators: Any, *, as_json: bool) -> None:
    rows = [integrators.get(name).summary() for name in integrators.names()]
    if as_json:
        print_json(rows)
        return
    print(f"{'name':<20} {'order':>5}  {'symplectic':<10} {'adaptive':<8} {'implicit':<8} description")
    for r in rows:
        flags = [("yes" if r[k] else "no") for k in ("symplectic", "adaptive", "implicit")]
        print(f"{r['name']:<20} {r['order']:>5}  {flags[0]:<10} {flags[1]:<8} {flags[2]:<8} {r['description']}")
