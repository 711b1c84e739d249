"""A closed chain's reduced Lagrangian in a user's formula file: the contract, checked where the file runs.

A formula file with ``KIND = "constrained"`` writes the dynamics of a constrained scene (loops,
springs) in its independent coordinates, the way a textbook derives them (Example 19.3: the
linkage in theta). It defines

* ``INDEPENDENT``: the URDF joints whose coordinates are the formula's, in order (``("joint_a",)``);
* ``parameters(scene) -> {name: number}``: the parameters ``p`` its functions take; ``scene`` is
  the scene file's path (a str) when the check has one, else None (the caller then gives ``p``);
* ``mass_matrix(q, p)`` (n, n) [kg m^2], ``coriolis_matrix(q, v, p)`` (n, n) [kg m^2/s] and
  ``gravity(q, p)`` (n,) [N m], the springs' moments included, so that
  ``M q'' + C q' + G = tau`` on the loop; optionally ``potential_energy(q, p)`` [J] (springs included);
* ``on_the_loop(q, v, p) -> ({joint: q}, {joint: v})``: the full state of every joint of the
  model on the loop for the independent (q, v) [rad | m, rad/s | m/s]; a continuous joint by
  its angle.

``q`` and ``v`` are (n,) arrays of the independent coordinates (n = len(INDEPENDENT)).
This module holds what is checked where the file runs (in its own process,
:mod:`robodyn.checker.sandbox`): :class:`ConstrainedFormula` and the batch calls
:func:`loop_states` and :func:`checked_parameters`, whose errors are one
:class:`~robodyn.errors.FormulaError` line naming the file, the function and the user's line.
The comparison with Pinocchio is :mod:`robodyn.checker.compare_constrained`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.errors import FormulaError
from robodyn.fileio import is_number
from robodyn.kinds.formula import Array, Formula, Params
from robodyn.user_import import at_line, exit_call

KIND = "constrained"
FUNCTIONS = ("parameters", "on_the_loop")
"""What a constrained file defines beyond mass_matrix, coriolis_matrix and gravity."""
MAX_INDEPENDENT = 64  # the most independent coordinates a file may name (a model has at most 200 DoF)


@dataclass(frozen=True)
class LoopStates:
    """Full states on the loop: ``joints`` (m names), ``q`` and ``v`` (k, m) [rad | m, rad/s | m/s]."""

    joints: tuple[str, ...]
    q: Array
    v: Array


@dataclass(frozen=True)
class ConstrainedFormula(Formula):
    """A constrained formula loaded in this process: a :class:`Formula` in ``independent``, plus its two maps."""

    independent: tuple[str, ...] = field(default=(), kw_only=True)
    path: Path = field(default=Path(), kw_only=True)
    read_parameters: Callable[..., object] | None = field(default=None, kw_only=True, compare=False, repr=False)
    to_the_loop: Callable[..., object] | None = field(default=None, kw_only=True, compare=False, repr=False)

    def parameters(self, scene: str | None) -> dict[str, float]:
        """The file's ``parameters(scene)``, checked: names to finite numbers."""
        if self.read_parameters is None:
            raise FormulaError(f"{self.source}: defines no parameters(scene)")
        raw = call_user(self.read_parameters, "parameters", self.source, self.path, scene)
        return checked_parameters(raw, self.source)

    def loop_states(self, q: Array, v: Array, p: Params) -> LoopStates:
        """The file's ``on_the_loop`` at every row of q, v (k, n): the full states, checked."""
        if self.to_the_loop is None:
            raise FormulaError(f"{self.source}: defines no on_the_loop(q, v, p)")
        return loop_states(self.to_the_loop, q, v, p, self.source, self.path)


def independent_names(value: object, source: str) -> tuple[str, ...]:
    """``INDEPENDENT`` as a tuple of distinct joint names, or one FormulaError line saying what came."""
    expected = 'a tuple of the URDF joints the formula is written in, e.g. INDEPENDENT = ("joint_a",)'
    if isinstance(value, str) or not isinstance(value, (tuple, list)) or not value:
        raise FormulaError(f"{source}: INDEPENDENT = {value!r}; expected {expected}")
    if len(value) > MAX_INDEPENDENT or not all(isinstance(n, str) and n for n in value):
        raise FormulaError(f"{source}: INDEPENDENT = {value!r}; expected {expected}")
    if len(set(value)) != len(value):
        raise FormulaError(f"{source}: INDEPENDENT names a joint twice: {value!r}")
    return tuple(value)


def checked_parameters(raw: object, source: str) -> dict[str, float]:
    """``{name: float}`` from what ``parameters`` returned; a FormulaError line when it is not that."""
    if not isinstance(raw, Mapping):
        raise FormulaError(f"{source}: parameters() must return {{name: number}}, got {type(raw).__name__}")
    out = {}
    for key, value in raw.items():
        if not isinstance(key, str):
            raise FormulaError(f"{source}: parameters() returned the key {key!r}; expected names (strings)")
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise FormulaError(f"{source}: parameters()[{key!r}] is {type(value).__name__}; expected a number")
        if not is_number(value):
            raise FormulaError(f"{source}: parameters()[{key!r}] = {value!r}; expected a finite number")
        out[key] = float(value)
    return out


def call_user(fn: Callable[..., object], name: str, source: str, path: Path, *args: object) -> object:
    """``fn(*args)``; what it raises (or a ``sys.exit``) is one FormulaError naming ``name`` and the user's line."""
    try:
        return fn(*args)
    except FormulaError:
        raise
    except SystemExit as exc:
        raise FormulaError(f"{source}: {name} called {exit_call(exc)}{at_line(exc, path)}") from None
    except Exception as exc:  # a user's function can raise anything
        text = str(exc).splitlines()[0] if str(exc) else ""
        raise FormulaError(f"{source}: {name} raised {type(exc).__name__}: {text}{at_line(exc, path)}") from None


def loop_states(
    fn: Callable[..., object], q: Array, v: Array, p: Params, source: str, path: Path = Path()
) -> LoopStates:
    """``on_the_loop`` at each row of ``q``, ``v`` (k, n); every sample names the same joints, with finite numbers."""
    names: tuple[str, ...] | None = None
    rows_q: list[list[float]] = []
    rows_v: list[list[float]] = []
    for k in range(len(q)):
        out = call_user(fn, "on_the_loop", source, path, q[k].copy(), v[k].copy(), dict(p))
        if not (isinstance(out, (tuple, list)) and len(out) == 2 and all(isinstance(m, Mapping) for m in out)):
            raise FormulaError(
                f"{source}: on_the_loop returned {type(out).__name__}; expected ({{joint: q}}, {{joint: v}})"
            )
        q_map, v_map = out
        keys = tuple(str(name) for name in q_map)
        if set(keys) != {str(name) for name in v_map}:
            raise FormulaError(
                f"{source}: on_the_loop's q and v name different joints: {sorted(q_map)} against {sorted(v_map)}"
            )
        if names is None:
            names = keys
        elif set(keys) != set(names):
            raise FormulaError(
                f"{source}: on_the_loop named joints {sorted(keys)} at q = {q[k].tolist()}, {sorted(names)} before"
            )
        rows_q.append([_number(q_map[n], "q", n, source) for n in names])
        rows_v.append([_number(v_map[n], "v", n, source) for n in names])
    joints = names or ()
    shape = (len(q), len(joints))
    q_full, v_full = (np.array(rows, dtype=np.float64).reshape(shape) for rows in (rows_q, rows_v))
    return LoopStates(joints, q_full, v_full)


def _number(value: Any, what: str, joint: str, source: str) -> float:
    try:
        array = np.asarray(value)
        if array.dtype.kind not in "fiu":  # complex (its imaginary part would be dropped), strings, objects
            raise TypeError
        x = float(array.astype(np.float64).reshape(()))
    except (TypeError, ValueError):
        raise FormulaError(
            f"{source}: on_the_loop's {what}[{joint!r}] is {type(value).__name__}; expected a number"
        ) from None
    if not math.isfinite(x):
        raise FormulaError(f"{source}: on_the_loop's {what}[{joint!r}] = {x!r}; expected a finite number")
    return x


def serve(
    formula: Formula, header: Mapping[str, Any], arrays: Mapping[str, Array]
) -> tuple[dict[str, Any], dict[str, Array]]:
    """The formula's process answering a ``call`` request: ``parameters`` or ``on_the_loop`` (the reply to send)."""
    if not isinstance(formula, ConstrainedFormula):
        raise FormulaError(f"{formula.source}: KIND = {formula.kind!r} has no {header.get('function')}")
    if header.get("function") == "parameters":
        scene = header.get("scene")
        return {"op": "parameters", "params": formula.parameters(scene if isinstance(scene, str) else None)}, {}
    if header.get("function") == "on_the_loop":
        states = formula.loop_states(arrays["q"], arrays["v"], header["params"])
        return {"op": "loop", "joints": list(states.joints)}, {"q": states.q, "v": states.v}
    raise FormulaError(f"{formula.source}: robodyn asked for an unknown function {header.get('function')!r}")
