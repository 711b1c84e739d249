"""``robodyn params``: the parameters of a built-in kind read from a URDF (+ SRDF), as JSON; ``--set`` changes them.

``--set m2=0.6`` prints the parameters of the modified model; with ``--write out.urdf`` the
modified URDF (and the SRDF, as ``out.srdf``, when the model has one or a rotor parameter is
set) is written, after the written file has been loaded and its parameters checked.
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path
from typing import Any

from robodyn.cli._common import add_model_arguments, file_path, load_robot, print_json
from robodyn.kinds import catalog


def assignments(text: str) -> list[tuple[str, float]]:
    """Argparse type: ``"m1=0.3,m2=0.6"`` -> [("m1", 0.3), ("m2", 0.6)] (one line of error otherwise)."""
    pairs: list[tuple[str, float]] = []
    for item in (part.strip() for part in text.split(",")):
        if not item and pairs:
            continue  # a trailing comma
        name, sep, value = item.partition("=")
        try:
            number = float(value)
        except ValueError:
            number = math.nan
        if not sep or not name.strip() or not math.isfinite(number):
            raise argparse.ArgumentTypeError(f"expected NAME=NUMBER like m2=0.6 (commas between several), got {item!r}")
        pairs.append((name.strip(), number))
    return pairs


# A printed parameter is the shortest decimal within this many units in the last place of the
# value read: the reading goes through Pinocchio's placements (a rotation by pi/2 turns the
# file's 0.10 into 0.09999999999999998, 2 ulp off), a round-off of a few ulp.
DECIMAL_ULPS = 4


def decimal(value: float) -> float:
    """``value`` as the shortest decimal (at most 15 significant digits) within ``DECIMAL_ULPS`` ulp of it.

    ``0.09999999999999998`` prints as ``0.1``, the file's 0.10; a value with more digits than
    round-off explains (1/3, a measured inertia) is left as it is.
    """
    if not math.isfinite(value):
        return value
    for digits in range(1, 16):
        candidate = float(f"{value:.{digits}g}")
        if abs(candidate - value) <= DECIMAL_ULPS * math.ulp(value):
            return candidate
    return value


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "params",
        help="print the formula parameters of a model as JSON; --set and --write change them",
        description="Read the parameters a hand-derived formula needs (masses, lengths, inertias about the joint "
        "axes, rotor inertia and gear ratio, g) from a URDF and print them as JSON in SI units. A model that "
        "breaks the kind's assumptions is refused with exit code 2 and the assumption named. --set changes "
        "parameters (masses, centres of mass and inertias in the URDF's <inertial>, link lengths in joint "
        "<origin>s, J_m and n in the SRDF's <rotor_params>; g cannot be set) and prints the parameters of the "
        "modified model; --write also writes it, once it has been loaded back and checked.",
    )
    add_model_arguments(p)
    p.add_argument("--kind", help=f"{catalog.listed('or')} (default: detect)")
    p.add_argument(
        "--set",
        metavar="NAME=VALUE",
        type=assignments,
        action="append",
        help="set a parameter in SI units, e.g. m2=0.6; repeat the option or separate with commas",
    )
    p.add_argument(
        "--write",
        metavar="OUT.urdf",
        type=file_path,
        help="write the modified URDF here (the SRDF goes along as OUT.srdf); not the model's own file",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Extract and print; with --set, modify (and with --write, write) first."""
    from robodyn.errors import AssumptionError
    from robodyn.kinds.params import detect_kind, extract

    robot = load_robot(args)
    kind = args.kind or detect_kind(robot)
    if kind is None:
        raise AssumptionError(
            f"{robot.name} meets the assumptions of none of the kinds {catalog.listed()}; "
            "name one with --kind to see which assumption it breaks"
        )
    params = extract(robot, kind)
    report: dict[str, Any] = {"model": robot.name, "urdf": str(robot.urdf_path), "kind": kind}
    if args.set is not None or args.write is not None:
        from robodyn.cli._output import refuse_clobbering, writable_path
        from robodyn.kinds.edit import check_changes, refuse_own_file, write_params

        changes = check_changes(kind, [pair for group in args.set or [] for pair in group])
        if args.write is not None:
            refuse_own_file(robot, args.write)
            written_files = [("--write", args.write), ("--write's SRDF", args.write.with_suffix(".srdf"))]
            refuse_clobbering(written_files, [("the model's URDF", robot.urdf_path), ("its SRDF", robot.srdf_path)])
            out = writable_path(args.write, suffix=".urdf")
            written = write_params(robot, kind, changes, out, free_flyer=args.free_flyer)
            report["written"] = {"urdf": str(written.urdf), "srdf": None if written.srdf is None else str(written.srdf)}
        else:
            with tempfile.TemporaryDirectory(prefix="robodyn-params-") as folder:
                stem = robot.urdf_path.stem if robot.urdf_path is not None else "model"
                written = write_params(robot, kind, changes, Path(folder) / f"{stem}.urdf", free_flyer=args.free_flyer)
        report["set"] = changes
        params = written.params
    report["params"] = {name: decimal(value) for name, value in params.as_dict().items()}
    report["units"] = {name: catalog.kind(kind).units[name] for name in params}
    print_json(report)
    return 0
