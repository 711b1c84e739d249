"""The single-link arm exactly as the textbook excerpt prints Eq. (6.1.33) of Example 6.1.1, in the motor angle.

    (J_m + J_l / n) theta_m'' + (M g l / n) sin(theta_m / n) = tau

The inertia should be J_m + J_l / n^2 (the excerpt's own Eq. 6.1.32 has n^2). Check it with:

    robodyn check geared_arm --formula examples/formulas/geared_arm_seed.py

The excerpt's M, the link's mass, is p["m"] here: in robodyn M is only ever the mass matrix.
"""

import numpy as np

KIND = "geared_arm"
COORDINATES = "motor"  # theta_m = n theta_l; robodyn maps to the link coordinate


def mass_matrix(q, p):
    return np.array([[p["J_m"] + p["J_l"] / p["n"]]])  # as printed


def coriolis_matrix(q, v, p):
    return np.zeros((1, 1))


def gravity(q, p):
    return np.array([p["m"] * p["g"] * p["l"] / p["n"] * np.sin(q[0] / p["n"])])


def potential_energy(q, p):
    return p["m"] * p["g"] * p["l"] * (1.0 - np.cos(q[0] / p["n"]))
