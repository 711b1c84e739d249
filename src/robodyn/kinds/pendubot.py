"""The Pendubot: two links in a vertical plane, angles from the horizontal.

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
"""

from __future__ import annotations

import numpy as np

from robodyn.kinds.formulas import Array, Formula, Params

PARAMS = ("m1", "m2", "l1", "lc1", "lc2", "I1", "I2", "g")


def mass_matrix(q: Array, p: Params) -> Array:
    """M(q) [kg m^2], (2, 2)."""
    c2 = np.cos(q[1])
    m22 = p["m2"] * p["lc2"] ** 2 + p["I2"]
    m12 = m22 + p["m2"] * p["l1"] * p["lc2"] * c2
    m11 = p["m1"] * p["lc1"] ** 2 + p["I1"] + p["m2"] * p["l1"] ** 2 + m22 + 2.0 * p["m2"] * p["l1"] * p["lc2"] * c2
    return np.array([[m11, m12], [m12, m22]])


def coriolis_matrix(q: Array, v: Array, p: Params) -> Array:
    """Christoffel-form C(q, v) [kg m^2/s], (2, 2)."""
    h = -p["m2"] * p["l1"] * p["lc2"] * np.sin(q[1])
    return np.array([[h * v[1], h * (v[0] + v[1])], [-h * v[0], 0.0]])


def gravity(q: Array, p: Params) -> Array:
    """G(q) = dV/dq [N m], (2,)."""
    g2 = p["m2"] * p["lc2"] * p["g"] * np.cos(q[0] + q[1])
    return np.array([(p["m1"] * p["lc1"] + p["m2"] * p["l1"]) * p["g"] * np.cos(q[0]) + g2, g2])


def potential_energy(q: Array, p: Params) -> float:
    """V(q) [J], zero with both links horizontal."""
    return float(
        (p["m1"] * p["lc1"] + p["m2"] * p["l1"]) * p["g"] * np.sin(q[0])
        + p["m2"] * p["lc2"] * p["g"] * np.sin(q[0] + q[1])
    )


FORMULA = Formula(
    "pendubot", "robodyn.kinds.pendubot", PARAMS, mass_matrix, coriolis_matrix, gravity, potential_energy, 2
)
