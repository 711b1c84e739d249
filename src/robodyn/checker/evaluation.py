"""A formula evaluated at a batch of points in one call: where (:class:`Points`), what came back (:class:`Values`).

``robodyn check`` needs M, C, G (and V) of a formula at a few hundred points. A user's formula
file runs in a process of its own (:mod:`robodyn.checker.sandbox`), so the points go there in one
message and the values come back in one: one round trip per check, not one per call. A built-in
kind is evaluated in-process by the same :func:`evaluate`. Each function is evaluated over all of
its points before the next one starts, so that a formula that never returns can be named.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.kinds.formula import Formula

Array = NDArray[np.float64]
Params = Mapping[str, float]

FUNCTIONS = ("mass_matrix", "coriolis_matrix", "gravity", "potential_energy")
"""The functions of a formula, in the order :func:`evaluate` runs them."""


@dataclass(frozen=True)
class Points:
    """Where to evaluate each function: one state per row, float64.

    ``mass`` (k_M, nq) for M(q); ``coriolis_q`` (k_C, nq) with ``coriolis_v`` (k_C, nv) for C(q, v);
    ``gravity`` (k_G, nq) for G(q); ``potential`` (k_V, nq) for V(q). A function with no rows is not called.
    """

    mass: Array
    coriolis_q: Array
    coriolis_v: Array
    gravity: Array
    potential: Array

    @classmethod
    def only(cls, function: str, q: Array, v: Array | None = None) -> Points:
        """One point for ``function`` (``"mass_matrix"``...), none for the others."""
        q_row = np.asarray(q, dtype=np.float64).reshape(1, -1)
        v_row = np.empty((1, 0)) if v is None else np.asarray(v, dtype=np.float64).reshape(1, -1)

        def rows(name: str, a: Array) -> Array:
            return a if name == function else a[:0]

        return cls(
            rows("mass_matrix", q_row),
            rows("coriolis_matrix", q_row),
            rows("coriolis_matrix", v_row),
            rows("gravity", q_row),
            rows("potential_energy", q_row),
        )

    def count(self, function: str) -> int:
        """Number of points at which ``function`` is evaluated."""
        return len(self.arguments(function)[0])

    def arguments(self, function: str) -> tuple[Array, ...]:
        """The state arrays ``function`` takes, before ``p``: ``(q,)`` or ``(q, v)``."""
        if function == "coriolis_matrix":
            return self.coriolis_q, self.coriolis_v
        return ({"mass_matrix": self.mass, "gravity": self.gravity, "potential_energy": self.potential}[function],)


@dataclass(frozen=True)
class Values:
    """A formula's values at :class:`Points`: M (k_M, n, n) [kg m^2], C (k_C, n, n), G (k_G, n) [N m], V (k_V,) [J]."""

    mass_matrix: Array
    coriolis_matrix: Array
    gravity: Array
    potential_energy: Array

    def of(self, function: str) -> Array:
        """The values of ``function`` (one of :data:`FUNCTIONS`)."""
        return {
            "mass_matrix": self.mass_matrix,
            "coriolis_matrix": self.coriolis_matrix,
            "gravity": self.gravity,
            "potential_energy": self.potential_energy,
        }[function]


def value_shape(function: str, dof: int) -> tuple[int, ...]:
    """Shape of one value of ``function`` for a formula of ``dof`` degrees of freedom."""
    return {"mass_matrix": (dof, dof), "coriolis_matrix": (dof, dof), "gravity": (dof,), "potential_energy": ()}[
        function
    ]


def evaluate(formula: Formula, p: Params, points: Points, *, on_start: Callable[[str], None] | None = None) -> Values:
    """Every function of ``formula`` at its ``points``, with parameters ``p``.

    ``on_start(function)`` is called before each function with points starts (the formula's
    process reports it, so a hang names the function). Each function receives a fresh copy
    of its state, so a formula that writes into ``q`` changes nothing else.

    Raises:
        ValueError: potential-energy points for a formula without ``potential_energy``.
        FormulaError: whatever a user's function does wrong (see :mod:`robodyn.checker.file_contract`).
    """
    functions: dict[str, Callable[..., Any] | None] = {
        "mass_matrix": formula.mass_matrix,
        "coriolis_matrix": formula.coriolis_matrix,
        "gravity": formula.gravity,
        "potential_energy": formula.potential_energy,
    }
    out = {}
    for name in FUNCTIONS:
        arguments = points.arguments(name)
        k = len(arguments[0])
        values = np.empty((k, *value_shape(name, formula.dof)))
        fn = functions[name]
        if k and fn is None:
            raise ValueError(f"{formula.source} defines no {name}, yet {k} point(s) ask for it")
        if k and fn is not None:
            if on_start is not None:
                on_start(name)
            for i in range(k):
                values[i] = fn(*(a[i].copy() for a in arguments), p)
        out[name] = values
    return Values(out["mass_matrix"], out["coriolis_matrix"], out["gravity"], out["potential_energy"])
