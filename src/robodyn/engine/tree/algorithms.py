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

Every quantity is expressed in world axes at its own joint's origin (spatial vectors as
[linear; angular], as Pinocchio writes them): a body's inertia is turned into world axes once per
evaluation and taken about its joint's origin o_i (``W_POS``), and what passes between a joint and
its parent is moved by the offset r = o_i - o_parent (:func:`pass_to_parent` for inertias and
forces, :func:`parent_acceleration` for motions): no rotation, only m r^2 terms over a link's
length. Taken about one point for the whole tree (the world origin), a light body at a distance d
carried terms m d^2 that cancel in the solve: the round-off grew as d^2 and as m d^2 over the
body's own inertia about its axis (Stretch's wrist, 1e-6 kg m^2 a metre out: ABA 7e-11 relative;
Talos at 100 m: 3e-10); taken at each joint, as Pinocchio's local frames do, it does not.
Where the model's ``F_LOCAL`` is set, ABA's passes 2 and 3 work in each joint's own axes instead
(:mod:`robodyn.engine.tree.local`): in world axes an exact zero or alignment of the model (a
wheel's centre of mass on its axis, a head's point mass on crossing neck axes) is only nearly one
after rounding, which an ill-conditioned M amplifies (iCub's neck: 1.6e-9 relative to Pinocchio);
:func:`robodyn.sim.tree.compiled_of` sets it only where the world axes fail its check (or keep
no exact 0 of Pinocchio's at rest), as they are faster (the Panda's step without stops: 22 % more in joint axes).
On a free-flyer tree the positions are taken from the free flyer's origin (its world position in
``ws[i, W_REF]``, ``W_POS`` relative to it).

* pass 1 (root to leaves): placements (Rodrigues: R_p R_J(q) = R_p + sin q K + (1 - cos q)
  (N - R_p)), motion axes S_i ([0; axis] or [axis; 0] at the joint's origin), velocities v_i
  (the parent's moved to o_i, plus S_i qd_i), velocity-product accelerations
  c_i = v_i x S_i qd_i, world inertias I_i, bias forces p_i = v_i x* I_i v_i, and the energies
  T = sum 1/2 v_i . I_i v_i + 1/2 sum armature qd^2, V = -sum m_i g . c_i;
* ABA pass 2 (leaves to root): U = IA S, D = S . U + armature, u = tau - S . pA, and the
  parent collects IA - U U^T / D (its upper triangle, mirrored) and
  pA + IA c + U (u - U . c) / D, moved to its origin (in local axes: turned into its axes first);
* ABA pass 3 (root to leaves): qdd = (u - U . (a_parent + c)) / D, a = a_parent + c + S qdd
  (a_parent moved to o_i, and turned into row i's axes in local axes), starting from a_0 = (-g, 0).

A joint held at its stop is locked: ``ws[i, W_LOCK]`` = 1 (the caller sets it; a fresh zero
workspace locks nothing). Its articulated inertia passes to the parent whole, its qdd is 0,
and pass 3 leaves the stop's generalised force lambda = S . (IA a + pA) - tau (the force
M a - (tau - C v - G) of :meth:`robodyn.sim.system.RobotSystem.stop_forces`) in
``ws[i, W_LAMBDA]``.

A free flyer is a root joint only (:func:`robodyn.sim.tree.unsupported` refuses any other).
Its world-frame motion subspace is the 6 x 6 transform of the body's placement (R, o = 0),
S = [R, [o]x R; 0, R], rebuilt from ``W_ROT`` and ``W_POS`` wherever it is applied
(:func:`ff_motion` computes S x, :func:`ff_force` S^T f), so its ``W_S`` and ``W_C`` are zero
(c = v_parent x S v = 0 below the still world). Pass 3 solves its 6 x 6 D = S^T IA S + armature
by Cholesky in ``ws[i, W_FD:W_FD + 36]`` (scratch vectors in ``W_FY`` and ``W_FB``). A free
flyer has no stop: its ``W_LOCK`` is ignored and its ``W_LAMBDA`` is set to 0.

Every kernel takes ``flyer``: None on a tree without a free flyer, True on one whose root is
(:attr:`robodyn.sim.tree.TreeModel.flyer`). numba removes a branch on an argument that is None
before it types the function, so with None no free-flyer code is compiled at all (the first run
of a fixed-base robot compiles about 9 s of CPU less); with True each row's type decides, as it
would alone. None on a tree with a free flyer would treat its root as a revolute joint: only
:mod:`robodyn.sim.tree` chooses it, from the tree.

RNEA and CRBA reuse pass 1. The steps and whole runs over these are in
:mod:`robodyn.engine.tree.steps`.
"""

from __future__ import annotations

import math

import numpy as np

from robodyn.engine import jit
from robodyn.engine.tree.body import body
from robodyn.engine.tree.flyer import (
    ff_force,
    ff_integrate,
    ff_joint_inertia,
    ff_kinematics,
    ff_motion,
    ff_root_acceleration,
)
from robodyn.engine.tree.layout import (
    CONTINUOUS,
    F_ARM6,
    F_ARMATURE,
    F_K,
    F_LOCAL,
    F_MASS,
    F_N,
    F_POS,
    F_RA,
    F_ROT,
    FREEFLYER,
    PRISMATIC,
    W_A,
    W_C,
    W_D,
    W_FD,
    W_IA,
    W_LAMBDA,
    W_LOCK,
    W_PA,
    W_POS,
    W_ROT,
    W_S,
    W_U,
    W_UU,
    W_V,
)
from robodyn.engine.tree.local import parent_acceleration_local, pass_to_parent_local, root_gravity_local, to_local

njit = jit.njit(nogil=True, error_model="numpy")


@njit
def offset(ws, i, par):  # type: ignore[no-untyped-def]
    """O_i - o_parent [m] in world: from the parent's origin to row i's (both in ``W_POS``)."""
    return (
        ws[i, W_POS] - ws[par, W_POS],
        ws[i, W_POS + 1] - ws[par, W_POS + 1],
        ws[i, W_POS + 2] - ws[par, W_POS + 2],
    )


@njit
def parent_acceleration(ws, i, par):  # type: ignore[no-untyped-def]
    """The parent's spatial acceleration ``W_A`` moved to row i's origin: [a + alpha x r; alpha]."""
    r0, r1, r2 = offset(ws, i, par)
    a3, a4, a5 = ws[par, W_A + 3], ws[par, W_A + 4], ws[par, W_A + 5]
    return (
        ws[par, W_A] + a4 * r2 - a5 * r1,
        ws[par, W_A + 1] + a5 * r0 - a3 * r2,
        ws[par, W_A + 2] + a3 * r1 - a4 * r0,
        a3,
        a4,
        a5,
    )


@njit
def pass_to_parent(ws, i, par):  # type: ignore[no-untyped-def]
    """Add row i's inertia ``W_IA`` and force ``W_PA`` to its parent's, moved to the parent's origin.

    With r = o_i - o_parent and K = [r]x, a motion vector moves as T = [1, -K; 0, 1], so a force
    as T^T (n + r x f) and an inertia X = [A, B; B^T, C] as T^T X T = [A, B'; B'^T, C'] with
    B' = B - A K and C' = C + K B' + (K B')^T + K A K. Row i's W_IA is changed (to T^T X T);
    its ``W_FD`` columns are scratch (a free flyer, the only row that uses them, has no parent).
    """
    r0, r1, r2 = offset(ws, i, par)
    f0, f1, f2 = ws[i, W_PA], ws[i, W_PA + 1], ws[i, W_PA + 2]
    ws[par, W_PA] += f0
    ws[par, W_PA + 1] += f1
    ws[par, W_PA + 2] += f2
    ws[par, W_PA + 3] += ws[i, W_PA + 3] + r1 * f2 - r2 * f1
    ws[par, W_PA + 4] += ws[i, W_PA + 4] + r2 * f0 - r0 * f2
    ws[par, W_PA + 5] += ws[i, W_PA + 5] + r0 * f1 - r1 * f0
    ak, kak, kb = W_FD, W_FD + 9, W_FD + 18  # scratch 3 x 3 blocks, row-major
    for a in range(3):  # A K: column b of K is e_b x r... K[k, b] = [r]x
        x0, x1, x2 = ws[i, W_IA + 6 * a], ws[i, W_IA + 6 * a + 1], ws[i, W_IA + 6 * a + 2]
        ws[i, ak + 3 * a] = x1 * r2 - x2 * r1
        ws[i, ak + 3 * a + 1] = x2 * r0 - x0 * r2
        ws[i, ak + 3 * a + 2] = x0 * r1 - x1 * r0
    for b in range(3):  # K (A K) and K B', column by column (K y = r x y)
        y0, y1, y2 = ws[i, ak + b], ws[i, ak + 3 + b], ws[i, ak + 6 + b]
        ws[i, kak + b] = r1 * y2 - r2 * y1
        ws[i, kak + 3 + b] = r2 * y0 - r0 * y2
        ws[i, kak + 6 + b] = r0 * y1 - r1 * y0
        for a in range(3):  # B' = B - A K, in both triangles
            x = ws[i, W_IA + 6 * a + 3 + b] - ws[i, ak + 3 * a + b]
            ws[i, W_IA + 6 * a + 3 + b] = x
            ws[i, W_IA + 6 * (3 + b) + a] = x
        y0, y1, y2 = ws[i, W_IA + 3 + b], ws[i, W_IA + 9 + b], ws[i, W_IA + 15 + b]
        ws[i, kb + b] = r1 * y2 - r2 * y1
        ws[i, kb + 3 + b] = r2 * y0 - r0 * y2
        ws[i, kb + 6 + b] = r0 * y1 - r1 * y0
    for a in range(3):
        for b in range(3):
            c = W_IA + 6 * (3 + a) + 3 + b
            ws[i, c] += ws[i, kb + 3 * a + b] + ws[i, kb + 3 * b + a] + ws[i, kak + 3 * a + b]
    for k in range(36):
        ws[par, W_IA + k] += ws[i, W_IA + k]


@njit
def kinematics(itree, ftree, grav, flyer, q, v, ws):  # type: ignore[no-untyped-def]
    """Pass 1 into ``ws``; returns (T, V) [J] (gravity potential only)."""
    n = itree.shape[0]
    kinetic = 0.0
    potential = 0.0
    start = 0
    if flyer is not None and n > 0 and itree[0, 1] == FREEFLYER:  # the tree's root (tree.unsupported checks it)
        kinetic, potential = ff_kinematics(itree, ftree, grav, q, v, ws)
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
        else:  # the parent's velocity moved from its origin to this joint's: l + g x (R_parent pl)
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
            d0 = b00 * pl0 + b01 * pl1 + b02 * pl2
            d1 = b10 * pl0 + b11 * pl1 + b12 * pl2
            d2 = b20 * pl0 + b21 * pl1 + b22 * pl2
            ox, oy, oz = ws[par, W_POS] + d0, ws[par, W_POS + 1] + d1, ws[par, W_POS + 2] + d2
            wx = b00 * ra0 + b01 * ra1 + b02 * ra2
            wy = b10 * ra0 + b11 * ra1 + b12 * ra2
            wz = b20 * ra0 + b21 * ra1 + b22 * ra2
            g0, g1, g2 = ws[par, W_V + 3], ws[par, W_V + 4], ws[par, W_V + 5]
            l0 = ws[par, W_V] + g1 * d2 - g2 * d1
            l1 = ws[par, W_V + 1] + g2 * d0 - g0 * d2
            l2 = ws[par, W_V + 2] + g0 * d1 - g1 * d0
        ws[i, W_ROT], ws[i, W_ROT + 1], ws[i, W_ROT + 2] = r00, r01, r02
        ws[i, W_ROT + 3], ws[i, W_ROT + 4], ws[i, W_ROT + 5] = r10, r11, r12
        ws[i, W_ROT + 6], ws[i, W_ROT + 7], ws[i, W_ROT + 8] = r20, r21, r22
        ws[i, W_POS], ws[i, W_POS + 1], ws[i, W_POS + 2] = ox, oy, oz
        # motion subspace at the joint's origin: S = [0; axis] (revolute) or [axis; 0] (prismatic)
        if jt == PRISMATIC:
            s0, s1, s2, s3, s4, s5 = wx, wy, wz, 0.0, 0.0, 0.0
        else:
            s0, s1, s2, s3, s4, s5 = 0.0, 0.0, 0.0, wx, wy, wz
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
        vhv, pot = body(
            ftree, grav, ws, i, r00, r01, r02, r10, r11, r12, r20, r21, r22, 0.0, 0.0, 0.0, l0, l1, l2, g0, g1, g2
        )
        arm = ftree[i, F_ARMATURE]
        kinetic += 0.5 * (vhv + arm * qd * qd)
        potential += pot - ftree[i, F_MASS] * (grav[0] * ox + grav[1] * oy + grav[2] * oz)
    return kinetic, potential


@njit
def aba_passes(itree, ftree, grav, flyer, tau, ws, out):  # type: ignore[no-untyped-def]
    """ABA passes 2 and 3 after :func:`kinematics`: the accelerations into ``out`` (nv,).

    In world axes, or in each joint's own axes where the model's ``F_LOCAL`` is set (:mod:`robodyn.engine.tree.local`).
    """
    n = itree.shape[0]
    local = n > 0 and ftree[0, F_LOCAL] != 0.0
    if local:
        for i in range(n):  # each joint in its own axes (a free flyer stays in world axes)
            if flyer is None or itree[i, 1] != FREEFLYER:
                to_local(itree, ftree, ws, i)
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
        # what passes to the parent, at this joint's origin, into this row's W_IA and W_PA (read no more):
        # locked, the whole articulated inertia and bias (with IA c); else IA - U U^T / D, pA + IA c + U (u - U . c) / D
        if locked:
            for r in range(6):
                ws[i, W_PA + r] += ws[i, W_A + r]
        else:
            inv = 1.0 / D
            for r in range(6):
                uc += ws[i, W_U + r] * (ws[i, W_C + r])
            coef = (uu - uc) * inv
            for r in range(6):
                ur = ws[i, W_U + r]
                ws[i, W_PA + r] += ws[i, W_A + r] + ur * coef
                ui = ur * inv
                for k in range(r, 6):
                    x = ws[i, W_IA + 6 * r + k] - ui * ws[i, W_U + k]
                    ws[i, W_IA + 6 * r + k] = x
                    ws[i, W_IA + 6 * k + r] = x
        if local:
            pass_to_parent_local(itree, ws, i, par)
        else:
            pass_to_parent(ws, i, par)
    for i in range(n):
        par, iv = itree[i, 0], itree[i, 3]
        if par < 0:
            if flyer is not None and itree[i, 1] == FREEFLYER:
                ff_root_acceleration(ftree, grav, tau, ws, out, i, iv)
                continue
            a0, a1, a2, a3, a4, a5 = -grav[0], -grav[1], -grav[2], 0.0, 0.0, 0.0
            if local:  # a_0 = (-g, 0) in the root joint's axes
                a0, a1, a2 = root_gravity_local(ws, i, grav)
        elif local:
            a0, a1, a2, a3, a4, a5 = parent_acceleration_local(ws, i, par)
        else:
            a0, a1, a2, a3, a4, a5 = parent_acceleration(ws, i, par)
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
def aba(itree, ftree, grav, flyer, q, v, tau, ws, out):  # type: ignore[no-untyped-def]
    """Forward dynamics a = M^-1 (tau - C v - G) into ``out`` (nv,); returns (T, V) of (q, v) [J]."""
    kin, pot = kinematics(itree, ftree, grav, flyer, q, v, ws)
    aba_passes(itree, ftree, grav, flyer, tau, ws, out)
    return kin, pot


@njit
def rnea(itree, ftree, grav, flyer, q, v, a, ws, out):  # type: ignore[no-untyped-def]
    """Inverse dynamics tau = M a + C v + G (armature included) into ``out`` (nv,)."""
    kinematics(itree, ftree, grav, flyer, q, v, ws)
    n = itree.shape[0]
    f = np.empty((n, 6))
    for i in range(n):
        par, iv = itree[i, 0], itree[i, 3]
        w = ws[i]
        if par >= 0:
            b0, b1, b2, b3, b4, b5 = parent_acceleration(ws, i, par)
        else:
            b0, b1, b2, b3, b4, b5 = -grav[0], -grav[1], -grav[2], 0.0, 0.0, 0.0
        w[W_A] = b0 + w[W_C] + w[W_S] * a[iv]
        w[W_A + 1] = b1 + w[W_C + 1] + w[W_S + 1] * a[iv]
        w[W_A + 2] = b2 + w[W_C + 2] + w[W_S + 2] * a[iv]
        w[W_A + 3] = b3 + w[W_C + 3] + w[W_S + 3] * a[iv]
        w[W_A + 4] = b4 + w[W_C + 4] + w[W_S + 4] * a[iv]
        w[W_A + 5] = b5 + w[W_C + 5] + w[W_S + 5] * a[iv]
        if flyer is not None and itree[i, 1] == FREEFLYER:  # a root: a_i = a_0 + S a
            x = ff_motion(ws, i, a[iv], a[iv + 1], a[iv + 2], a[iv + 3], a[iv + 4], a[iv + 5])
            for k in range(6):
                w[W_A + k] += x[k]
        for r in range(6):
            acc = w[W_PA + r]
            for k in range(6):
                acc += w[W_IA + 6 * r + k] * w[W_A + k]
            f[i, r] = acc
    for i in range(n - 1, -1, -1):
        par, iv = itree[i, 0], itree[i, 3]
        if flyer is not None and itree[i, 1] == FREEFLYER:  # tau = S^T f + armature a, six entries
            x = ff_force(ws, i, f[i, 0], f[i, 1], f[i, 2], f[i, 3], f[i, 4], f[i, 5])
            for k in range(6):
                out[iv + k] = x[k] + ftree[i, F_ARM6 + k] * a[iv + k]
            continue
        t = ftree[i, F_ARMATURE] * a[iv]
        for k in range(6):
            t += ws[i, W_S + k] * f[i, k]
        out[iv] = t
        if par >= 0:  # the force moved to the parent's origin: n + (o_i - o_parent) x f
            r0, r1, r2 = offset(ws, i, par)
            for k in range(3):
                f[par, k] += f[i, k]
            f[par, 3] += f[i, 3] + r1 * f[i, 2] - r2 * f[i, 1]
            f[par, 4] += f[i, 4] + r2 * f[i, 0] - r0 * f[i, 2]
            f[par, 5] += f[i, 5] + r0 * f[i, 1] - r1 * f[i, 0]


@njit
def crba(itree, ftree, grav, flyer, q, ws, M):  # type: ignore[no-untyped-def]
    """Joint-space inertia M(q) (nv, nv), armature included, into ``M`` (both triangles)."""
    n = itree.shape[0]
    zero = np.zeros(M.shape[0])
    kinematics(itree, ftree, grav, flyer, q, zero, ws)
    F = np.empty(6)
    for i in range(n - 1, -1, -1):  # row i's composite inertia is whole once the rows below it are added
        iv = itree[i, 3]
        if flyer is not None and itree[i, 1] == FREEFLYER:  # a root: its 6 x 6 block S^T Ic S + armature
            ff_joint_inertia(ftree, ws, i)
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
        child, j = i, itree[i, 0]
        while j >= 0:  # F moved up to each ancestor's origin
            r0, r1, r2 = offset(ws, child, j)
            F[3] += r1 * F[2] - r2 * F[1]
            F[4] += r2 * F[0] - r0 * F[2]
            F[5] += r0 * F[1] - r1 * F[0]
            jv = itree[j, 3]
            if flyer is not None and itree[j, 1] == FREEFLYER:  # the root's six rows: S_j^T F
                x = ff_force(ws, j, F[0], F[1], F[2], F[3], F[4], F[5])
                for k in range(6):
                    M[iv, jv + k] = x[k]
                    M[jv + k, iv] = x[k]
            else:
                val = 0.0
                for r in range(6):
                    val += ws[j, W_S + r] * F[r]
                M[iv, jv] = val
                M[jv, iv] = val
            child, j = j, itree[j, 0]
        par = itree[i, 0]
        if par >= 0:  # v = 0: W_PA is zero, only the inertia passes
            pass_to_parent(ws, i, par)


@njit
def integrate(itree, flyer, q, dq, out):  # type: ignore[no-untyped-def]
    """Out = q (+) dq: addition, but a (cos, sin) pair turned by its angle (and renormalised).

    A free flyer moves by the SE(3) exponential of its local twist dq[iv:iv + 6]
    (:func:`ff_integrate`).
    """
    start = 0
    if flyer is not None and itree.shape[0] > 0 and itree[0, 1] == FREEFLYER:  # the root (row 0) when there is one
        ff_integrate(q, dq, itree[0, 2], itree[0, 3], out)
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
