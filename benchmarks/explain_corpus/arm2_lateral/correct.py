"""A 2-link arm in a vertical plane with centres of mass off the link lines: the explain benchmark's correct file.

    robodyn check benchmarks/explain_corpus/arm2_lateral/robot.urdf \
        --formula benchmarks/explain_corpus/arm2_lateral/correct.py

alpha: link 1's angle from the horizontal, beta: link 2's relative to link 1, counter-clockwise in the
x-z plane (z up). Each centre of mass is (cx, cz) in its link's frame (cx along the link, cz across it,
in the plane), so with R(phi) the rotation by phi and e(phi) = (cos phi, sin phi):

    p1 = R(alpha) (cx1, cz1),   p2 = l1 e(alpha) + R(alpha + beta) (cx2, cz2)

    k = m2 l1 (cx2 cos beta - cz2 sin beta),  d1 = I1 + m1 (cx1^2 + cz1^2) + m2 l1^2,  d2 = I2 + m2 (cx2^2 + cz2^2)
    M11 = d1 + d2 + 2 k,  M12 = d2 + k,  M22 = d2,   C = [[h beta', h (alpha' + beta')], [-h alpha', 0]]

with h = dk/dbeta = -m2 l1 (cx2 sin beta + cz2 cos beta), and
V = g (m1 (cx1 sin alpha + cz1 cos alpha) + m2 (l1 sin alpha + cx2 sin(alpha + beta) + cz2 cos(alpha + beta))).
"""

import numpy as np

KIND = "any"
JOINTS = ["shoulder", "elbow"]
NAMES = ["alpha", "beta"]


def parameters(robot):
    """Masses, the upper link's length, centres of mass (along, across) and inertias about the joint axes."""
    upper, lower = robot["shoulder"], robot["elbow"]
    return {
        "m1": upper.mass, "m2": lower.mass, "l1": lower.origin[0],
        "cx1": upper.com[0], "cz1": upper.com[2], "cx2": lower.com[0], "cz2": lower.com[2],
        "I1": upper.inertia_about_axis, "I2": lower.inertia_about_axis,
        "g": robot.g,
    }  # fmt: skip


def mass_matrix(q, p):
    beta = q[1]
    m1, m2, l1, cx1, cz1, cx2, cz2, I1, I2 = (p[k] for k in ("m1", "m2", "l1", "cx1", "cz1", "cx2", "cz2", "I1", "I2"))
    k = m2 * l1 * (cx2 * np.cos(beta) - cz2 * np.sin(beta))
    d1 = I1 + m1 * (cx1**2 + cz1**2) + m2 * l1**2
    d2 = I2 + m2 * (cx2**2 + cz2**2)
    return np.array([[d1 + d2 + 2 * k, d2 + k], [d2 + k, d2]])


def coriolis_matrix(q, v, p):
    beta = q[1]
    alpha_dot, beta_dot = v
    h = -p["m2"] * p["l1"] * (p["cx2"] * np.sin(beta) + p["cz2"] * np.cos(beta))
    return np.array([[h * beta_dot, h * (alpha_dot + beta_dot)], [-h * alpha_dot, 0.0]])


def gravity(q, p):
    alpha, beta = q
    m1, m2, l1, cx1, cz1, cx2, cz2, g = (p[k] for k in ("m1", "m2", "l1", "cx1", "cz1", "cx2", "cz2", "g"))
    g2 = g * m2 * (cx2 * np.cos(alpha + beta) - cz2 * np.sin(alpha + beta))
    g1 = g * (m1 * (cx1 * np.cos(alpha) - cz1 * np.sin(alpha)) + m2 * l1 * np.cos(alpha)) + g2
    return np.array([g1, g2])


def potential_energy(q, p):
    alpha, beta = q
    m1, m2, l1, cx1, cz1, cx2, cz2, g = (p[k] for k in ("m1", "m2", "l1", "cx1", "cz1", "cx2", "cz2", "g"))
    y1 = cx1 * np.sin(alpha) + cz1 * np.cos(alpha)
    y2 = l1 * np.sin(alpha) + cx2 * np.sin(alpha + beta) + cz2 * np.cos(alpha + beta)
    return g * (m1 * y1 + m2 * y2)
