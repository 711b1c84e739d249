"""numba kernels of the recursive rigid-body algorithms on a kinematic tree, and whole runs over them.

Imported only by :mod:`robodyn.sim.tree` when a compiled path is asked for (numba is heavy).
The model arrives as three arrays (:class:`robodyn.sim.tree.TreeModel`): ``itree`` (n, 4) int64
rows (parent, joint type, index in q, index in v), ``ftree`` (n, FCOLS) float64 rows (joint
axis, joint placement R and p in the parent joint's frame, mass, lever, rotational inertia about
the centre of mass, armature), and ``grav`` (3,) [m/s^2]. Joint types: ``REVOLUTE`` (one angle),
``PRISMATIC`` (one slide), ``CONTINUOUS`` (a revolute joint stored as (cos, sin), nq = 2).

Every quantity is expressed in the world frame, at the world origin (spatial vectors as
[linear; angular], as Pinocchio writes them): a body's inertia is turned into world axes once
per evaluation, after which the articulated inertias add up without a change of frame (the
world-frame formulation of the articulated-body algorithm, Featherstone 2008, sec. 7.3).

* pass 1 (root to leaves): placements, motion axes S_i, velocities v_i, velocity-product
  accelerations c_i = v_i x S_i qd_i, world inertias I_i, bias forces p_i = v_i x* I_i v_i,
  and the energies T = sum 1/2 v_i . I_i v_i + 1/2 sum armature qd^2, V = -sum m_i g . c_i;
* ABA pass 2 (leaves to root): U = IA S, D = S . U + armature, u = tau - S . pA, and the
  parent collects IA - U U^T / D and pA + Ia c + U u / D;
* ABA pass 3 (root to leaves): qdd = (u - U . (a_parent + c)) / D, a = a_parent + c + S qdd,
  starting from a_0 = (-g, 0).

RNEA and CRBA reuse pass 1. The steps and whole runs over these are in
:mod:`robodyn.sim.tree_steps`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

njit = numba.njit(cache=True, nogil=True, error_model="numpy")

REVOLUTE, PRISMATIC, CONTINUOUS = 0, 1, 2

# ftree columns
F_AXIS, F_ROT, F_POS, F_MASS, F_LEVER, F_INERTIA, F_ARMATURE = 0, 3, 12, 15, 16, 19, 28
FCOLS = 29

# workspace columns, one row per joint
W_ROT, W_POS, W_S, W_V, W_C, W_IA, W_PA, W_U, W_D, W_UU, W_A = 0, 9, 12, 18, 24, 30, 66, 72, 78, 79, 80
WCOLS = 86


@njit
def kinematics(itree, ftree, grav, q, v, ws):  # type: ignore[no-untyped-def]
    """Pass 1 into ``ws``; returns (T, V) [J] (gravity potential only)."""
    n = itree.shape[0]
    kinetic = 0.0
    potential = 0.0
    for i in range(n):
        par, jt, iq, iv = itree[i, 0], itree[i, 1], itree[i, 2], itree[i, 3]
        f = ftree[i]
        w = ws[i]
        ax, ay, az = f[F_AXIS], f[F_AXIS + 1], f[F_AXIS + 2]
        # joint transform: rotation RJ about the axis, or the slide d along it
        d = 0.0
        if jt == PRISMATIC:
            d = q[iq]
            c, s = 1.0, 0.0
        elif jt == CONTINUOUS:
            c, s = q[iq], q[iq + 1]
        else:
            c, s = math.cos(q[iq]), math.sin(q[iq])
        t = 1.0 - c
        rj0, rj1, rj2 = c + t * ax * ax, t * ax * ay - s * az, t * ax * az + s * ay
        rj3, rj4, rj5 = t * ax * ay + s * az, c + t * ay * ay, t * ay * az - s * ax
        rj6, rj7, rj8 = t * ax * az - s * ay, t * ay * az + s * ax, c + t * az * az
        # local placement: Rp RJ, pp + Rp (d axis)
        p00, p01, p02 = f[F_ROT], f[F_ROT + 1], f[F_ROT + 2]
        p10, p11, p12 = f[F_ROT + 3], f[F_ROT + 4], f[F_ROT + 5]
        p20, p21, p22 = f[F_ROT + 6], f[F_ROT + 7], f[F_ROT + 8]
        l00, l01, l02 = (
            p00 * rj0 + p01 * rj3 + p02 * rj6,
            p00 * rj1 + p01 * rj4 + p02 * rj7,
            p00 * rj2 + p01 * rj5 + p02 * rj8,
        )
        l10, l11, l12 = (
            p10 * rj0 + p11 * rj3 + p12 * rj6,
            p10 * rj1 + p11 * rj4 + p12 * rj7,
            p10 * rj2 + p11 * rj5 + p12 * rj8,
        )
        l20, l21, l22 = (
            p20 * rj0 + p21 * rj3 + p22 * rj6,
            p20 * rj1 + p21 * rj4 + p22 * rj7,
            p20 * rj2 + p21 * rj5 + p22 * rj8,
        )
        pl0 = f[F_POS] + d * (p00 * ax + p01 * ay + p02 * az)
        pl1 = f[F_POS + 1] + d * (p10 * ax + p11 * ay + p12 * az)
        pl2 = f[F_POS + 2] + d * (p20 * ax + p21 * ay + p22 * az)
        if par < 0:
            w[W_ROT], w[W_ROT + 1], w[W_ROT + 2] = l00, l01, l02
            w[W_ROT + 3], w[W_ROT + 4], w[W_ROT + 5] = l10, l11, l12
            w[W_ROT + 6], w[W_ROT + 7], w[W_ROT + 8] = l20, l21, l22
            w[W_POS], w[W_POS + 1], w[W_POS + 2] = pl0, pl1, pl2
            for k in range(6):
                w[W_V + k] = 0.0
        else:
            wp = ws[par]
            for r in range(3):
                a0, a1, a2 = wp[W_ROT + 3 * r], wp[W_ROT + 3 * r + 1], wp[W_ROT + 3 * r + 2]
                w[W_ROT + 3 * r] = a0 * l00 + a1 * l10 + a2 * l20
                w[W_ROT + 3 * r + 1] = a0 * l01 + a1 * l11 + a2 * l21
                w[W_ROT + 3 * r + 2] = a0 * l02 + a1 * l12 + a2 * l22
                w[W_POS + r] = wp[W_POS + r] + a0 * pl0 + a1 * pl1 + a2 * pl2
            for k in range(6):
                w[W_V + k] = wp[W_V + k]
        R = w[W_ROT : W_ROT + 9]
        ox, oy, oz = w[W_POS], w[W_POS + 1], w[W_POS + 2]
        # world axis and motion subspace S = [o x axis; axis] (revolute) or [axis; 0] (prismatic)
        wx = R[0] * ax + R[1] * ay + R[2] * az
        wy = R[3] * ax + R[4] * ay + R[5] * az
        wz = R[6] * ax + R[7] * ay + R[8] * az
        if jt == PRISMATIC:
            w[W_S], w[W_S + 1], w[W_S + 2] = wx, wy, wz
            w[W_S + 3], w[W_S + 4], w[W_S + 5] = 0.0, 0.0, 0.0
        else:
            w[W_S], w[W_S + 1], w[W_S + 2] = oy * wz - oz * wy, oz * wx - ox * wz, ox * wy - oy * wx
            w[W_S + 3], w[W_S + 4], w[W_S + 5] = wx, wy, wz
        qd = v[iv]
        # c = v_i x (S qd), v_i = v_parent + S qd (the parent's part: S x S = 0)
        vj0, vj1, vj2 = w[W_S] * qd, w[W_S + 1] * qd, w[W_S + 2] * qd
        vj3, vj4, vj5 = w[W_S + 3] * qd, w[W_S + 4] * qd, w[W_S + 5] * qd
        l0, l1, l2, g0, g1, g2 = w[W_V], w[W_V + 1], w[W_V + 2], w[W_V + 3], w[W_V + 4], w[W_V + 5]
        w[W_C] = g1 * vj2 - g2 * vj1 + l1 * vj5 - l2 * vj4
        w[W_C + 1] = g2 * vj0 - g0 * vj2 + l2 * vj3 - l0 * vj5
        w[W_C + 2] = g0 * vj1 - g1 * vj0 + l0 * vj4 - l1 * vj3
        w[W_C + 3] = g1 * vj5 - g2 * vj4
        w[W_C + 4] = g2 * vj3 - g0 * vj5
        w[W_C + 5] = g0 * vj4 - g1 * vj3
        l0, l1, l2 = l0 + vj0, l1 + vj1, l2 + vj2
        g0, g1, g2 = g0 + vj3, g1 + vj4, g2 + vj5
        w[W_V], w[W_V + 1], w[W_V + 2], w[W_V + 3], w[W_V + 4], w[W_V + 5] = l0, l1, l2, g0, g1, g2
        # world inertia about the world origin
        m = f[F_MASS]
        lx, ly, lz = f[F_LEVER], f[F_LEVER + 1], f[F_LEVER + 2]
        cx = ox + R[0] * lx + R[1] * ly + R[2] * lz
        cy = oy + R[3] * lx + R[4] * ly + R[5] * lz
        cz = oz + R[6] * lx + R[7] * ly + R[8] * lz
        IA = w[W_IA : W_IA + 36]
        cc = cx * cx + cy * cy + cz * cz
        for r in range(3):
            # row r of R Ic
            t0 = R[3 * r] * f[F_INERTIA] + R[3 * r + 1] * f[F_INERTIA + 3] + R[3 * r + 2] * f[F_INERTIA + 6]
            t1 = R[3 * r] * f[F_INERTIA + 1] + R[3 * r + 1] * f[F_INERTIA + 4] + R[3 * r + 2] * f[F_INERTIA + 7]
            t2 = R[3 * r] * f[F_INERTIA + 2] + R[3 * r + 1] * f[F_INERTIA + 5] + R[3 * r + 2] * f[F_INERTIA + 8]
            cr = cx if r == 0 else (cy if r == 1 else cz)
            for k in range(r, 3):
                ck = cx if k == 0 else (cy if k == 1 else cz)
                val = t0 * R[3 * k] + t1 * R[3 * k + 1] + t2 * R[3 * k + 2] - m * cr * ck
                if r == k:
                    val += m * cc
                IA[6 * (3 + r) + 3 + k] = val
                IA[6 * (3 + k) + 3 + r] = val
        for r in range(3):
            for k in range(3):
                IA[6 * r + k] = m if r == k else 0.0
        mcx, mcy, mcz = m * cx, m * cy, m * cz
        # top right -m [c]x, bottom left m [c]x
        IA[3], IA[4], IA[5] = 0.0, mcz, -mcy
        IA[9], IA[10], IA[11] = -mcz, 0.0, mcx
        IA[15], IA[16], IA[17] = mcy, -mcx, 0.0
        IA[18], IA[19], IA[20] = 0.0, -mcz, mcy
        IA[24], IA[25], IA[26] = mcz, 0.0, -mcx
        IA[30], IA[31], IA[32] = -mcy, mcx, 0.0
        # h = I v; bias p = v x* h = [w x hf; v x hf + w x hn]
        h0 = m * l0 + IA[4] * g1 + IA[5] * g2
        h1 = m * l1 + IA[9] * g0 + IA[11] * g2
        h2 = m * l2 + IA[15] * g0 + IA[16] * g1
        h3 = IA[19] * l1 + IA[20] * l2 + IA[21] * g0 + IA[22] * g1 + IA[23] * g2
        h4 = IA[24] * l0 + IA[26] * l2 + IA[27] * g0 + IA[28] * g1 + IA[29] * g2
        h5 = IA[30] * l0 + IA[31] * l1 + IA[33] * g0 + IA[34] * g1 + IA[35] * g2
        h = (h0, h1, h2, h3, h4, h5)
        w[W_PA] = g1 * h[2] - g2 * h[1]
        w[W_PA + 1] = g2 * h[0] - g0 * h[2]
        w[W_PA + 2] = g0 * h[1] - g1 * h[0]
        w[W_PA + 3] = l1 * h[2] - l2 * h[1] + g1 * h[5] - g2 * h[4]
        w[W_PA + 4] = l2 * h[0] - l0 * h[2] + g2 * h[3] - g0 * h[5]
        w[W_PA + 5] = l0 * h[1] - l1 * h[0] + g0 * h[4] - g1 * h[3]
        kinetic += 0.5 * (l0 * h[0] + l1 * h[1] + l2 * h[2] + g0 * h[3] + g1 * h[4] + g2 * h[5])
        kinetic += 0.5 * f[F_ARMATURE] * qd * qd
        potential -= m * (grav[0] * cx + grav[1] * cy + grav[2] * cz)
    return kinetic, potential


@njit
def aba_passes(itree, ftree, grav, tau, ws, out):  # type: ignore[no-untyped-def]
    """ABA passes 2 and 3 after :func:`kinematics`: the accelerations into ``out`` (nv,)."""
    n = itree.shape[0]
    for i in range(n - 1, -1, -1):
        par, iv = itree[i, 0], itree[i, 3]
        w = ws[i]
        IA = w[W_IA : W_IA + 36]
        S = w[W_S : W_S + 6]
        D = ftree[i, F_ARMATURE]
        sp = 0.0
        for r in range(6):
            ur = 0.0
            for k in range(6):
                ur += IA[6 * r + k] * S[k]
            w[W_U + r] = ur
            D += S[r] * ur
            sp += S[r] * w[W_PA + r]
        uu = tau[iv] - sp
        w[W_D] = D
        w[W_UU] = uu
        if par >= 0:
            wp = ws[par]
            U = w[W_U : W_U + 6]
            inv = 1.0 / D
            # Ia = IA - U U^T / D; pa = pA + Ia c + U uu / D
            for r in range(6):
                acc = w[W_PA + r] + U[r] * uu * inv
                for k in range(6):
                    ia = IA[6 * r + k] - U[r] * U[k] * inv
                    wp[W_IA + 6 * r + k] += ia
                    acc += ia * w[W_C + k]
                wp[W_PA + r] += acc
    for i in range(n):
        par, iv = itree[i, 0], itree[i, 3]
        w = ws[i]
        if par < 0:
            a0, a1, a2, a3, a4, a5 = -grav[0], -grav[1], -grav[2], 0.0, 0.0, 0.0
        else:
            wp = ws[par]
            a0, a1, a2 = wp[W_A], wp[W_A + 1], wp[W_A + 2]
            a3, a4, a5 = wp[W_A + 3], wp[W_A + 4], wp[W_A + 5]
        a0 += w[W_C]
        a1 += w[W_C + 1]
        a2 += w[W_C + 2]
        a3 += w[W_C + 3]
        a4 += w[W_C + 4]
        a5 += w[W_C + 5]
        U = w[W_U : W_U + 6]
        qdd = (w[W_UU] - (U[0] * a0 + U[1] * a1 + U[2] * a2 + U[3] * a3 + U[4] * a4 + U[5] * a5)) / w[W_D]
        out[iv] = qdd
        S = w[W_S : W_S + 6]
        w[W_A] = a0 + S[0] * qdd
        w[W_A + 1] = a1 + S[1] * qdd
        w[W_A + 2] = a2 + S[2] * qdd
        w[W_A + 3] = a3 + S[3] * qdd
        w[W_A + 4] = a4 + S[4] * qdd
        w[W_A + 5] = a5 + S[5] * qdd


@njit
def aba(itree, ftree, grav, q, v, tau, ws, out):  # type: ignore[no-untyped-def]
    """Forward dynamics a = M^-1 (tau - C v - G) into ``out`` (nv,); returns (T, V) of (q, v) [J]."""
    kin, pot = kinematics(itree, ftree, grav, q, v, ws)
    aba_passes(itree, ftree, grav, tau, ws, out)
    return kin, pot


@njit
def rnea(itree, ftree, grav, q, v, a, ws, out):  # type: ignore[no-untyped-def]
    """Inverse dynamics tau = M a + C v + G (armature included) into ``out`` (nv,)."""
    kinematics(itree, ftree, grav, q, v, ws)
    n = itree.shape[0]
    f = np.empty((n, 6))
    for i in range(n):
        par, iv = itree[i, 0], itree[i, 3]
        w = ws[i]
        for k in range(6):
            base = -grav[k] if (par < 0 and k < 3) else 0.0
            if par >= 0:
                base = ws[par, W_A + k]
            w[W_A + k] = base + w[W_C + k] + w[W_S + k] * a[iv]
        for r in range(6):
            acc = w[W_PA + r]
            for k in range(6):
                acc += w[W_IA + 6 * r + k] * w[W_A + k]
            f[i, r] = acc
    for i in range(n - 1, -1, -1):
        par, iv = itree[i, 0], itree[i, 3]
        t = ftree[i, F_ARMATURE] * a[iv]
        for k in range(6):
            t += ws[i, W_S + k] * f[i, k]
        out[iv] = t
        if par >= 0:
            for k in range(6):
                f[par, k] += f[i, k]


@njit
def crba(itree, ftree, grav, q, ws, M):  # type: ignore[no-untyped-def]
    """Joint-space inertia M(q) (nv, nv), armature included, into ``M`` (both triangles)."""
    n = itree.shape[0]
    zero = np.zeros(M.shape[0])
    kinematics(itree, ftree, grav, q, zero, ws)
    for i in range(n - 1, -1, -1):
        par = itree[i, 0]
        if par >= 0:
            for k in range(36):
                ws[par, W_IA + k] += ws[i, W_IA + k]
    F = np.empty(6)
    for i in range(n):
        iv = itree[i, 3]
        for r in range(6):
            acc = 0.0
            for k in range(6):
                acc += ws[i, W_IA + 6 * r + k] * ws[i, W_S + k]
            F[r] = acc
        diag = ftree[i, F_ARMATURE]
        for r in range(6):
            diag += ws[i, W_S + r] * F[r]
        M[iv, iv] = diag
        j = itree[i, 0]
        while j >= 0:
            jv = itree[j, 3]
            val = 0.0
            for r in range(6):
                val += ws[j, W_S + r] * F[r]
            M[iv, jv] = val
            M[jv, iv] = val
            j = itree[j, 0]


@njit
def integrate(itree, q, dq, out):  # type: ignore[no-untyped-def]
    """Out = q (+) dq: addition, but a (cos, sin) pair turned by its angle (and renormalised)."""
    for i in range(itree.shape[0]):
        iq, iv = itree[i, 2], itree[i, 3]
        if itree[i, 1] == CONTINUOUS:
            c, s = math.cos(dq[iv]), math.sin(dq[iv])
            x = q[iq] * c - q[iq + 1] * s
            y = q[iq + 1] * c + q[iq] * s
            scale = 0.5 * (3.0 - (x * x + y * y))
            out[iq], out[iq + 1] = x * scale, y * scale
        else:
            out[iq] = q[iq] + dq[iv]
