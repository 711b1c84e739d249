"""The cart-pole: a cart at y on a rail and a pole at angle theta from the upward vertical.

Derivation: the pole's centre of mass is at (y + l sin th, l cos th), so

    T = 1/2 M y'^2 + 1/2 m [(y' + l th' cos th)^2 + (l th' sin th)^2] + 1/2 I th'^2
      = 1/2 (M + m) y'^2 + m l cos th y' th' + 1/2 (m l^2 + I) th'^2
    V = m g l cos th

and Lagrange's equations give

    (M + m) y'' + m l cos th th'' - m l sin th th'^2 = f
    m l cos th y'' + (m l^2 + I) th'' - m g l sin th = 0

(the m l sin th y' th' terms of d/dt dL/dth' and of dL/dth cancel). In matrix form
M = [[M + m, m l cos th], [m l cos th, m l^2 + I]], C = [[0, -m l sin th th'], [0, 0]],
G = [0, -m g l sin th]. I = 0 is the seed's point bob; I = m (2 l)^2 / 12 a uniform rod.
"""

from __future__ import annotations

import numpy as np

from robodyn.kinds.formulas import Array, Formula, Params

PARAMS = ("M", "m", "l", "I", "g")


def mass_matrix(q: Array, p: Params) -> Array:
    """M(q) [kg, kg m, kg m^2], (2, 2)."""
    coupling = p["m"] * p["l"] * np.cos(q[1])
    return np.array([[p["M"] + p["m"], coupling], [coupling, p["m"] * p["l"] ** 2 + p["I"]]])


def coriolis_matrix(q: Array, v: Array, p: Params) -> Array:
    """Christoffel-form C(q, v), (2, 2)."""
    return np.array([[0.0, -p["m"] * p["l"] * np.sin(q[1]) * v[1]], [0.0, 0.0]])


def gravity(q: Array, p: Params) -> Array:
    """G(q) = dV/dq [N, N m], (2,)."""
    return np.array([0.0, -p["m"] * p["g"] * p["l"] * np.sin(q[1])])


def potential_energy(q: Array, p: Params) -> float:
    """V(q) [J], zero with the pole's centre of mass at the pivot's height."""
    return float(p["m"] * p["g"] * p["l"] * np.cos(q[1]))


FORMULA = Formula(
    "cart_pole", "robodyn.kinds.cart_pole", PARAMS, mass_matrix, coriolis_matrix, gravity, potential_energy, 2
)
