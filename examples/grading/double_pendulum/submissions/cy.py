"""examples/formulas/double_pendulum.py with a convention slip: COORDINATES forgets the shoulder's zero.

    robodyn check examples/urdf/double_pendulum.urdf --formula tests/fixtures/double_pendulum_no_offset.py

theta1 is link 1's angle from the downward vertical, but the URDF measures the shoulder from the
horizontal: theta1 = q_shoulder + pi/2. This file leaves the shoulder out of COORDINATES (so
theta1 = q_shoulder), and every term of the derivation is right: the check FAILs with a wall of
mismatches, and its first hint names the COORDINATES entry that makes it agree.
"""

import numpy as np

KIND = "any"
JOINTS = ["shoulder", "elbow"]
COORDINATES = {"elbow": (-1.0, 0.0)}  # the slip: no "shoulder": (1.0, math.pi / 2)


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
