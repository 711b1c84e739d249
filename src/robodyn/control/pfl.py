"""Collocated partial feedback linearisation: the torque that gives the actuated joints a chosen acceleration.

Split the velocities into actuated (a) and passive (p) ones. The passive rows of
M qdd + h = S u, with h = C v + G + D v (the joint damping as :func:`robodyn.simulate` applies it),
carry no torque, so qdd_p = -M_pp^-1 (M_pa qdd_a + h_p), and the actuated rows then give

    u = Mbar qdd_a + hbar,  Mbar = M_aa - M_ap M_pp^-1 M_pa,  hbar = h_a - M_ap M_pp^-1 h_p

(Spong, "Partial feedback linearization of underactuated mechanical systems", IROS 1994).
Mbar, a Schur complement of M, is positive definite, so any actuated acceleration is reachable;
the torque it takes may exceed the effort limit, which the controllers then clip.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.robot import Robot

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Collocated:
    """The collocated PFL of one robot: index sets and damping read once, for the per-step calls."""

    robot: Robot
    act: NDArray[np.intp]
    pas: NDArray[np.intp]
    damping: Array

    def reduced(self, q: Array, v: Array) -> tuple[Array, Array, Array]:
        """(Mbar (n_act, n_act), hbar (n_act,), M (nv, nv)) at (q, v): u = Mbar qdd_a + hbar."""
        model, data = self.robot.model, self.robot.data
        M = dynamics.mass_matrix(model, data, q)
        h = dynamics.nonlinear_effects(model, data, q, v) + self.damping * v
        a, p = self.act, self.pas
        if p.size == 0:
            return M, h, M
        if a.size == 1 and p.size == 1:  # the built-in kinds: scalar arithmetic, 5x faster than the solve
            i, j = a[0], p[0]
            ratio = M[i, j] / M[j, j]
            return np.array([[M[i, i] - ratio * M[j, i]]]), np.array([h[i] - ratio * h[j]]), M
        M_ap = M[a][:, p]
        X = np.linalg.solve(M[p][:, p], np.column_stack([M[p][:, a], h[p]]))
        return M[a][:, a] - M_ap @ X[:, :-1], h[a] - M_ap @ X[:, -1], M

    def torque(self, q: Array, v: Array, accel: Array) -> Array:
        """The actuated torques (n_act,) [N m | N] that give the actuated joints the acceleration ``accel`` (n_act,)."""
        Mbar, hbar, _ = self.reduced(q, v)
        return np.asarray(Mbar @ accel + hbar, dtype=np.float64)


def collocated(robot: Robot) -> Collocated:
    """The :class:`Collocated` PFL of ``robot``."""
    mask = robot.actuated
    return Collocated(robot, np.flatnonzero(mask), np.flatnonzero(~mask), robot.damping)
