"""Argument types and helpers shared by the subcommands."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np


def float_list(text: str) -> np.ndarray:
    """Argparse type: ``"0.1,-2,3e-3"`` -> float array (one line of error otherwise)."""
    try:
        values = [float(x) for x in text.replace(" ", "").split(",") if x != ""]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers like 0.1,-2, got {text!r}") from None
    if not values:
        raise argparse.ArgumentTypeError("expected at least one number")
    if not np.all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"expected finite numbers, got {text!r}")
    return np.array(values, dtype=np.float64)


def positive_float(text: str) -> float:
    """Argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """Argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text!r}")
    return value


def add_model_arguments(parser: argparse.ArgumentParser, *, many: bool = False) -> None:
    """The positional model (built-in name, example-robot-data name or URDF path) and its options.

    With ``many`` the positional is ``models`` and takes one or more.
    """
    parser.add_argument(
        "models" if many else "model",
        metavar="URDF_OR_NAME",
        nargs="+" if many else None,
        help="built-in model (geared_arm, cart_pole, pendubot), an example-robot-data robot (panda, talos, ...) "
        "or a path to a .urdf file",
    )
    parser.add_argument("--srdf", type=Path, default=None, help="SRDF file (default: same stem as the URDF)")
    parser.add_argument("--free-flyer", action="store_true", help="mount the root on a free-flyer joint")


def load_robot(args: argparse.Namespace, model: str | None = None, **options: Any) -> Any:
    """Load the robot named by ``model`` (default ``args.model``) with the common options."""
    from robodyn.model.load import load

    return load(args.model if model is None else model, srdf=args.srdf, free_flyer=args.free_flyer, **options)


def urdf_mimic_joints(urdf: Path | None) -> list[str]:
    """Names of the moving joints of ``urdf`` that carry a ``<mimic>`` tag (none for no file or bad XML).

    A ``<mimic>`` on a fixed joint couples nothing and is not counted.
    """
    import xml.etree.ElementTree as ET

    if urdf is None:
        return []
    try:
        root = ET.parse(urdf).getroot()
    except (OSError, ET.ParseError):
        return []
    return [str(j.get("name")) for j in root.iter("joint") if j.find("mimic") is not None and j.get("type") != "fixed"]


def warn_ignored_mimic(robot: Any, *, mimic: bool, command: str) -> None:
    """One line on stderr when ``robot``'s URDF couples joints by ``<mimic>`` but ``--mimic`` was not given."""
    if mimic:
        return
    names = urdf_mimic_joints(getattr(robot, "urdf_path", None))
    if names:
        listed = ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
        print(
            f"robodyn {command}: warning: {robot.name}'s URDF couples {listed} by <mimic>; "
            "the coupling is ignored and those joints move on their own (pass --mimic to keep it)",
            file=sys.stderr,
        )


def print_json(obj: Any) -> None:
    """Print ``obj`` as indented JSON on stdout."""
    json.dump(obj, sys.stdout, indent=2, default=_json_default)
    sys.stdout.write("\n")


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot serialise {type(obj).__name__}")
