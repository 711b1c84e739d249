"""A SCARA (three vertical revolute axes), derived by hand: the explain benchmark's correct file.

    robodyn check benchmarks/explain_corpus/scara/robot.urdf --formula benchmarks/explain_corpus/scara/correct.py

th1, th2, th3: relative joint angles about z. With phi1 = th1, phi2 = th1 + th2, phi3 = phi2 + th3 the
absolute angles, R(phi) the rotation by phi and c_i = (lx_i, ly_i) link i's centre of mass in its frame:

    p1 = R(phi1) c1,   p2 = a1 e(phi1) + R(phi2) c2,   p3 = a1 e(phi1) + a2 e(phi2) + R(phi3) c3

In absolute velocities T = 1/2 w^T Ma w with Ma11 = I1 + m1 |c1|^2 + (m2 + m3) a1^2, Ma22 = I2 + m2 |c2|^2
+ m3 a2^2, Ma33 = I3 + m3 |c3|^2 and the couplings k12 = m2 a1 (lx2 cos th2 - ly2 sin th2) + m3 a1 a2 cos th2,
k13 = m3 a1 (lx3 cos(th2 + th3) - ly3 sin(th2 + th3)), k23 = m3 a2 (lx3 cos th3 - ly3 sin th3); in relative
angles M[i,j] = sum over k >= i, l >= j of Ma[k,l]. C from the Christoffel symbols of the hand-written dM/dth2,
dM/dth3. Gravity is along the axes: G = 0.
"""

import numpy as np

KIND = "any"
JOINTS = ["j1", "j2", "j3"]
NAMES = ["th1", "th2", "th3"]


def parameters(robot):
    """Masses, link lengths, centres of mass (x along the link, y lateral) and inertias about z."""
    l1, l2, l3 = robot["j1"], robot["j2"], robot["j3"]
    return {
        "m1": l1.mass, "m2": l2.mass, "m3": l3.mass,
        "a1": l2.origin[0], "a2": l3.origin[0],
        "lx1": l1.com[0], "ly1": l1.com[1],
        "lx2": l2.com[0], "ly2": l2.com[1],
        "lx3": l3.com[0], "ly3": l3.com[1],
        "I1": l1.inertia[2, 2], "I2": l2.inertia[2, 2], "I3": l3.inertia[2, 2],
    }  # fmt: skip


def _couplings(q, p):
    th2, th3 = q[1], q[2]
    k12 = p["m2"] * p["a1"] * (p["lx2"] * np.cos(th2) - p["ly2"] * np.sin(th2))
    k12 += p["m3"] * p["a1"] * p["a2"] * np.cos(th2)
    k13 = p["m3"] * p["a1"] * (p["lx3"] * np.cos(th2 + th3) - p["ly3"] * np.sin(th2 + th3))
    k23 = p["m3"] * p["a2"] * (p["lx3"] * np.cos(th3) - p["ly3"] * np.sin(th3))
    return k12, k13, k23


def mass_matrix(q, p):
    d1 = p["I1"] + p["m1"] * (p["lx1"] ** 2 + p["ly1"] ** 2) + (p["m2"] + p["m3"]) * p["a1"] ** 2
    d2 = p["I2"] + p["m2"] * (p["lx2"] ** 2 + p["ly2"] ** 2) + p["m3"] * p["a2"] ** 2
    d3 = p["I3"] + p["m3"] * (p["lx3"] ** 2 + p["ly3"] ** 2)
    k12, k13, k23 = _couplings(q, p)
    m11 = d1 + d2 + d3 + 2 * (k12 + k13 + k23)
    m12 = d2 + d3 + 2 * k23 + k12 + k13
    m13 = d3 + k23 + k13
    m22 = d2 + d3 + 2 * k23
    m23 = d3 + k23
    m33 = d3
    return np.array([[m11, m12, m13], [m12, m22, m23], [m13, m23, m33]])


def _dM(q, p):
    """dM/dth1 (zero), dM/dth2, dM/dth3, written out by hand from the couplings' derivatives."""
    th2, th3 = q[1], q[2]
    dk12 = -p["m2"] * p["a1"] * (p["lx2"] * np.sin(th2) + p["ly2"] * np.cos(th2))
    dk12 -= p["m3"] * p["a1"] * p["a2"] * np.sin(th2)
    dk13 = -p["m3"] * p["a1"] * (p["lx3"] * np.sin(th2 + th3) + p["ly3"] * np.cos(th2 + th3))
    dk23 = -p["m3"] * p["a2"] * (p["lx3"] * np.sin(th3) + p["ly3"] * np.cos(th3))
    D1 = np.zeros((3, 3))
    D2 = np.array([[2 * (dk12 + dk13), dk12 + dk13, dk13], [dk12 + dk13, 0.0, 0.0], [dk13, 0.0, 0.0]])
    D3 = np.array(
        [
            [2 * (dk13 + dk23), dk13 + 2 * dk23, dk13 + dk23],
            [dk13 + 2 * dk23, 2 * dk23, dk23],
            [dk13 + dk23, dk23, 0.0],
        ]
    )
    return D1, D2, D3


def coriolis_matrix(q, v, p):
    D = _dM(q, p)
    C = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            for k in range(3):
                C[i, j] += 0.5 * (D[k][i, j] + D[j][i, k] - D[i][j, k]) * v[k]
    return C


def gravity(q, p):
    return np.zeros(3)
