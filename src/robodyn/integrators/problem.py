"""What is integrated: a second-order problem q' = v, u' = rates(t, q, u) with q on a manifold.

A :class:`SecondOrderProblem` is a configuration ``q`` (nq,), a vector ``u = [v, w]`` whose
first ``nv`` entries are the velocity and whose remaining ``nw`` entries are running integrals
(e.g. the work done by a torque), the rates ``du/dt = rates(t, q, u)`` (the acceleration, then
dw/dt), and the retraction ``integrate(q, dq)`` (``q + dq`` for plain angles, ``pin.integrate``
on a manifold). :class:`ArrayProblem` builds one from plain callables.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

# Forward-difference step of finite_difference_jacobian, relative to max(1, |u_k|): about the
# square root of the float64 epsilon, which balances truncation against round-off.
FD_STEP = 1e-7


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
        accel: rates function (t [s], q (nq,), u (nv + nw,)) -> [a (nv,), dw/dt (nw,)].
        nq, nv: sizes of q and v (nv defaults to nq).
        integrate_fn: retraction q (+) dq; plain addition when omitted.
        jacobian_fn: (t, q, v) -> (da/dq, da/dv); implicit methods fall back to finite
            differences (step ``FD_STEP`` relative) when omitted.
        nw: number of running integrals carried after v in u.
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
        """The acceleration a(t, q, v) (then dw/dt), as a float64 array."""
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
    """(da/dq, da/dv) by forward differences (relative step ``FD_STEP``), each (nv, nv)."""
    nv = problem.nv
    a0 = problem.rates(t, q, u)[:nv]
    da_dq = np.empty((nv, nv))
    da_dv = np.empty((nv, nv))
    for k in range(nv):
        e = np.zeros(nv)
        eps = FD_STEP * max(1.0, abs(float(u[k])))
        e[k] = eps
        da_dq[:, k] = (problem.rates(t, problem.integrate(q, e), u)[:nv] - a0) / eps
        du = u.copy()
        du[k] += eps
        da_dv[:, k] = (problem.rates(t, q, du)[:nv] - a0) / eps
    return da_dq, da_dv
