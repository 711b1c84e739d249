"""Argument types and helpers shared by the subcommands."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.kinds import catalog


def shown(text: str, limit: int = 40) -> str:
    """``text`` quoted for a message, cut to ``limit`` characters (a hostile value keeps the line short)."""
    return repr(text) if len(text) <= limit else f"{text[:limit]!r}... ({len(text)} characters)"


def float_list(text: str) -> np.ndarray:
    """Argparse type: ``"0.1,-2,3e-3"`` -> float array (one line of error otherwise)."""
    try:
        values = [float(x) for x in text.replace(" ", "").split(",") if x != ""]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers like 0.1,-2, got {shown(text)}") from None
    if not values:
        raise argparse.ArgumentTypeError("expected at least one number")
    if not np.all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"expected finite numbers, got {shown(text)}")
    return np.array(values, dtype=np.float64)


def number_in(
    *, low: float = 0.0, high: float = math.inf, low_open: bool = True, integer: bool = False, noun: str = ""
) -> Callable[[str], Any]:
    """An argparse type: a finite number (a whole number with ``integer``) in a stated range.

    The range is ``low < x <= high`` (``low <= x`` when not ``low_open``); the one line of
    error states it, e.g. "expected a positive whole number from 1 to 100000, got '0'".
    ``noun`` names the value ("port number"; default "positive number" for ranges above 0).
    """
    positive = (low == 0 and low_open) or (integer and low == 1 and not low_open)
    noun = noun or ("positive " if positive else "") + ("whole number" if integer else "number")
    lo, hi = (str(int(x)) if integer and math.isfinite(x) else f"{x:g}" for x in (low, high))
    if high == math.inf:
        expected = f"a {noun}" if integer and positive else f"a {noun} ({'>' if low_open else '>='} {lo})"
    else:
        expected = f"a {noun} {f'> {lo} and <=' if low_open else f'from {lo} to'} {hi}"

    def convert(text: str) -> Any:
        try:
            value: Any = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {shown(text)}") from None
        inside = (low < value if low_open else low <= value) and value <= high
        if not ((integer or math.isfinite(value)) and inside):  # a whole number is finite (and may not fit a float)
            raise argparse.ArgumentTypeError(f"expected {expected}, got {shown(text)}")
        return value

    convert.__name__ = noun.replace(" ", "_") or ("whole_number" if integer else "number")
    return convert


positive_float = number_in()
"""Argparse type: a finite number > 0."""

positive_int = number_in(integer=True, low=1, low_open=False)
"""Argparse type: a whole number >= 1."""

MAX_SEED = 2**63 - 1
"""The largest seed: what a TOML integer (and a C int64) holds; numpy takes any number >= 0."""

seed_number = number_in(integer=True, low=0, high=MAX_SEED, low_open=False, noun="seed")
"""Argparse type: a random seed, a whole number from 0 to 2**63 - 1."""


NAME_MAX = 255
"""The most bytes in one part of a path (Linux): a longer part names no file, and pathlib raises on it."""


def file_path(text: str) -> Path:
    """Argparse type: a non-empty path whose every part fits in a file name (at most NAME_MAX bytes)."""
    if not text:
        raise argparse.ArgumentTypeError("expected a path, got an empty string")
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected a path, got only white space {text!r}")
    if any(len(os.fsencode(part)) > NAME_MAX for part in Path(text).parts):
        raise argparse.ArgumentTypeError(
            f"expected a path whose every part is at most {NAME_MAX} bytes (a file name), got {shown(text)}"
        )
    return Path(text)


def model_argument(text: str) -> str:
    """Argparse type: a model name, or a path as :func:`file_path` takes it."""
    if not text:
        raise argparse.ArgumentTypeError("expected a model name or a path to a .urdf file, got an empty string")
    file_path(text)
    return text


def add_model_arguments(parser: argparse.ArgumentParser, *, many: bool = False) -> None:
    """The positional model (built-in name, example-robot-data name or URDF path) and its options.

    With ``many`` the positional is ``models`` and takes one or more.
    """
    parser.add_argument(
        "models" if many else "model",
        type=model_argument,
        metavar="URDF_OR_NAME",
        nargs="+" if many else None,
        help=f"built-in model ({catalog.listed()}), an example-robot-data robot (panda, talos, ...) "
        "or a path to a .urdf file",
    )
    parser.add_argument("--srdf", type=file_path, default=None, help="SRDF file (default: same stem as the URDF)")
    parser.add_argument("--free-flyer", action="store_true", help="mount the root on a free-flyer joint")
    add_physics_argument(parser)


def add_physics_argument(parser: argparse.ArgumentParser) -> None:
    """``--no-physics-check``: load a model's masses and inertias as written, even impossible ones."""
    parser.add_argument(
        "--no-physics-check",
        dest="physics_check",
        action="store_false",
        help="load the file's masses and inertias as written, even physically impossible ones (a negative "
        "mass, an inertia breaking the triangle inequality), saying so in one warning line; by default such a "
        "model is refused (exit 2)",
    )


def physics_checked(args: argparse.Namespace) -> bool:
    """False when ``--no-physics-check`` was given (True for a parser without the option)."""
    return bool(getattr(args, "physics_check", True))


def warn_unchecked(robot: Any, *, command: str) -> None:
    """The one warning line of a model loaded with ``--no-physics-check``: what it let through."""
    from robodyn.model.consistency import all_findings

    errors = [f for f in all_findings(robot.model, urdf=robot.urdf_path) if f.severity == "error"]
    found = (
        f"{len(errors)} physically impossible finding(s) among them, the first {errors[0]} (robodyn info lists them)"
        if errors
        else "none of them physically impossible"
    )
    print(
        f"robodyn {command}: warning: --no-physics-check: {robot.name} is loaded with its file's masses and "
        f"inertias as written, {found}",
        file=sys.stderr,
    )


def unchecked_scene(scene: Any, args: argparse.Namespace) -> Any:
    """``scene`` with ``[model] physics_check = false`` when ``--no-physics-check`` was given."""
    if physics_checked(args):
        return scene
    import dataclasses

    return dataclasses.replace(scene, model={**scene.model, "physics_check": False})


def joint_list(text: str) -> tuple[str, ...]:
    """Argparse type: ``"joint2"`` or ``"joint1,joint2"`` -> the joint names (one line of error otherwise)."""
    names = tuple(name.strip() for name in text.split(","))
    if not text.strip() or not all(names):
        raise argparse.ArgumentTypeError(
            f"expected joint names separated by commas like joint2,joint3, got {shown(text)}"
        )
    return names


def add_passive_argument(parser: argparse.ArgumentParser, *, what: str = "the model") -> None:
    """``--passive JOINT[,JOINT]``: joints without an actuator, added to those the SRDF declares."""
    parser.add_argument(
        "--passive",
        type=joint_list,
        default=(),
        metavar="JOINT[,JOINT]",
        help=f"joints of {what} that no actuator drives (they take no torque), added to the SRDF's <passive_joint> "
        "entries: declares an underactuated robot without writing an SRDF",
    )


def load_robot(args: argparse.Namespace, model: str | None = None, **options: Any) -> Any:
    """Load the robot named by ``model`` (default ``args.model``) with the common options and ``--passive``.

    With ``--no-physics-check`` the file's numbers are loaded as written, and one warning line says so.
    """
    from robodyn.errors import InputError, UnknownNameError
    from robodyn.model.load import PASSIVE_JOINT, load

    checked = physics_checked(args)
    passive = getattr(args, "passive", ())
    try:
        robot = load(
            args.model if model is None else model,
            srdf=args.srdf,
            free_flyer=args.free_flyer,
            passive=passive,
            **{"check_physics": checked, **options},
        )
    except UnknownNameError as exc:
        if exc.what != PASSIVE_JOINT:
            raise
        raise InputError(f"--passive {','.join(passive)}: {exc}") from None
    if not checked:
        warn_unchecked(robot, command=str(getattr(args, "command", "")))
    return robot


def urdf_mimic_joints(urdf: Path | None) -> list[str]:
    """Names of the moving joints of ``urdf`` that carry a ``<mimic>`` tag (none for no file or bad XML).

    A ``<mimic>`` on a fixed joint couples nothing and is not counted.
    """
    from robodyn.errors import ModelError
    from robodyn.model.files import read_xml

    if urdf is None:
        return []
    try:
        root = read_xml(urdf, "URDF")
    except ModelError:
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


def refuse_uncoupled_sizes(robot: Any, *, q0: Any, v0: Any, mimic: bool) -> None:
    """Refuse a ``--q0`` / ``--v0`` sized for the coupled robot when ``--mimic`` was left out (one line, with the hint).

    Without ``--mimic`` every ``<mimic>`` joint of the URDF moves on its own and has its own
    coordinate, so a state written for the coupled robot is short by one entry per follower.
    """
    if mimic:
        return
    followers = urdf_mimic_joints(getattr(robot, "urdf_path", None))
    if not followers:
        return
    for name, value, sizes in (("q0", q0, (robot.nq, robot.nv)), ("v0", v0, (robot.nv,))):
        if value is None or np.size(value) in sizes:
            continue
        from robodyn.errors import InputError

        listed = ", ".join(followers[:3]) + (f" and {len(followers) - 3} more" if len(followers) > 3 else "")
        raise InputError(
            f"{name} must have {sizes[0]} entries for {robot.name}, got {np.size(value)}: without --mimic the "
            f"<mimic> coupling of {listed} is dropped and each of those joints has a coordinate of its own "
            "(pass --mimic to keep the coupling, or give one entry per joint)"
        )


NON_FINITE_KEY = "non_finite"
"""The key a JSON object gains when some of its numbers were NaN or infinite: where each was, and what it was."""


def strict_json(obj: Any) -> Any:
    """``obj`` made fit for strict JSON parsers: every NaN or infinity becomes null.

    JSON has no NaN or Infinity (Python's ``json`` writes them, strict parsers refuse them). A
    top-level object that had some gains the key :data:`NON_FINITE_KEY`: the place of each
    (``"energy_drift"``, ``"q_final[1]"``) and what it was (``"nan"``, ``"inf"``, ``"-inf"``), so that a
    null says why. NumPy arrays and scalars become lists and numbers, paths strings.
    """
    found: dict[str, str] = {}
    clean = _finite_only(obj, "", found)
    if found and isinstance(clean, dict):
        clean[NON_FINITE_KEY] = found
    return clean


def _finite_only(obj: Any, where: str, found: dict[str, str]) -> Any:
    if isinstance(obj, (np.ndarray, np.generic, Path)):
        obj = _json_default(obj)
    if isinstance(obj, float):
        if math.isfinite(obj):
            return obj
        found[where or "value"] = repr(obj)
        return None
    if isinstance(obj, dict):
        return {k: _finite_only(v, f"{where}.{k}" if where else str(k), found) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite_only(v, f"{where}[{i}]", found) for i, v in enumerate(obj)]
    return obj


def print_json(obj: Any) -> None:
    """Print ``obj`` as indented strict JSON on stdout: NaN and infinities as null (:func:`strict_json`)."""
    json.dump(strict_json(obj), sys.stdout, indent=2, default=_json_default, allow_nan=False)
    sys.stdout.write("\n")


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot serialise {type(obj).__name__}")
