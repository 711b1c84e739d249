"""A formula's coordinates as a linear map of the URDF's joints: ``q_formula = A q_urdf + b``.

A ``KIND = "any"`` formula file (``robodyn check``) and ``robodyn derive --coordinates`` take the
same ``COORDINATES``, in one of two forms, over the joints of ``JOINTS`` (q_urdf in that order):

* ``{joint: (sign, offset)}``: ``q_i = sign * q_urdf_i + offset``, sign +1 or -1, a joint left out
  ``(1, 0)``; ``A`` is then diagonal and ``b`` the offsets (``OFFSETS`` does not go with it);
* a square matrix (a list of ``len(JOINTS)`` rows of numbers): ``A`` itself, invertible, with
  ``b`` from ``OFFSETS``, a list of ``len(JOINTS)`` numbers [rad | m] (default all 0). Absolute
  angles of a 3-link arm, theta1 = q1, theta2 = q1 + q2, theta3 = q1 + q2 + q3, are
  ``[[1, 0, 0], [1, 1, 0], [1, 1, 1]]``.

A row may not mix angles and lengths (:meth:`CoordinateMap.check_units`): a formula coordinate is
an angle [rad] or a length [m]. Imports nothing but NumPy and :mod:`robodyn.errors`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import InputError

Array = NDArray[np.float64]

# A matrix whose condition number passes this is singular to working precision: its inverse carries
# no correct digit (1 / eps = 4.5e15), and a formula's coordinates would not determine the joints.
SINGULAR_COND = 1e12


@dataclass(frozen=True, eq=False)
class CoordinateMap:
    """``q_formula = A q_urdf + b`` over ``joints`` (q_urdf in that order); ``A`` (n, n) invertible, ``b`` (n,)."""

    joints: tuple[str, ...]
    A: Array
    b: Array

    @classmethod
    def identity(cls, joints: Sequence[str]) -> CoordinateMap:
        """q_formula = q_urdf."""
        n = len(joints)
        return cls(tuple(joints), np.eye(n), np.zeros(n))

    @property
    def A_inv(self) -> Array:
        """A^-1 = d q_urdf / d q_formula, (n, n)."""
        return np.asarray(np.linalg.inv(self.A), dtype=np.float64)

    @property
    def diagonal(self) -> bool:
        """True for the ``{joint: (sign, offset)}`` form: A diagonal with entries +-1."""
        return bool(np.array_equal(self.A, np.diag(np.diag(self.A))) and np.all(np.abs(np.diag(self.A)) == 1.0))

    @property
    def signs(self) -> tuple[float, ...]:
        """The diagonal of A (the signs of the ``{joint: (sign, offset)}`` form)."""
        return tuple(float(x) for x in np.diag(self.A))

    def with_rows(self, A: Array, b: Array) -> CoordinateMap:
        """The same joints with another A and b (a candidate map, :mod:`robodyn.checker.hints`)."""
        return CoordinateMap(self.joints, np.asarray(A, dtype=np.float64), np.asarray(b, dtype=np.float64))

    def check_units(self, prismatic: Sequence[bool], where: str) -> tuple[bool, ...]:
        """Which formula coordinates are lengths; a row mixing a slide with a hinge is refused.

        Raises:
            InputError: row i has non-zero entries on both a prismatic and an angular joint.
        """
        out = []
        for i, row in enumerate(self.A):
            used = [int(j) for j in np.flatnonzero(row)]
            kinds = {bool(prismatic[j]) for j in used}
            if len(kinds) > 1:
                slides = [self.joints[j] for j in used if prismatic[j]]
                hinges = [self.joints[j] for j in used if not prismatic[j]]
                raise InputError(
                    f"{where}: row {i + 1} of COORDINATES adds the slide {', '.join(slides)} [m] to the hinge "
                    f"{', '.join(hinges)} [rad]; expected each q to be an angle or a length (mix joints of one kind)"
                )
            out.append(kinds == {True})
        return tuple(out)

    def describe(
        self,
        prismatic: Sequence[bool],
        number: Callable[[float], str] | None = None,
        *,
        units: bool = True,
        names: Sequence[str] = (),
    ) -> list[str]:
        """``q1 = joint1``, ``q2 = joint1 + joint2 + 3.14159 rad``: one string per formula coordinate.

        ``number`` writes an offset's magnitude (default ``%.6g``); with ``units`` its unit follows it;
        ``names``: the formula's own names of its coordinates (its ``NAMES``), in place of q1, q2, ...
        """
        write = number or (lambda x: f"{x:.6g}")
        out = []
        for i, row in enumerate(self.A):
            text = ""
            for j in np.flatnonzero(row):
                c = float(row[j])
                size = "" if abs(c) == 1.0 else f"{abs(c):.6g}*"
                if not text:
                    text = f"{'-' if c < 0 else ''}{size}{self.joints[j]}"
                else:
                    text += f" {'-' if c < 0 else '+'} {size}{self.joints[j]}"
            offset = float(self.b[i])
            if offset:
                unit = (" m" if prismatic[i] else " rad") if units else ""
                text += f" {'+' if offset > 0 else '-'} {write(abs(offset))}{unit}"
            out.append(f"{names[i] if names else f'q{i + 1}'} = {text}")
        return out


def coordinate_map(value: object, offsets: object, joints: Sequence[str], where: str) -> CoordinateMap:
    """``COORDINATES`` (None, a dict or a matrix) and ``OFFSETS`` (None or a list) over ``joints``, checked.

    Raises:
        InputError: one line naming ``where`` and what was expected.
    """
    n = len(joints)
    if value is None or isinstance(value, Mapping):
        if offsets is not None:
            raise InputError(
                f"{where}: OFFSETS goes with a COORDINATES matrix; with {{joint: (sign, offset)}} the offsets are "
                "in the pairs"
            )
        return _from_pairs(value or {}, tuple(joints), where)
    rows = _matrix(value, n, where)
    b = np.zeros(n) if offsets is None else _offsets(offsets, n, where)
    A = np.array(rows, dtype=np.float64)
    if not np.all(np.isfinite(A)):
        raise InputError(f"{where}: COORDINATES has a non-finite entry; expected finite numbers")
    cond = float(np.linalg.cond(A))
    if not cond < SINGULAR_COND:
        raise InputError(
            f"{where}: COORDINATES = {_short(value)} is singular (condition number {cond:.3g}); expected an invertible "
            "matrix, q_formula = A q_urdf + b, so that the formula's q determine the joints"
        )
    return CoordinateMap(tuple(joints), A, b)


def _from_pairs(value: Mapping[object, object], joints: tuple[str, ...], where: str) -> CoordinateMap:
    for joint in value:
        if joint not in joints:
            raise InputError(f"{where}: COORDINATES names {joint!r}, which is not in JOINTS ({', '.join(joints)})")
    signs, offsets = [], []
    for joint in joints:
        pair = value.get(joint, (1.0, 0.0))
        sign, offset = _pair(pair)
        if sign not in (1.0, -1.0):
            raise InputError(
                f"{where}: COORDINATES[{joint!r}] = {pair!r}; expected (sign, offset) with sign +1 or -1 "
                "(q_formula = sign * q_urdf + offset), or a matrix over JOINTS"
            )
        if not math.isfinite(offset):
            raise InputError(f"{where}: COORDINATES[{joint!r}] = {pair!r}; expected a finite offset [rad | m]")
        signs.append(sign)
        offsets.append(offset)
    return CoordinateMap(joints, np.diag(signs).astype(np.float64), np.array(offsets, dtype=np.float64))


def _matrix(value: object, n: int, where: str) -> list[list[float]]:
    expected = (
        f"expected {{joint: (sign, offset)}} or a {n}x{n} matrix over JOINTS (q_formula = A q_urdf + b), "
        "e.g. [[1, 0], [1, 1]] for absolute angles"
    )
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise InputError(f"{where}: COORDINATES = {_short(value)}; {expected}")
    rows = []
    for row in value:
        if not isinstance(row, (list, tuple, np.ndarray)) or len(row) != n:
            raise InputError(f"{where}: COORDINATES = {_short(value)}; {expected}")
        numbers = [_float(x) for x in row]
        if any(math.isnan(x) for x in numbers):
            raise InputError(f"{where}: COORDINATES has the row {_short(row)}; expected {n} finite numbers")
        rows.append(numbers)
    return rows


def _offsets(value: object, n: int, where: str) -> Array:
    if isinstance(value, (list, tuple)) and len(value) == n:
        b = np.array([_float(x) for x in value], dtype=np.float64)
        if np.all(np.isfinite(b)):
            return b
    raise InputError(
        f"{where}: OFFSETS = {_short(value)}; expected a list of {n} finite numbers [rad | m], b of q_formula = "
        "A q_urdf + b in the formula's order"
    )


def _pair(pair: object) -> tuple[float, float]:
    """(sign, offset) as floats; NaN for what is not a number (the caller names it)."""
    if not isinstance(pair, (tuple, list)) or len(pair) != 2:
        return math.nan, math.nan
    return _float(pair[0]), _float(pair[1])


def _float(x: object) -> float:
    """``x`` as a float when it is a real number (not a bool); NaN otherwise."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        return math.nan
    return float(x)


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 80 else f"{text[:77]}..."
