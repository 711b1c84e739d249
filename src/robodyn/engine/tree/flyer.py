"""A free flyer at the root of a compiled tree: its placement, motion subspace, 6 x 6 solve and step.

Pinocchio's ``JointModelFreeFlyer``: q = [position [m] (3); unit quaternion x, y, z, w],
v = [linear [m/s]; angular [rad/s]] in the body's own frame. Used by the kernels of
:mod:`robodyn.engine.tree.algorithms` on row 0 when it is a free flyer.
"""

from __future__ import annotations

import math

import numpy as np

from robodyn.engine import jit
from robodyn.engine.tree.body import body
from robodyn.engine.tree.layout import (
    F_ARM6,
    F_POS,
    F_ROT,
    F_TOTAL,
    W_A,
    W_C,
    W_FB,
    W_FD,
    W_FY,
    W_IA,
    W_LAMBDA,
    W_PA,
    W_POS,
    W_REF,
    W_ROT,
    W_S,
    W_V,
)

njit = jit.njit(nogil=True, error_model="numpy")


@njit
def ff_kinematics(itree, ftree, grav, q, v, ws):  # type: ignore[no-untyped-def]
    """Pass 1 at a free-flyer root (row 0); returns its (T, V) [J].

    Its world position goes to W_REF and becomes the reference point (W_POS = 0); S v with v
    local is its velocity (the world is still: c = 0, and W_S, W_C are zero: S is applied
    through :func:`ff_motion`). V holds the whole tree's -M g . W_REF, each body adding its own
    -m g . c from the reference point.
    """
    iq, iv = itree[0, 2], itree[0, 3]
    r00, r01, r02, r10, r11, r12, r20, r21, r22, p0, p1, p2 = ff_placement(ftree, 0, q, iq)
    ws[0, W_REF], ws[0, W_REF + 1], ws[0, W_REF + 2] = p0, p1, p2
    ws[0, W_ROT], ws[0, W_ROT + 1], ws[0, W_ROT + 2] = r00, r01, r02
    ws[0, W_ROT + 3], ws[0, W_ROT + 4], ws[0, W_ROT + 5] = r10, r11, r12
    ws[0, W_ROT + 6], ws[0, W_ROT + 7], ws[0, W_ROT + 8] = r20, r21, r22
    ws[0, W_POS], ws[0, W_POS + 1], ws[0, W_POS + 2] = 0.0, 0.0, 0.0
    for k in range(6):
        ws[0, W_S + k] = 0.0
        ws[0, W_C + k] = 0.0
    # row 0 as an int64, not a literal: ff_motion compiles once, for every row
    l0, l1, l2, g0, g1, g2 = ff_motion(ws, np.int64(0), v[iv], v[iv + 1], v[iv + 2], v[iv + 3], v[iv + 4], v[iv + 5])
    ws[0, W_V], ws[0, W_V + 1], ws[0, W_V + 2] = l0, l1, l2
    ws[0, W_V + 3], ws[0, W_V + 4], ws[0, W_V + 5] = g0, g1, g2
    vhv, pot = body(
        ftree, grav, ws, 0, r00, r01, r02, r10, r11, r12, r20, r21, r22, 0.0, 0.0, 0.0, l0, l1, l2, g0, g1, g2
    )
    rotor = 0.0
    for k in range(6):
        rotor += ftree[0, F_ARM6 + k] * v[iv + k] * v[iv + k]
    pot -= ftree[0, F_TOTAL] * (p0 * grav[0] + p1 * grav[1] + p2 * grav[2])
    return 0.5 * (vhv + rotor), pot


@njit
def ff_placement(ftree, i, q, iq):  # type: ignore[no-untyped-def]
    """The placement R_p R(quat), p + R_p t of a free flyer in its parent's frame, as 12 numbers.

    R(quat): the rotation matrix of the unit quaternion (x, y, z, w).
    """
    x, y, z, w = q[iq + 3], q[iq + 4], q[iq + 5], q[iq + 6]
    tx, ty, tz = 2.0 * x, 2.0 * y, 2.0 * z
    twx, twy, twz = tx * w, ty * w, tz * w
    txx, txy, txz = tx * x, ty * x, tz * x
    tyy, tyz, tzz = ty * y, tz * y, tz * z
    q00, q01, q02 = 1.0 - (tyy + tzz), txy - twz, txz + twy
    q10, q11, q12 = txy + twz, 1.0 - (txx + tzz), tyz - twx
    q20, q21, q22 = txz - twy, tyz + twx, 1.0 - (txx + tyy)
    p00, p01, p02 = ftree[i, F_ROT], ftree[i, F_ROT + 1], ftree[i, F_ROT + 2]
    p10, p11, p12 = ftree[i, F_ROT + 3], ftree[i, F_ROT + 4], ftree[i, F_ROT + 5]
    p20, p21, p22 = ftree[i, F_ROT + 6], ftree[i, F_ROT + 7], ftree[i, F_ROT + 8]
    t0, t1, t2 = q[iq], q[iq + 1], q[iq + 2]
    return (
        p00 * q00 + p01 * q10 + p02 * q20,
        p00 * q01 + p01 * q11 + p02 * q21,
        p00 * q02 + p01 * q12 + p02 * q22,
        p10 * q00 + p11 * q10 + p12 * q20,
        p10 * q01 + p11 * q11 + p12 * q21,
        p10 * q02 + p11 * q12 + p12 * q22,
        p20 * q00 + p21 * q10 + p22 * q20,
        p20 * q01 + p21 * q11 + p22 * q21,
        p20 * q02 + p21 * q12 + p22 * q22,
        ftree[i, F_POS] + p00 * t0 + p01 * t1 + p02 * t2,
        ftree[i, F_POS + 1] + p10 * t0 + p11 * t1 + p12 * t2,
        ftree[i, F_POS + 2] + p20 * t0 + p21 * t1 + p22 * t2,
    )


@njit
def ff_motion(ws, i, x0, x1, x2, x3, x4, x5):  # type: ignore[no-untyped-def]
    """S x for the free flyer of row i: the local twist x = [linear; angular] in world, at the origin.

    S = [R, [o]x R; 0, R] with the body's (R, o) in ``ws[i, W_ROT]``, ``ws[i, W_POS]``.
    """
    r00, r01, r02 = ws[i, W_ROT], ws[i, W_ROT + 1], ws[i, W_ROT + 2]
    r10, r11, r12 = ws[i, W_ROT + 3], ws[i, W_ROT + 4], ws[i, W_ROT + 5]
    r20, r21, r22 = ws[i, W_ROT + 6], ws[i, W_ROT + 7], ws[i, W_ROT + 8]
    ox, oy, oz = ws[i, W_POS], ws[i, W_POS + 1], ws[i, W_POS + 2]
    w0 = r00 * x3 + r01 * x4 + r02 * x5
    w1 = r10 * x3 + r11 * x4 + r12 * x5
    w2 = r20 * x3 + r21 * x4 + r22 * x5
    v0 = r00 * x0 + r01 * x1 + r02 * x2 + oy * w2 - oz * w1
    v1 = r10 * x0 + r11 * x1 + r12 * x2 + oz * w0 - ox * w2
    v2 = r20 * x0 + r21 * x1 + r22 * x2 + ox * w1 - oy * w0
    return v0, v1, v2, w0, w1, w2


@njit
def ff_force(ws, i, f0, f1, f2, f3, f4, f5):  # type: ignore[no-untyped-def]
    """S^T f for the free flyer of row i: a world force at the origin in the body's frame, at its origin.

    S^T [f; n] = [R^T f; R^T (n - o x f)].
    """
    r00, r01, r02 = ws[i, W_ROT], ws[i, W_ROT + 1], ws[i, W_ROT + 2]
    r10, r11, r12 = ws[i, W_ROT + 3], ws[i, W_ROT + 4], ws[i, W_ROT + 5]
    r20, r21, r22 = ws[i, W_ROT + 6], ws[i, W_ROT + 7], ws[i, W_ROT + 8]
    ox, oy, oz = ws[i, W_POS], ws[i, W_POS + 1], ws[i, W_POS + 2]
    n0 = f3 - (oy * f2 - oz * f1)
    n1 = f4 - (oz * f0 - ox * f2)
    n2 = f5 - (ox * f1 - oy * f0)
    return (
        r00 * f0 + r10 * f1 + r20 * f2,
        r01 * f0 + r11 * f1 + r21 * f2,
        r02 * f0 + r12 * f1 + r22 * f2,
        r00 * n0 + r10 * n1 + r20 * n2,
        r01 * n0 + r11 * n1 + r21 * n2,
        r02 * n0 + r12 * n1 + r22 * n2,
    )


@njit
def ff_joint_inertia(ftree, ws, i):  # type: ignore[no-untyped-def]
    """D = S^T IA S + armature (6 x 6, the inertia in ``ws[i, W_IA]`` seen in the body's frame) into W_FD."""
    for k in range(6):
        s = ff_motion(
            ws,
            i,
            1.0 if k == 0 else 0.0,
            1.0 if k == 1 else 0.0,
            1.0 if k == 2 else 0.0,
            1.0 if k == 3 else 0.0,
            1.0 if k == 4 else 0.0,
            1.0 if k == 5 else 0.0,
        )
        for r in range(6):
            b = W_IA + 6 * r
            ws[i, W_FY + r] = (
                ws[i, b] * s[0]
                + ws[i, b + 1] * s[1]
                + ws[i, b + 2] * s[2]
                + ws[i, b + 3] * s[3]
                + ws[i, b + 4] * s[4]
                + ws[i, b + 5] * s[5]
            )
        d = ff_force(
            ws, i, ws[i, W_FY], ws[i, W_FY + 1], ws[i, W_FY + 2], ws[i, W_FY + 3], ws[i, W_FY + 4], ws[i, W_FY + 5]
        )
        for r in range(6):
            ws[i, W_FD + 6 * r + k] = d[r]
        ws[i, W_FD + 7 * k] += ftree[i, F_ARM6 + k]


@njit
def ff_root_acceleration(ftree, grav, tau, ws, out, i, iv):  # type: ignore[no-untyped-def]
    """ABA pass 3 at a free-flyer root: D qdd = tau - S^T (IA a_0 + pA), a_i = a_0 + S qdd, a_0 = (-g, 0).

    D = S^T IA S + armature is symmetric positive definite: Cholesky D = L L^T in W_FD.
    """
    ff_joint_inertia(ftree, ws, i)
    for r in range(6):  # IA a_0 + pA
        b = W_IA + 6 * r
        ws[i, W_FY + r] = ws[i, W_PA + r] - (ws[i, b] * grav[0] + ws[i, b + 1] * grav[1] + ws[i, b + 2] * grav[2])
    rhs = ff_force(
        ws, i, ws[i, W_FY], ws[i, W_FY + 1], ws[i, W_FY + 2], ws[i, W_FY + 3], ws[i, W_FY + 4], ws[i, W_FY + 5]
    )
    for r in range(6):
        ws[i, W_FB + r] = tau[iv + r] - rhs[r]
    # Cholesky, lower triangle in place (row-major: L[r, k] at W_FD + 6 r + k)
    for k in range(6):
        d = ws[i, W_FD + 7 * k]
        for m in range(k):
            d -= ws[i, W_FD + 6 * k + m] ** 2
        d = math.sqrt(d)
        ws[i, W_FD + 7 * k] = d
        for r in range(k + 1, 6):
            x = ws[i, W_FD + 6 * r + k]
            for m in range(k):
                x -= ws[i, W_FD + 6 * r + m] * ws[i, W_FD + 6 * k + m]
            ws[i, W_FD + 6 * r + k] = x / d
    for r in range(6):  # L y = b
        x = ws[i, W_FB + r]
        for m in range(r):
            x -= ws[i, W_FD + 6 * r + m] * ws[i, W_FB + m]
        ws[i, W_FB + r] = x / ws[i, W_FD + 7 * r]
    for r in range(5, -1, -1):  # L^T qdd = y
        x = ws[i, W_FB + r]
        for m in range(r + 1, 6):
            x -= ws[i, W_FD + 6 * m + r] * ws[i, W_FB + m]
        ws[i, W_FB + r] = x / ws[i, W_FD + 7 * r]
    for r in range(6):
        out[iv + r] = ws[i, W_FB + r]
    s = ff_motion(
        ws, i, ws[i, W_FB], ws[i, W_FB + 1], ws[i, W_FB + 2], ws[i, W_FB + 3], ws[i, W_FB + 4], ws[i, W_FB + 5]
    )
    ws[i, W_A], ws[i, W_A + 1], ws[i, W_A + 2] = s[0] - grav[0], s[1] - grav[1], s[2] - grav[2]
    ws[i, W_A + 3], ws[i, W_A + 4], ws[i, W_A + 5] = s[3], s[4], s[5]
    ws[i, W_LAMBDA] = 0.0


@njit
def ff_integrate(q, dq, iq, iv, out):  # type: ignore[no-untyped-def]
    """Free flyer q (+) dq: the SE(3) exponential of the local twist dq = (nu, w) [m, rad].

    With theta = |w|: the body turns by the rotation vector w (quaternion
    dq_r = (sin(theta/2) w / theta, cos(theta/2))) and moves by R V nu, where
    V = I + beta [w]x + gamma [w]x^2, beta = (1 - cos theta) / theta^2 = 2 sin^2(theta/2) / theta^2
    and gamma = (theta - sin theta) / theta^3 (its Taylor series below theta = 1/2, where the
    difference would cancel). The quaternion of q is normalised first (a long run drifts it
    off unit length) and the result is normalised, on the hemisphere of q.
    """
    vx, vy, vz = dq[iv], dq[iv + 1], dq[iv + 2]
    wx, wy, wz = dq[iv + 3], dq[iv + 4], dq[iv + 5]
    x, y, z, w = q[iq + 3], q[iq + 4], q[iq + 5], q[iq + 6]
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    th2 = wx * wx + wy * wy + wz * wz
    th = math.sqrt(th2)
    if th < 1e-8:  # sin(theta/2) / theta and beta to round-off from their first two terms
        half, beta = 0.5 - th2 / 48.0, 0.5 - th2 / 24.0
        ch = 1.0 - th2 / 8.0
    else:
        sh = math.sin(0.5 * th)
        half, ch = sh / th, math.cos(0.5 * th)
        beta = 2.0 * (sh / th) * (sh / th)
    if th < 0.5:  # gamma = sum_k (-1)^k theta^(2k) / (2k + 3)!, to theta^12 (the next term < 2e-19)
        gamma, term = 0.0, 1.0 / 6.0
        for k in range(7):
            gamma += term
            term *= -th2 / ((2 * k + 4) * (2 * k + 5))
    else:
        gamma = (th - math.sin(th)) / (th2 * th)
    # V nu in the body's frame
    cx, cy, cz = wy * vz - wz * vy, wz * vx - wx * vz, wx * vy - wy * vx
    p0 = vx + beta * cx + gamma * (wy * cz - wz * cy)
    p1 = vy + beta * cy + gamma * (wz * cx - wx * cz)
    p2 = vz + beta * cz + gamma * (wx * cy - wy * cx)
    # turned into the parent's frame by R(q): p + 2 w (u x p) + 2 u x (u x p), u the vector part
    t0, t1, t2 = y * p2 - z * p1, z * p0 - x * p2, x * p1 - y * p0
    out[iq] = q[iq] + p0 + 2.0 * (w * t0 + y * t2 - z * t1)
    out[iq + 1] = q[iq + 1] + p1 + 2.0 * (w * t1 + z * t0 - x * t2)
    out[iq + 2] = q[iq + 2] + p2 + 2.0 * (w * t2 + x * t1 - y * t0)
    # q dq_r (Hamilton product), normalised, with the sign that keeps it on q's hemisphere
    ex, ey, ez = half * wx, half * wy, half * wz
    rw = w * ch - x * ex - y * ey - z * ez
    rx = w * ex + x * ch + y * ez - z * ey
    ry = w * ey + y * ch + z * ex - x * ez
    rz = w * ez + z * ch + x * ey - y * ex
    scale = 1.0 / math.sqrt(rx * rx + ry * ry + rz * rz + rw * rw)
    if rx * x + ry * y + rz * z + rw * w < 0.0:
        scale = -scale
    out[iq + 3], out[iq + 4], out[iq + 5], out[iq + 6] = rx * scale, ry * scale, rz * scale, rw * scale
