"""numba kernels of the recursive rigid-body algorithms on a kinematic tree.

Imported only by :mod:`robodyn.sim.tree` when a compiled path is asked for (numba is heavy).
The model arrives as three arrays (:class:`robodyn.sim.tree.TreeModel`): ``itree`` (n, 4) int64
rows (parent, joint type, index in q, index in v), ``ftree`` (n, FCOLS) float64 rows (joint
axis, joint placement R_p and p in the parent joint's frame, mass, lever, rotational inertia
about the centre of mass, armature, and three products of the placement with the axis that
turn the joint's rotation into a sum: K = R_p [a]x, N = (R_p a) a^T, R_p a), and ``grav`` (3,)
[m/s^2]. Joint types: ``REVOLUTE`` (one angle), ``PRISMATIC`` (one slide), ``CONTINUOUS`` (a
revolute joint stored as (cos, sin), nq = 2), ``FREEFLYER`` (a root body free in space, as
Pinocchio's ``JointModelFreeFlyer``: q = [position [m] (3); unit quaternion x, y, z, w], nq = 7,
v = [linear [m/s]; angular [rad/s]] in the body's own frame, nv = 6; its six armatures are in
``ftree[i, F_ARM6:F_ARM6 + 6]``, its ``F_ARMATURE`` is 0).

Every quantity is expressed in the world frame, at the world origin (spatial vectors as
[linear; angular], as Pinocchio writes them): a body's inertia is turned into world axes once
per evaluation, after which the articulated inertias add up without a change of frame (the
world-frame formulation of the articulated-body algorithm, Featherstone 2008, sec. 7.3). On a
free-flyer tree the point is the free flyer's origin instead (its world position in
``ws[i, W_REF]``, ``W_POS`` relative to it): world-origin inertias of bodies at a distance d
carry terms m d^2 that cancel in the solve, and the round-off grew as d^2 (ABA on Talos 3e-12
relative at 10 m, 3e-10 at 100 m; taken at the free flyer it does not depend on d).

* pass 1 (root to leaves): placements (Rodrigues: R_p R_J(q) = R_p + sin q K + (1 - cos q)
  (N - R_p)), motion axes S_i, velocities v_i, velocity-product accelerations
  c_i = v_i x S_i qd_i, world inertias I_i, bias forces p_i = v_i x* I_i v_i, and the energies
  T = sum 1/2 v_i . I_i v_i + 1/2 sum armature qd^2, V = -sum m_i g . c_i;
* ABA pass 2 (leaves to root): U = IA S, D = S . U + armature, u = tau - S . pA, and the
  parent collects IA - U U^T / D (its upper triangle, mirrored) and
  pA + IA c + U (u - U . c) / D;
* ABA pass 3 (root to leaves): qdd = (u - U . (a_parent + c)) / D, a = a_parent + c + S qdd,
  starting from a_0 = (-g, 0).

A joint held at its stop is locked: ``ws[i, W_LOCK]`` = 1 (the caller sets it; a fresh zero
workspace locks nothing). Its articulated inertia passes to the parent whole, its qdd is 0,
and pass 3 leaves the stop's generalised force lambda = S . (IA a + pA) - tau (the force
M a - (tau - C v - G) of :meth:`robodyn.sim.system.RobotSystem.stop_forces`) in
``ws[i, W_LAMBDA]``.

A free flyer is a root joint only (:func:`robodyn.sim.tree.unsupported` refuses any other).
Its world-frame motion subspace is the 6 x 6 transform of the body's placement (R, o = 0),
S = [R, [o]x R; 0, R], rebuilt from ``W_ROT`` and ``W_POS`` wherever it is applied
(:func:`_ff_motion` computes S x, :func:`_ff_force` S^T f), so its ``W_S`` and ``W_C`` are zero
(c = v_parent x S v = 0 below the still world). Pass 3 solves its 6 x 6 D = S^T IA S + armature
by Cholesky in ``ws[i, W_FD:W_FD + 36]`` (scratch vectors in ``W_FY`` and ``W_FB``). A free
flyer has no stop: its ``W_LOCK`` is ignored and its ``W_LAMBDA`` is set to 0.

RNEA and CRBA reuse pass 1. The steps and whole runs over these are in
:mod:`robodyn.sim.tree_steps`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

njit = numba.njit(cache=True, nogil=True, error_model="numpy")
# the body's inertia and bias, shared by the loop and the free-flyer root: inlined in numba's IR (an LLVM
# call there cost the Panda's pass 1 40 %, measured)
njit_inline = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")

REVOLUTE, PRISMATIC, CONTINUOUS, FREEFLYER = 0, 1, 2, 3

# ftree columns
F_AXIS, F_ROT, F_POS, F_MASS, F_LEVER, F_INERTIA, F_ARMATURE = 0, 3, 12, 15, 16, 19, 28
F_K, F_N, F_RA = 29, 38, 47
F_ARM6 = 50  # a free flyer's six armatures [kg | kg m^2], zero on other rows
F_TOTAL = 56  # a free flyer's mass with all the bodies below it [kg], zero on other rows
FCOLS = 57

# workspace columns, one row per joint
W_ROT, W_POS, W_S, W_V, W_C, W_IA, W_PA, W_U, W_D, W_UU, W_A = 0, 9, 12, 18, 24, 30, 66, 72, 78, 79, 80
W_LOCK, W_LAMBDA = 86, 87
W_FD, W_FY, W_FB = 88, 124, 130  # a free flyer's 6 x 6 D (then its Cholesky factor), two 6-vectors
W_REF = 136  # a free flyer's position in world [m]: the point every world-frame vector is taken at
WCOLS = 139


@njit_inline
def _body(ftree, grav, ws, i, r00, r01, r02, r10, r11, r12, r20, r21, r22, ox, oy, oz, l0, l1, l2, g0, g1, g2):  # type: ignore[no-untyped-def]
    """Body i's world inertia into W_IA and bias v x* I v into W_PA; returns (v . I v [J x 2], -m g . c [J]).

    (R, o) is its placement, (l, g) its velocity [linear; angular], all in world at the reference point.
    """
    # world inertia about the world origin: [m 1, -m [c]x; m [c]x, R Ic R^T - m [c]x [c]x]
    m = ftree[i, F_MASS]
    lx, ly, lz = ftree[i, F_LEVER], ftree[i, F_LEVER + 1], ftree[i, F_LEVER + 2]
    cx = ox + r00 * lx + r01 * ly + r02 * lz
    cy = oy + r10 * lx + r11 * ly + r12 * lz
    cz = oz + r20 * lx + r21 * ly + r22 * lz
    i00, i01, i02 = ftree[i, F_INERTIA], ftree[i, F_INERTIA + 1], ftree[i, F_INERTIA + 2]
    i11, i12, i22 = ftree[i, F_INERTIA + 4], ftree[i, F_INERTIA + 5], ftree[i, F_INERTIA + 8]
    # rows of R Ic (Ic symmetric)
    t00 = r00 * i00 + r01 * i01 + r02 * i02
    t01 = r00 * i01 + r01 * i11 + r02 * i12
    t02 = r00 * i02 + r01 * i12 + r02 * i22
    t10 = r10 * i00 + r11 * i01 + r12 * i02
    t11 = r10 * i01 + r11 * i11 + r12 * i12
    t12 = r10 * i02 + r11 * i12 + r12 * i22
    t20 = r20 * i00 + r21 * i01 + r22 * i02
    t21 = r20 * i01 + r21 * i11 + r22 * i12
    t22 = r20 * i02 + r21 * i12 + r22 * i22
    mcx, mcy, mcz = m * cx, m * cy, m * cz
    cc = mcx * cx + mcy * cy + mcz * cz
    j00 = t00 * r00 + t01 * r01 + t02 * r02 + cc - mcx * cx
    j01 = t00 * r10 + t01 * r11 + t02 * r12 - mcx * cy
    j02 = t00 * r20 + t01 * r21 + t02 * r22 - mcx * cz
    j11 = t10 * r10 + t11 * r11 + t12 * r12 + cc - mcy * cy
    j12 = t10 * r20 + t11 * r21 + t12 * r22 - mcy * cz
    j22 = t20 * r20 + t21 * r21 + t22 * r22 + cc - mcz * cz
    b = W_IA
    ws[i, b + 0], ws[i, b + 1], ws[i, b + 2] = m, 0.0, 0.0
    ws[i, b + 3], ws[i, b + 4], ws[i, b + 5] = 0.0, mcz, -mcy
    ws[i, b + 6], ws[i, b + 7], ws[i, b + 8] = 0.0, m, 0.0
    ws[i, b + 9], ws[i, b + 10], ws[i, b + 11] = -mcz, 0.0, mcx
    ws[i, b + 12], ws[i, b + 13], ws[i, b + 14] = 0.0, 0.0, m
    ws[i, b + 15], ws[i, b + 16], ws[i, b + 17] = mcy, -mcx, 0.0
    ws[i, b + 18], ws[i, b + 19], ws[i, b + 20] = 0.0, -mcz, mcy
    ws[i, b + 21], ws[i, b + 22], ws[i, b + 23] = j00, j01, j02
    ws[i, b + 24], ws[i, b + 25], ws[i, b + 26] = mcz, 0.0, -mcx
    ws[i, b + 27], ws[i, b + 28], ws[i, b + 29] = j01, j11, j12
    ws[i, b + 30], ws[i, b + 31], ws[i, b + 32] = -mcy, mcx, 0.0
    ws[i, b + 33], ws[i, b + 34], ws[i, b + 35] = j02, j12, j22
    # h = I v; bias p = v x* h = [w x hf; v x hf + w x hn]
    h0 = m * l0 + mcz * g1 - mcy * g2
    h1 = m * l1 - mcz * g0 + mcx * g2
    h2 = m * l2 + mcy * g0 - mcx * g1
    h3 = -mcz * l1 + mcy * l2 + j00 * g0 + j01 * g1 + j02 * g2
    h4 = mcz * l0 - mcx * l2 + j01 * g0 + j11 * g1 + j12 * g2
    h5 = -mcy * l0 + mcx * l1 + j02 * g0 + j12 * g1 + j22 * g2
    ws[i, W_PA] = g1 * h2 - g2 * h1
    ws[i, W_PA + 1] = g2 * h0 - g0 * h2
    ws[i, W_PA + 2] = g0 * h1 - g1 * h0
    ws[i, W_PA + 3] = l1 * h2 - l2 * h1 + g1 * h5 - g2 * h4
    ws[i, W_PA + 4] = l2 * h0 - l0 * h2 + g2 * h3 - g0 * h5
    ws[i, W_PA + 5] = l0 * h1 - l1 * h0 + g0 * h4 - g1 * h3
    return (
        l0 * h0 + l1 * h1 + l2 * h2 + g0 * h3 + g1 * h4 + g2 * h5,
        -(mcx * grav[0] + mcy * grav[1] + mcz * grav[2]),
    )


@njit
def kinematics(itree, ftree, grav, q, v, ws):  # type: ignore[no-untyped-def]
    """Pass 1 into ``ws``; returns (T, V) [J] (gravity potential only)."""
    n = itree.shape[0]
    kinetic = 0.0
    potential = 0.0
    start = 0
    if n > 0 and itree[0, 1] == FREEFLYER:  # the root of the whole tree (tree.unsupported checks it)
        kinetic, potential = _ff_kinematics(itree, ftree, grav, q, v, ws)
        start = 1
    for i in range(start, n):
        par, jt, iq, iv = itree[i, 0], itree[i, 1], itree[i, 2], itree[i, 3]
        # local placement L = R_p R_J and pl = p + R_p a d
        if jt == PRISMATIC:
            d = q[iq]
            l00, l01, l02 = ftree[i, F_ROT], ftree[i, F_ROT + 1], ftree[i, F_ROT + 2]
            l10, l11, l12 = ftree[i, F_ROT + 3], ftree[i, F_ROT + 4], ftree[i, F_ROT + 5]
            l20, l21, l22 = ftree[i, F_ROT + 6], ftree[i, F_ROT + 7], ftree[i, F_ROT + 8]
            pl0 = ftree[i, F_POS] + d * ftree[i, F_RA]
            pl1 = ftree[i, F_POS + 1] + d * ftree[i, F_RA + 1]
            pl2 = ftree[i, F_POS + 2] + d * ftree[i, F_RA + 2]
        else:
            if jt == CONTINUOUS:
                c, s = q[iq], q[iq + 1]
            else:
                c, s = math.cos(q[iq]), math.sin(q[iq])
            t = 1.0 - c
            # R_p (c I + s [a]x + t a a^T) = c R_p + s K + t N
            l00 = c * ftree[i, F_ROT] + s * ftree[i, F_K] + t * ftree[i, F_N]
            l01 = c * ftree[i, F_ROT + 1] + s * ftree[i, F_K + 1] + t * ftree[i, F_N + 1]
            l02 = c * ftree[i, F_ROT + 2] + s * ftree[i, F_K + 2] + t * ftree[i, F_N + 2]
            l10 = c * ftree[i, F_ROT + 3] + s * ftree[i, F_K + 3] + t * ftree[i, F_N + 3]
            l11 = c * ftree[i, F_ROT + 4] + s * ftree[i, F_K + 4] + t * ftree[i, F_N + 4]
            l12 = c * ftree[i, F_ROT + 5] + s * ftree[i, F_K + 5] + t * ftree[i, F_N + 5]
            l20 = c * ftree[i, F_ROT + 6] + s * ftree[i, F_K + 6] + t * ftree[i, F_N + 6]
            l21 = c * ftree[i, F_ROT + 7] + s * ftree[i, F_K + 7] + t * ftree[i, F_N + 7]
            l22 = c * ftree[i, F_ROT + 8] + s * ftree[i, F_K + 8] + t * ftree[i, F_N + 8]
            pl0, pl1, pl2 = ftree[i, F_POS], ftree[i, F_POS + 1], ftree[i, F_POS + 2]
        # world placement R = R_parent L, o = o_parent + R_parent pl; world axis R_parent (R_p a)
        ra0, ra1, ra2 = ftree[i, F_RA], ftree[i, F_RA + 1], ftree[i, F_RA + 2]
        if par < 0:
            r00, r01, r02, r10, r11, r12, r20, r21, r22 = l00, l01, l02, l10, l11, l12, l20, l21, l22
            ox, oy, oz = pl0, pl1, pl2
            wx, wy, wz = ra0, ra1, ra2
            l0 = l1 = l2 = g0 = g1 = g2 = 0.0
        else:
            b00, b01, b02 = ws[par, W_ROT], ws[par, W_ROT + 1], ws[par, W_ROT + 2]
            b10, b11, b12 = ws[par, W_ROT + 3], ws[par, W_ROT + 4], ws[par, W_ROT + 5]
            b20, b21, b22 = ws[par, W_ROT + 6], ws[par, W_ROT + 7], ws[par, W_ROT + 8]
            r00 = b00 * l00 + b01 * l10 + b02 * l20
            r01 = b00 * l01 + b01 * l11 + b02 * l21
            r02 = b00 * l02 + b01 * l12 + b02 * l22
            r10 = b10 * l00 + b11 * l10 + b12 * l20
            r11 = b10 * l01 + b11 * l11 + b12 * l21
            r12 = b10 * l02 + b11 * l12 + b12 * l22
            r20 = b20 * l00 + b21 * l10 + b22 * l20
            r21 = b20 * l01 + b21 * l11 + b22 * l21
            r22 = b20 * l02 + b21 * l12 + b22 * l22
            ox = ws[par, W_POS] + b00 * pl0 + b01 * pl1 + b02 * pl2
            oy = ws[par, W_POS + 1] + b10 * pl0 + b11 * pl1 + b12 * pl2
            oz = ws[par, W_POS + 2] + b20 * pl0 + b21 * pl1 + b22 * pl2
            wx = b00 * ra0 + b01 * ra1 + b02 * ra2
            wy = b10 * ra0 + b11 * ra1 + b12 * ra2
            wz = b20 * ra0 + b21 * ra1 + b22 * ra2
            l0, l1, l2 = ws[par, W_V], ws[par, W_V + 1], ws[par, W_V + 2]
            g0, g1, g2 = ws[par, W_V + 3], ws[par, W_V + 4], ws[par, W_V + 5]
        ws[i, W_ROT], ws[i, W_ROT + 1], ws[i, W_ROT + 2] = r00, r01, r02
        ws[i, W_ROT + 3], ws[i, W_ROT + 4], ws[i, W_ROT + 5] = r10, r11, r12
        ws[i, W_ROT + 6], ws[i, W_ROT + 7], ws[i, W_ROT + 8] = r20, r21, r22
        ws[i, W_POS], ws[i, W_POS + 1], ws[i, W_POS + 2] = ox, oy, oz
        # motion subspace S = [o x axis; axis] (revolute) or [axis; 0] (prismatic)
        if jt == PRISMATIC:
            s0, s1, s2, s3, s4, s5 = wx, wy, wz, 0.0, 0.0, 0.0
        else:
            s0, s1, s2 = oy * wz - oz * wy, oz * wx - ox * wz, ox * wy - oy * wx
            s3, s4, s5 = wx, wy, wz
        ws[i, W_S], ws[i, W_S + 1], ws[i, W_S + 2] = s0, s1, s2
        ws[i, W_S + 3], ws[i, W_S + 4], ws[i, W_S + 5] = s3, s4, s5
        qd = v[iv]
        # c = v_parent x (S qd) (S x S = 0), v_i = v_parent + S qd
        vj0, vj1, vj2, vj3, vj4, vj5 = s0 * qd, s1 * qd, s2 * qd, s3 * qd, s4 * qd, s5 * qd
        ws[i, W_C] = g1 * vj2 - g2 * vj1 + l1 * vj5 - l2 * vj4
        ws[i, W_C + 1] = g2 * vj0 - g0 * vj2 + l2 * vj3 - l0 * vj5
        ws[i, W_C + 2] = g0 * vj1 - g1 * vj0 + l0 * vj4 - l1 * vj3
        ws[i, W_C + 3] = g1 * vj5 - g2 * vj4
        ws[i, W_C + 4] = g2 * vj3 - g0 * vj5
        ws[i, W_C + 5] = g0 * vj4 - g1 * vj3
        l0, l1, l2 = l0 + vj0, l1 + vj1, l2 + vj2
        g0, g1, g2 = g0 + vj3, g1 + vj4, g2 + vj5
        ws[i, W_V], ws[i, W_V + 1], ws[i, W_V + 2] = l0, l1, l2
        ws[i, W_V + 3], ws[i, W_V + 4], ws[i, W_V + 5] = g0, g1, g2
        vhv, pot = _body(
            ftree, grav, ws, i, r00, r01, r02, r10, r11, r12, r20, r21, r22, ox, oy, oz, l0, l1, l2, g0, g1, g2
        )
        arm = ftree[i, F_ARMATURE]
        kinetic += 0.5 * (vhv + arm * qd * qd)
        potential += pot
    return kinetic, potential


@njit
def aba_passes(itree, ftree, grav, tau, ws, out):  # type: ignore[no-untyped-def]
    """ABA passes 2 and 3 after :func:`kinematics`: the accelerations into ``out`` (nv,)."""
    n = itree.shape[0]
    for i in range(n - 1, -1, -1):
        par, iv = itree[i, 0], itree[i, 3]
        s0, s1, s2 = ws[i, W_S], ws[i, W_S + 1], ws[i, W_S + 2]
        s3, s4, s5 = ws[i, W_S + 3], ws[i, W_S + 4], ws[i, W_S + 5]
        c0, c1, c2 = ws[i, W_C], ws[i, W_C + 1], ws[i, W_C + 2]
        c3, c4, c5 = ws[i, W_C + 3], ws[i, W_C + 4], ws[i, W_C + 5]
        locked = ws[i, W_LOCK] != 0.0
        # U = IA S and y = IA c, one row of IA at a time
        D = ftree[i, F_ARMATURE]
        sp = 0.0
        uc = 0.0
        for r in range(6):
            b = W_IA + 6 * r
            x0, x1, x2, x3, x4, x5 = ws[i, b], ws[i, b + 1], ws[i, b + 2], ws[i, b + 3], ws[i, b + 4], ws[i, b + 5]
            ur = x0 * s0 + x1 * s1 + x2 * s2 + x3 * s3 + x4 * s4 + x5 * s5
            ws[i, W_U + r] = ur
            ws[i, W_A + r] = x0 * c0 + x1 * c1 + x2 * c2 + x3 * c3 + x4 * c4 + x5 * c5  # IA c, kept in W_A
            sr = ws[i, W_S + r]
            D += sr * ur
            sp += sr * ws[i, W_PA + r]
        uu = tau[iv] - sp
        ws[i, W_D] = D
        ws[i, W_UU] = uu
        if par < 0:
            continue
        if locked:  # the whole articulated inertia and bias (with IA c) pass to the parent
            for r in range(6):
                ws[par, W_PA + r] += ws[i, W_PA + r] + ws[i, W_A + r]
                for k in range(6):
                    ws[par, W_IA + 6 * r + k] += ws[i, W_IA + 6 * r + k]
            continue
        inv = 1.0 / D
        for r in range(6):
            uc += ws[i, W_U + r] * (ws[i, W_C + r])
        coef = (uu - uc) * inv
        for r in range(6):
            ur = ws[i, W_U + r]
            ws[par, W_PA + r] += ws[i, W_PA + r] + ws[i, W_A + r] + ur * coef
            ui = ur * inv
            for k in range(r, 6):
                x = ws[i, W_IA + 6 * r + k] - ui * ws[i, W_U + k]
                ws[par, W_IA + 6 * r + k] += x
                if k != r:
                    ws[par, W_IA + 6 * k + r] += x
    for i in range(n):
        par, iv = itree[i, 0], itree[i, 3]
        if par < 0:
            if itree[i, 1] == FREEFLYER:
                _ff_root_acceleration(ftree, grav, tau, ws, out, i, iv)
                continue
            a0, a1, a2, a3, a4, a5 = -grav[0], -grav[1], -grav[2], 0.0, 0.0, 0.0
        else:
            a0, a1, a2 = ws[par, W_A], ws[par, W_A + 1], ws[par, W_A + 2]
            a3, a4, a5 = ws[par, W_A + 3], ws[par, W_A + 4], ws[par, W_A + 5]
        a0 += ws[i, W_C]
        a1 += ws[i, W_C + 1]
        a2 += ws[i, W_C + 2]
        a3 += ws[i, W_C + 3]
        a4 += ws[i, W_C + 4]
        a5 += ws[i, W_C + 5]
        ua = (
            ws[i, W_U] * a0
            + ws[i, W_U + 1] * a1
            + ws[i, W_U + 2] * a2
            + ws[i, W_U + 3] * a3
            + ws[i, W_U + 4] * a4
            + ws[i, W_U + 5] * a5
        )
        if ws[i, W_LOCK] != 0.0:
            # held: qdd = 0; the stop's force lambda = S . (IA a + pA) - tau = U . a - u
            out[iv] = 0.0
            ws[i, W_LAMBDA] = ua - ws[i, W_UU]
            qdd = 0.0
        else:
            qdd = (ws[i, W_UU] - ua) / ws[i, W_D]
            out[iv] = qdd
        ws[i, W_A] = a0 + ws[i, W_S] * qdd
        ws[i, W_A + 1] = a1 + ws[i, W_S + 1] * qdd
        ws[i, W_A + 2] = a2 + ws[i, W_S + 2] * qdd
        ws[i, W_A + 3] = a3 + ws[i, W_S + 3] * qdd
        ws[i, W_A + 4] = a4 + ws[i, W_S + 4] * qdd
        ws[i, W_A + 5] = a5 + ws[i, W_S + 5] * qdd


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
        if itree[i, 1] == FREEFLYER:  # a root: a_i = a_0 + S a
            x = _ff_motion(ws, i, a[iv], a[iv + 1], a[iv + 2], a[iv + 3], a[iv + 4], a[iv + 5])
            for k in range(6):
                w[W_A + k] += x[k]
        for r in range(6):
            acc = w[W_PA + r]
            for k in range(6):
                acc += w[W_IA + 6 * r + k] * w[W_A + k]
            f[i, r] = acc
    for i in range(n - 1, -1, -1):
        par, iv = itree[i, 0], itree[i, 3]
        if itree[i, 1] == FREEFLYER:  # tau = S^T f + armature a, six entries
            x = _ff_force(ws, i, f[i, 0], f[i, 1], f[i, 2], f[i, 3], f[i, 4], f[i, 5])
            for k in range(6):
                out[iv + k] = x[k] + ftree[i, F_ARM6 + k] * a[iv + k]
            continue
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
        if itree[i, 1] == FREEFLYER:  # a root: its 6 x 6 block S^T Ic S + armature
            _ff_joint_inertia(ftree, ws, i)
            for r in range(6):
                for k in range(6):
                    M[iv + r, iv + k] = ws[i, W_FD + 6 * r + k]
            continue
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
            if itree[j, 1] == FREEFLYER:  # the root's six rows: S_j^T F
                x = _ff_force(ws, j, F[0], F[1], F[2], F[3], F[4], F[5])
                for k in range(6):
                    M[iv, jv + k] = x[k]
                    M[jv + k, iv] = x[k]
                j = itree[j, 0]
                continue
            val = 0.0
            for r in range(6):
                val += ws[j, W_S + r] * F[r]
            M[iv, jv] = val
            M[jv, iv] = val
            j = itree[j, 0]


@njit
def integrate(itree, q, dq, out):  # type: ignore[no-untyped-def]
    """Out = q (+) dq: addition, but a (cos, sin) pair turned by its angle (and renormalised).

    A free flyer moves by the SE(3) exponential of its local twist dq[iv:iv + 6]
    (:func:`_ff_integrate`).
    """
    start = 0
    if itree.shape[0] > 0 and itree[0, 1] == FREEFLYER:  # the root (row 0) when there is one
        _ff_integrate(q, dq, itree[0, 2], itree[0, 3], out)
        start = 1
    for i in range(start, itree.shape[0]):
        iq, iv = itree[i, 2], itree[i, 3]
        if itree[i, 1] == CONTINUOUS:
            c, s = math.cos(dq[iv]), math.sin(dq[iv])
            x = q[iq] * c - q[iq + 1] * s
            y = q[iq + 1] * c + q[iq] * s
            scale = 0.5 * (3.0 - (x * x + y * y))
            out[iq], out[iq + 1] = x * scale, y * scale
        else:
            out[iq] = q[iq] + dq[iv]


# ----------------------------------------------------------------------------- the free flyer


@njit
def _ff_kinematics(itree, ftree, grav, q, v, ws):  # type: ignore[no-untyped-def]
    """Pass 1 at a free-flyer root (row 0); returns its (T, V) [J].

    Its world position goes to W_REF and becomes the reference point (W_POS = 0); S v with v
    local is its velocity (the world is still: c = 0, and W_S, W_C are zero: S is applied
    through :func:`_ff_motion`). V holds the whole tree's -M g . W_REF, each body adding its own
    -m g . c from the reference point.
    """
    iq, iv = itree[0, 2], itree[0, 3]
    r00, r01, r02, r10, r11, r12, r20, r21, r22, p0, p1, p2 = _ff_placement(ftree, 0, q, iq)
    ws[0, W_REF], ws[0, W_REF + 1], ws[0, W_REF + 2] = p0, p1, p2
    ws[0, W_ROT], ws[0, W_ROT + 1], ws[0, W_ROT + 2] = r00, r01, r02
    ws[0, W_ROT + 3], ws[0, W_ROT + 4], ws[0, W_ROT + 5] = r10, r11, r12
    ws[0, W_ROT + 6], ws[0, W_ROT + 7], ws[0, W_ROT + 8] = r20, r21, r22
    ws[0, W_POS], ws[0, W_POS + 1], ws[0, W_POS + 2] = 0.0, 0.0, 0.0
    for k in range(6):
        ws[0, W_S + k] = 0.0
        ws[0, W_C + k] = 0.0
    l0, l1, l2, g0, g1, g2 = _ff_motion(ws, 0, v[iv], v[iv + 1], v[iv + 2], v[iv + 3], v[iv + 4], v[iv + 5])
    ws[0, W_V], ws[0, W_V + 1], ws[0, W_V + 2] = l0, l1, l2
    ws[0, W_V + 3], ws[0, W_V + 4], ws[0, W_V + 5] = g0, g1, g2
    vhv, pot = _body(
        ftree, grav, ws, 0, r00, r01, r02, r10, r11, r12, r20, r21, r22, 0.0, 0.0, 0.0, l0, l1, l2, g0, g1, g2
    )
    rotor = 0.0
    for k in range(6):
        rotor += ftree[0, F_ARM6 + k] * v[iv + k] * v[iv + k]
    pot -= ftree[0, F_TOTAL] * (p0 * grav[0] + p1 * grav[1] + p2 * grav[2])
    return 0.5 * (vhv + rotor), pot


@njit
def _ff_placement(ftree, i, q, iq):  # type: ignore[no-untyped-def]
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
def _ff_motion(ws, i, x0, x1, x2, x3, x4, x5):  # type: ignore[no-untyped-def]
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
def _ff_force(ws, i, f0, f1, f2, f3, f4, f5):  # type: ignore[no-untyped-def]
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
def _ff_joint_inertia(ftree, ws, i):  # type: ignore[no-untyped-def]
    """D = S^T IA S + armature (6 x 6, the inertia in ``ws[i, W_IA]`` seen in the body's frame) into W_FD."""
    for k in range(6):
        s = _ff_motion(
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
        d = _ff_force(
            ws, i, ws[i, W_FY], ws[i, W_FY + 1], ws[i, W_FY + 2], ws[i, W_FY + 3], ws[i, W_FY + 4], ws[i, W_FY + 5]
        )
        for r in range(6):
            ws[i, W_FD + 6 * r + k] = d[r]
        ws[i, W_FD + 7 * k] += ftree[i, F_ARM6 + k]


@njit
def _ff_root_acceleration(ftree, grav, tau, ws, out, i, iv):  # type: ignore[no-untyped-def]
    """ABA pass 3 at a free-flyer root: D qdd = tau - S^T (IA a_0 + pA), a_i = a_0 + S qdd, a_0 = (-g, 0).

    D = S^T IA S + armature is symmetric positive definite: Cholesky D = L L^T in W_FD.
    """
    _ff_joint_inertia(ftree, ws, i)
    for r in range(6):  # IA a_0 + pA
        b = W_IA + 6 * r
        ws[i, W_FY + r] = ws[i, W_PA + r] - (ws[i, b] * grav[0] + ws[i, b + 1] * grav[1] + ws[i, b + 2] * grav[2])
    rhs = _ff_force(
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
    s = _ff_motion(
        ws, i, ws[i, W_FB], ws[i, W_FB + 1], ws[i, W_FB + 2], ws[i, W_FB + 3], ws[i, W_FB + 4], ws[i, W_FB + 5]
    )
    ws[i, W_A], ws[i, W_A + 1], ws[i, W_A + 2] = s[0] - grav[0], s[1] - grav[1], s[2] - grav[2]
    ws[i, W_A + 3], ws[i, W_A + 4], ws[i, W_A + 5] = s[3], s[4], s[5]
    ws[i, W_LAMBDA] = 0.0


@njit
def _ff_integrate(q, dq, iq, iv, out):  # type: ignore[no-untyped-def]
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
