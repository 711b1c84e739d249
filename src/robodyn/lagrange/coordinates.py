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
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.errors import InputError
from robodyn.lagrange.trig import Trig
from robodyn.model.coordinate_map import CoordinateMap, coordinate_map

MAX_BYTES = 2**20  # a formula file is a few kB; this one is only parsed
MAX_POWER = 64.0  # the largest exponent of ** in a constant (no 10**10**10)
WHOLE_TOL = 1e-9  # an entry of A^-1 this close to a whole number is that number (A is written to ~1e-15)

_MODULES = ("math.", "np.", "numpy.")
_CONSTANTS = {"pi": math.pi, "tau": math.tau, "e": math.e}
FUNCTIONS: dict[str, Callable[..., float]] = {
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


@dataclass(frozen=True)
class Coordinate:
    """One formula coordinate: the URDF joint it stands for, ``q = sign * q_urdf + offset``.

    A list of these is the ``{joint: (sign, offset)}`` form; a general linear map is a
    :class:`~robodyn.model.coordinate_map.CoordinateMap` (:func:`derive` takes either).
    """

    joint: str
    joint_type: str  # revolute, continuous or prismatic
    sign: float = 1.0
    offset: float = 0.0  # [rad | m]

    @property
    def angular(self) -> bool:
        """True for a revolute or continuous joint."""
        return self.joint_type != "prismatic"


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


def coordinates_of(
    table: Any, coordinates: Sequence[Coordinate] | CoordinateMap | None, max_joints: int
) -> CoordinateMap:
    """The coordinates as q = A q_urdf + b, over every moving joint of ``table`` once (else InputError)."""
    names = tuple(table.joints)
    if len(names) > max_joints:
        raise InputError(
            f"{table.name} has {len(names)} moving joints; robodyn derive takes at most {max_joints} "
            f"(name at most {max_joints} in a --coordinates file's JOINTS: the others are locked)"
        )
    if coordinates is None:
        return CoordinateMap.identity([link.joint for link in table.links])
    if isinstance(coordinates, CoordinateMap):
        cmap = coordinates
    else:
        for c in coordinates:
            if c.sign not in (1.0, -1.0) or not np.isfinite(c.offset):
                raise InputError(f"coordinate of {c.joint}: sign must be +1 or -1 and the offset finite")
        cmap = CoordinateMap(
            tuple(c.joint for c in coordinates),
            np.diag([c.sign for c in coordinates]).astype(np.float64),
            np.array([c.offset for c in coordinates], dtype=np.float64),
        )
    given = list(cmap.joints)
    if sorted(given) != sorted(names) or len(set(given)) != len(given):
        raise InputError(f"the coordinates name joints {given}; expected each of {list(names)} once")
    return cmap


def whole_inverse(cmap: CoordinateMap, angular: Sequence[bool]) -> np.ndarray:
    """A^-1, its entries between angles rounded to the whole numbers they must be (else InputError)."""
    back = cmap.A_inv
    for j in range(len(back)):
        for k in range(len(back)):
            if angular[k] and abs(back[j, k] - round(back[j, k])) > WHOLE_TOL:
                raise InputError(
                    f"COORDINATES makes the joint {cmap.joints[j]} = ... {back[j, k]:+.6g} q{k + 1}: robodyn derive "
                    "needs whole numbers there (a joint angle as a whole combination of the formula's angles, so "
                    "that M is a trigonometric polynomial); robodyn check takes any invertible COORDINATES"
                )
            if angular[k]:
                back[j, k] = round(back[j, k])
    return back


def congruence(M_urdf: list[list[Trig]], back: np.ndarray, zero: Trig) -> list[list[Trig]]:
    """A^-T M_urdf A^-1 (back = A^-1); a +-1 diagonal only flips signs, exactly."""
    n = len(M_urdf)
    out = [[zero for _ in range(n)] for _ in range(n)]
    for a in range(n):
        for b in range(a, n):
            entry = zero
            for i in np.flatnonzero(back[:, a]):
                for j in np.flatnonzero(back[:, b]):
                    if M_urdf[i][j].terms:
                        entry = entry + M_urdf[i][j].scale(float(back[i, a] * back[j, b]))
            out[a][b] = out[b][a] = entry
    return out
