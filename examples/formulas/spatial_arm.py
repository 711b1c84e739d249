"""A spatial 3-DoF arm (yaw, shoulder pitch, elbow pitch), derived by hand in elevation angles.

    robodyn check examples/urdf/spatial_arm.urdf --formula examples/formulas/spatial_arm.py

q = (t1, t2, t3): the yaw about the vertical, the upper arm's elevation above the horizontal and the
forearm's relative to it (positive up). The URDF's pitch axes are 0 1 0, so a positive URDF angle lowers
the arm: t2 = -q_pitch, t3 = -q_elbow (COORDINATES). With t23 = t2 + t3, the centres of mass sit at
radius rho and height z from the yaw axis:

    upper arm: rho2 = lc2 cos t2,                z2 = lc2 sin t2
    forearm:   rho3 = l2 cos t2 + lc3 cos t23,   z3 = l2 sin t2 + lc3 sin t23

and each moves at rho t1' around the axis and (rho', z') in its plane. In each link's own (principal) axes
its angular velocity is (-sin(t) t1', t', cos(t) t1') up to the sign of the middle entry (t = t2 or t23), so

    M11 = I1z + I2x sin^2 t2 + (I2z + m2 lc2^2) cos^2 t2 + I3x sin^2 t23 + I3z cos^2 t23 + m3 rho3^2
    M22 = I2y + m2 lc2^2 + I3y + m3 (l2^2 + lc3^2 + 2 l2 lc3 cos t3),  M23 = I3y + m3 (lc3^2 + l2 lc3 cos t3)
    M33 = I3y + m3 lc3^2,  M12 = M13 = 0

Christoffel symbols with a2 = dM11/dt2, a3 = dM11/dt3 and b = 1/2 dM22/dt3 = dM23/dt3 = -m3 l2 lc3 sin t3:
C = [[(a2 w2 + a3 w3)/2, a2 w1/2, a3 w1/2], [-a2 w1/2, b w3, b (w2 + w3)], [-a3 w1/2, -b w2, 0]].
V = g (m2 z2 + m3 z3) + const. The parameters come from robodyn's per-link table.
"""

import numpy as np

KIND = "any"
JOINTS = ["yaw", "pitch", "elbow"]
COORDINATES = {"pitch": (-1.0, 0.0), "elbow": (-1.0, 0.0)}


def parameters(robot):
    column, upper, fore = robot["yaw"], robot["pitch"], robot["elbow"]
    return {
        "I1z": column.inertia[2, 2],
        "m2": upper.mass, "lc2": upper.com[0], "l2": fore.origin[0],
        "I2x": upper.inertia[0, 0], "I2y": upper.inertia[1, 1], "I2z": upper.inertia[2, 2],
        "m3": fore.mass, "lc3": fore.com[0],
        "I3x": fore.inertia[0, 0], "I3y": fore.inertia[1, 1], "I3z": fore.inertia[2, 2],
        "g": robot.g,
    }  # fmt: skip


def _m11_and_slopes(q, p):
    """M11 and its derivatives a2 = dM11/dt2, a3 = dM11/dt3."""
    _, t2, t3 = q
    t23 = t2 + t3
    s2, c2, s23, c23 = np.sin(t2), np.cos(t2), np.sin(t23), np.cos(t23)
    rho3 = p["l2"] * c2 + p["lc3"] * c23
    k2 = p["I2z"] + p["m2"] * p["lc2"] ** 2
    m11 = p["I1z"] + p["I2x"] * s2**2 + k2 * c2**2 + p["I3x"] * s23**2 + p["I3z"] * c23**2 + p["m3"] * rho3**2
    a3 = 2 * (p["I3x"] - p["I3z"]) * s23 * c23 - 2 * p["m3"] * rho3 * p["lc3"] * s23
    a2 = 2 * (p["I2x"] - k2) * s2 * c2 + a3 - 2 * p["m3"] * rho3 * p["l2"] * s2
    return m11, a2, a3


def mass_matrix(q, p):
    m11, _, _ = _m11_and_slopes(q, p)
    m3, l2, lc3, I3y = p["m3"], p["l2"], p["lc3"], p["I3y"]
    c3 = np.cos(q[2])
    m22 = p["I2y"] + p["m2"] * p["lc2"] ** 2 + I3y + m3 * (l2**2 + lc3**2 + 2 * l2 * lc3 * c3)
    m23 = I3y + m3 * (lc3**2 + l2 * lc3 * c3)
    m33 = I3y + m3 * lc3**2
    return np.array([[m11, 0.0, 0.0], [0.0, m22, m23], [0.0, m23, m33]])


def coriolis_matrix(q, v, p):
    _, a2, a3 = _m11_and_slopes(q, p)
    w1, w2, w3 = v
    b = -p["m3"] * p["l2"] * p["lc3"] * np.sin(q[2])
    return np.array(
        [
            [(a2 * w2 + a3 * w3) / 2, a2 * w1 / 2, a3 * w1 / 2],
            [-a2 * w1 / 2, b * w3, b * (w2 + w3)],
            [-a3 * w1 / 2, -b * w2, 0.0],
        ]
    )


def gravity(q, p):
    _, t2, t3 = q
    g, m3, lc3 = p["g"], p["m3"], p["lc3"]
    g3 = g * m3 * lc3 * np.cos(t2 + t3)
    return np.array([0.0, g * (p["m2"] * p["lc2"] + m3 * p["l2"]) * np.cos(t2) + g3, g3])


def potential_energy(q, p):
    _, t2, t3 = q
    z2 = p["lc2"] * np.sin(t2)
    z3 = p["l2"] * np.sin(t2) + p["lc3"] * np.sin(t2 + t3)
    return p["g"] * (p["m2"] * z2 + p["m3"] * z3)
