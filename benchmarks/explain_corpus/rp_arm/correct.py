"""A revolute-prismatic arm in a vertical plane, the slider's rail offset from the link: the correct file.

    robodyn check benchmarks/explain_corpus/rp_arm/robot.urdf --formula benchmarks/explain_corpus/rp_arm/correct.py

theta: the arm's angle from the horizontal (counter-clockwise in the x-z plane, z up); d: the slider's
position along its rail [m], which runs parallel to the arm at a height h above it. With r = d + lc2 and
R(theta) the rotation by theta:

    p1 = lc1 e(theta),   p2 = R(theta) (r, h)

    M11 = I1 + m1 lc1^2 + I2 + m2 (r^2 + h^2),  M12 = -m2 h,  M22 = m2
    C = [[m2 r d', m2 r theta'], [-m2 r theta', 0]],   V = g (m1 lc1 sin theta + m2 (r sin theta + h cos theta))

The numbers are the URDF's, typed in (PARAMETERS).
"""

import numpy as np

KIND = "any"
JOINTS = ["shoulder", "slide"]
NAMES = ["theta", "d"]
PARAMETERS = {"m1": 0.5, "lc1": 0.25, "I1": 0.01, "m2": 0.8, "lc2": 0.2, "I2": 0.02, "h": 0.4, "g": 9.81}


def mass_matrix(q, p):
    r = q[1] + p["lc2"]
    m2 = p["m2"]
    m11 = p["I1"] + p["m1"] * p["lc1"] ** 2 + p["I2"] + m2 * (r**2 + p["h"] ** 2)
    return np.array([[m11, -m2 * p["h"]], [-m2 * p["h"], m2]])


def coriolis_matrix(q, v, p):
    r = q[1] + p["lc2"]
    theta_dot, d_dot = v
    m2 = p["m2"]
    return np.array([[m2 * r * d_dot, m2 * r * theta_dot], [-m2 * r * theta_dot, 0.0]])


def gravity(q, p):
    theta, d = q
    r = d + p["lc2"]
    g, m2 = p["g"], p["m2"]
    g1 = g * ((p["m1"] * p["lc1"] + m2 * r) * np.cos(theta) - m2 * p["h"] * np.sin(theta))
    return np.array([g1, g * m2 * np.sin(theta)])


def potential_energy(q, p):
    theta, d = q
    r = d + p["lc2"]
    return p["g"] * (p["m1"] * p["lc1"] * np.sin(theta) + p["m2"] * (r * np.sin(theta) + p["h"] * np.cos(theta)))
