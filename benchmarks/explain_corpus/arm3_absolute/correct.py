"""The 3-link arm of arm3 in ABSOLUTE angles (a linear COORDINATES map): the explain benchmark's correct file.

    robodyn check benchmarks/explain_corpus/arm3/robot.urdf \
        --formula benchmarks/explain_corpus/arm3_absolute/correct.py

th1, th2, th3: each link's angle from the horizontal, counter-clockwise in the x-z plane (z up), as many
textbooks write them: th1 = q_shoulder, th2 = q_shoulder + q_elbow, th3 = q_shoulder + q_elbow + q_wrist,
the matrix COORDINATES (q_formula = A q_urdf). Then T = 1/2 w^T M w with

    M11 = I1 + m1 lc1^2 + (m2 + m3) l1^2,  M22 = I2 + m2 lc2^2 + m3 l2^2,  M33 = I3 + m3 lc3^2,
    M12 = a12 cos(th2 - th1),  M13 = a13 cos(th3 - th1),  M23 = a23 cos(th3 - th2)

with a12 = (m2 lc2 + m3 l2) l1, a13 = m3 l1 lc3, a23 = m3 l2 lc3; each M[i,j] depends on th_i and th_j
only, so the Christoffel C[i,j] = a_ij sin(th_i - th_j) th_j' (i != j) and C[i,i] = 0.
V = g ((m1 lc1 + (m2 + m3) l1) sin th1 + (m2 lc2 + m3 l2) sin th2 + m3 lc3 sin th3).
"""

import numpy as np

KIND = "any"
JOINTS = ["shoulder", "elbow", "wrist"]
COORDINATES = [[1, 0, 0], [1, 1, 0], [1, 1, 1]]  # absolute angles: q_formula = A q_urdf
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
    th1, th2, th3 = q
    m1, m2, m3, l1, l2, lc1, lc2, lc3, I1, I2, I3 = (
        p[k] for k in ("m1", "m2", "m3", "l1", "l2", "lc1", "lc2", "lc3", "I1", "I2", "I3")
    )
    m11 = I1 + m1 * lc1**2 + (m2 + m3) * l1**2
    m22 = I2 + m2 * lc2**2 + m3 * l2**2
    m33 = I3 + m3 * lc3**2
    m12 = (m2 * lc2 + m3 * l2) * l1 * np.cos(th2 - th1)
    m13 = m3 * l1 * lc3 * np.cos(th3 - th1)
    m23 = m3 * l2 * lc3 * np.cos(th3 - th2)
    return np.array([[m11, m12, m13], [m12, m22, m23], [m13, m23, m33]])


def coriolis_matrix(q, v, p):
    th1, th2, th3 = q
    w1, w2, w3 = v
    m2, m3, l1, l2, lc2, lc3 = (p[k] for k in ("m2", "m3", "l1", "l2", "lc2", "lc3"))
    a12 = (m2 * lc2 + m3 * l2) * l1
    a13 = m3 * l1 * lc3
    a23 = m3 * l2 * lc3
    return np.array(
        [
            [0.0, a12 * np.sin(th1 - th2) * w2, a13 * np.sin(th1 - th3) * w3],
            [a12 * np.sin(th2 - th1) * w1, 0.0, a23 * np.sin(th2 - th3) * w3],
            [a13 * np.sin(th3 - th1) * w1, a23 * np.sin(th3 - th2) * w2, 0.0],
        ]
    )


def gravity(q, p):
    th1, th2, th3 = q
    m1, m2, m3, l1, l2, lc1, lc2, lc3, g = (p[k] for k in ("m1", "m2", "m3", "l1", "l2", "lc1", "lc2", "lc3", "g"))
    return g * np.array(
        [(m1 * lc1 + (m2 + m3) * l1) * np.cos(th1), (m2 * lc2 + m3 * l2) * np.cos(th2), m3 * lc3 * np.cos(th3)]
    )


def potential_energy(q, p):
    th1, th2, th3 = q
    m1, m2, m3, l1, l2, lc1, lc2, lc3, g = (p[k] for k in ("m1", "m2", "m3", "l1", "l2", "lc1", "lc2", "lc3", "g"))
    return g * ((m1 * lc1 + (m2 + m3) * l1) * np.sin(th1) + (m2 * lc2 + m3 * l2) * np.sin(th2) + m3 * lc3 * np.sin(th3))
