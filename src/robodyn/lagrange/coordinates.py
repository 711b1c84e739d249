"""The ``JOINTS`` / ``COORDINATES`` / ``OFFSETS`` / ``LOCKED`` block of a formula file, read without running it.

``robodyn derive --coordinates FILE`` takes the coordinates of a ``KIND = "any"`` formula file::

    UP = math.pi
    JOINTS = ["shoulder", "elbow"]                                  # q1, q2 stand for these joints
    COORDINATES = {"shoulder": (1.0, UP / 2), "elbow": (-1, 0)}     # q = sign * q_urdf + offset
    LOCKED = {"wrist": 0.3}                                         # the joints not in JOINTS, held there

or ``COORDINATES`` as a matrix over JOINTS with ``OFFSETS`` (q = A q_urdf + b,
:mod:`robodyn.model.coordinate_map`): ``COORDINATES = [[1, 0], [1, 1]]`` for absolute angles.

The file is parsed, not imported (a derivation never runs a user's code). Each value is
evaluated from constants only: literals (numbers, strings, lists, tuples, dicts), ``+ - * / **``,
``pi``, ``tau`` and ``e`` (bare or as ``math.``, ``np.``, ``numpy.``), the functions of
:data:`FUNCTIONS` (``math.radians(180)``, ``np.deg2rad(90)``), and names assigned such a value
earlier at the top of the file (``UP = math.pi``, then ``-UP``). Anything else is refused in one
line naming the file and the line.
"""

from __future__ import annotations

import ast
import math
from pathlib import Path
from typing import Any

from robodyn.errors import InputError
from robodyn.model.coordinate_map import CoordinateMap, coordinate_map

MAX_BYTES = 2**20  # a formula file is a few kB; this one is only parsed
MAX_POWER = 64.0  # the largest exponent of ** in a constant (no 10**10**10)

_MODULES = ("math.", "np.", "numpy.")
_CONSTANTS = {"pi": math.pi, "tau": math.tau, "e": math.e}
FUNCTIONS = {
    "radians": math.radians,
    "deg2rad": math.radians,
    "degrees": math.degrees,
    "rad2deg": math.degrees,
    "sqrt": math.sqrt,
    "cos": math.cos,
    "sin": math.sin,
    "tan": math.tan,
    "atan2": math.atan2,
    "arctan2": math.atan2,
}
"""The functions a constant may call, by their name in math or NumPy."""


def read_coordinates(path: Path) -> tuple[list[str], CoordinateMap, dict[str, float]]:
    """(JOINTS, the map q = A q_urdf + b, LOCKED) of a formula file; q = q_urdf and ``{}`` when it has none.

    Raises:
        InputError: the file cannot be read or parsed, has no ``JOINTS`` list of names, a value
            that is not a constant, or a COORDINATES / OFFSETS the map refuses; the message names
            the file (and the line).
    """
    tree = _parse(path)
    found: dict[str, ast.expr] = {}
    constants: dict[str, Any] = {}
    for node in tree.body:
        target, value = _assignment(node)
        if target is None or value is None:
            continue
        found[target] = value
        try:
            constants[target] = _value(value, path, target, constants)
        except InputError:
            constants.pop(target, None)  # not a constant: an error only if a value uses it
    if "JOINTS" not in found:
        raise InputError(f"{path}: no JOINTS = [...] (the URDF joints q1, q2, ... stand for, in order)")
    joints = _value(found["JOINTS"], path, "JOINTS", constants)
    if not isinstance(joints, list | tuple) or not joints or not all(isinstance(j, str) for j in joints):
        raise InputError(f"{path}: JOINTS must be a list of joint names, got {ast.unparse(found['JOINTS'])[:60]}")
    if len(set(joints)) != len(joints):
        raise InputError(f"{path}: JOINTS names a joint twice: {list(joints)}")
    raw = {
        name: _value(found[name], path, name, constants) if name in found else None
        for name in ("COORDINATES", "OFFSETS")
    }
    cmap = coordinate_map(raw["COORDINATES"], raw["OFFSETS"], [str(j) for j in joints], str(path))
    locked: dict[str, float] = {}
    if "LOCKED" in found:
        raw_locked = _value(found["LOCKED"], path, "LOCKED", constants)
        if not isinstance(raw_locked, dict):
            raise InputError(f"{path}: LOCKED must be a dict joint -> value [rad | m] for joints not in JOINTS")
        for joint, x in raw_locked.items():
            if joint in joints or not isinstance(x, int | float) or not math.isfinite(float(x)):
                raise InputError(
                    f"{path}: LOCKED[{joint!r}] = {x!r}: expected a finite value of a joint that is not in JOINTS"
                )
            locked[str(joint)] = float(x)
    return [str(j) for j in joints], cmap, locked


def _parse(path: Path) -> ast.Module:
    try:
        with path.open("rb") as stream:
            raw = stream.read(MAX_BYTES + 1)
    except OSError as exc:
        raise InputError(f"{path}: cannot read the coordinates: {exc.strerror or exc}") from None
    if len(raw) > MAX_BYTES:
        raise InputError(f"{path}: larger than 1 MiB (expected a formula file)")
    try:
        return ast.parse(raw.decode("utf-8"), filename=str(path))
    except UnicodeDecodeError:
        raise InputError(f"{path}: not UTF-8 text (expected a Python formula file)") from None
    except (SyntaxError, ValueError, RecursionError) as exc:
        line = getattr(exc, "lineno", None)
        raise InputError(f"{path}: not valid Python{f' (line {line})' if line else ''}") from None


def _assignment(node: ast.stmt) -> tuple[str | None, ast.expr | None]:
    """``NAME = value`` or ``NAME: type = value`` at the top of the file; (None, None) for anything else."""
    if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
        return node.targets[0].id, node.value
    if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.value is not None:
        return node.target.id, node.value
    return None, None


def _value(node: ast.expr, path: Path, name: str, constants: dict[str, Any]) -> Any:
    """A constant: literals, numbers with pi, + - * / **, the FUNCTIONS, and the file's earlier constants."""
    if (
        isinstance(node, ast.Constant)
        and isinstance(node.value, str | int | float)
        and not isinstance(node.value, bool)
    ):
        return node.value
    if isinstance(node, ast.List | ast.Tuple):
        items = [_value(x, path, name, constants) for x in node.elts]
        return items if isinstance(node, ast.List) else tuple(items)
    if isinstance(node, ast.Dict):
        return {
            _value(k, path, name, constants): _value(v, path, name, constants)
            for k, v in zip(node.keys, node.values, strict=True)
            if k
        }
    text = ast.unparse(node)
    bare = next((text[len(m) :] for m in _MODULES if text.startswith(m)), text)
    if isinstance(node, ast.Name | ast.Attribute) and bare in _CONSTANTS and (bare != text or text not in constants):
        return _CONSTANTS[bare]
    if isinstance(node, ast.Name) and node.id in constants:
        return constants[node.id]
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
        x = _number(_value(node.operand, path, name, constants), node, path, name)
        return -x if isinstance(node.op, ast.USub) else x
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add | ast.Sub | ast.Mult | ast.Div | ast.Pow):
        a = _number(_value(node.left, path, name, constants), node, path, name)
        b = _number(_value(node.right, path, name, constants), node, path, name)
        result = _arithmetic(node.op, a, b)
        if result is not None:
            return result
    if isinstance(node, ast.Call) and not node.keywords:
        function = ast.unparse(node.func)
        called = next((function[len(m) :] for m in _MODULES if function.startswith(m)), function)
        if called in FUNCTIONS and (called != function or function not in constants):
            args = [_number(_value(x, path, name, constants), node, path, name) for x in node.args]
            try:
                value = float(FUNCTIONS[called](*args))
            except (TypeError, ValueError, OverflowError):
                value = math.nan
            if math.isfinite(value):
                return value
    raise InputError(
        f"{path}: line {node.lineno}: {name} must be written with constants (numbers, pi, + - * / **, "
        f"math.radians(...) and the like, names assigned such a value above), got {text[:60]!r}"
    )


def _arithmetic(op: ast.operator, a: float, b: float) -> float | None:
    """The number a op b, or None where it is not a finite number (a division by zero, a huge power)."""
    try:
        if isinstance(op, ast.Pow):
            if abs(b) > MAX_POWER:
                return None
            value = a**b
        else:
            value = (
                {ast.Add: a + b, ast.Sub: a - b, ast.Mult: a * b}.get(type(op))
                if not isinstance(op, ast.Div)
                else a / b
            )
    except (ZeroDivisionError, OverflowError):
        return None
    return value if isinstance(value, float | int) and math.isfinite(value) else None


def _number(x: Any, node: ast.expr, path: Path, name: str) -> float:
    if isinstance(x, int | float) and not isinstance(x, bool):
        return float(x)
    raise InputError(f"{path}: line {node.lineno}: {name}: expected a number, got {ast.unparse(node)[:60]!r}")
