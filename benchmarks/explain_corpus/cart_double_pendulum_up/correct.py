"""A double pendulum on a cart, angles from the UPWARD vertical: the explain benchmark's correct file.

    robodyn check benchmarks/explain_corpus/cart_double_pendulum_up/robot.urdf \
        --formula benchmarks/explain_corpus/cart_double_pendulum_up/correct.py

x: the cart's position [m]; phi1: link 1's angle from the upward vertical, phi2: link 2's relative to link 1
(both turning the links from +z towards +x). The URDF hangs down at q = 0, so phi1 = q_hinge1 + pi. With
phi12 = phi1 + phi2 the centres of mass are

    p1 = (x + lc1 sin phi1, lc1 cos phi1),   p2 = (x + l1 sin phi1 + lc2 sin phi12, l1 cos phi1 + lc2 cos phi12)

    M11 = mc + m1 + m2,   M12 = (m1 lc1 + m2 l1) cos phi1 + m2 lc2 cos phi12,   M13 = m2 lc2 cos phi12
    M22 = I1 + m1 lc1^2 + I2 + m2 (l1^2 + lc2^2 + 2 l1 lc2 cos phi2),  M23 = I2 + m2 (lc2^2 + l1 lc2 cos phi2)
    M33 = I2 + m2 lc2^2,   V = g (m1 lc1 cos phi1 + m2 (l1 cos phi1 + lc2 cos phi12))

Christoffel symbols with h = -m2 l1 lc2 sin phi2, Q = m2 lc2 sin phi12 and P = (m1 lc1 + m2 l1) sin phi1 + Q.
"""

import math

import numpy as np

KIND = "any"
JOINTS = ["cart", "hinge1", "hinge2"]
COORDINATES = {"hinge1": (1.0, math.pi)}
NAMES = ["x", "phi1", "phi2"]


def parameters(robot):
    """The cart's mass, the links' masses, centres of mass below the hinges and inertias about y."""
    cart, upper, lower = robot["cart"], robot["hinge1"], robot["hinge2"]
    return {
        "mc": cart.mass,
        "m1": upper.mass, "lc1": -upper.com[2], "I1": upper.inertia_about_axis,
        "m2": lower.mass, "lc2": -lower.com[2], "I2": lower.inertia_about_axis,
        "l1": -lower.origin[2],
        "g": robot.g,
    }  # fmt: skip


def mass_matrix(q, p):
    phi1, phi2 = q[1], q[2]
    mc, m1, m2, l1, lc1, lc2, I1, I2 = (p[k] for k in ("mc", "m1", "m2", "l1", "lc1", "lc2", "I1", "I2"))
    m11 = mc + m1 + m2
    m12 = (m1 * lc1 + m2 * l1) * np.cos(phi1) + m2 * lc2 * np.cos(phi1 + phi2)
    m13 = m2 * lc2 * np.cos(phi1 + phi2)
    m22 = I1 + m1 * lc1**2 + I2 + m2 * (l1**2 + lc2**2 + 2 * l1 * lc2 * np.cos(phi2))
    m23 = I2 + m2 * (lc2**2 + l1 * lc2 * np.cos(phi2))
    m33 = I2 + m2 * lc2**2
    return np.array([[m11, m12, m13], [m12, m22, m23], [m13, m23, m33]])


def coriolis_matrix(q, v, p):
    phi1, phi2 = q[1], q[2]
    w1, w2 = v[1], v[2]
    m1, m2, l1, lc1, lc2 = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2"))
    h = -m2 * l1 * lc2 * np.sin(phi2)
    Q = m2 * lc2 * np.sin(phi1 + phi2)
    P = (m1 * lc1 + m2 * l1) * np.sin(phi1) + Q
    return np.array(
        [
            [0.0, -P * w1 - Q * w2, -Q * (w1 + w2)],
            [0.0, h * w2, h * (w1 + w2)],
            [0.0, -h * w1, 0.0],
        ]
    )


def gravity(q, p):
    phi1, phi2 = q[1], q[2]
    m1, m2, l1, lc1, lc2, g = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "g"))
    g2 = -g * m2 * lc2 * np.sin(phi1 + phi2)
    return np.array([0.0, -g * (m1 * lc1 + m2 * l1) * np.sin(phi1) + g2, g2])


def potential_energy(q, p):
    phi1, phi2 = q[1], q[2]
    m1, m2, l1, lc1, lc2, g = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "g"))
    return g * (m1 * lc1 * np.cos(phi1) + m2 * (l1 * np.cos(phi1) + lc2 * np.cos(phi1 + phi2)))
