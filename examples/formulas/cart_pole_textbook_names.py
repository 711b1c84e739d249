"""The cart-pole in the textbook's own names: M is the cart's mass (L = 1/2 (M + m) y'^2 + ...); it is correct.

    robodyn check cart_pole --formula examples/formulas/cart_pole_textbook_names.py

robodyn names the cart's mass m_cart (in robodyn M is only ever the mass matrix); a file written
before that rename, or after the book, reads p["M"] and still passes, with one note on stderr.
"""

import numpy as np

KIND = "cart_pole"


def mass_matrix(q, p):
    M, m, l, I = p["M"], p["m"], p["l"], p["I"]
    c = np.cos(q[1])
    return np.array([[M + m, m * l * c], [m * l * c, m * l**2 + I]])


def coriolis_matrix(q, v, p):
    m, l = p["m"], p["l"]
    return np.array([[0.0, -m * l * np.sin(q[1]) * v[1]], [0.0, 0.0]])


def gravity(q, p):
    return np.array([0.0, -p["m"] * p["g"] * p["l"] * np.sin(q[1])])
