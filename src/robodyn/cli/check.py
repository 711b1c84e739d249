"""``robodyn check``: compare Pinocchio with a hand-derived formula and with its own identities."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robodyn.checker.rows import EQUATIONS_AGREE, FAIL, PASS, CheckReport, CheckRow
from robodyn.checker.sandbox import DEFAULT_TIMEOUT, MAX_TIMEOUT
from robodyn.cli._against import add_against_argument, run_against
from robodyn.cli._common import (
    add_model_arguments,
    add_passive_argument,
    file_path,
    load_robot,
    positive_float,
    positive_int,
    print_json,
    seed_number,
    unchecked_scene,
    warn_ignored_mimic,
    warn_unchecked,
)
from robodyn.errors import EXIT_MISMATCH, EXIT_OK, InputError
from robodyn.fileio import read_user_file
from robodyn.kinds import catalog
from robodyn.wording import count

if TYPE_CHECKING:
    from robodyn.robot import Robot


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "check",
        help="check M, C, G against a formula and Pinocchio's identities",
        description="Compare Pinocchio's M(q), C(q, v), G(q), inverse and forward dynamics and energies with a "
        "hand-derived formula over seeded random states, and check the structural properties "
        "(M SPD, dM/dt - 2C skew, G = dV/dq). Exit 0: all agree, or the equations of motion agree with a C that is "
        "not Christoffel's; 1: a mismatch; 2: bad input.",
    )
    add_model_arguments(p, many=True)
    add_passive_argument(p, what="each model (or scene)")
    p.epilog = (
        "A scene file (SCENE.toml) in place of a model checks the scene's model; with a formula file whose KIND is "
        "'constrained' (a closed chain's reduced Lagrangian, e.g. examples/textbook/linkage/reduced_formula.py) it "
        "is compared with Pinocchio's constrained dynamics on the scene's loops and springs. Without --formula, a "
        "scene's [check] formula is used."
    )
    p.add_argument(
        "--formula",
        metavar="KIND_OR_FILE",
        help=f"built-in kind ({catalog.listed()}), 'auto' (the kind each model meets, if any) or a "
        ".py file with your own derivation (KIND = a built-in kind, or 'any': any tree robot in your own joints "
        "and coordinates); without it only the structural properties and Pinocchio's identities are checked",
    )
    p.add_argument("--samples", type=_samples, default=100, help="number of random states, 1 to 100,000 (default 100)")
    p.add_argument("--seed", type=seed_number, default=0, help="seed of the random states (default 0)")
    p.add_argument("--rtol", type=positive_float, default=1e-9, help="relative tolerance (default 1e-9)")
    p.add_argument(
        "--params",
        type=file_path,
        metavar="FILE.json",
        help="use these formula parameters (a JSON object, or the output of robodyn params) instead of "
        "reading them from the model: checks a URDF against numbers you trust",
    )
    p.add_argument(
        "--formula-timeout",
        type=_formula_timeout,
        default=DEFAULT_TIMEOUT,
        metavar="SECONDS",
        help=f"time limit on the code of a formula FILE.py, which runs in a process of its own: its import, then "
        f"all its evaluations together (default {DEFAULT_TIMEOUT:g} s); past it, exit 2 naming the function",
    )
    p.add_argument(
        "--mimic", action="store_true", help="keep URDF <mimic> couplings as mimic joints (checked with CRBA)"
    )
    p.add_argument(
        "--explain",
        action="store_true",
        help="name the wrong term of each mismatching entry in the formula's own symbols (its difference from "
        "Pinocchio fitted over the samples, its coefficient named by the file's parameters)",
    )
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    # --against: another engine's reading of the same URDF (robodyn.cli._against; issue 35).
    add_against_argument(p)
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Check each model, print a table (or JSON) per model; exit 1 if any FAILs (:func:`exit_code`)."""
    if args.against is not None:  # another engine's reading of the file, not a formula: its own path
        return run_against(args)
    from robodyn.checker.sandbox import FormulaProcess
    from robodyn.checker.user_formula import looks_like_file

    if args.params is not None and args.formula in (None, "auto"):
        raise InputError("--params needs --formula KIND: parameters belong to one formula kind")
    given = read_params(args.params) if args.params is not None else None
    user_file = args.formula not in (None, "auto") and looks_like_file(args.formula)
    # A formula file runs in a Python of its own: start it now, so that it starts while the models load.
    process = FormulaProcess(Path(args.formula), args.formula, timeout=args.formula_timeout) if user_file else None
    try:
        return _check_all(args, given, process)
    finally:
        if process is not None:
            process.close()


def _check_all(args: argparse.Namespace, given: dict[str, Any] | None, process: Any) -> int:
    from robodyn.checker.compare import check
    from robodyn.checker.user_formula import load_user_formula
    from robodyn.kinds.params import detect_kind

    targets = [_target(args, name) for name in args.models]  # bad input fails before any work
    user = load_user_formula(args.formula, process=process) if process is not None else None
    reports = []
    robots = [robot for robot, _ in targets]
    source = str(args.params) if args.params is not None else None
    for robot, scene in targets:
        formula = user if user is not None else (detect_kind(robot) if args.formula == "auto" else args.formula)
        if formula is None and scene is not None and scene.check is not None:
            formula = scene.check.get("formula")  # the scene's own, its path read from the scene's folder
        where: dict[str, Any] = {}
        if scene is not None:
            where = {"loops": scene.constraints.loops, "springs": scene.constraints.springs, "scene": scene.path}
        report = check(
            robot,
            formula,
            samples=args.samples,
            seed=args.seed,
            rtol=args.rtol,
            params=given,
            params_source=source,
            explain=args.explain,
            **where,
        )
        warn_ignored_mimic(robot, mimic=args.mimic, command="check")  # after the check: a refusal is one line
        reports.append(report)
        if not args.json:
            if len(robots) > 1:
                print(f"{'=' * 30} {robot.name} {'=' * 30}")
            print(format_report(report, robot))
    renamed = dict.fromkeys(note for r in reports for note in r.renamed)  # p["M"]: the file's earlier names
    if renamed:
        sys.stdout.flush()  # the note comes after the report, as the terminal shows them
        print("\n".join(f"note: {note}" for note in renamed), file=sys.stderr)
    if args.json:
        print_json(reports[0].as_dict() if len(reports) == 1 else [r.as_dict() for r in reports])
    elif len(reports) > 1:
        print("\nsummary: " + ", ".join(f"{r.model} {_SUMMARY[r.verdict]}" for r in reports))
    return exit_code(reports)


def exit_code(reports: list[CheckReport]) -> int:
    """0 when every report's equations of motion agree with Pinocchio (PASS, or a C v right in a non-Christoffel C).

    1 when any formula's equations of motion, or Pinocchio's own identities, disagree.
    """
    return EXIT_MISMATCH if any(r.verdict == FAIL for r in reports) else EXIT_OK


def _target(args: argparse.Namespace, name: str) -> tuple[Any, Any]:
    """(robot, scene): a model loaded as named, or a scene file's model (its reduction, loops and springs)."""
    if not name.endswith(".toml"):
        return load_robot(args, name, mimic=args.mimic), None
    from robodyn.scene import read_scene

    if args.srdf is not None or args.free_flyer or args.mimic:
        raise InputError(
            f"{name}: --srdf, --free-flyer and --mimic are a model's options; a scene sets them in [model]"
        )
    scene = unchecked_scene(read_scene(Path(name)), args).with_passive(args.passive)
    robot, _ = scene.build()
    if scene.model.get("physics_check") is False:
        warn_unchecked(robot, command="check")
    return robot, scene


def _samples(text: str) -> int:
    """Argparse type: a whole number from 1 to MAX_SAMPLES (the help states it; a test holds the two together)."""
    from robodyn.checker.compare import MAX_SAMPLES  # here, not at the top: it loads Pinocchio

    value = positive_int(text)
    if value > MAX_SAMPLES:
        raise argparse.ArgumentTypeError(f"expected a whole number from 1 to {MAX_SAMPLES}, got {text!r}")
    return value


def _formula_timeout(text: str) -> float:
    """Argparse type: seconds in (0, MAX_TIMEOUT]."""
    value = positive_float(text)
    if value > MAX_TIMEOUT:
        raise argparse.ArgumentTypeError(f"expected at most {MAX_TIMEOUT:g} seconds (a day), got {text!r}")
    return value


# robodyn params writes ~300 bytes; a parameter file past 1 MiB is not one (and /dev/zero never ends).
MAX_PARAMS_BYTES = 2**20


def read_params(path: Path) -> dict[str, Any]:
    """Read ``{"m1": ..}`` or robodyn params' ``{"params": {"m1": ..}}`` from a UTF-8 JSON file.

    Raises:
        InputError: the file cannot be read, is larger than :data:`MAX_PARAMS_BYTES`, is not UTF-8,
            not JSON, nested too deeply for the parser, or not an object; the message names the file.
    """
    raw = read_user_file(path, what="parameter", expected="a short JSON object", limit=MAX_PARAMS_BYTES)
    try:
        data = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not UTF-8 text: byte 0x{raw[exc.start]:02x} at offset {exc.start}") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno})") from None
    except RecursionError:
        raise InputError(
            f"{path}: arrays or objects nested too deeply to read (expected a flat JSON object of names to numbers)"
        ) from None
    except ValueError as exc:  # e.g. an integer of more than 4,300 digits
        raise InputError(f"{path}: a value cannot be read: {str(exc).split(';')[0]}") from None
    if isinstance(data, dict) and isinstance(data.get("params"), dict):
        data = data["params"]
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a JSON object of parameter names to numbers")
    return data


_DIMENSION_UNITS = {(1, 0, 0): "kg", (0, 1, 0): "m", (1, 2, 0): "kg m^2", (0, 1, -2): "m/s^2"}


def _unit(name: str, kind: str | None) -> str:
    """`` kg`` for a parameter: a built-in kind's table, or (KIND = "any") guessed from the name as --explain does."""
    unit = catalog.units().get(name, "")
    unit = "" if unit == "1" else unit
    if not unit and kind == "any":
        from robodyn.checker.explain_names import parameter_dimension

        dim = parameter_dimension(name)
        unit = _DIMENSION_UNITS.get(dim, "") if dim is not None else ""
    return f" {unit}" if unit else ""


def _vector(x: Any) -> str:
    return "[" + ", ".join(f"{v:.4g}" for v in x) + "]"


def format_report(report: CheckReport, robot: Robot) -> str:
    """The human-readable table with a line per mismatch naming the entry and the state."""
    lines = [
        f"model {report.model}: {report.urdf}",
        f"formula: {report.formula or '(none: structural properties and Pinocchio identities only)'}"
        f"   samples: {report.samples}   seed: {report.seed}   rtol: {report.rtol:g}",
    ]
    if report.params:
        params = ", ".join(f"{k} = {v:.6g}{_unit(k, report.kind)}" for k, v in report.params.items())
        origin = "given with --params" if report.params_given else _origin(report)
        lines.append(f"parameters {origin}: {params}")
    if report.formula is None:
        from robodyn.kinds.params import detect_kind

        kind = detect_kind(robot)
        if kind is not None:
            lines.append(f"note: this model meets the assumptions of the {kind} formula: add --formula {kind}")
    width = max(len(r.quantity) for r in report.rows) + 2
    lines.append("")
    lines.append(f"{'quantity':<{width}}{'max abs err':>12}  {'max rel err':>11}  {'tol':>7}  {'result':<6}  unit")
    group = None
    for r in report.rows:
        if r.group != group:
            group = r.group
            lines.append(f"-- {_GROUP_TITLES[group]}")
        errors = f"{r.max_abs_error:>12.3e}  {r.max_rel_error:>11.3e}  {r.tolerance:>7.0e}"
        lines.append(f"{r.quantity:<{width}}{errors}  {r.status:<6}  {r.unit}")
    for r in report.rows:
        if not r.applicable:
            lines.append(f"n/a: {r.quantity}: {r.note}")
    lines.extend(f"note: {note}" for note in report.notes)
    for r in report.rows:
        if r.applicable and r.within_floor_only:
            lines.append(
                f"note: {r.quantity}: the error {r.max_abs_error:.3g} {r.unit} is round-off, within the floor "
                f"{r.floor:.3g} {r.unit} that the magnitudes of the terms it is computed from allow"
            )
    for r in report.failures + report.gaps:
        lines.extend(_mismatch_lines(r))
        if r.note:
            lines.append(f"    {r.note}")
    if report.explanation:  # a convention hint first: it explains the terms below it at once
        lines.append("")
        lines.extend((*report.hints, *report.explanation))
    verdict = {
        PASS: "PASS: everything agrees within tolerance",
        EQUATIONS_AGREE: "PASS (equations of motion): M, C v + G, tau and a agree; note: the formula's C is not "
        "the Christoffel C (dM/dt - 2C is not skew)",
        FAIL: f"FAIL: {count(len(report.failures), 'mismatch', 'mismatches')}",
    }[report.verdict]
    lines.append("")
    lines.append(f"{verdict}  ({report.wall_time_s:.2f} s)")
    if not report.explanation:
        lines.extend(report.hints)  # without --explain, right under the verdict
    return "\n".join(lines)


def _mismatch_lines(r: CheckRow) -> list[str]:
    """``MISMATCH M[0,1] (M): formula .., Pinocchio ..``: the worst entry, then every other one out of tolerance."""
    label = "MISMATCH" if r.counts else "PINOCCHIO GAP"
    ref = "Pinocchio" if r.group == "formula" else "expected"
    got = "formula" if r.group == "formula" else "got"
    worst = (r.entry, r.got, r.expected, r.worst_sample, r.worst_q, r.worst_v)
    others = [
        (m.entry, m.got, m.expected, m.worst_sample, m.worst_q, m.worst_v) for m in r.mismatches if m.entry != r.entry
    ]
    return [
        f"{label} {r.entry_label(entry)} ({r.quantity}): {got} {value:.10g}, {ref} {expected:.10g}, "
        f"difference {value - expected:.3g} {r.unit} at sample {k}: q = {_vector(q)}, v = {_vector(v)}"
        for entry, value, expected, k, q, v in (worst, *others)
    ]


def _origin(report: CheckReport) -> str:
    """Where the parameters of a report came from, when the user did not give them."""
    if report.kind == "any":
        return "from the formula file"
    return "from the formula file's parameters(scene)" if report.kind == "constrained" else "read from the model"


_SUMMARY = {PASS: "pass", EQUATIONS_AGREE: "pass (equations of motion; C not Christoffel)", FAIL: "FAIL"}
_GROUP_TITLES = {
    "formula": "formula vs Pinocchio",
    "structure": "structural properties",
    "identity": "Pinocchio identities",
    "pinocchio": "Pinocchio's routines against each other (reported, never failing the check)",
}
