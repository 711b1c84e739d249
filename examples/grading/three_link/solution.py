"""A 3-link arm in a vertical plane, derived by hand in absolute angles (each link's angle from the horizontal).

    robodyn check examples/urdf/three_link_arm.urdf --formula examples/formulas/three_link_absolute.py

theta_i is link i's angle from the horizontal, counter-clockwise (x right, z up), as many textbooks
write it; the URDF measures each joint relative to its parent, so theta1 = q1, theta2 = q1 + q2,
theta3 = q1 + q2 + q3: COORDINATES is that matrix (q_formula = A q_urdf). Centres of mass:

    r1 = lc1 e(t1),   r2 = l1 e(t1) + lc2 e(t2),   r3 = l1 e(t1) + l2 e(t2) + lc3 e(t3),   e(t) = (cos t, sin t)

so M[i,j] = a_ij cos(t_i - t_j) off the diagonal, with a_12 = l1 (m2 lc2 + m3 l2), a_13 = m3 l1 lc3,
a_23 = m3 l2 lc3; the Christoffel C[i,j] = a_ij sin(t_i - t_j) w_j (w = dtheta/dt), and
V = g (b1 sin t1 + b2 sin t2 + b3 sin t3), b1 = m1 lc1 + (m2 + m3) l1, b2 = m2 lc2 + m3 l2, b3 = m3 lc3.
I1, I2, I3 are the moments of inertia about the centres of mass, about the joint axis.
"""

import numpy as np

KIND = "any"
JOINTS = ["joint1", "joint2", "joint3"]
COORDINATES = [[1, 0, 0], [1, 1, 0], [1, 1, 1]]  # theta = A q_urdf: absolute angles


def parameters(robot):
    """From robodyn's per-link table: each link's frame is its joint's, the link along its x axis."""
    link1, link2, link3 = robot["joint1"], robot["joint2"], robot["joint3"]
    return {
        "m1": link1.mass,
        "m2": link2.mass,
        "m3": link3.mass,
        "l1": link2.origin[0],
        "l2": link3.origin[0],
        "lc1": link1.com[0],
        "lc2": link2.com[0],
        "lc3": link3.com[0],
        "I1": link1.inertia_about_axis,
        "I2": link2.inertia_about_axis,
        "I3": link3.inertia_about_axis,
        "g": robot.g,
    }


def _a(p):
    """The couplings a_12, a_13, a_23 [kg m^2]."""
    return (
        p["l1"] * (p["m2"] * p["lc2"] + p["m3"] * p["l2"]),
        p["m3"] * p["l1"] * p["lc3"],
        p["m3"] * p["l2"] * p["lc3"],
    )


def mass_matrix(q, p):
    m1, m2, m3, l1, l2, lc1, lc2, lc3 = (p[k] for k in ("m1", "m2", "m3", "l1", "l2", "lc1", "lc2", "lc3"))
    a12, a13, a23 = _a(p)
    t1, t2, t3 = q
    d1 = p["I1"] + m1 * lc1**2 + (m2 + m3) * l1**2
    d2 = p["I2"] + m2 * lc2**2 + m3 * l2**2
    d3 = p["I3"] + m3 * lc3**2
    m12, m13, m23 = a12 * np.cos(t1 - t2), a13 * np.cos(t1 - t3), a23 * np.cos(t2 - t3)
    return np.array([[d1, m12, m13], [m12, d2, m23], [m13, m23, d3]])


def coriolis_matrix(q, v, p):
    a12, a13, a23 = _a(p)
    t1, t2, t3 = q
    w1, w2, w3 = v
    s12, s13, s23 = np.sin(t1 - t2), np.sin(t1 - t3), np.sin(t2 - t3)
    return np.array(
        [
            [0.0, a12 * s12 * w2, a13 * s13 * w3],
            [-a12 * s12 * w1, 0.0, a23 * s23 * w3],
            [-a13 * s13 * w1, -a23 * s23 * w2, 0.0],
        ]
    )


def _b(p):
    """The gravity moments b1, b2, b3 [kg m]."""
    m1, m2, m3, l1, l2, lc1, lc2, lc3 = (p[k] for k in ("m1", "m2", "m3", "l1", "l2", "lc1", "lc2", "lc3"))
    return m1 * lc1 + (m2 + m3) * l1, m2 * lc2 + m3 * l2, m3 * lc3


def gravity(q, p):
    b1, b2, b3 = _b(p)
    return p["g"] * np.array([b1 * np.cos(q[0]), b2 * np.cos(q[1]), b3 * np.cos(q[2])])


def potential_energy(q, p):
    b1, b2, b3 = _b(p)
    return p["g"] * (b1 * np.sin(q[0]) + b2 * np.sin(q[1]) + b3 * np.sin(q[2]))
