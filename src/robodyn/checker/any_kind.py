"""A formula file for any tree robot, in the user's own coordinates: the ``KIND = "any"`` contract.

The file defines

* ``KIND = "any"``;
* ``JOINTS``: the URDF joints (revolute, continuous or prismatic) the formula's q1, q2, ... stand for,
  in order (``["shoulder", "elbow"]``); every other moving joint is locked and welded to its parent;
* ``COORDINATES`` (optional): ``{joint: (sign, offset)}`` with ``q_formula = sign * q_urdf + offset``,
  sign +1 or -1 and offset a finite number [rad | m], a joint left out ``(1.0, 0.0)``; or a square
  matrix A over JOINTS, ``q_formula = A q_urdf + b``, A invertible, with ``OFFSETS`` (optional) the
  list b [rad | m] in the formula's order (:mod:`robodyn.model.coordinate_map`): absolute angles
  theta1 = q1, theta2 = q1 + q2 are ``[[1, 0], [1, 1]]``;
* ``LOCKED`` (optional): ``{joint: value}`` [rad | m], where the joints not in ``JOINTS`` are held
  (default: the neutral pose, 0);
* ``PARAMETERS = {name: number}`` or ``def parameters(robot) -> {name: number}``, where ``robot`` is
  robodyn's per-link table of the model the formula describes (:class:`robodyn.model.links.LinkTable`);
* ``NAMES`` (optional): the formula's names of its coordinates, ``["x", "phi1", "phi2"]`` (identifiers,
  distinct, one per joint of ``JOINTS``): ``--explain`` writes its terms in them (``cos(phi1)``,
  velocities ``phi1_dot``); default q1, q2, ... and v1, v2, ...;
* ``mass_matrix(q, p)`` (n, n) [kg m^2 | kg], ``coriolis_matrix(q, v, p)`` (n, n) (or
  ``coriolis_vector(q, v, p)`` (n,): C v alone, :mod:`robodyn.checker.velocity_terms`) and
  ``gravity(q, p)`` (n,) [N m | N], and optionally ``potential_energy(q, p)`` [J], with n = len(JOINTS),
  ``q`` and ``v`` (n,) in the formula's coordinates and ``p`` the parameters.

This module checks the contract where the file runs (its own process, :mod:`robodyn.checker.sandbox`);
each broken rule is one :class:`~robodyn.errors.FormulaError` line naming the file. The comparison
with Pinocchio, in the formula's coordinates, is :mod:`robodyn.checker.compare_any`.
"""

from __future__ import annotations

import keyword
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from robodyn.checker.constrained_kind import call_user, checked_parameters, independent_names
from robodyn.checker.velocity_terms import coriolis_function
from robodyn.errors import FormulaError, InputError
from robodyn.kinds.formula import Formula
from robodyn.model.coordinate_map import coordinate_map

KIND = "any"
MAX_JOINTS = 64  # the most joints a file may name (as a constrained file's INDEPENDENT)


@dataclass(frozen=True)
class AnyFormula(Formula):
    """A ``KIND = "any"`` file loaded in this process: a :class:`Formula` in the coordinates of ``independent``."""

    independent: tuple[str, ...] = field(default=(), kw_only=True)  # JOINTS, in the formula's order
    matrix: tuple[tuple[float, ...], ...] = field(default=(), kw_only=True)  # A of q_formula = A q_urdf + b
    offsets: tuple[float, ...] = field(default=(), kw_only=True)  # b [rad | m]
    locked: tuple[tuple[str, float], ...] = field(default=(), kw_only=True)  # LOCKED, as (joint, value)
    names: tuple[str, ...] = field(default=(), kw_only=True)  # NAMES: the coordinates' own names, or ()
    path: Path = field(default=Path(), kw_only=True)
    fixed_parameters: Mapping[str, float] | None = field(default=None, kw_only=True)
    read_parameters: Callable[..., object] | None = field(default=None, kw_only=True, compare=False, repr=False)

    def link_parameters(self, table: Any) -> dict[str, float]:
        """``PARAMETERS``, or the file's ``parameters(robot)`` with ``table`` the per-link table: checked."""
        if self.read_parameters is None:
            return dict(self.fixed_parameters or {})
        raw = call_user(self.read_parameters, "parameters", self.source, self.path, table)
        return checked_parameters(raw, self.source)


def load_any(module: ModuleType, source: str, path: Path, wrap: Callable[..., Any]) -> AnyFormula:
    """The ``KIND = "any"`` file ``module``; ``wrap(fn, name, shape, source, path)`` shape-checks a function."""
    joints = _joints(getattr(module, "JOINTS", None), source)
    try:
        cmap = coordinate_map(getattr(module, "COORDINATES", None), getattr(module, "OFFSETS", None), joints, source)
    except InputError as exc:
        raise FormulaError(str(exc)) from None
    locked = _locked(getattr(module, "LOCKED", None), joints, source)
    fixed = getattr(module, "PARAMETERS", None)
    reader = getattr(module, "parameters", None)
    if fixed is not None and reader is not None:
        raise FormulaError(f"{source}: defines both PARAMETERS and parameters(robot); keep one")
    if fixed is None and not callable(reader):
        raise FormulaError(
            f"{source}: define PARAMETERS = {{name: number}} or def parameters(robot) -> {{name: number}}"
        )
    n = len(joints)
    V = getattr(module, "potential_energy", None)
    C, form = coriolis_function(module, n, source, path, wrap)
    return AnyFormula(
        KIND,
        source,
        tuple(fixed) if fixed is not None else (),
        wrap(module.mass_matrix, "mass_matrix", (n, n), source, path),
        C,
        wrap(module.gravity, "gravity", (n,), source, path),
        wrap(V, "potential_energy", (), source, path) if callable(V) else None,
        n,
        form,
        independent=joints,
        matrix=tuple(tuple(float(x) for x in row) for row in cmap.A),
        offsets=tuple(float(x) for x in cmap.b),
        locked=locked,
        names=coordinate_names(getattr(module, "NAMES", None), len(joints), source),
        path=path,
        fixed_parameters=None if fixed is None else _fixed(fixed, source),
        read_parameters=reader if fixed is None else None,
    )


def _joints(value: object, source: str) -> tuple[str, ...]:
    """``JOINTS`` as distinct names (the rules of a constrained file's INDEPENDENT), said as JOINTS."""
    try:
        joints = independent_names(value, source)
    except FormulaError:
        raise FormulaError(
            f"{source}: JOINTS = {value!r}; expected a list of the URDF joints the formula's q1, q2, ... stand "
            'for, in order, e.g. JOINTS = ["shoulder", "elbow"]'
        ) from None
    if len(joints) > MAX_JOINTS:
        raise FormulaError(f"{source}: JOINTS names {len(joints)} joints; at most {MAX_JOINTS}")
    return joints


def _float(x: object) -> float:
    """``x`` as a float when it is a real number (not a bool); NaN otherwise."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        return math.nan
    return float(x)


def _locked(value: object, joints: tuple[str, ...], source: str) -> tuple[tuple[str, float], ...]:
    """``LOCKED`` as (joint, value) pairs of finite numbers, none of them in JOINTS."""
    if value is None:
        return ()
    if not isinstance(value, Mapping):
        raise FormulaError(
            f"{source}: LOCKED = {value!r}; expected {{joint: value}} [rad | m] for joints not in JOINTS"
        )
    out = []
    for joint, x in value.items():
        if not isinstance(joint, str):
            raise FormulaError(f"{source}: LOCKED has the key {joint!r}; expected joint names")
        if joint in joints:
            raise FormulaError(f"{source}: LOCKED names {joint!r}, which is in JOINTS: a joint moves or is locked")
        number = _float(x)
        if not math.isfinite(number):
            raise FormulaError(f"{source}: LOCKED[{joint!r}] = {x!r}; expected a finite number [rad | m]")
        out.append((joint, number))
    return tuple(out)


def coordinate_names(value: object, n: int, source: str) -> tuple[str, ...]:
    """``NAMES``: n distinct identifiers naming the formula's coordinates in order (None: ())."""
    if value is None:
        return ()
    expected = f'expected {n} distinct identifiers, one per joint of JOINTS, e.g. NAMES = ["x", "phi1"]'
    if not isinstance(value, (list, tuple)) or not all(isinstance(x, str) for x in value):
        raise FormulaError(f"{source}: NAMES = {value!r}; {expected}")
    if len(value) != n:
        raise FormulaError(f"{source}: NAMES has {len(value)} name(s) for {n} joint(s) in JOINTS; {expected}")
    bad = [x for x in value if not x.isidentifier() or keyword.iskeyword(x)]
    if bad:
        raise FormulaError(f"{source}: NAMES has {bad[0]!r}, which is not an identifier; {expected}")
    twice = [x for x in value if value.count(x) > 1]
    if twice:
        raise FormulaError(f"{source}: NAMES has {twice[0]!r} twice; {expected}")
    return tuple(value)


def _fixed(value: object, source: str) -> dict[str, float]:
    """``PARAMETERS`` checked as a parameters() return value, its errors said as PARAMETERS."""
    try:
        return checked_parameters(value, source)
    except FormulaError as exc:
        raise FormulaError(str(exc).replace("parameters()", "PARAMETERS").replace("must return", "must be")) from None


def loaded_header(formula: Formula) -> dict[str, Any]:
    """What robodyn learns of a ``KIND = "any"`` file when its process loads it (nothing for other kinds)."""
    if not isinstance(formula, AnyFormula):
        return {}
    return {
        "matrix": [list(row) for row in formula.matrix],
        "offsets": list(formula.offsets),
        "locked": [list(pair) for pair in formula.locked],
        "names": list(formula.names),
        "constant_parameters": formula.read_parameters is None,
    }


def serve(
    formula: Formula, header: Mapping[str, Any], arrays: Mapping[str, Any]
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The formula's process answering ``{"function": "parameters", "robot": table}`` (the reply to send)."""
    from robodyn.model.links import LinkTable

    if not isinstance(formula, AnyFormula):
        raise FormulaError(f"{formula.source}: KIND = {formula.kind!r} has no parameters(robot)")
    table = LinkTable.from_dict(header["robot"])
    return {"op": "parameters", "params": formula.link_parameters(table)}, {}
