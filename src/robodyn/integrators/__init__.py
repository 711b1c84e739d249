"""Time integrators for second-order systems; they know nothing about robots.

Three things are kept apart (as in diffrax):

* **what is integrated** -- a :class:`SecondOrderProblem`: a configuration ``q`` (nq,) on a
  manifold, a vector ``u = [v, w]`` whose first ``nv`` entries are the velocity and whose
  remaining ``nw`` entries are running integrals (e.g. the work done by a torque), the
  rates ``du/dt = rates(t, q, u)`` (the acceleration, then dw/dt), and the retraction
  ``integrate(q, dq)`` (``q + dq`` for plain angles, ``pin.integrate`` on a manifold);
* **how a step is taken** -- an :class:`Integrator`, which declares its ``order`` and
  whether it is ``symplectic``, ``adaptive`` and ``implicit``;
* **what is recorded** -- the caller's business (:func:`robodyn.simulate`, or :func:`solve`
  for plain arrays).

Every integrator is reached by name through :data:`INTEGRATORS` (``get("rk4")``). A run
starts with :meth:`Integrator.start`, which returns a :class:`Stepper`; its ``advance``
moves the state from ``t`` to ``t + h`` -- one step for the fixed-step methods, as many
error-controlled steps as needed for the adaptive ones -- and also returns the rates at the
start of the interval when the method evaluated them there anyway (so a recorder gets the
acceleration at every sample for free).

Explicit Runge--Kutta stages on a manifold are taken as ``q_i = q (+) h sum_j a_ij v_j``.
That is exact Lie-group Runge--Kutta for the abelian joints (revolute, prismatic and the
``continuous`` joint's SO(2)); on free-flyer or spherical joints the declared order is only
guaranteed up to 2.
"""

from __future__ import annotations

import abc
import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import InputError, StepError
from robodyn.registry import Registry

Array = NDArray[np.float64]

# Butcher tableaux are checked to this absolute tolerance: their coefficients are exact
# rationals printed as doubles, so the sums are exact up to a few ulps.
TABLEAU_TOL = 1e-12

# The iterations of the symplectic methods (Newton for the midpoint rule, fixed point for
# symplectic Euler) stop when the residual is below NEWTON_RTOL times the step's velocity
# scale |v0| + h |a0| (or stalls within NEWTON_STALL times that: rounding noise of the
# dynamics), and fail after NEWTON_MAX_ITER iterations. 1e-14 a step keeps the energy
# error after 1e5 steps far below the methods' own O(h) or O(h^2) oscillation.
NEWTON_RTOL = 1e-14
NEWTON_STALL = 1e3
NEWTON_MAX_ITER = 30


# ----------------------------------------------------------------------------- problems
@runtime_checkable
class SecondOrderProblem(Protocol):
    """What is integrated: q on a manifold, u = [v, w] with q' = v and u' = rates(t, q, u).

    Attributes:
        nq: size of the configuration q.
        nv: size of the velocity v (the tangent space of q).
        nw: number of running integrals carried after v in u (0 when none).
        flat: True when ``integrate(q, dq)`` is plain ``q + dq`` (nq == nv).
        evaluations: number of ``rates`` and ``momentum_rates`` calls so far.

    The symplectic methods step the canonical pair (q, p = M(q) v) with
    dp/dt = momentum_rates(...) (for a mechanical system tau + C^T v - G); an
    :class:`ArrayProblem` has M = I, so p = v and dp/dt = a.
    """

    nq: int
    nv: int
    nw: int
    flat: bool
    evaluations: int

    def rates(self, t: float, q: Array, u: Array) -> Array:
        """du/dt at (t, q, u): the acceleration (nv,), then dw/dt (nw,)."""
        ...

    def integrate(self, q: Array, dq: Array) -> Array:
        """Q (+) dq on the configuration manifold, shape (nq,)."""
        ...

    def jacobian(self, t: float, q: Array, u: Array) -> tuple[Array, Array]:
        """(da/dq, da/dv), each (nv, nv): needed by the implicit methods only."""
        ...

    def mass_matrix(self, q: Array) -> Array:
        """M(q) (nv, nv), defining the momentum p = M(q) v of the symplectic methods."""
        ...

    def momentum_rates(self, t: float, q: Array, u: Array) -> Array:
        """[dp/dt (nv,), dw/dt (nw,)] at (t, q, u): the force of Hamilton's equations."""
        ...


@dataclass(eq=False)
class ArrayProblem:
    """A :class:`SecondOrderProblem` from plain callables: a = accel(t, q, v).

    Args:
        accel: acceleration function (t [s], q (nq,), v (nv,)) -> a (nv,).
        nq, nv: sizes of q and v (nv defaults to nq).
        integrate: retraction q (+) dq; plain addition when omitted.
        jacobian_fn: (t, q, v) -> (da/dq, da/dv); implicit methods fall back to finite
            differences (step 1e-7 relative) when omitted.
    """

    accel: Callable[[float, Array, Array], Array]
    nq: int
    nv: int = -1
    integrate_fn: Callable[[Array, Array], Array] | None = None
    jacobian_fn: Callable[[float, Array, Array], tuple[Array, Array]] | None = None
    nw: int = 0
    evaluations: int = 0

    def __post_init__(self) -> None:
        if self.nv < 0:
            self.nv = self.nq
        self.flat = self.integrate_fn is None

    def rates(self, t: float, q: Array, u: Array) -> Array:
        """The acceleration a(t, q, v), as a float64 array."""
        self.evaluations += 1
        return np.asarray(self.accel(t, q, u), dtype=np.float64)

    def integrate(self, q: Array, dq: Array) -> Array:
        """Q (+) dq (plain addition unless ``integrate_fn`` was given)."""
        if self.integrate_fn is None:
            return q + dq
        return self.integrate_fn(q, dq)

    def jacobian(self, t: float, q: Array, u: Array) -> tuple[Array, Array]:
        """(da/dq, da/dv) from ``jacobian_fn`` or by forward differences."""
        if self.jacobian_fn is not None:
            return self.jacobian_fn(t, q, u)
        return finite_difference_jacobian(self, t, q, u)

    def mass_matrix(self, q: Array) -> Array:
        """The identity: on plain arrays the momentum is the velocity."""
        return np.eye(self.nv)

    def momentum_rates(self, t: float, q: Array, u: Array) -> Array:
        """dp/dt = a, since p = v."""
        return self.rates(t, q, u)


def finite_difference_jacobian(problem: SecondOrderProblem, t: float, q: Array, u: Array) -> tuple[Array, Array]:
    """(da/dq, da/dv) by forward differences (relative step 1e-7), each (nv, nv)."""
    nv = problem.nv
    a0 = problem.rates(t, q, u)[:nv]
    da_dq = np.empty((nv, nv))
    da_dv = np.empty((nv, nv))
    for k in range(nv):
        e = np.zeros(nv)
        eps = 1e-7 * max(1.0, abs(float(u[k])))
        e[k] = eps
        da_dq[:, k] = (problem.rates(t, problem.integrate(q, e), u)[:nv] - a0) / eps
        du = u.copy()
        du[k] += eps
        da_dv[:, k] = (problem.rates(t, q, du)[:nv] - a0) / eps
    return da_dq, da_dv


# ----------------------------------------------------------------------------- tableaux
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


# ----------------------------------------------------------------------------- steppers
class Stepper(abc.ABC):
    """One run of an integrator on one problem: call :meth:`advance` interval by interval."""

    problem: SecondOrderProblem

    @abc.abstractmethod
    def advance(self, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array | None]:
        """Move (q, u) from t to t + h [s]; return (q1, u1, rates at t or None)."""


@dataclass(frozen=True)
class Integrator(abc.ABC):
    """How a step is taken. Subclasses declare what they are; instances are immutable."""

    name: str
    order: int
    symplectic: bool
    adaptive: bool
    implicit: bool
    description: str

    def start(
        self,
        problem: SecondOrderProblem,
        t0: float,
        q0: Array,
        u0: Array,
        *,
        t_end: float,
        rtol: float = 1e-9,
        atol: float = 1e-12,
    ) -> Stepper:
        """Begin a run on ``problem`` from (t0, q0, u0) towards ``t_end`` [s].

        Raises:
            InputError: an adaptive method got ``rtol`` or ``atol`` <= 0.
        """
        if self.adaptive and not (rtol > 0 and atol > 0):
            raise InputError(f"rtol and atol must be > 0, got rtol={rtol!r}, atol={atol!r}")
        return self._stepper(problem, t0, q0, u0, t_end, rtol, atol)

    @abc.abstractmethod
    def _stepper(
        self, problem: SecondOrderProblem, t0: float, q0: Array, u0: Array, t_end: float, rtol: float, atol: float
    ) -> Stepper:
        """The :class:`Stepper` of one run (tolerances already checked)."""

    def summary(self) -> dict[str, Any]:
        """Name, order and properties as a plain dict."""
        return {
            "name": self.name,
            "order": self.order,
            "symplectic": self.symplectic,
            "adaptive": self.adaptive,
            "implicit": self.implicit,
            "description": self.description,
        }


class FixedStepIntegrator(Integrator):
    """A method that takes exactly one step of the requested size."""

    @abc.abstractmethod
    def step(self, problem: SecondOrderProblem, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array]:
        """One step of size h [s] from (t, q, u); return (q1, u1, rates at (t, q, u))."""

    def _stepper(
        self, problem: SecondOrderProblem, t0: float, q0: Array, u0: Array, t_end: float, rtol: float, atol: float
    ) -> Stepper:
        """A stepper whose ``advance`` is one :meth:`step`."""
        return _FixedStepper(self, problem)


class _FixedStepper(Stepper):
    def __init__(self, method: FixedStepIntegrator, problem: SecondOrderProblem) -> None:
        self.problem = problem
        # advance(t, q, u, h) is step(problem, t, q, u, h): bound once, no wrapper call per step.
        self.advance = functools.partial(method.step, problem)  # type: ignore[method-assign]

    def advance(self, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array | None]:
        """One step of size h [s] (replaced per instance by a partial of ``step``)."""
        return self.advance(t, q, u, h)  # pragma: no cover


@dataclass(frozen=True)
class ExplicitEuler(FixedStepIntegrator):
    """q1 = q (+) h v, u1 = u + h F(q, u): first order, not symplectic, energy grows."""

    def step(self, problem: SecondOrderProblem, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array]:
        """One explicit Euler step."""
        k = problem.rates(t, q, u)
        return problem.integrate(q, h * u[: problem.nv]), u + h * k, k


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
class ExplicitRungeKutta(FixedStepIntegrator):
    """Any explicit Runge--Kutta method given by its (checked) Butcher tableau."""

    tableau: ButcherTableau = field(default=CLASSIC_RK4)

    def __post_init__(self) -> None:
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
    ``simulate``'s overhead over a hand-written ``pin.aba`` loop small.
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
        nv = problem.nv
        integrate = problem.integrate
        k2 = rates(th, integrate(q, h2 * u[:nv]), u2)
        u3 = u + h2 * k2
        k3 = rates(th, integrate(q, h2 * u2[:nv]), u3)
        u4 = u + h * k3
        k4 = rates(t + h, integrate(q, h * u3[:nv]), u4)
        h6 = h / 6.0
        q1 = integrate(q, h6 * (u[:nv] + 2.0 * (u2[:nv] + u3[:nv]) + u4[:nv]))
        return q1, u + h6 * (k1 + 2.0 * (k2 + k3) + k4), k1


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


# ----------------------------------------------------------------------------- adaptive
@dataclass(frozen=True)
class EmbeddedRungeKutta(Integrator):
    """An embedded explicit Runge--Kutta pair with error control (Dormand--Prince 5(4)).

    Each ``advance`` over an output interval takes as many steps as the error estimate
    allows: the scaled RMS norm of the difference between the two solutions, with scale
    atol + rtol max(|y0|, |y1|) over (q, v) (running integrals excluded), must be <= 1.
    The next step is h * min(5, max(0.2, 0.9 err^(-1/5))), never beyond the interval's end.
    """

    tableau: ButcherTableau = field(default=DORMAND_PRINCE_54)

    def __post_init__(self) -> None:
        if self.tableau.b_error is None:
            raise ValueError(f"integrator {self.name!r} needs a tableau with an embedded solution (b_error)")

    def _stepper(
        self, problem: SecondOrderProblem, t0: float, q0: Array, u0: Array, t_end: float, rtol: float, atol: float
    ) -> Stepper:
        """A stepper that keeps its step size from interval to interval."""
        return _EmbeddedStepper(self.tableau, problem, rtol, atol)

    def fixed(self) -> ExplicitRungeKutta:
        """The same tableau's higher-order solution taken at a fixed step (to measure its order)."""
        t = self.tableau
        plain = ButcherTableau(name=t.name, a=t.a, b=t.b, c=t.c, order=t.order)
        return ExplicitRungeKutta(f"{self.name}-fixed", t.order, False, False, False, self.description, plain)


class _EmbeddedStepper(Stepper):
    SAFETY = 0.9
    MIN_FACTOR = 0.2
    MAX_FACTOR = 5.0

    def __init__(self, tableau: ButcherTableau, problem: SecondOrderProblem, rtol: float, atol: float) -> None:
        self.problem = problem
        self.tableau = tableau
        self.rtol = rtol
        self.atol = atol
        self.h: float | None = None
        self.k_first: Array | None = None
        self.exponent = -1.0 / (min(tableau.order, tableau.error_order or tableau.order) + 1)
        self.A = np.array(tableau.a)
        self.b = np.array(tableau.b)
        self.e = np.array(tableau.b) - np.array(tableau.b_error)  # type: ignore[arg-type]
        self.steps = 0
        self.rejected = 0

    def _attempt(self, t: float, q: Array, u: Array, h: float, k0: Array) -> tuple[Array, Array, float, Array]:
        p = self.problem
        nv = p.nv
        s = self.tableau.stages
        U = np.empty((s, u.size))
        K = np.empty((s, u.size))
        U[0] = u
        K[0] = k0
        for i in range(1, s):
            w = h * self.A[i, :i]
            U[i] = u + w @ K[:i]
            K[i] = p.rates(t + self.tableau.c[i] * h, p.integrate(q, w @ U[:i, :nv]), U[i])
        hb = h * self.b
        u1 = u + hb @ K
        q1 = p.integrate(q, hb @ U[:, :nv])
        he = h * self.e
        err_v = he @ K[:, :nv]
        err_q = he @ U[:, :nv]
        v0, v1 = u[:nv], u1[:nv]
        # q error in the tangent space: scaled by |q| on flat problems, by 1 on manifolds.
        sq = self.atol + self.rtol * (np.maximum(np.abs(q), np.abs(q1)) if p.flat else 1.0)
        sv = self.atol + self.rtol * np.maximum(np.abs(v0), np.abs(v1))
        err = float(np.sqrt((np.sum((err_q / sq) ** 2) + np.sum((err_v / sv) ** 2)) / (2 * nv)))
        k_last = K[-1] if self.tableau.fsal else p.rates(t + h, q1, u1)
        return q1, u1, err, k_last

    def _initial_step(self, t: float, q: Array, u: Array, k0: Array, h_max: float) -> float:
        nv = self.problem.nv
        scale = self.atol + self.rtol * np.abs(u[:nv])
        d1 = float(np.sqrt(np.mean((k0[:nv] / scale) ** 2)))
        d0 = float(np.sqrt(np.mean((u[:nv] / scale) ** 2)))
        h = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
        return min(h, h_max)

    def advance(self, t: float, q: Array, u: Array, h_out: float) -> tuple[Array, Array, Array | None]:
        """Take error-controlled steps from t to exactly t + h_out [s]."""
        t_end = t + h_out
        k = self.k_first if self.k_first is not None else self.problem.rates(t, q, u)
        k_start = k
        h = self.h if self.h is not None else self._initial_step(t, q, u, k, h_out)
        while True:
            remaining = t_end - t
            last = h >= remaining * (1.0 - 1e-12)
            step = remaining if last else h
            q1, u1, err, k1 = self._attempt(t, q, u, step, k)
            if err <= 1.0:  # accept (a NaN error compares False and is rejected)
                self.steps += 1
                factor = self.MAX_FACTOR if err == 0.0 else min(self.MAX_FACTOR, self.SAFETY * err**self.exponent)
                # A step clipped to the interval's end says little about the next one.
                h = max(h, step * factor) if last else step * factor
                q, u, k = q1, u1, k1
                if last:
                    break
                t = t + step
            else:
                self.rejected += 1
                shrink = self.SAFETY * err**self.exponent if np.isfinite(err) else self.MIN_FACTOR
                h = step * min(1.0, max(self.MIN_FACTOR, shrink))
                if h <= 16 * np.finfo(np.float64).eps * max(1.0, abs(t)):
                    raise StepError(
                        f"adaptive step size underflowed at t = {t:.6g} s (error estimate {err:.3g}); "
                        "the solution is probably blowing up",
                        time=t,
                        reason=f"the adaptive step size underflowed at t = {t:.6g} s (error estimate {err:.3g})",
                    )
        self.h = h
        self.k_first = k
        return q, u, k_start


# ----------------------------------------------------------------------------- scipy
SCIPY_METHODS = {
    "RK45": (5, False, "scipy RK45: Dormand-Prince 5(4), error control"),
    "DOP853": (8, False, "scipy DOP853: Dormand-Prince 8(5,3), error control"),
    "Radau": (5, True, "scipy Radau IIA: implicit, order 5, for stiff problems"),
    "BDF": (5, True, "scipy BDF: implicit multistep, variable order 1-5"),
    "LSODA": (12, True, "scipy LSODA: switches between Adams (order <= 12) and BDF"),
}


@dataclass(frozen=True)
class ScipyIntegrator(Integrator):
    """One of scipy's ``solve_ivp`` methods, stepped through its ``OdeSolver`` class.

    The state is y = [x, v, w] with q = q0 (+) x: x is a chart of the configuration
    manifold around q0 (exact for revolute, prismatic and continuous joints). Output
    samples come from the solver's dense output. Implicit methods get the analytical
    Jacobian from ``problem.jacobian``. ``order`` is the method's highest order.

    ``fixed_step`` [s] (explicit methods only) turns error control off and takes steps of
    exactly that size -- how the tests measure the order of RK45 and DOP853.
    """

    method: str = "RK45"
    fixed_step: float | None = None

    def __post_init__(self) -> None:
        if self.fixed_step is not None and (self.implicit or not self.fixed_step > 0):
            raise ValueError(f"{self.name}: fixed_step needs an explicit method and a step > 0")

    def _stepper(
        self, problem: SecondOrderProblem, t0: float, q0: Array, u0: Array, t_end: float, rtol: float, atol: float
    ) -> Stepper:
        """Create the scipy solver for the whole run [t0, t_end]."""
        return _ScipyStepper(self, problem, t0, q0, u0, t_end, rtol, atol)


class _ScipyStepper(Stepper):
    def __init__(
        self,
        method: ScipyIntegrator,
        problem: SecondOrderProblem,
        t0: float,
        q0: Array,
        u0: Array,
        t_end: float,
        rtol: float,
        atol: float,
    ) -> None:
        from scipy import integrate as sp_integrate

        self.problem = problem
        self.q0 = np.array(q0, dtype=np.float64)
        nv = problem.nv
        self.nv = nv
        y0 = np.concatenate([np.zeros(nv), u0])
        cls = getattr(sp_integrate, method.method)
        options: dict[str, Any] = {"rtol": rtol, "atol": atol}
        if method.fixed_step is not None:  # every step accepted, none longer than fixed_step
            options = {"rtol": 1e10, "atol": 1e10, "first_step": method.fixed_step, "max_step": method.fixed_step}
        if method.implicit:
            options["jac"] = self._jac
        self.solver = cls(self._fun, t0, y0, t_end, **options)
        self.dense: Any = None

    def _q(self, x: Array) -> Array:
        return self.problem.integrate(self.q0, x)

    def _fun(self, t: float, y: Array) -> Array:
        nv = self.nv
        u = y[nv:]
        return np.concatenate([u[:nv], self.problem.rates(t, self._q(y[:nv]), u)])

    def _jac(self, t: float, y: Array) -> Array:
        nv = self.nv
        n = y.size
        da_dq, da_dv = self.problem.jacobian(t, self._q(y[:nv]), y[nv:])
        J = np.zeros((n, n))
        J[:nv, nv : 2 * nv] = np.eye(nv)
        J[nv : 2 * nv, :nv] = da_dq
        J[nv : 2 * nv, nv : 2 * nv] = da_dv
        return J

    def advance(self, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array | None]:
        """Step the scipy solver past t + h and read the state there from dense output."""
        target = t + h
        solver = self.solver
        while solver.t < target and solver.status == "running":
            message = solver.step()
            self.dense = None
            if solver.status == "failed":
                what = f"scipy {type(solver).__name__} failed at t = {solver.t:.6g} s: {message}"
                raise StepError(what, time=t, reason=what)
        if solver.t == target:
            y = solver.y.copy()
        else:  # the last step went past the target: read it from that step's interpolant
            if self.dense is None:
                self.dense = solver.dense_output()
            y = self.dense(target)
        nv = self.nv
        return self._q(y[:nv]), y[nv:].copy(), None


# ----------------------------------------------------------------------------- registry
INTEGRATORS: Registry[Integrator] = Registry("integrator")
INTEGRATORS.register(
    "euler",
    ExplicitEuler("euler", 1, False, False, False, "explicit Euler: q += h v, v += h a(q, v); energy grows"),
)
INTEGRATORS.register(
    "semi_implicit_euler",
    SemiImplicitEuler(
        "semi_implicit_euler",
        1,
        False,
        False,
        False,
        "kick-drift Euler in (q, v): v += h a(q, v), then q += h v; symplectic only for constant M",
    ),
)
INTEGRATORS.register(
    "symplectic_euler",
    SymplecticEuler(
        "symplectic_euler",
        1,
        True,
        False,
        True,
        "symplectic Euler in (q, p = M v): p += h F(q, v*), q += h v*; fixed-point for v*",
    ),
)
INTEGRATORS.register("heun", ExplicitRungeKutta("heun", 2, False, False, False, "Heun's method (explicit RK2)", HEUN))
INTEGRATORS.register("rk4", ClassicRK4("rk4", 4, False, False, False, "classic 4-stage Runge-Kutta", CLASSIC_RK4))
INTEGRATORS.register(
    "implicit_midpoint",
    ImplicitMidpoint(
        "implicit_midpoint", 2, True, False, True, "implicit midpoint in (q, p = M v), Newton with ABA derivatives"
    ),
)
INTEGRATORS.register(
    "dopri5",
    EmbeddedRungeKutta(
        "dopri5", 5, False, True, False, "Dormand-Prince 5(4), embedded error control (rtol, atol)", DORMAND_PRINCE_54
    ),
)
for _method, (_order, _implicit, _text) in SCIPY_METHODS.items():
    _name = f"scipy_{_method.lower()}"
    INTEGRATORS.register(_name, ScipyIntegrator(_name, _order, False, True, _implicit, _text, _method))


def get(name: str) -> Integrator:
    """The integrator called ``name``; :class:`UnknownNameError` lists what exists."""
    return INTEGRATORS.get(name)


def names() -> tuple[str, ...]:
    """Every integrator name, sorted."""
    return INTEGRATORS.names()


# ----------------------------------------------------------------------------- plain arrays
def step_count(duration: float, dt: float) -> int:
    """How many steps of ``dt`` [s] make ``duration`` [s] exactly (to 1e-9 relative).

    Raises:
        InputError: ``dt`` or ``duration`` is not a positive finite number, or ``duration``
            is not a whole number of steps of ``dt``.
    """
    for name, value in (("dt", dt), ("duration", duration)):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{name} must be a positive number of seconds, got {value!r}")
    n = round(duration / dt)
    if n < 1 or abs(n * dt - duration) > 1e-9 * duration:
        raise InputError(f"duration {duration} s is not a whole number of steps of dt = {dt} s")
    return n


@dataclass(frozen=True)
class Solution:
    """States at t_k = t0 + k dt from :func:`solve`: t (n+1,), q (n+1, nq), v (n+1, nv)."""

    t: Array
    q: Array
    v: Array
    evaluations: int


def solve(
    accel: Callable[[float, Array, Array], Array] | SecondOrderProblem,
    q0: Array,
    v0: Array,
    *,
    dt: float,
    n_steps: int,
    method: str | Integrator = "rk4",
    t0: float = 0.0,
    rtol: float = 1e-9,
    atol: float = 1e-12,
) -> Solution:
    """Integrate q'' = accel(t, q, v) on plain arrays, recording every step.

    Args:
        accel: (t [s], q (n,), v (n,)) -> a (n,), or a ready :class:`SecondOrderProblem`.
        q0: initial configuration (nq,).
        v0: initial velocity (nv,).
        dt: step (output interval for the adaptive methods) [s], > 0.
        n_steps: number of steps, >= 1.
        method: an integrator name or object.
        t0: initial time [s].
        rtol: relative tolerance of the adaptive methods.
        atol: absolute tolerance of the adaptive methods.
    """
    q = np.array(q0, dtype=np.float64)
    v = np.array(v0, dtype=np.float64)
    if not dt > 0:
        raise InputError(f"dt must be > 0, got {dt!r}")
    if n_steps < 1:
        raise InputError(f"n_steps must be >= 1, got {n_steps!r}")
    problem = accel if isinstance(accel, SecondOrderProblem) else ArrayProblem(accel, q.size, v.size)
    integrator = get(method) if isinstance(method, str) else method
    t_grid = np.asarray(t0 + dt * np.arange(n_steps + 1), dtype=np.float64)
    Q = np.empty((n_steps + 1, q.size))
    V = np.empty((n_steps + 1, v.size))
    Q[0], V[0] = q, v
    u = v
    stepper = integrator.start(problem, t0, q, u, t_end=float(t_grid[-1]), rtol=rtol, atol=atol)
    advance = stepper.advance
    for k in range(n_steps):
        q, u, _ = advance(float(t_grid[k]), q, u, float(t_grid[k + 1] - t_grid[k]))
        Q[k + 1] = q
        V[k + 1] = u[: v.size]
    return Solution(t_grid, Q, V, problem.evaluations)
