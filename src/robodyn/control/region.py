"""A region of attraction of the LQR, estimated by sampling its Lyapunov function on the nonlinear model.

The region is the ellipsoid {e : V(e) = e^T P e < rho} around the equilibrium, with P from the
LQR. It is positively invariant, and inside the region of attraction, when V decreases along the
nonlinear closed loop (saturation at the effort limit included) everywhere in it but at e = 0.
That is checked on samples, not proven:

* ``samples`` states are drawn uniformly in the ellipsoid V < c_max (seeded), where c_max keeps
  every revolute error within pi (so the wrapped error is the error);
* dV/dt = 2 e^T P f(x, sat(u)) is evaluated on each, f the robot's forward dynamics (damping
  included, as :func:`robodyn.simulate` applies it);
* rho_lyapunov = ``SAFETY`` times the smallest V among the samples with dV/dt >= 0 (c_max if none);
* for the cart-pole, rho is also capped so that the ellipsoid lies inside the rail's usable
  interval: the largest cart excursion over {V < rho} is sqrt(rho (P^-1)_yy).

A sample that misses a thin bad set can overestimate rho: the benchmark's basin map shows the
true basin on a grid, by simulation, next to this ellipsoid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics
from robodyn.control.lqr import LQR
from robodyn.errors import InputError
from robodyn.wording import count

Array = NDArray[np.float64]

# rho is this fraction of the smallest sampled V where V does not decrease: a margin for the
# bad states between the samples.
SAFETY = 0.8

DEFAULT_SAMPLES = 4000


@dataclass(frozen=True)
class Region:
    """The ellipsoid e^T P e < rho; ``rho_lyapunov`` and ``rho_rail`` are its two bounds (inf: none)."""

    rho: float
    rho_lyapunov: float
    rho_rail: float
    c_max: float
    samples: int
    seed: int

    def describe(self) -> str:
        """One line: the region and how it was found."""
        rail = f", rail bound {self.rho_rail:.4g}" if np.isfinite(self.rho_rail) else ""
        return (
            f"e^T P e < {self.rho:.4g} (sampled dV/dt < 0 on {count(self.samples, 'state')}, seed {self.seed}: "
            f"{self.rho_lyapunov:.4g}{rail})"
        )


def contains(lqr: LQR, region: Region, q: ArrayLike, v: ArrayLike) -> NDArray[np.bool_]:
    """True where (q, v) (one state, or a batch) lies inside the region."""
    return np.asarray(lqr.value(q, v) < region.rho)


def estimate(lqr: LQR, *, samples: int = DEFAULT_SAMPLES, seed: int = 0) -> Region:
    """Estimate the region of attraction of ``lqr`` as an ellipsoid of its Lyapunov function (see the module)."""
    p = lqr.plant
    n = p.n
    smallest = float(np.min(np.linalg.eigvalsh(lqr.P))) if np.all(np.isfinite(lqr.P)) else np.nan
    if not smallest > 0.0:  # no ellipsoid: V = e^T P e does not grow in every direction (NaN too)
        raise InputError(
            f"the LQR's cost-to-go P is not positive definite (smallest eigenvalue {smallest:.3g}), so it bounds "
            "no region of attraction: give a weight Q > 0 on every state (and R > 0)"
        )
    Pinv = np.linalg.inv(lqr.P)
    extents = np.diag(Pinv)[:n]
    c_max = float(np.min(np.pi**2 / extents[p.angular])) if np.any(p.angular) else 1e6
    rho_rail = np.inf
    if p.rail is not None and p.rail_index is not None:
        y_eq = float(lqr.q_eq[p.rail_index])
        room = min(p.rail[1] - y_eq, y_eq - p.rail[0])
        rho_rail = max(room, 0.0) ** 2 / float(Pinv[p.rail_index, p.rail_index])
        c_max = min(c_max, rho_rail)
    rng = np.random.default_rng(seed)
    e = _uniform_in_ellipsoid(lqr.P, c_max, samples, rng)
    V = np.einsum("ki,ij,kj->k", e, lqr.P, e)
    Vdot = _lyapunov_rate(lqr, e)
    bad = Vdot >= 0.0
    rho_lyapunov = SAFETY * float(np.min(V[bad])) if np.any(bad) else c_max
    rho = min(rho_lyapunov, rho_rail)
    return Region(float(rho), float(rho_lyapunov), float(rho_rail), c_max, samples, seed)


def _uniform_in_ellipsoid(P: Array, c: float, count: int, rng: np.random.Generator) -> Array:
    """``count`` points (count, d) uniform in {e : e^T P e <= c}."""
    d = P.shape[0]
    w = rng.standard_normal((count, d))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    w *= np.sqrt(c) * rng.uniform(0.0, 1.0, (count, 1)) ** (1.0 / d)
    L = np.linalg.cholesky(P)  # P = L L^T, so e = L^-T w has e^T P e = |w|^2
    return np.asarray(np.linalg.solve(L.T, w.T).T, dtype=np.float64)


def _lyapunov_rate(lqr: LQR, e: Array) -> Array:
    """dV/dt = 2 e^T P f at the states q_eq + e (count,), under the saturated LQR, on the nonlinear model."""
    robot = lqr.plant.robot
    n = lqr.plant.n
    S = robot.input_matrix()
    q = lqr.q_eq + e[:, :n]
    v = e[:, n:]
    u = lqr.batch(q, v)
    tau = u @ S.T - robot.damping * v
    a = np.array([dynamics.aba(robot.model, robot.data, qi, vi, ti) for qi, vi, ti in zip(q, v, tau, strict=True)])
    f = np.concatenate([v, a], axis=1)
    return np.asarray(2.0 * np.einsum("ki,ij,kj->k", e, lqr.P, f), dtype=np.float64)
