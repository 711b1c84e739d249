"""The Pendubot with a C grouped by hand from Lagrange's equations: C v is right, C is not Christoffel's.

    robodyn check pendubot --formula examples/formulas/pendubot_grouped_c.py

Every equation of motion (M a + C v + G = tau) agrees with Pinocchio, so the check is headed PASS
(equations of motion) and exits 0; its C differs from the Christoffel C in C[0,0] and C[0,1], and
dM/dt - 2C is not skew, which the note under the headline says. The Christoffel form is
examples/formulas/pendubot_mine.py.
"""

import numpy as np

KIND = "pendubot"


def mass_matrix(q, p):
    # theta1..theta3 in Spong and Block's lumped notation
    t1 = p["m1"] * p["lc1"] ** 2 + p["m2"] * p["l1"] ** 2 + p["I1"]
    t2 = p["m2"] * p["lc2"] ** 2 + p["I2"]
    t3 = p["m2"] * p["l1"] * p["lc2"]
    c2 = np.cos(q[1])
    return np.array([[t1 + t2 + 2 * t3 * c2, t2 + t3 * c2], [t2 + t3 * c2, t2]])


def coriolis_matrix(q, v, p):
    # the velocity terms of Lagrange's equations grouped by hand:
    # -t3 s2 (2 v1 v2 + v2^2) = (-2 t3 s2 v2) v1 + (-t3 s2 v2) v2, and t3 s2 v1^2 = (t3 s2 v1) v1
    t3 = p["m2"] * p["l1"] * p["lc2"]
    s2 = np.sin(q[1])
    return np.array([[-2 * t3 * s2 * v[1], -t3 * s2 * v[1]], [t3 * s2 * v[0], 0.0]])


def gravity(q, p):
    t4 = p["m1"] * p["lc1"] + p["m2"] * p["l1"]
    t5 = p["m2"] * p["lc2"]
    return p["g"] * np.array([t4 * np.cos(q[0]) + t5 * np.cos(q[0] + q[1]), t5 * np.cos(q[0] + q[1])])


def potential_energy(q, p):
    t4 = p["m1"] * p["lc1"] + p["m2"] * p["l1"]
    t5 = p["m2"] * p["lc2"]
    return p["g"] * (t4 * np.sin(q[0]) + t5 * np.sin(q[0] + q[1]))
