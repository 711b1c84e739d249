"""The Pendubot with C v alone: coriolis_vector(q, v, p) in place of coriolis_matrix (it is correct).

    robodyn check pendubot --formula examples/formulas/pendubot_cv.py

robodyn checks C v and what follows from it (C v + G, inverse and forward dynamics), and says in one
line that C itself and the skew property of dM/dt - 2C were not checked: a file that gives no C has
none to check. Otherwise as examples/formulas/pendubot_mine.py.
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


def coriolis_vector(q, v, p):
    # C(q, v) v straight from Lagrange's equations, never written as a matrix
    t3 = p["m2"] * p["l1"] * p["lc2"]
    s2 = np.sin(q[1])
    return np.array([-t3 * s2 * (2 * v[0] * v[1] + v[1] ** 2), t3 * s2 * v[0] ** 2])


def gravity(q, p):
    t4 = p["m1"] * p["lc1"] + p["m2"] * p["l1"]
    t5 = p["m2"] * p["lc2"]
    return p["g"] * np.array([t4 * np.cos(q[0]) + t5 * np.cos(q[0] + q[1]), t5 * np.cos(q[0] + q[1])])


def potential_energy(q, p):
    t4 = p["m1"] * p["lc1"] + p["m2"] * p["l1"]
    t5 = p["m2"] * p["lc2"]
    return p["g"] * (t4 * np.sin(q[0]) + t5 * np.sin(q[0] + q[1]))
