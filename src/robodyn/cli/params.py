"""``robodyn params``: the seed-kind parameters read from a URDF (+ SRDF), as JSON."""

from __future__ import annotations

import argparse
from typing import Any

from robodyn.cli._common import add_model_arguments, load_robot, print_json


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "params",
        help="print the formula parameters of a model as JSON",
        description="Read the parameters a hand-derived formula needs (masses, lengths, inertias about the joint "
        "axes, rotor inertia and gear ratio, g) from a URDF and print them as JSON in SI units. A model that "
        "breaks the kind's assumptions is refused with exit code 2 and the assumption named.",
    )
    add_model_arguments(p)
    p.add_argument("--kind", help="geared_arm, cart_pole or pendubot (default: detect)")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Extract and print."""
    from robodyn.errors import AssumptionError
    from robodyn.kinds.params import EXTRACTORS, detect_kind, extract

    robot = load_robot(args)
    kind = args.kind or detect_kind(robot)
    if kind is None:
        raise AssumptionError(
            f"{robot.name} meets the assumptions of none of the kinds {', '.join(EXTRACTORS.names())}; "
            "name one with --kind to see which assumption it breaks"
        )
    params = extract(robot, kind)
    from robodyn.cli.check import PARAM_UNITS

    units = {name: PARAM_UNITS.get(name, "") or "1" for name in params}
    print_json(
        {"model": robot.name, "urdf": str(robot.urdf_path), "kind": kind, "params": params.as_dict(), "units": units}
    )
    return 0
