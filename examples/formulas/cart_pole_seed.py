"""The cart-pole (point bob) exactly as the textbook excerpt prints its equations of motion (Example 2).

    (M + m) y'' + m l cos th th'' - m l th'^2 sin th = f
    m l cos th y'' - m l sin th y' th' + m l^2 th'' - m g l sin th = 0

Read as M q'' + C q' + G = tau, the second equation's "- m l sin th y' th'" term puts
-m l sin th th' in C21. It is a misprint: that term cancels between d/dt dL/dth' and
dL/dth. The excerpt's bob is a point (I = 0), so check this against a point-bob cart-pole:

    robodyn check examples/urdf/cart_pole_point_bob.urdf --formula examples/formulas/cart_pole_seed.py

The excerpt's M, the cart's mass, is p["m_cart"] here: in robodyn M is only ever the mass matrix.
"""

import numpy as np

KIND = "cart_pole"


def mass_matrix(q, p):
    m_cart, m, l = p["m_cart"], p["m"], p["l"]
    c = np.cos(q[1])
    return np.array([[m_cart + m, m * l * c], [m * l * c, m * l**2]])


def coriolis_matrix(q, v, p):
    m, l = p["m"], p["l"]
    s = np.sin(q[1])
    return np.array([[0.0, -m * l * s * v[1]], [-m * l * s * v[1], 0.0]])  # C21 from the printed equation


def gravity(q, p):
    return np.array([0.0, -p["m"] * p["g"] * p["l"] * np.sin(q[1])])
