"""The cart-pole: a cart at y on a rail and a pole at angle theta from the upward vertical (closed form written once).

Derivation: the pole's centre of mass is at (y + l sin th, l cos th), so

    T = 1/2 m_cart y'^2 + 1/2 m [(y' + l th' cos th)^2 + (l th' sin th)^2] + 1/2 I th'^2
      = 1/2 (m_cart + m) y'^2 + m l cos th y' th' + 1/2 (m l^2 + I) th'^2
    V = m g l cos th

and Lagrange's equations give

    (m_cart + m) y'' + m l cos th th'' - m l sin th th'^2 = f
    m l cos th y'' + (m l^2 + I) th'' - m g l sin th = 0

(the m l sin th y' th' terms of d/dt dL/dth' and of dL/dth cancel). In matrix form
M = [[m_cart + m, m l cos th], [m l cos th, m l^2 + I]], C = [[0, -m l sin th th'], [0, 0]],
G = [0, -m g l sin th], with m_cart the cart's mass [kg] and m the pole's (M is only ever the mass
matrix). I = 0 is a point bob; I = m (2 l)^2 / 12 a uniform rod.

The four functions below are the only place this closed form is written: see
:mod:`robodyn.kinds.formula` for how they serve NumPy, numba and extended precision.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robodyn.kinds.bodies import (
    EX,
    EY,
    EZ,
    Body,
    along,
    axis_inertia,
    require_axis,
    require_gravity,
    require_joints,
    require_no_armature,
)
from robodyn.kinds.formula import Array, ClosedForm, Scalar
from robodyn.kinds.kind import Balance, Kind

PARAMS = ("m_cart", "m", "l", "I", "g")


def mass(p: Scalar, y: Scalar, th: Scalar) -> tuple[Scalar, Scalar, Scalar]:
    """(M11 [kg], M12 [kg m], M22 [kg m^2])."""
    m_cart, m, l, I = p[0], p[1], p[2], p[3]
    return m_cart + m, m * l * np.cos(th), m * l * l + I


def coriolis(p: Scalar, y: Scalar, th: Scalar, vy: Scalar, vth: Scalar) -> tuple[Scalar, Scalar, Scalar, Scalar]:
    """(C11, C12, C21, C22) of the Christoffel-form C(q, v)."""
    c12 = -p[1] * p[2] * np.sin(th) * vth
    zero = 0.0 * c12
    return zero, c12, zero, zero


def gravity(p: Scalar, y: Scalar, th: Scalar) -> tuple[Scalar, Scalar]:
    """(G1 [N], G2 [N m]) = dV/dq."""
    g2 = -p[1] * p[4] * p[2] * np.sin(th)
    return 0.0 * g2, g2


def potential(p: Scalar, y: Scalar, th: Scalar) -> Scalar:
    """V [J], zero with the pole's centre of mass at the pivot's height."""
    return p[1] * p[4] * p[2] * np.cos(th)


def read(bodies: Sequence[Body], gravity_vector: Array) -> dict[str, float]:
    """The parameters of a model that is a cart-pole: rail along +x, pole axis 0 1 0, pole up at theta = 0."""
    kind = "cart_pole"
    require_joints(kind, bodies, ("P", "R"))
    cart, pole = bodies
    require_axis(kind, cart, EX, "linear")
    require_axis(kind, pole, EY, "angular")
    g = require_gravity(kind, gravity_vector)
    require_no_armature(kind, bodies)
    l = along(kind, f"the pole's centre of mass ({pole.name})", pole.com - pole.origin, EZ, EY)
    return {"m_cart": cart.mass, "m": pole.mass, "l": l, "I": axis_inertia(pole, EY), "g": g}


CLOSED_FORM = ClosedForm(PARAMS, 2, mass, coriolis, gravity, potential)
KIND = Kind(
    "cart_pole",
    CLOSED_FORM,
    read,
    {"m_cart": "kg", "m": "kg", "l": "m", "I": "kg m^2", "g": "m/s^2"},
    code=1,
    balance=Balance(upright=(0.0, 0.0), hanging=(0.0, np.pi), driven=0),
    renamed={"M": ("m_cart", "the cart's mass")},
)
FORMULA = KIND.formula
