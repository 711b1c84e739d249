"""A double pendulum hanging from the vertical, derived by hand in the textbook's own coordinates.

    robodyn check examples/urdf/double_pendulum.urdf --formula examples/formulas/double_pendulum.py

theta1 is link 1's angle from the downward vertical, theta2 link 2's angle relative to link 1, both
counter-clockwise in the x-z plane (x right, z up). The URDF measures the shoulder from the horizontal
about 0 -1 0 and the elbow about 0 1 0, so theta1 = q_shoulder + pi/2 and theta2 = -q_elbow: that is
COORDINATES. Centres of mass:

    x1 = lc1 sin t1,                       z1 = -lc1 cos t1
    x2 = l1 sin t1 + lc2 sin(t1 + t2),     z2 = -l1 cos t1 - lc2 cos(t1 + t2)

T = 1/2 m1 |v1|^2 + 1/2 I1 w1^2 + 1/2 m2 |v2|^2 + 1/2 I2 (w1 + w2)^2, V = m1 g z1 + m2 g z2,
with I1, I2 the moments of inertia about the centres of mass, about the joint axis.
"""

import math

import numpy as np

KIND = "any"
JOINTS = ["shoulder", "elbow"]
COORDINATES = {"shoulder": (1.0, math.pi / 2), "elbow": (-1.0, 0.0)}  # q_formula = sign * q_urdf + offset


def parameters(robot):
    """From robodyn's per-link table: the link frames are those of the URDF joints."""
    upper, lower = robot["shoulder"], robot["elbow"]
    return {
        "m1": upper.mass,
        "m2": lower.mass,
        "l1": lower.origin[0],
        "lc1": upper.com[0],
        "lc2": lower.com[0],
        "I1": upper.inertia_about_axis,
        "I2": lower.inertia_about_axis,
        "g": robot.g,
    }


def mass_matrix(q, p):
    m1, m2, l1, lc1, lc2, I1, I2 = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "I1", "I2"))
    c2 = np.cos(q[1])
    m11 = m1 * lc1**2 + I1 + m2 * (l1**2 + lc2**2 + 2 * l1 * lc2 * c2) + I2
    m12 = m2 * (lc2**2 + l1 * lc2 * c2) + I2
    m22 = m2 * lc2**2 + I2
    return np.array([[m11, m12], [m12, m22]])


def coriolis_matrix(q, v, p):
    h = -p["m2"] * p["l1"] * p["lc2"] * np.sin(q[1])  # the Christoffel symbols are +-h
    return np.array([[h * v[1], h * (v[0] + v[1])], [-h * v[0], 0.0]])


def gravity(q, p):
    m1, m2, l1, lc1, lc2, g = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "g"))
    g2 = m2 * g * lc2 * np.sin(q[0] + q[1])
    return np.array([(m1 * lc1 + m2 * l1) * g * np.sin(q[0]) + g2, g2])


def potential_energy(q, p):
    m1, m2, l1, lc1, lc2, g = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "g"))
    return -m1 * g * lc1 * np.cos(q[0]) - m2 * g * (l1 * np.cos(q[0]) + lc2 * np.cos(q[0] + q[1]))
