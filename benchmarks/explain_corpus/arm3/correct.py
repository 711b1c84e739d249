"""A 3-link arm in a vertical plane, relative angles: the explain benchmark's correct file.

    robodyn check benchmarks/explain_corpus/arm3/robot.urdf --formula benchmarks/explain_corpus/arm3/correct.py

th1: link 1's angle from the horizontal, th2 and th3 each link's angle relative to the one before,
counter-clockwise in the x-z plane (z up). Absolute angles phi1 = th1, phi12 = th1 + th2,
phi123 = th1 + th2 + th3. In absolute velocities T = 1/2 w^T Ma w with

    Ma11 = I1 + m1 lc1^2 + (m2 + m3) l1^2,  Ma22 = I2 + m2 lc2^2 + m3 l2^2,  Ma33 = I3 + m3 lc3^2,
    Ma12 = (m2 lc2 + m3 l2) l1 cos th2,  Ma13 = m3 l1 lc3 cos(th2 + th3),  Ma23 = m3 l2 lc3 cos th3

and in relative angles M[i,j] = sum over k >= i, l >= j of Ma[k,l]. C: the Christoffel symbols of the
hand-written dM/dth2 and dM/dth3. V = g ((m1 lc1 + (m2 + m3) l1) sin phi1 + (m2 lc2 + m3 l2) sin phi12
+ m3 lc3 sin phi123).
"""

import numpy as np

KIND = "any"
JOINTS = ["shoulder", "elbow", "wrist"]
NAMES = ["th1", "th2", "th3"]


def parameters(robot):
    """Masses, lengths, centres of mass along the links and inertias about the joint axes."""
    upper, fore, hand = robot["shoulder"], robot["elbow"], robot["wrist"]
    return {
        "m1": upper.mass, "m2": fore.mass, "m3": hand.mass,
        "l1": fore.origin[0], "l2": hand.origin[0],
        "lc1": upper.com[0], "lc2": fore.com[0], "lc3": hand.com[0],
        "I1": upper.inertia_about_axis, "I2": fore.inertia_about_axis, "I3": hand.inertia_about_axis,
        "g": robot.g,
    }  # fmt: skip


def mass_matrix(q, p):
    th2, th3 = q[1], q[2]
    m1, m2, m3, l1, l2, lc1, lc2, lc3, I1, I2, I3 = (
        p[k] for k in ("m1", "m2", "m3", "l1", "l2", "lc1", "lc2", "lc3", "I1", "I2", "I3")
    )
    d1 = I1 + m1 * lc1**2 + (m2 + m3) * l1**2
    d2 = I2 + m2 * lc2**2 + m3 * l2**2
    d3 = I3 + m3 * lc3**2
    k12 = (m2 * lc2 + m3 * l2) * l1 * np.cos(th2)
    k13 = m3 * l1 * lc3 * np.cos(th2 + th3)
    k23 = m3 * l2 * lc3 * np.cos(th3)
    m11 = d1 + d2 + d3 + 2 * (k12 + k13 + k23)
    m12 = d2 + d3 + 2 * k23 + k12 + k13
    m13 = d3 + k23 + k13
    m22 = d2 + d3 + 2 * k23
    m23 = d3 + k23
    return np.array([[m11, m12, m13], [m12, m22, m23], [m13, m23, d3]])


def coriolis_matrix(q, v, p):
    th2, th3 = q[1], q[2]
    m2, m3, l1, l2, lc2, lc3 = (p[k] for k in ("m2", "m3", "l1", "l2", "lc2", "lc3"))
    s12 = -(m2 * lc2 + m3 * l2) * l1 * np.sin(th2)  # dk12/dth2
    s13 = -m3 * l1 * lc3 * np.sin(th2 + th3)  # dk13/dth2 = dk13/dth3
    s23 = -m3 * l2 * lc3 * np.sin(th3)  # dk23/dth3
    D = [
        np.zeros((3, 3)),
        np.array([[2 * (s12 + s13), s12 + s13, s13], [s12 + s13, 0.0, 0.0], [s13, 0.0, 0.0]]),
        np.array([[2 * (s13 + s23), s13 + 2 * s23, s13 + s23], [s13 + 2 * s23, 2 * s23, s23], [s13 + s23, s23, 0.0]]),
    ]
    C = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            for k in range(3):
                C[i, j] += 0.5 * (D[k][i, j] + D[j][i, k] - D[i][j, k]) * v[k]
    return C


def gravity(q, p):
    th1, th2, th3 = q
    m1, m2, m3, l1, l2, lc1, lc2, lc3, g = (p[k] for k in ("m1", "m2", "m3", "l1", "l2", "lc1", "lc2", "lc3", "g"))
    g3 = g * m3 * lc3 * np.cos(th1 + th2 + th3)
    g2 = g * (m2 * lc2 + m3 * l2) * np.cos(th1 + th2) + g3
    g1 = g * (m1 * lc1 + (m2 + m3) * l1) * np.cos(th1) + g2
    return np.array([g1, g2, g3])


def potential_energy(q, p):
    th1, th2, th3 = q
    m1, m2, m3, l1, l2, lc1, lc2, lc3, g = (p[k] for k in ("m1", "m2", "m3", "l1", "l2", "lc1", "lc2", "lc3", "g"))
    heights = (m1 * lc1 + (m2 + m3) * l1) * np.sin(th1) + (m2 * lc2 + m3 * l2) * np.sin(th1 + th2)
    return g * (heights + m3 * lc3 * np.sin(th1 + th2 + th3))
