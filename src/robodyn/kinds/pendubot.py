"""The Pendubot: two links in a vertical plane, angles from the horizontal (closed form written once).

Derivation (link coordinates, q1 from the horizontal, q2 relative to link 1):
centres of mass at r1 = lc1 (cos q1, sin q1) and r2 = l1 (cos q1, sin q1) + lc2 (cos q12, sin q12),
q12 = q1 + q2, so

    T = 1/2 (m1 lc1^2 + I1) q1'^2 + 1/2 m2 |r2'|^2 + 1/2 I2 (q1' + q2')^2
    V = (m1 lc1 + m2 l1) g sin q1 + m2 lc2 g sin q12

and Lagrange's equations give M q'' + C q' + G = tau with

    M11 = m1 lc1^2 + m2 (l1^2 + lc2^2 + 2 l1 lc2 cos q2) + I1 + I2
    M12 = M21 = m2 (lc2^2 + l1 lc2 cos q2) + I2
    M22 = m2 lc2^2 + I2
    h = -m2 l1 lc2 sin q2 = 1/2 dM11/dq2 = dM12/dq2
    C = [[h q2', h (q1' + q2')], [-h q1', 0]]        (Christoffel symbols of M)
    G = [(m1 lc1 + m2 l1) g cos q1 + m2 lc2 g cos q12,  m2 lc2 g cos q12]

The four functions below are the only place this closed form is written: see
:mod:`robodyn.kinds.formula` for how they serve NumPy, numba and extended precision.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robodyn.kinds.bodies import (
    EX,
    EY,
    Body,
    along,
    axis_inertia,
    fail,
    require_axis,
    require_gravity,
    require_joints,
    require_no_armature,
)
from robodyn.kinds.formula import Array, ClosedForm, Scalar
from robodyn.kinds.kind import Balance, Kind

PARAMS = ("m1", "m2", "l1", "lc1", "lc2", "I1", "I2", "g")


def mass(p: Scalar, q1: Scalar, q2: Scalar) -> tuple[Scalar, Scalar, Scalar]:
    """(M11, M12, M22) [kg m^2]."""
    m1, m2, l1, lc1, lc2, I1, I2 = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
    c = m2 * l1 * lc2 * np.cos(q2)
    m22 = m2 * lc2 * lc2 + I2
    return m1 * lc1 * lc1 + m2 * l1 * l1 + I1 + m22 + 2.0 * c, m22 + c, m22


def coriolis(p: Scalar, q1: Scalar, q2: Scalar, v1: Scalar, v2: Scalar) -> tuple[Scalar, Scalar, Scalar, Scalar]:
    """(C11, C12, C21, C22) of the Christoffel-form C(q, v) [kg m^2/s]."""
    h = -p[1] * p[2] * p[4] * np.sin(q2)
    return h * v2, h * (v1 + v2), -h * v1, 0.0 * h


def gravity(p: Scalar, q1: Scalar, q2: Scalar) -> tuple[Scalar, Scalar]:
    """(G1, G2) = dV/dq [N m]."""
    m1, m2, l1, lc1, lc2, g = p[0], p[1], p[2], p[3], p[4], p[7]
    g2 = m2 * lc2 * g * np.cos(q1 + q2)
    return (m1 * lc1 + m2 * l1) * g * np.cos(q1) + g2, g2


def potential(p: Scalar, q1: Scalar, q2: Scalar) -> Scalar:
    """V [J], zero with both links horizontal."""
    m1, m2, l1, lc1, lc2, g = p[0], p[1], p[2], p[3], p[4], p[7]
    return (m1 * lc1 + m2 * l1) * g * np.sin(q1) + m2 * lc2 * g * np.sin(q1 + q2)


def read(bodies: Sequence[Body], gravity_vector: Array) -> dict[str, float]:
    """The parameters of a model that is a Pendubot: planar in x-z, axes 0 -1 0, links along +x at q = 0."""
    kind = "pendubot"
    require_joints(kind, bodies, ("R", "R"))
    axis = -EY
    for body in bodies:
        require_axis(kind, body, axis, "angular")
    g = require_gravity(kind, gravity_vector)
    require_no_armature(kind, bodies)
    b1, b2 = bodies
    l1 = along(kind, f"joint {b2.name} (link 1's end)", b2.origin - b1.origin, EX, axis)
    lc1 = along(kind, f"the centre of mass of link 1 ({b1.name})", b1.com - b1.origin, EX, axis)
    lc2 = along(kind, f"the centre of mass of link 2 ({b2.name})", b2.com - b2.origin, EX, axis)
    if l1 <= 0:
        raise fail(
            kind, f"link 1 must point along +x at q = 0 (joint {b2.name} is at x = {l1:.6g} m from joint {b1.name})"
        )
    return {
        "m1": b1.mass,
        "m2": b2.mass,
        "l1": l1,
        "lc1": lc1,
        "lc2": lc2,
        "I1": axis_inertia(b1, axis),
        "I2": axis_inertia(b2, axis),
        "g": g,
    }


CLOSED_FORM = ClosedForm(PARAMS, 2, mass, coriolis, gravity, potential)
UNITS = {"m1": "kg", "m2": "kg", "l1": "m", "lc1": "m", "lc2": "m", "I1": "kg m^2", "I2": "kg m^2", "g": "m/s^2"}
KIND = Kind(
    "pendubot",
    CLOSED_FORM,
    read,
    UNITS,
    code=0,
    balance=Balance(upright=(np.pi / 2, 0.0), hanging=(-np.pi / 2, 0.0), driven=0),
)
FORMULA = KIND.formula
