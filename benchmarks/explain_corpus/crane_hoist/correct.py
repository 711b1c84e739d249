"""A trolley crane with a hoisted hook, derived by hand: the explain benchmark's correct file.

    robodyn check benchmarks/explain_corpus/crane_hoist/robot.urdf \
        --formula benchmarks/explain_corpus/crane_hoist/correct.py

x: the trolley's position [m]; theta: the rope's angle from the downward vertical (towards +x); ell: the
hook frame's distance below the pivot [m]. The hook's centre of mass is r = ell + lc2 below the pivot:

    rope p1 = (x + lc1 sin theta, -lc1 cos theta),   hook p2 = (x + r sin theta, -r cos theta)

    M11 = mt + m1 + m2,  M12 = (m1 lc1 + m2 r) cos theta,  M13 = m2 sin theta,
    M22 = I1 + m1 lc1^2 + I2 + m2 r^2,  M23 = 0,  M33 = m2,   V = -g (m1 lc1 + m2 r) cos theta

Christoffel symbols with S = (m1 lc1 + m2 r) sin theta: C12 = -S theta' + m2 cos theta ell',
C13 = m2 cos theta theta', C22 = m2 r ell', C23 = m2 r theta', C32 = -m2 r theta', the others 0.
The numbers are the URDF's, typed in (PARAMETERS).
"""

import numpy as np

KIND = "any"
JOINTS = ["trolley", "swing", "hoist"]
NAMES = ["x", "theta", "ell"]
PARAMETERS = {
    "mt": 2.0,
    "m1": 0.5, "lc1": 0.4, "I1": 0.02,
    "m2": 0.8, "lc2": 0.25, "I2": 0.005,
    "g": 9.81,
}  # fmt: skip


def mass_matrix(q, p):
    theta, ell = q[1], q[2]
    r = ell + p["lc2"]
    m1, m2 = p["m1"], p["m2"]
    m12 = (m1 * p["lc1"] + m2 * r) * np.cos(theta)
    m13 = m2 * np.sin(theta)
    m22 = p["I1"] + m1 * p["lc1"] ** 2 + p["I2"] + m2 * r**2
    return np.array([[p["mt"] + m1 + m2, m12, m13], [m12, m22, 0.0], [m13, 0.0, m2]])


def coriolis_matrix(q, v, p):
    theta, ell = q[1], q[2]
    w, ell_dot = v[1], v[2]
    r = ell + p["lc2"]
    m2 = p["m2"]
    S = (p["m1"] * p["lc1"] + m2 * r) * np.sin(theta)
    return np.array(
        [
            [0.0, -S * w + m2 * np.cos(theta) * ell_dot, m2 * np.cos(theta) * w],
            [0.0, m2 * r * ell_dot, m2 * r * w],
            [0.0, -m2 * r * w, 0.0],
        ]
    )


def gravity(q, p):
    theta, ell = q[1], q[2]
    r = ell + p["lc2"]
    g, m2 = p["g"], p["m2"]
    return np.array([0.0, g * (p["m1"] * p["lc1"] + m2 * r) * np.sin(theta), -g * m2 * np.cos(theta)])


def potential_energy(q, p):
    theta, ell = q[1], q[2]
    return -p["g"] * (p["m1"] * p["lc1"] + p["m2"] * (ell + p["lc2"])) * np.cos(theta)
