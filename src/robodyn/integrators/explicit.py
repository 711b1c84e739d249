"""Explicit one-step methods: explicit Euler and the explicit Runge--Kutta family (Heun, RK4).

Stages on a manifold are taken as ``q_i = q (+) h sum_j a_ij v_j``. That is exact Lie-group
Runge--Kutta for the abelian joints (revolute, prismatic and the ``continuous`` joint's SO(2));
on free-flyer or spherical joints the declared order is only guaranteed up to 2. The running
integrals w in u = [v, w] ride along in the same stages as v.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from robodyn.integrators.base import FixedStepIntegrator
from robodyn.integrators.problem import Array, SecondOrderProblem
from robodyn.integrators.tableau import CLASSIC_RK4, ButcherTableau


@dataclass(frozen=True)
class ExplicitEuler(FixedStepIntegrator):
    """q1 = q (+) h v, u1 = u + h F(q, u): first order, not symplectic, energy grows."""

    def step(self, problem: SecondOrderProblem, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array]:
        """One explicit Euler step: both updates read the OLD state."""
        k = problem.rates(t, q, u)
        return problem.integrate(q, h * u[: problem.nv]), u + h * k, k


@dataclass(frozen=True)
class ExplicitRungeKutta(FixedStepIntegrator):
    """Any explicit Runge--Kutta method given by its (checked) Butcher tableau.

    Raises:
        ValueError: the declared ``order`` is not the tableau's.
    """

    tableau: ButcherTableau = field(default=CLASSIC_RK4)

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.order != self.tableau.order:
            raise ValueError(f"integrator {self.name!r} declares order {self.order}, its tableau {self.tableau.order}")
        # Non-zero coefficients only, as (stage index, coefficient) pairs per row.
        rows = tuple(tuple((j, float(x)) for j, x in enumerate(row) if x != 0.0) for row in self.tableau.a)
        weights = tuple((j, float(x)) for j, x in enumerate(self.tableau.b) if x != 0.0)
        object.__setattr__(self, "_rows", rows)
        object.__setattr__(self, "_weights", weights)

    def step(self, problem: SecondOrderProblem, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array]:
        """One Runge--Kutta step; stage velocities are the u-stages' first nv entries."""
        nv = problem.nv
        rows: tuple[tuple[tuple[int, float], ...], ...] = self._rows  # type: ignore[attr-defined]
        c = self.tableau.c
        U = [u]
        K = [problem.rates(t, q, u)]
        for i in range(1, len(rows)):
            if not rows[i]:  # a row of zeros: the stage is the start point
                U.append(u)
                K.append(problem.rates(t + c[i] * h, q, u))
                continue
            dq, du = _combine(rows[i], h, U, K, nv)
            ui = u + du
            U.append(ui)
            K.append(problem.rates(t + c[i] * h, problem.integrate(q, dq), ui))
        dq, du = _combine(self._weights, h, U, K, nv)  # type: ignore[attr-defined]
        return problem.integrate(q, dq), u + du, K[0]


def _combine(
    coefficients: tuple[tuple[int, float], ...], h: float, U: list[Array], K: list[Array], nv: int
) -> tuple[Array, Array]:
    """(h sum_j c_j v_j, h sum_j c_j k_j) over the non-zero (j, c_j): a stage or the step's increment."""
    (j, x), *rest = coefficients
    hx = h * x
    dq = hx * U[j][:nv]
    du = hx * K[j]
    for j, x in rest:
        hx = h * x
        dq = dq + hx * U[j][:nv]
        du = du + hx * K[j]
    return dq, du


@dataclass(frozen=True)
class ClassicRK4(ExplicitRungeKutta):
    """The classic RK4 tableau, stepped by hand: the same arithmetic as a bare NumPy loop.

    The generic :class:`ExplicitRungeKutta` step loops over the tableau; this one writes
    the four stages out (half the small-array operations), which is what keeps
    ``simulate``'s overhead over a hand-written ``pin.aba`` loop small. It has two branches:
    plain arrays (flat q, no running integrals: u is v), and the general one (q on a
    manifold, or running integrals w carried in u).

    Raises:
        ValueError: the tableau is not :data:`CLASSIC_RK4`.
    """

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.tableau != CLASSIC_RK4:
            raise ValueError(f"integrator {self.name!r}: ClassicRK4 steps the classic RK4 tableau only")

    def step(self, problem: SecondOrderProblem, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array]:
        """One classic RK4 step."""
        rates = problem.rates
        h2 = 0.5 * h
        th = t + h2
        k1 = rates(t, q, u)
        u2 = u + h2 * k1
        if problem.nw == 0 and problem.flat:  # u is v and q lives in R^n: the bare-loop arithmetic
            k2 = rates(th, q + h2 * u, u2)
            u3 = u + h2 * k2
            k3 = rates(th, q + h2 * u2, u3)
            u4 = u + h * k3
            k4 = rates(t + h, q + h * u3, u4)
            h6 = h / 6.0
            return q + h6 * (u + 2.0 * (u2 + u3) + u4), u + h6 * (k1 + 2.0 * (k2 + k3) + k4), k1
        nv = problem.nv  # q on a manifold, or running integrals after v in u
        integrate = problem.integrate
        k2 = rates(th, integrate(q, h2 * u[:nv]), u2)
        u3 = u + h2 * k2
        k3 = rates(th, integrate(q, h2 * u2[:nv]), u3)
        u4 = u + h * k3
        k4 = rates(t + h, integrate(q, h * u3[:nv]), u4)
        h6 = h / 6.0
        q1 = integrate(q, h6 * (u[:nv] + 2.0 * (u2[:nv] + u3[:nv]) + u4[:nv]))
        return q1, u + h6 * (k1 + 2.0 * (k2 + k3) + k4), k1
