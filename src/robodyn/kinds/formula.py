"""The closed-form dynamics of a kind: written once as scalar functions, served three ways.

A built-in kind writes its Lagrangian closed form once, as four scalar functions of a parameter
sequence ``p`` (in the kind's ``PARAMS`` order) and the coordinates:

* ``mass(p, q...) -> (m11, m12, m22)``, or ``(m11,)`` for one degree of freedom;
* ``coriolis(p, q..., v...) -> (c11, c12, c21, c22)`` (Christoffel form), or ``(c11,)``;
* ``gravity(p, q...) -> (g1, g2)``, or ``(g1,)``;
* ``potential(p, q...) -> V``.

They use only arithmetic and NumPy ufuncs (``np.cos``, ``np.sin``), so the same functions are

* wrapped into the NumPy matrices of :class:`Formula` (``robodyn check``, the ``formula`` backend);
* compiled by numba for the fast path (:mod:`robodyn.sim.fast`);
* evaluated in extended precision by handing them ``np.longdouble`` numbers
  (:func:`accelerations`, the reference of the conditioning study).

A fix to a closed form is made in one place. Nothing here imports Pinocchio.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]
Params = Mapping[str, float]
MDOT_STEP = 1e-6  # [s] central difference of M along v: truncation ~1e-12, round-off ~eps/step = 2e-10
Scalar = Any  # a float, np.float64 or np.longdouble: the closed forms are generic in it


@dataclass(frozen=True)
class ClosedForm:
    """One kind's scalar closed form: ``PARAMS`` order, degrees of freedom and the four functions."""

    params: tuple[str, ...]
    dof: int
    mass: Callable[..., tuple[Scalar, ...]]
    coriolis: Callable[..., tuple[Scalar, ...]]
    gravity: Callable[..., tuple[Scalar, ...]]
    potential: Callable[..., Scalar]

    def __post_init__(self) -> None:
        if self.dof not in (1, 2):
            raise ValueError(f"closed forms have 1 or 2 degrees of freedom, got {self.dof}")

    def vector(self, p: Params, dtype: Any = np.float64) -> NDArray[Any]:
        """The parameters in ``PARAMS`` order as an array of ``dtype``."""
        return np.array([p[name] for name in self.params], dtype=dtype)

    # ------------------------------------------------------------------ NumPy matrices
    def mass_matrix(self, q: Array, p: Params) -> Array:
        """M(q), (dof, dof)."""
        return _symmetric(self.mass(self.vector(p), *q[: self.dof]), self.dof)

    def coriolis_matrix(self, q: Array, v: Array, p: Params) -> Array:
        """Christoffel-form C(q, v), (dof, dof)."""
        entries = self.coriolis(self.vector(p), *q[: self.dof], *v[: self.dof])
        return np.array(entries, dtype=np.float64).reshape(self.dof, self.dof)

    def gravity_vector(self, q: Array, p: Params) -> Array:
        """G(q) = dV/dq, (dof,)."""
        return np.array(self.gravity(self.vector(p), *q[: self.dof]), dtype=np.float64)

    def potential_energy(self, q: Array, p: Params) -> float:
        """V(q) [J] on the kind's own zero."""
        return float(self.potential(self.vector(p), *q[: self.dof]))

    def formula(self, kind: str, source: str) -> Formula:
        """The :class:`Formula` of this closed form."""
        return Formula(
            kind,
            source,
            self.params,
            self.mass_matrix,
            self.coriolis_matrix,
            self.gravity_vector,
            self.potential_energy,
            self.dof,
        )


def _symmetric(entries: Sequence[Scalar], dof: int) -> Array:
    if dof == 1:
        return np.array([[entries[0]]], dtype=np.float64)
    m11, m12, m22 = entries
    return np.array([[m11, m12], [m12, m22]], dtype=np.float64)


def accelerations(
    form: ClosedForm, p: NDArray[Any], q: Sequence[Scalar], v: Sequence[Scalar], tau: Sequence[Scalar]
) -> tuple[Scalar, ...]:
    """M^-1 (tau - C v - G) in the number type of ``p``, ``q``, ``v`` and ``tau`` (Cramer's rule).

    Generic in the scalar type: given ``np.longdouble`` numbers it evaluates the closed form in
    extended precision (64-bit mantissa), the reference against which float64 backends are judged.
    """
    n = form.dof
    M = form.mass(p, *q[:n])
    C = form.coriolis(p, *q[:n], *v[:n])
    G = form.gravity(p, *q[:n])
    if n == 1:
        return ((tau[0] - C[0] * v[0] - G[0]) / M[0],)
    r0 = tau[0] - (C[0] * v[0] + C[1] * v[1]) - G[0]
    r1 = tau[1] - (C[2] * v[0] + C[3] * v[1]) - G[1]
    return solve_2x2(M[0], M[1], M[2], r0, r1)


def solve_2x2(m11: Scalar, m12: Scalar, m22: Scalar, r0: Scalar, r1: Scalar) -> tuple[Scalar, Scalar]:
    """The solution of [[m11, m12], [m12, m22]] x = r by Cramer's rule (det > 0 for any physical M)."""
    det = m11 * m22 - m12 * m12
    return (m22 * r0 - m12 * r1) / det, (m11 * r1 - m12 * r0) / det


@dataclass(frozen=True)
class Formula:
    """A set of closed-form dynamics for one kind of system, as NumPy matrices.

    ``mass_matrix(q, p)`` -> (n, n), ``coriolis_matrix(q, v, p)`` -> (n, n) and
    ``gravity(q, p)`` -> (n,) in Pinocchio's (link) coordinates; ``potential_energy(q, p)``
    [J] is optional (None when a user's file does not define it).

    ``coriolis_form`` is ``"matrix"`` when ``coriolis_matrix`` is the formula's own C, and ``"vector"``
    when the formula gives only C v (a user's ``coriolis_vector``): ``coriolis_matrix`` is then a
    stand-in whose product with v is that C v (:mod:`robodyn.checker.velocity_terms`), right in every
    equation of motion but not itself a C to compare.
    """

    kind: str
    source: str
    param_names: tuple[str, ...]
    mass_matrix: Callable[[Array, Params], Array]
    coriolis_matrix: Callable[[Array, Array, Params], Array]
    gravity: Callable[[Array, Params], Array]
    potential_energy: Callable[[Array, Params], float | Array] | None = None
    dof: int = 2
    coriolis_form: str = "matrix"

    def nle(self, q: Array, v: Array, p: Params) -> Array:
        """C(q, v) v + G(q)."""
        return self.coriolis_matrix(q, v, p) @ v + self.gravity(q, p)

    def momentum_rate(self, q: Array, v: Array, tau: Array, p: Params) -> Array:
        """dp/dt for p = M(q) v: tau + C(q, v)^T v - G(q) (dM/dt = C + C^T for the Christoffel C).

        A formula that gives only C v has no C^T: dp/dt = dM/dt v + tau - C v - G, with dM/dt along v
        by a central difference of step ``MDOT_STEP`` (truncation ~ step^2 |M''| |v|^3).
        """
        if self.coriolis_form == "vector":
            h = MDOT_STEP
            Mdot = (self.mass_matrix(q + h * v, p) - self.mass_matrix(q - h * v, p)) / (2 * h)
            return Mdot @ v + tau - self.nle(q, v, p)
        return tau + self.coriolis_matrix(q, v, p).T @ v - self.gravity(q, p)

    def inverse_dynamics(self, q: Array, v: Array, a: Array, p: Params) -> Array:
        """Tau = M a + C v + G."""
        return self.mass_matrix(q, p) @ a + self.nle(q, v, p)

    def forward_dynamics(self, q: Array, v: Array, tau: Array, p: Params) -> Array:
        """A = M^-1 (tau - C v - G), by a linear solve."""
        return np.asarray(np.linalg.solve(self.mass_matrix(q, p), tau - self.nle(q, v, p)), dtype=np.float64)

    def kinetic_energy(self, q: Array, v: Array, p: Params) -> float:
        """T = 1/2 v^T M v [J]."""
        return 0.5 * float(v @ self.mass_matrix(q, p) @ v)
