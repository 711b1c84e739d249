"""A student's own Pendubot derivation, written out term by term (it is correct).

Use it as a template for your own:  robodyn check pendubot --formula examples/formulas/pendubot_mine.py

The file defines KIND and three functions of q (and v) and the parameter mapping p, whose
names are those of `robodyn params pendubot`: m1, m2, l1, lc1, lc2, I1, I2, g.
Optionally potential_energy(q, p). Angles from the horizontal, counter-clockwise positive.
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
    t3 = p["m2"] * p["l1"] * p["lc2"]
    s2 = np.sin(q[1])
    return np.array([[-t3 * s2 * v[1], -t3 * s2 * (v[0] + v[1])], [t3 * s2 * v[0], 0.0]])


def gravity(q, p):
    t4 = p["m1"] * p["lc1"] + p["m2"] * p["l1"]
    t5 = p["m2"] * p["lc2"]
    return p["g"] * np.array([t4 * np.cos(q[0]) + t5 * np.cos(q[0] + q[1]), t5 * np.cos(q[0] + q[1])])


def potential_energy(q, p):
    t4 = p["m1"] * p["lc1"] + p["m2"] * p["l1"]
    t5 = p["m2"] * p["lc2"]
    return p["g"] * (t4 * np.sin(q[0]) + t5 * np.sin(q[0] + q[1]))
