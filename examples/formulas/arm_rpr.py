"""A planar revolute-prismatic-revolute arm, derived by hand (Lagrange, Christoffel symbols).

    robodyn check examples/urdf/arm_rpr.urdf --formula examples/formulas/arm_rpr.py

q = (t1, d, t3): the shoulder angle from the horizontal, the slide d [m] along link 1, the wrist angle
relative to link 1 (both counter-clockwise in the x-z plane, x right, z up). With e(a) = (cos a, sin a),
s = d + l2 (shoulder to wrist) and r2 = d + lc2 (shoulder to the slider's centre of mass):

    p1 = lc1 e(t1),   p2 = r2 e(t1),   p3 = s e(t1) + lc3 e(t1 + t3)

T = 1/2 sum m_i |p_i'|^2 + 1/2 (I1 + I2) t1'^2 + 1/2 I3 (t1' + t3')^2, with e(t1) . e'(t1 + t3) = -sin t3:

    M11 = I1 + m1 lc1^2 + I2 + m2 r2^2 + I3 + m3 (s^2 + lc3^2 + 2 s lc3 cos t3)
    M12 = M23 = -m3 lc3 sin t3,   M13 = I3 + m3 (lc3^2 + s lc3 cos t3)
    M22 = m2 + m3,   M33 = I3 + m3 lc3^2

C[i,j] = sum_k 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i) v_k with A = 1/2 dM11/dd = m2 r2 + m3 (s + lc3 cos t3),
B = m3 s lc3 sin t3 (dM11/dt3 = -2B, dM13/dt3 = -B) and D = m3 lc3 cos t3 (dM13/dd = D, dM12/dt3 = dM23/dt3 = -D).
V = g (m1 lc1 sin t1 + m2 r2 sin t1 + m3 (s sin t1 + lc3 sin(t1 + t3))).
The numbers are the URDF's, typed in (PARAMETERS); examples/formulas/double_pendulum.py reads them instead.
"""

import numpy as np

KIND = "any"
JOINTS = ["shoulder", "slide", "wrist"]
PARAMETERS = {
    "m1": 1.5, "lc1": 0.18, "I1": 0.021,
    "m2": 0.8, "lc2": 0.12, "I2": 0.009, "l2": 0.35,
    "m3": 0.45, "lc3": 0.14, "I3": 0.0041,
    "g": 9.81,
}  # fmt: skip


def mass_matrix(q, p):
    t3, d = q[2], q[1]
    s, r2 = d + p["l2"], d + p["lc2"]
    m3, lc3, I3 = p["m3"], p["lc3"], p["I3"]
    m11 = p["I1"] + p["m1"] * p["lc1"] ** 2 + p["I2"] + p["m2"] * r2**2 + I3
    m11 += m3 * (s**2 + lc3**2 + 2 * s * lc3 * np.cos(t3))
    m12 = -m3 * lc3 * np.sin(t3)
    m13 = I3 + m3 * (lc3**2 + s * lc3 * np.cos(t3))
    m22 = p["m2"] + m3
    m33 = I3 + m3 * lc3**2
    return np.array([[m11, m12, m13], [m12, m22, m12], [m13, m12, m33]])


def coriolis_matrix(q, v, p):
    t3, d = q[2], q[1]
    w1, dd, w3 = v
    s, r2 = d + p["l2"], d + p["lc2"]
    m3, lc3 = p["m3"], p["lc3"]
    A = p["m2"] * r2 + m3 * (s + lc3 * np.cos(t3))
    B = m3 * s * lc3 * np.sin(t3)
    D = m3 * lc3 * np.cos(t3)
    return np.array(
        [
            [A * dd - B * w3, A * w1, -B * (w1 + w3)],
            [-A * w1 - D * w3, 0.0, -D * (w1 + w3)],
            [B * w1 + D * dd, D * w1, 0.0],
        ]
    )


def gravity(q, p):
    t1, d, t3 = q
    s, r2 = d + p["l2"], d + p["lc2"]
    g, m3, lc3 = p["g"], p["m3"], p["lc3"]
    g3 = g * m3 * lc3 * np.cos(t1 + t3)
    g1 = g * (p["m1"] * p["lc1"] + p["m2"] * r2 + m3 * s) * np.cos(t1) + g3
    return np.array([g1, g * (p["m2"] + m3) * np.sin(t1), g3])


def potential_energy(q, p):
    t1, d, t3 = q
    s, r2 = d + p["l2"], d + p["lc2"]
    heights = (p["m1"] * p["lc1"] + p["m2"] * r2 + p["m3"] * s) * np.sin(t1) + p["m3"] * p["lc3"] * np.sin(t1 + t3)
    return p["g"] * heights
