"""A formula file's velocity terms: ``coriolis_matrix(q, v, p)`` (C), or ``coriolis_vector(q, v, p)`` (C v alone).

Many derivations stop at the vector C(q, v) v (Lagrange's equations give it directly) and never
write C out. Such a file defines ``coriolis_vector(q, v, p)`` -> (n,) in place of
``coriolis_matrix``; robodyn then checks C v and everything built from it (C v + G, inverse and
forward dynamics), and says that C itself and the skew property of dM/dt - 2C were not checked.

Inside robodyn the file's C v travels as a stand-in matrix (:func:`stand_in`), the rank-one
C~ = (C v) v^T / (v^T v), whose product with v is the file's C v to round-off: M a + C~ v + G and
M^-1 (tau - C~ v - G) are then the file's equations of motion. C~ is not the file's C (it has none)
and is never compared with one: the :class:`~robodyn.kinds.formula.Formula` says so by its
``coriolis_form = "vector"``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from robodyn.errors import FormulaError
from robodyn.kinds.formula import Array

MATRIX, VECTOR = "matrix", "vector"
BOTH_OPTIONS = "coriolis_matrix(q, v, p) (the matrix C) or coriolis_vector(q, v, p) (the vector C v)"


def defines_coriolis(module: ModuleType) -> bool:
    """True when the file defines one of the two (the caller names both when it does not)."""
    return callable(getattr(module, "coriolis_matrix", None)) or callable(getattr(module, "coriolis_vector", None))


def coriolis_function(
    module: ModuleType, n: int, source: str, path: Path, wrap: Callable[..., Callable[..., Array]]
) -> tuple[Callable[..., Array], str]:
    """(C(q, v, p) as an (n, n) function, ``"matrix"`` or ``"vector"``) from the file's C or C v.

    ``wrap(fn, name, shape, source, path)`` shape-checks the file's own function.
    """
    matrix, vector = getattr(module, "coriolis_matrix", None), getattr(module, "coriolis_vector", None)
    if callable(matrix) and callable(vector):
        raise FormulaError(f"{source}: defines both coriolis_matrix and coriolis_vector; keep one")
    if callable(matrix):
        return wrap(matrix, "coriolis_matrix", (n, n), source, path), MATRIX
    if callable(vector):
        return stand_in(wrap(vector, "coriolis_vector", (n,), source, path), source), VECTOR
    raise FormulaError(f"{source}: define {BOTH_OPTIONS}")


def stand_in(cv: Callable[..., Array], source: str) -> Callable[..., Array]:
    """C~(q, v, p) = (C v) v^T / (v^T v) from ``cv(q, v, p)`` -> C v: the matrix whose product with v is C v.

    At v = 0, C v must be 0 (it is quadratic in v); C~ is then 0.
    """

    def matrix(q: Any, v: Any, p: Any) -> Array:
        out = cv(q, v, p)
        vv = np.asarray(v, dtype=np.float64)
        speed2 = float(vv @ vv)
        if speed2 == 0.0:
            if np.any(out != 0.0):
                raise FormulaError(
                    f"{source}: coriolis_vector returned {out.tolist()} at v = 0; expected 0 (C v is quadratic in v: "
                    "gravity and applied forces go in gravity(q, p))"
                )
            return np.zeros((len(out), len(out)))
        return np.asarray(np.outer(out, vv) / speed2, dtype=np.float64)

    return matrix
