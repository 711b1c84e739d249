"""The Pendubot exactly as the textbook excerpt prints its matrix form, misprints included.

Check it with:  robodyn check pendubot --formula examples/formulas/pendubot_seed.py
It fails on purpose: docs/errata.md lists the two misprints the check exposes here
(d12 carries a spurious factor 2; C21 is -h q2' instead of -h q1').
"""

import numpy as np

KIND = "pendubot"


def mass_matrix(q, p):
    m1, m2, l1, lc1, lc2, I1, I2 = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "I1", "I2"))
    c2 = np.cos(q[1])
    d11 = m1 * lc1**2 + m2 * (l1**2 + lc2**2 + 2 * l1 * lc2 * c2) + I1 + I2
    d12 = m2 * (lc2**2 + 2 * l1 * lc2 * c2) + I2  # as printed
    d22 = m2 * lc2**2 + I2
    return np.array([[d11, d12], [d12, d22]])


def coriolis_matrix(q, v, p):
    h = -p["m2"] * p["l1"] * p["lc2"] * np.sin(q[1])
    return np.array([[h * v[1], h * v[1] + h * v[0]], [-h * v[1], 0.0]])  # C21 as printed


def gravity(q, p):
    m1, m2, l1, lc1, lc2, g = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "g"))
    phi2 = m2 * lc2 * g * np.cos(q[0] + q[1])
    return np.array([(m1 * lc1 + m2 * l1) * g * np.cos(q[0]) + phi2, phi2])
