"""Partitioned and symplectic methods: kick-drift Euler, symplectic Euler and the implicit midpoint rule.

Each shows its update order in code: first the velocity or momentum (the kick), then the
configuration (the drift) with the NEW velocity. Kick-drift Euler works in (q, v) and is
explicit; symplectic Euler and the implicit midpoint rule work in the canonical pair
(q, p = M(q) v), solving for the velocity that enters the drift by iteration, and so are
symplectic for any mass matrix M(q).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robodyn.errors import StepError
from robodyn.integrators.base import FixedStepIntegrator
from robodyn.integrators.problem import Array, SecondOrderProblem

# The iterations of the symplectic methods (Newton for the midpoint rule, fixed point for
# symplectic Euler) stop when the residual is below NEWTON_RTOL times the step's velocity
# scale |v0| + h |a0| (or stalls within NEWTON_STALL times that: rounding noise of the
# dynamics), and fail after NEWTON_MAX_ITER iterations. 1e-14 a step keeps the energy
# error after 1e5 steps far below the methods' own O(h) or O(h^2) oscillation.
NEWTON_RTOL = 1e-14
NEWTON_STALL = 1e3
NEWTON_MAX_ITER = 30


@dataclass(frozen=True)
class SemiImplicitEuler(FixedStepIntegrator):
    """Kick-drift Euler in (q, v): v1 = v + h a(t, q, v), then q1 = q (+) h v1.

    Symplectic only when M is constant (e.g. a single joint, or plain arrays); on robots
    whose M(q) varies (the Pendubot) its energy drifts. First order, one evaluation a step.
    """

    def step(self, problem: SecondOrderProblem, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array]:
        """One kick-then-drift step."""
        k = problem.rates(t, q, u)
        u1 = u + h * k  # 1. kick: new velocity from the old configuration
        q1 = problem.integrate(q, h * u1[: problem.nv])  # 2. drift: move with the NEW velocity
        return q1, u1, k


def _velocity_scale(v: Array, a: Array, h: float) -> float:
    """|v| + h |a| (max norms) [m/s or rad/s]: the size a step's velocity iteration is measured against."""
    return float(np.max(np.abs(v))) + h * float(np.max(np.abs(a))) + 1e-300


def _converged(size: float, previous: float, tol: float) -> bool:
    """A fixed-point or Newton iteration is done: below tol, or stalled just above it."""
    return size <= tol or (size >= previous and size <= NEWTON_STALL * tol)


@dataclass(frozen=True)
class SymplecticEuler(FixedStepIntegrator):
    """Symplectic Euler in canonical coordinates (q, p = M(q) v): first order, symplectic.

    p1 = p0 + h F(t, q0, v*) with v* = M(q0)^-1 p1 (solved by fixed-point iteration:
    explicit when F does not depend on v), then q1 = q0 (+) h v*, and the new velocity
    v1 = M(q1)^-1 p1. F = dp/dt = tau + C^T v - G (``problem.momentum_rates``). The
    running integrals take the rate at (q0, v*).
    """

    def step(self, problem: SecondOrderProblem, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array]:
        """One step; raises :class:`StepError` if the fixed-point iteration fails."""
        nv = problem.nv
        k0 = problem.rates(t, q, u)
        M0 = problem.mass_matrix(q)
        M0_inv = np.linalg.inv(M0)  # one inverse a step; the iteration only multiplies
        p0 = M0 @ u[:nv]
        us = u + h * k0  # predictor for v* (and a placeholder tail)
        scale = _velocity_scale(u[:nv], k0[:nv], h)
        previous = np.inf
        for _ in range(NEWTON_MAX_ITER):
            f = problem.momentum_rates(t, q, us)  # 1. momentum kick at the OLD configuration...
            p1 = p0 + h * f[:nv]
            vs = M0_inv @ p1  # ...and the velocity it implies there
            size = float(np.max(np.abs(vs - us[:nv])))
            us[:nv] = vs
            if _converged(size, previous, NEWTON_RTOL * scale):
                q1 = problem.integrate(q, h * vs)  # 2. drift with v*
                u1 = u + h * f
                u1[:nv] = np.linalg.solve(problem.mass_matrix(q1), p1)  # 3. velocity at q1
                return q1, u1, k0
            if not np.isfinite(size):
                break
            previous = size
        raise StepError(
            f"symplectic Euler: the momentum iteration did not converge at t = {t:.6g} s with dt = {h:g} s; "
            "try a smaller dt",
            time=t,
            reason=f"symplectic Euler's momentum iteration did not converge in {NEWTON_MAX_ITER} iterations",
        )


@dataclass(frozen=True)
class ImplicitMidpoint(FixedStepIntegrator):
    """Implicit midpoint rule in canonical coordinates (q, p = M(q) v): second order, symplectic.

    The unknown is the midpoint velocity vm, with qm = q0 (+) h/2 vm:
    M(qm) vm = p0 + h/2 F(t + h/2, qm, vm). Newton's method on
    vm - M(qm)^-1 (p0 + h/2 F) = 0 uses the Jacobian I - h/2 (h/2 da/dq + da/dv) from the
    problem's analytical derivatives (Pinocchio's ABA derivatives for a robot), starting
    from an explicit Euler predictor. Then q1 = q0 (+) h vm, p1 = p0 + h F and
    v1 = M(q1)^-1 p1; the running integrals take the midpoint rate.
    """

    def step(self, problem: SecondOrderProblem, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array]:
        """One implicit midpoint step; raises :class:`StepError` if Newton fails."""
        nv = problem.nv
        k0 = problem.rates(t, q, u)
        p0 = problem.mass_matrix(q) @ u[:nv]
        tm = t + 0.5 * h
        um = u + 0.5 * h * k0  # predictor: explicit Euler to the midpoint
        scale = _velocity_scale(u[:nv], k0[:nv], h)
        eye = np.eye(nv)
        previous = np.inf
        for _ in range(NEWTON_MAX_ITER):
            vm = um[:nv].copy()
            qm = problem.integrate(q, 0.5 * h * vm)
            fm = problem.momentum_rates(tm, qm, um)
            residual = vm - np.linalg.solve(problem.mass_matrix(qm), p0 + 0.5 * h * fm[:nv])
            size = float(np.max(np.abs(residual)))
            if _converged(size, previous, NEWTON_RTOL * scale):
                q1 = problem.integrate(q, h * vm)
                u1 = u + h * fm
                u1[:nv] = np.linalg.solve(problem.mass_matrix(q1), p0 + h * fm[:nv])
                return q1, u1, k0
            if not np.isfinite(size):
                break
            previous = size
            da_dq, da_dv = problem.jacobian(tm, qm, um)
            um[:nv] = vm - np.linalg.solve(eye - 0.5 * h * (0.5 * h * da_dq + da_dv), residual)
        raise StepError(
            f"implicit midpoint: Newton did not converge in {NEWTON_MAX_ITER} iterations at t = {t:.6g} s "
            f"with dt = {h:g} s; try a smaller dt",
            time=t,
            reason=f"implicit midpoint's Newton iteration did not converge in {NEWTON_MAX_ITER} iterations",
        )
