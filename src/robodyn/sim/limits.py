"""Joint stops: the URDF's position limits as one-sided constraints, their impacts and how they hold.

Each stop is a row (joint, side): side +1 for the lower limit (the stop pushes towards +q),
-1 for the upper. Its gap g = side (q - bound) is >= 0 while the joint is free, its
Jacobian row is side * e_j, and J v < 0 means the joint runs into it.

* **Impact.** A joint that reaches a stop gets the exact impulse of Newton's restitution law:
  v+ = v- + M^-1 J^T L with J v+ = -e J v- on the impacting rows, and J v+ = 0 on the rows
  already held (and on the loop closures). For one stop the kinetic energy lost is
  1/2 (J v)^2 / (J M^-1 J^T) (1 - e^2); :func:`impact` returns it and the run books it as
  ``work_limits``. A row whose impulse would pull (L < 0) lets go and the solve is redone.
* **Hold.** A joint that stays at its stop (e = 0, or a rebound too small to leave within one
  step) is held: its acceleration is 0 and the others follow M_ff a_f = (tau - C v - G)_f
  (Gauss's principle: the acceleration closest to the smooth one in the metric of M), exact
  and without drift. The force of the stop is lambda = (M a - (tau - C v - G))_j, >= 0 while
  it pushes; it lets go where lambda crosses 0.

Why not Pinocchio's ``JointLimitConstraintModel`` + ADMM: that path is a velocity-level time
step, first order in dt (its loss at an impact is right only to the step), costs 60-95 us a
step when every row is solved, and segfaults if its selection changes under live data. A stop
is one row of the identity, so the exact impulse and the exact hold above take two small
solves with M from :mod:`robodyn.dynamics`, and keep every integrator at its own order
between impacts located to round-off (:mod:`robodyn.sim.events`).

Only joints with one coordinate (revolute, prismatic) and a declared range lower < upper have
stops; a ``continuous`` joint, a free flyer, or a joint whose URDF range is empty (lower >=
upper, as a <limit> without bounds reads) turns freely, and says so in the run's metadata.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

# A joint counts as past its stop when its gap is below -GAP_TOL x max(1, |bound|) [rad | m]:
# ~50 ulps of the bound, so a joint released at its stop and sitting there does not re-hit it
# on round-off, while any real crossing (>= 1e-12 of a step's travel) is caught.
GAP_TOL = 1e-14

# An impulse that pulls by more than this fraction of the largest one lets its row go.
PULL_RTOL = 1e-12
# lstsq's rcond in the Delassus solve of an impact: singular values below it (relative) are dropped.
IMPACT_RCOND = 1e-13


@dataclass(frozen=True, eq=False)
class Stops:
    """The stops of a robot: per limited joint its indices and bounds, and the restitution.

    Attributes:
        names: the joint of each limited coordinate.
        iq, iv: its index in q and in v.
        lower, upper: its bounds [rad | m] (a side may be -inf / +inf).
        restitution: e in [0, 1] for every stop.
        free: (joint, reason) for every joint that turns without stops.
    """

    names: tuple[str, ...]
    iq: NDArray[np.intp]
    iv: NDArray[np.intp]
    lower: Array
    upper: Array
    restitution: float
    free: tuple[tuple[str, str], ...] = ()

    @property
    def empty(self) -> bool:
        """True when no joint has a stop."""
        return self.iq.size == 0

    def tolerance(self) -> Array:
        """GAP_TOL scaled by the bounds, per limited joint [rad | m]."""
        bound = np.maximum(np.abs(np.where(np.isfinite(self.lower), self.lower, 0.0)), 1.0)
        bound = np.maximum(bound, np.abs(np.where(np.isfinite(self.upper), self.upper, 0.0)))
        return GAP_TOL * bound

    def bound(self, k: int, side: int) -> float:
        """The bound of limited joint k on ``side`` (+1 lower, -1 upper)."""
        return float(self.lower[k] if side > 0 else self.upper[k])

    def crossed(self, q: Array, held: dict[int, int]) -> list[tuple[int, int]]:
        """The rows (k, side) of joints not held whose gap at q is below -tolerance."""
        x = q[self.iq]
        tol = self.tolerance()
        rows = [(int(k), 1) for k in np.flatnonzero(x - self.lower < -tol)]
        rows += [(int(k), -1) for k in np.flatnonzero(self.upper - x < -tol)]
        return [r for r in rows if r[0] not in held]

    def gap(self, q: Array, row: tuple[int, int]) -> float:
        """Side (q - bound) of ``row`` [rad | m]: >= 0 on the free side."""
        k, side = row
        return side * (float(q[self.iq[k]]) - self.bound(k, side))

    def touching(self, q: Array, v: Array, held: dict[int, int]) -> list[tuple[int, int]]:
        """Rows of free joints that sit at a stop (|gap| <= tolerance) and move into it."""
        x = q[self.iq]
        tol = self.tolerance()
        rows = []
        for k in range(self.iq.size):
            if k in held:
                continue
            for side, bound in ((1, self.lower[k]), (-1, self.upper[k])):
                if abs(x[k] - bound) <= tol[k] and side * v[self.iv[k]] < 0:
                    rows.append((k, side))
        return rows

    def snap(self, q: Array, rows: list[tuple[int, int]]) -> Array:
        """The configuration with each row's joint put exactly on its bound (moved by at most the root tolerance)."""
        q = q.copy()
        for k, side in rows:
            q[self.iq[k]] = self.bound(k, side)
        return q

    def violation(self, Q: Array) -> tuple[float, str]:
        """The worst excursion past a bound over a batch Q (n, nq) [rad | m], and its joint ('' if none)."""
        if self.empty or Q.shape[0] == 0:
            return 0.0, ""
        X = Q[:, self.iq]
        past = np.maximum(self.lower - X, X - self.upper)
        worst = np.max(past, axis=0)
        k = int(np.argmax(worst))
        return max(float(worst[k]), 0.0), self.names[k] if worst[k] > 0 else ""

    def clamp(self, q: Array) -> tuple[Array, list[tuple[str, float, float]]]:
        """The configuration moved inside the bounds, and (joint, given, clamped) for every joint that moved."""
        x = q[self.iq]
        inside = np.clip(x, self.lower, self.upper)
        moved = [(self.names[k], float(x[k]), float(inside[k])) for k in np.flatnonzero(inside != x)]
        out = q.copy()
        out[self.iq] = inside
        return out, moved

    def describe(self) -> dict[str, list[float]]:
        """Joint -> [lower, upper] for every stop (inf where a side is open)."""
        return {n: [float(lo), float(hi)] for n, lo, hi in zip(self.names, self.lower, self.upper, strict=True)}


def no_stops() -> Stops:
    """A robot whose joints all turn freely (``limits=False``)."""
    empty = np.zeros(0, dtype=np.intp)
    return Stops((), empty, empty.copy(), np.zeros(0), np.zeros(0), 0.0)


def stops_of(robot: Robot, *, restitution: float = 0.0) -> Stops:
    """The stops of ``robot`` from its model's position limits (read from the URDF)."""
    model = robot.model
    lower_all = np.asarray(model.lowerPositionLimit, dtype=np.float64)
    upper_all = np.asarray(model.upperPositionLimit, dtype=np.float64)
    names, iq, iv, lo, hi, free = [], [], [], [], [], []
    for j in robot.joints:
        if j.nq == 0 and j.nv == 0:
            continue  # a mimic joint: its leader carries it
        if not (j.nq == 1 and j.nv == 1):
            reason = "continuous joint (no stop)" if j.kind.startswith("JointModelRUB") else f"{j.kind} (no stop)"
            free.append((j.name, reason))
            continue
        lower, upper = float(lower_all[j.idx_q]), float(upper_all[j.idx_q])
        if not lower < upper:
            free.append((j.name, f"no range declared (lower {lower:g} >= upper {upper:g})"))
            continue
        if not (np.isfinite(lower) or np.isfinite(upper)):
            free.append((j.name, "unbounded range"))
            continue
        names.append(j.name)
        iq.append(j.idx_q)
        iv.append(j.idx_v)
        lo.append(lower)
        hi.append(upper)
    return Stops(
        names=tuple(names),
        iq=np.array(iq, dtype=np.intp),
        iv=np.array(iv, dtype=np.intp),
        lower=np.array(lo, dtype=np.float64),
        upper=np.array(hi, dtype=np.float64),
        restitution=float(restitution),
        free=tuple(free),
    )


def stop_rows(stops: Stops, rows: list[tuple[int, int]], nv: int) -> Array:
    """The Jacobian rows side * e_j (len(rows), nv) of stop rows (k, side)."""
    J = np.zeros((len(rows), nv))
    for i, (k, side) in enumerate(rows):
        J[i, stops.iv[k]] = side
    return J


@dataclass(frozen=True)
class Impact:
    """The outcome of an impact: v+ (nv,), the impulse per stop row, the rows that stay in contact, dT [J]."""

    v: Array
    impulses: dict[tuple[int, int], float]
    contact: list[tuple[int, int]]
    energy_change: float


def impact(
    M: Array,
    v: Array,
    stops: Stops,
    hitting: list[tuple[int, int]],
    held: list[tuple[int, int]],
    loops: Array | None = None,
    *,
    restitution: float | None = None,
    plastic: bool = False,
) -> Impact:
    """The exact impulse when the rows ``hitting`` reach their stops while ``held`` rows (and loops) hold.

    Newton's law J v+ = -e J v- on the hitting rows, J v+ = 0 on the held rows and on the loop
    Jacobian ``loops`` (rows, nv); v+ = v- + M^-1 J^T L. A stop row whose impulse pulls lets go
    and the solve is redone without it.

    Args:
        M: the mass matrix (nv, nv) at the impact configuration.
        v: the velocity before the impact (nv,).
        stops: the stops (for the rows' joints and the restitution).
        hitting: rows (k, side) that reach their stop now.
        held: rows already held at their stop.
        loops: the loop-closure Jacobian, or None.
        restitution: e for this impact (default: the stops' own).
        plastic: keep every row, pulling or not (a joint brought to rest at its stop: the
            tiny impulse that stops a slow leaver is allowed to pull).

    Returns:
        The :class:`Impact`; its ``contact`` rows are the stop rows that pushed.
    """
    e = stops.restitution if restitution is None else restitution
    rows = [*hitting, *held]
    nv = v.size
    while True:
        J_stop = stop_rows(stops, rows, nv)
        J = J_stop if loops is None or loops.size == 0 else np.vstack([J_stop, loops])
        target = np.zeros(J.shape[0])
        for i, row in enumerate(rows):
            if row in hitting:
                target[i] = -e * float(J_stop[i] @ v)
        if J.shape[0] == 0:
            return Impact(v.copy(), {}, [], 0.0)
        Minv_Jt = np.linalg.solve(M, J.T)
        delassus = J @ Minv_Jt
        L = np.linalg.lstsq(delassus, target - J @ v, rcond=IMPACT_RCOND)[0]
        pulls = [i for i in range(len(rows)) if L[i] < -PULL_RTOL * max(1.0, float(np.max(np.abs(L))))]
        if plastic or not pulls:
            break
        rows = [r for i, r in enumerate(rows) if i not in pulls]
    v_plus = v + Minv_Jt @ L
    dT = 0.5 * float(v_plus @ M @ v_plus) - 0.5 * float(v @ M @ v)
    impulses = {r: float(L[i]) for i, r in enumerate(rows)}
    return Impact(v_plus, impulses, rows, dT)


def hold(
    M: Array, force: Array, held_iv: NDArray[np.intp], free_iv: NDArray[np.intp] | None = None
) -> tuple[Array, Array]:
    """(a, f): the acceleration with the joints ``held_iv`` held still, and the generalized stop force f (nv,).

    ``force`` is tau - C v - G = M a_smooth. Gauss's principle: a = a_smooth + M^-1 S^T lambda
    with a[held] = 0, i.e. M_ff a_f = force_f; f = M a - force is zero off the held joints.
    ``free_iv`` (the other velocity indices) may be given to save working it out.
    """
    nv = force.size
    free = np.setdiff1d(np.arange(nv), held_iv, assume_unique=True) if free_iv is None else free_iv
    a = np.zeros(nv)
    if free.size == 1:
        a[free] = force[free] / M[free, free]
    elif free.size:
        a[free] = np.linalg.solve(M.take(free, 0).take(free, 1), force[free])
    f = M @ a - force
    f[free] = 0.0
    return a, f
