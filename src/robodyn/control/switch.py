"""The hand-over from swing-up to LQR balance inside a stated region of attraction.

The switch is stateless: at every call it is the LQR when the state lies inside the region
{e : e^T P e < rho} of :mod:`robodyn.control.region`, and the swing-up law outside it. The region
is (by the sampled estimate) invariant under the LQR, so once inside the state stays inside and
the hand-over happens once; no memory means the integrators' intermediate stages see the same
law as the recorded samples.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn.control.lqr import LQR
from robodyn.control.region import Region

Array = NDArray[np.float64]

SWING_UP, BALANCE = 0, 1


@dataclass(frozen=True, eq=False)
class Switched:
    """``swing_up`` outside the region, ``lqr`` inside it; call as tau(t, q, v) -> u (n_act,)."""

    swing_up: Callable[[float, Array, Array], Array]
    lqr: LQR
    region: Region

    def mode(self, q: ArrayLike, v: ArrayLike) -> int:
        """``BALANCE`` (1) inside the region, ``SWING_UP`` (0) outside."""
        return BALANCE if float(self.lqr.value(q, v)) < self.region.rho else SWING_UP

    def modes(self, q: Array, v: Array) -> NDArray[np.int_]:
        """The mode of each state of a batch q (m, nq), v (m, nv), shape (m,)."""
        return np.where(self.lqr.value(q, v) < self.region.rho, BALANCE, SWING_UP)

    def record(self, q: Array, v: Array) -> dict[str, object]:
        """What a trajectory's ``meta["controller"]`` records of this law, sample by sample (the replay charts it).

        ``modes`` the modes' names; ``mode`` the mode at each state of q (m, nq), v (m, nv);
        ``energy`` the swing-up law's own energy at each state [J] (the cart-pole's pole energy,
        zero upright at rest; the Pendubot's link 2 energy, zero upright at rest), ``energy_target`` [J] the value it
        pumps towards and ``energy_name`` what that energy is (left out when the swing-up law
        states no energy); ``upright`` the LQR's equilibrium q (nq,) and ``angular`` the
        coordinates whose error is an angle.
        """
        q, v = np.asarray(q, dtype=np.float64), np.asarray(v, dtype=np.float64)
        out: dict[str, object] = {
            "modes": ["swing-up", "LQR balance"],
            "mode": [int(m) for m in self.modes(q, v)],
            "upright": [float(x) for x in self.lqr.q_eq],
            "angular": [bool(a) for a in np.broadcast_to(self.lqr.plant.angular, self.lqr.q_eq.shape)],
        }
        energy = getattr(self.swing_up, "energy", None)
        target = getattr(self.swing_up, "energy_up", None)
        if energy is not None and target is not None:
            out["energy"] = [float(energy(qi, vi)) for qi, vi in zip(q, v, strict=True)]
            out["energy_target"] = float(target)
            out["energy_name"] = str(getattr(self.swing_up, "energy_name", "the swing-up law's energy"))
        return out

    def __call__(self, t: float, q: Array, v: Array) -> Array:
        """The actuated torques [N m | N] (n_act,)."""
        if self.mode(q, v) == BALANCE:
            return self.lqr(t, q, v)
        return self.swing_up(t, q, v)
