"""Butcher tableaux: the coefficients of explicit Runge--Kutta methods, checked on construction.

A :class:`ButcherTableau` is a frozen dataclass that refuses (with ``ValueError``) a matrix
that is not strictly lower triangular, a row that does not sum to its node, or weights that
do not sum to 1. The built-in tableaux -- classic RK4, Heun and Dormand--Prince 5(4) -- live here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Butcher tableaux are checked to this absolute tolerance: their coefficients are exact
# rationals printed as doubles, so the sums are exact up to a few ulps.
TABLEAU_TOL = 1e-12


@dataclass(frozen=True)
class ButcherTableau:
    """Coefficients of an explicit Runge--Kutta method, checked on construction.

    ``a`` is strictly lower triangular (s x s), ``b`` the weights (s,), ``c`` the nodes
    (s,), and ``b_error`` (optional) the weights of the embedded lower-order solution.

    Raises:
        ValueError: shapes disagree, ``a`` is not strictly lower triangular, a row of ``a``
            does not sum to its node, or a set of weights does not sum to 1.
    """

    name: str
    a: tuple[tuple[float, ...], ...]
    b: tuple[float, ...]
    c: tuple[float, ...]
    order: int
    b_error: tuple[float, ...] | None = None
    error_order: int | None = None

    def __post_init__(self) -> None:
        s = len(self.b)
        if len(self.c) != s or len(self.a) != s or any(len(row) != s for row in self.a):
            raise ValueError(f"tableau {self.name!r}: a must be {s}x{s} and c of length {s} to match b")
        A = np.array(self.a, dtype=np.float64)
        if np.any(np.triu(A) != 0.0):
            raise ValueError(f"tableau {self.name!r}: a must be strictly lower triangular (explicit method)")
        sums = A.sum(axis=1)
        bad = np.flatnonzero(np.abs(sums - np.array(self.c)) > TABLEAU_TOL)
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"tableau {self.name!r}: row {i} of a sums to {sums[i]!r}, expected c[{i}] = {self.c[i]!r}"
            )
        for label, weights in (("b", self.b), ("b_error", self.b_error)):
            if weights is None:
                continue
            if len(weights) != s:
                raise ValueError(f"tableau {self.name!r}: {label} must have {s} entries, got {len(weights)}")
            if abs(sum(weights) - 1.0) > TABLEAU_TOL:
                raise ValueError(f"tableau {self.name!r}: weights {label} sum to {sum(weights)!r}, expected 1")
        if self.order < 1:
            raise ValueError(f"tableau {self.name!r}: order must be >= 1, got {self.order}")
        if (self.b_error is None) != (self.error_order is None):
            raise ValueError(f"tableau {self.name!r}: b_error and error_order go together")

    @property
    def stages(self) -> int:
        """Number of stages s (rates evaluations per step)."""
        return len(self.b)

    @property
    def fsal(self) -> bool:
        """First same as last: the last stage is evaluated at the step's end point."""
        return self.c[-1] == 1.0 and tuple(self.a[-1]) == tuple(self.b)


CLASSIC_RK4 = ButcherTableau(
    name="rk4",
    a=((0, 0, 0, 0), (0.5, 0, 0, 0), (0, 0.5, 0, 0), (0, 0, 1, 0)),
    b=(1 / 6, 1 / 3, 1 / 3, 1 / 6),
    c=(0, 0.5, 0.5, 1),
    order=4,
)

HEUN = ButcherTableau(name="heun", a=((0, 0), (1, 0)), b=(0.5, 0.5), c=(0, 1), order=2)

# Dormand and Prince (1980), "A family of embedded Runge-Kutta formulae": 5th-order
# solution b, 4th-order embedded solution b_error, first same as last.
DORMAND_PRINCE_54 = ButcherTableau(
    name="dopri5",
    a=(
        (0, 0, 0, 0, 0, 0, 0),
        (1 / 5, 0, 0, 0, 0, 0, 0),
        (3 / 40, 9 / 40, 0, 0, 0, 0, 0),
        (44 / 45, -56 / 15, 32 / 9, 0, 0, 0, 0),
        (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0, 0, 0),
        (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0, 0),
        (35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0),
    ),
    b=(35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0),
    c=(0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1, 1),
    order=5,
    b_error=(5179 / 57600, 0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40),
    error_order=4,
)
