"""A double pendulum hanging from a cart (a gantry crane), derived by hand in its own coordinates.

    robodyn check examples/urdf/cart_double_pendulum.urdf --formula examples/formulas/cart_double_pendulum.py

q = (t1, t2, x), in this order: link 1's angle from the downward vertical, link 2's relative to link 1
(counter-clockwise in the x-z plane, x right, z up), and the cart's position x [m] along +x. The URDF's
rail axis is -1 0 0, so x = -q_cart (COORDINATES), and its joints come in the order cart, hinge1, hinge2.
With t12 = t1 + t2 the centres of mass are

    cart (x, 0),   p1 = (x + lc1 sin t1, -lc1 cos t1),   p2 = (x + l1 sin t1 + lc2 sin t12, -l1 cos t1 - lc2 cos t12)

    M11 = I1 + m1 lc1^2 + I2 + m2 (l1^2 + lc2^2 + 2 l1 lc2 cos t2),  M12 = I2 + m2 (lc2^2 + l1 lc2 cos t2)
    M22 = I2 + m2 lc2^2,  M13 = (m1 lc1 + m2 l1) cos t1 + m2 lc2 cos t12,  M23 = m2 lc2 cos t12,  M33 = mc + m1 + m2

Christoffel symbols, with h = -m2 l1 lc2 sin t2, P = (m1 lc1 + m2 l1) sin t1 + m2 lc2 sin t12 = -dM13/dt1 and
Q = m2 lc2 sin t12 = -dM13/dt2 = -dM23/dt1 = -dM23/dt2: the pendulum block is the double pendulum's, the cart's
row is (-P w1 - Q w2, -Q (w1 + w2), 0), the pendulum rows' cart column 0.
V = -g (m1 lc1 cos t1 + m2 (l1 cos t1 + lc2 cos t12)).
"""

import numpy as np

KIND = "any"
JOINTS = ["hinge1", "hinge2", "cart"]
COORDINATES = {"cart": (-1.0, 0.0)}  # x = -q_cart; the hinges as in the URDF
PARAMETERS = {
    "mc": 2.0,
    "m1": 0.6, "lc1": 0.27, "l1": 0.55, "I1": 0.016,
    "m2": 0.35, "lc2": 0.2, "I2": 0.0052,
    "g": 9.81,
}  # fmt: skip


def mass_matrix(q, p):
    t1, t2, _ = q
    m1, m2, l1, lc1, lc2, I1, I2 = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "I1", "I2"))
    m11 = I1 + m1 * lc1**2 + I2 + m2 * (l1**2 + lc2**2 + 2 * l1 * lc2 * np.cos(t2))
    m12 = I2 + m2 * (lc2**2 + l1 * lc2 * np.cos(t2))
    m22 = I2 + m2 * lc2**2
    m13 = (m1 * lc1 + m2 * l1) * np.cos(t1) + m2 * lc2 * np.cos(t1 + t2)
    m23 = m2 * lc2 * np.cos(t1 + t2)
    m33 = p["mc"] + m1 + m2
    return np.array([[m11, m12, m13], [m12, m22, m23], [m13, m23, m33]])


def coriolis_matrix(q, v, p):
    t1, t2, _ = q
    w1, w2, _ = v
    m1, m2, l1, lc1, lc2 = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2"))
    h = -m2 * l1 * lc2 * np.sin(t2)
    Q = m2 * lc2 * np.sin(t1 + t2)
    P = (m1 * lc1 + m2 * l1) * np.sin(t1) + Q
    return np.array(
        [
            [h * w2, h * (w1 + w2), 0.0],
            [-h * w1, 0.0, 0.0],
            [-P * w1 - Q * w2, -Q * (w1 + w2), 0.0],
        ]
    )


def gravity(q, p):
    t1, t2, _ = q
    m1, m2, l1, lc1, lc2, g = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "g"))
    g2 = g * m2 * lc2 * np.sin(t1 + t2)
    return np.array([g * (m1 * lc1 + m2 * l1) * np.sin(t1) + g2, g2, 0.0])


def potential_energy(q, p):
    t1, t2, _ = q
    m1, m2, l1, lc1, lc2, g = (p[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "g"))
    return -g * (m1 * lc1 * np.cos(t1) + m2 * (l1 * np.cos(t1) + lc2 * np.cos(t1 + t2)))
