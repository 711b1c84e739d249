"""The ``JOINTS`` / ``COORDINATES`` block of a formula file, read without running the file.

``robodyn derive --coordinates FILE`` takes the coordinates of a ``KIND = "any"`` formula file::

    JOINTS = ["shoulder", "elbow"]                                  # q1, q2 stand for these joints
    COORDINATES = {"shoulder": (1.0, math.pi / 2), "elbow": (-1, 0)}   # q = sign * q_urdf + offset
    LOCKED = {"wrist": 0.3}                                         # the joints not in JOINTS, held there

The file is parsed, not imported (a derivation never runs a user's code): each value must be
a literal, and a number may be written with ``pi`` (``math.pi``, ``np.pi``, ``numpy.pi``) and
``+ - * /``. Anything else is refused in one line naming the file and the line.
"""

from __future__ import annotations

import ast
import math
from pathlib import Path
from typing import Any

from robodyn.errors import InputError

MAX_BYTES = 2**20  # a formula file is a few kB; this one is only parsed

_PI_NAMES = {"pi", "math.pi", "np.pi", "numpy.pi"}


def read_coordinates(path: Path) -> tuple[list[str], dict[str, tuple[float, float]], dict[str, float]]:
    """(JOINTS, COORDINATES, LOCKED) of a formula file; COORDINATES and LOCKED are ``{}`` when the file has none.

    Raises:
        InputError: the file cannot be read or parsed, has no ``JOINTS`` list of names, or a
            value that is not a literal; the message names the file (and the line).
    """
    try:
        with path.open("rb") as stream:
            raw = stream.read(MAX_BYTES + 1)
    except OSError as exc:
        raise InputError(f"{path}: cannot read the coordinates: {exc.strerror or exc}") from None
    if len(raw) > MAX_BYTES:
        raise InputError(f"{path}: larger than 1 MiB (expected a formula file)")
    try:
        tree = ast.parse(raw.decode("utf-8"), filename=str(path))
    except UnicodeDecodeError:
        raise InputError(f"{path}: not UTF-8 text (expected a Python formula file)") from None
    except (SyntaxError, ValueError, RecursionError) as exc:
        line = getattr(exc, "lineno", None)
        raise InputError(f"{path}: not valid Python{f' (line {line})' if line else ''}") from None
    found: dict[str, ast.expr] = {}
    for node in tree.body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
            found[node.targets[0].id] = node.value
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.value is not None:
            found[node.target.id] = node.value
    if "JOINTS" not in found:
        raise InputError(f"{path}: no JOINTS = [...] (the URDF joints q1, q2, ... stand for, in order)")
    joints = _value(found["JOINTS"], path, "JOINTS")
    if not isinstance(joints, list | tuple) or not joints or not all(isinstance(j, str) for j in joints):
        raise InputError(f"{path}: JOINTS must be a list of joint names, got {ast.unparse(found['JOINTS'])[:60]}")
    if len(set(joints)) != len(joints):
        raise InputError(f"{path}: JOINTS names a joint twice: {list(joints)}")
    maps: dict[str, tuple[float, float]] = {}
    if "COORDINATES" in found:
        raw_map = _value(found["COORDINATES"], path, "COORDINATES")
        if not isinstance(raw_map, dict):
            raise InputError(f"{path}: COORDINATES must be a dict joint -> (sign, offset)")
        for joint, pair in raw_map.items():
            if joint not in joints:
                raise InputError(f"{path}: COORDINATES names {joint!r}, which is not in JOINTS {list(joints)}")
            if not isinstance(pair, tuple | list) or len(pair) != 2:
                raise InputError(f"{path}: COORDINATES[{joint!r}] must be (sign, offset), got {pair!r}")
            sign, offset = (float(x) for x in pair)
            if sign not in (1.0, -1.0) or not math.isfinite(offset):
                raise InputError(
                    f"{path}: COORDINATES[{joint!r}] = {tuple(pair)!r}: the sign must be 1 or -1 and the offset finite"
                )
            maps[str(joint)] = (sign, offset)
    locked: dict[str, float] = {}
    if "LOCKED" in found:
        raw_locked = _value(found["LOCKED"], path, "LOCKED")
        if not isinstance(raw_locked, dict):
            raise InputError(f"{path}: LOCKED must be a dict joint -> value [rad | m] for joints not in JOINTS")
        for joint, x in raw_locked.items():
            if joint in joints or not isinstance(x, int | float) or not math.isfinite(float(x)):
                raise InputError(
                    f"{path}: LOCKED[{joint!r}] = {x!r}: expected a finite value of a joint that is not in JOINTS"
                )
            locked[str(joint)] = float(x)
    return [str(j) for j in joints], maps, locked


def _value(node: ast.expr, path: Path, name: str) -> Any:
    """A literal: strings, numbers (with pi and + - * /), lists, tuples, dicts."""
    if (
        isinstance(node, ast.Constant)
        and isinstance(node.value, str | int | float)
        and not isinstance(node.value, bool)
    ):
        return node.value
    if isinstance(node, ast.List | ast.Tuple):
        items = [_value(x, path, name) for x in node.elts]
        return items if isinstance(node, ast.List) else tuple(items)
    if isinstance(node, ast.Dict):
        return {_value(k, path, name): _value(v, path, name) for k, v in zip(node.keys, node.values, strict=True) if k}
    if ast.unparse(node) in _PI_NAMES:
        return math.pi
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
        x = _number(_value(node.operand, path, name), node, path, name)
        return -x if isinstance(node.op, ast.USub) else x
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add | ast.Sub | ast.Mult | ast.Div):
        a = _number(_value(node.left, path, name), node, path, name)
        b = _number(_value(node.right, path, name), node, path, name)
        try:
            return (
                {ast.Add: a + b, ast.Sub: a - b, ast.Mult: a * b}.get(type(node.op))
                if not isinstance(node.op, ast.Div)
                else a / b
            )
        except ZeroDivisionError:
            pass
    raise InputError(
        f"{path}: line {node.lineno}: {name} must be written with literals (numbers, pi, + - * /), "
        f"got {ast.unparse(node)[:60]!r}"
    )


def _number(x: Any, node: ast.expr, path: Path, name: str) -> float:
    if isinstance(x, int | float) and not isinstance(x, bool):
        return float(x)
    raise InputError(f"{path}: line {node.lineno}: {name}: expected a number, got {ast.unparse(node)[:60]!r}")
