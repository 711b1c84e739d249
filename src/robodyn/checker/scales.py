"""The round-off floors of ``robodyn check``'s rows: the magnitudes each sample's quantities are summed from.

A row passes within an absolute floor of ``ROUNDOFF`` eps times the magnitude of the terms its
quantity is computed from (:mod:`robodyn.checker.rows`): |M|, the sample's speeds and
accelerations, the energy scale |g| sum m_i |c_i|; the round trips through M are held to cond(M)
|a| on top. :func:`scales` reads them for one sample.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.checker.rows import EPS, ROUNDOFF
from robodyn.robot import Robot

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Scales:
    """The magnitudes of the terms one sample's quantities are computed from: their round-off scale.

    Each ``*_floor`` is ROUNDOFF eps times such a magnitude, in the unit of the rows it serves.
    """

    mass: float  # max |M_ij| [kg m^2]
    cond: float  # lambda_max / lambda_min of M (inf when M is not positive definite)
    inverse: float  # 1 / lambda_min of M [1/(kg m^2)]
    energy: float  # |g| sum_i m_i |c_i| [J]: the potential energy's terms, and the gravity torques' scale
    speed: float  # max |v| [rad/s | m/s]
    accel: float  # max |a| [rad/s^2 | m/s^2]
    torque: float  # max |tau| [N m | N]

    @property
    def torque_terms(self) -> float:
        """|M| (|a| + |v|^2) + the energy scale + |tau| [N m]: the terms of M a + C v + G and of tau."""
        return self.mass * (self.accel + self.speed**2) + self.energy + self.torque

    @property
    def coriolis_terms(self) -> float:
        """|M| |v| + the energy scale / |v| [kg m^2/s]: C is built from RNEA(q, v, 0) - G, divided by |v|."""
        return self.mass * self.speed + (self.energy / self.speed if self.speed > 0 else 0.0)

    def floor(self, terms: float) -> float:
        """The round-off ROUNDOFF eps ``terms`` of a quantity summed from terms of magnitude ``terms``."""
        return ROUNDOFF * EPS * terms

    def forward_floor(self, a: Array) -> float:
        """Round-off of a = M^-1 (tau - C v - G) [rad/s^2]: cond(M) |a| + |M^-1| |the right side's terms|."""
        return self.floor(self.cond * float(np.abs(a).max(initial=0.0)) + self.inverse * self.torque_terms)


def scales(robot: Robot, s: Any, M: Array, *, energy: float | None = None) -> Scales:
    """The round-off scales of sample ``s`` (``.q``, ``.v``, ``.a``, ``.tau``) whose mass matrix is ``M``."""
    eig = np.linalg.eigvalsh(0.5 * (M + M.T)) if np.all(np.isfinite(M)) else np.full(1, np.nan)
    positive = bool(eig[0] > 0)
    return Scales(
        mass=float(np.abs(M).max()),
        cond=float(eig[-1] / eig[0]) if positive else np.inf,
        inverse=float(1.0 / eig[0]) if positive else np.inf,
        energy=dynamics.gravity_scale(robot.model, robot.data, s.q) if energy is None else energy,
        speed=float(np.abs(s.v).max()),
        accel=float(np.abs(s.a).max()),
        torque=float(np.abs(s.tau).max()),
    )
