"""The articulated-body algorithm's passes 2 and 3 in each joint's own axes, for the compiled tree kernels.

:func:`robodyn.engine.tree.algorithms.aba_passes` runs them, on a model whose ``F_LOCAL`` column is
set, over pass 1's world placements: each joint's ABA inputs are put in its own axes at its origin
(:func:`to_local`: the body's inertia from the model's numbers, :func:`local_inertia`, S its axis,
the bias force and c turned), what passes to the parent is turned by the joint's rotation E in its
parent's axes and moved by its origin r there (:func:`pass_to_parent_local`), and the parent's
acceleration comes down the same way (:func:`parent_acceleration_local`), as Pinocchio's local
frames do. A free flyer's rows stay in world axes at its origin (:func:`frame` takes its axes as
the world's). Inlined in numba's IR (as :mod:`robodyn.engine.tree.body`: an LLVM call per joint costs).
"""

from __future__ import annotations

from robodyn.engine import jit
from robodyn.engine.tree.layout import (
    F_AXIS,
    F_INERTIA,
    F_LEVER,
    F_MASS,
    FREEFLYER,
    PRISMATIC,
    W_A,
    W_C,
    W_FD,
    W_IA,
    W_PA,
    W_POS,
    W_ROT,
    W_S,
)

njit_inline = jit.njit(nogil=True, error_model="numpy", inline="always")


@njit_inline
def local_inertia(ftree, ws, i):  # type: ignore[no-untyped-def]
    """Body i's inertia about its joint's origin in the joint's own axes into W_IA, from the model's numbers.

    [m 1, -m [l]x; m [l]x, Ic + m (|l|^2 1 - l l^T)] with l the lever and Ic the inertia about the
    centre of mass, both as the URDF gives them: no rotation, and each diagonal entry a sum of
    squares (m (l_y^2 + l_z^2), not m |l|^2 - m l_x^2), so a zero or an alignment in the model's
    numbers stays exact (the articulated-body algorithm's D = S . IA S of a body whose mass lies
    near its axis is then not a difference of large terms).
    """
    m = ftree[i, F_MASS]
    lx, ly, lz = ftree[i, F_LEVER], ftree[i, F_LEVER + 1], ftree[i, F_LEVER + 2]
    mx, my, mz = m * lx, m * ly, m * lz
    b = W_IA
    ws[i, b + 0], ws[i, b + 1], ws[i, b + 2] = m, 0.0, 0.0
    ws[i, b + 3], ws[i, b + 4], ws[i, b + 5] = 0.0, mz, -my
    ws[i, b + 6], ws[i, b + 7], ws[i, b + 8] = 0.0, m, 0.0
    ws[i, b + 9], ws[i, b + 10], ws[i, b + 11] = -mz, 0.0, mx
    ws[i, b + 12], ws[i, b + 13], ws[i, b + 14] = 0.0, 0.0, m
    ws[i, b + 15], ws[i, b + 16], ws[i, b + 17] = my, -mx, 0.0
    j01 = ftree[i, F_INERTIA + 1] - mx * ly
    j02 = ftree[i, F_INERTIA + 2] - mx * lz
    j12 = ftree[i, F_INERTIA + 5] - my * lz
    ws[i, b + 18], ws[i, b + 19], ws[i, b + 20] = 0.0, -mz, my
    ws[i, b + 21], ws[i, b + 22], ws[i, b + 23] = ftree[i, F_INERTIA] + (my * ly + mz * lz), j01, j02
    ws[i, b + 24], ws[i, b + 25], ws[i, b + 26] = mz, 0.0, -mx
    ws[i, b + 27], ws[i, b + 28], ws[i, b + 29] = j01, ftree[i, F_INERTIA + 4] + (mx * lx + mz * lz), j12
    ws[i, b + 30], ws[i, b + 31], ws[i, b + 32] = -my, mx, 0.0
    ws[i, b + 33], ws[i, b + 34], ws[i, b + 35] = j02, j12, ftree[i, F_INERTIA + 8] + (mx * lx + my * ly)


@njit_inline
def frame(itree, ws, i, par):  # type: ignore[no-untyped-def]
    """Row i's joint frame in its parent's: the rotation E = P^T R_i and the origin r = P^T (o_i - o_parent) [m].

    R_i, o_i and the parent's P, o_parent are the world placements of pass 1 (``W_ROT``, ``W_POS``);
    P = 1 where the parent is a free flyer, whose ABA quantities stay in world axes at its origin.
    Returns (e00, e01, ..., e22, r0, r1, r2), E row-major.
    """
    d0, d1, d2 = _offset(ws, i, par)
    c00, c01, c02 = ws[i, W_ROT], ws[i, W_ROT + 1], ws[i, W_ROT + 2]
    c10, c11, c12 = ws[i, W_ROT + 3], ws[i, W_ROT + 4], ws[i, W_ROT + 5]
    c20, c21, c22 = ws[i, W_ROT + 6], ws[i, W_ROT + 7], ws[i, W_ROT + 8]
    if itree[par, 1] == FREEFLYER:
        return c00, c01, c02, c10, c11, c12, c20, c21, c22, d0, d1, d2
    p00, p01, p02 = ws[par, W_ROT], ws[par, W_ROT + 1], ws[par, W_ROT + 2]
    p10, p11, p12 = ws[par, W_ROT + 3], ws[par, W_ROT + 4], ws[par, W_ROT + 5]
    p20, p21, p22 = ws[par, W_ROT + 6], ws[par, W_ROT + 7], ws[par, W_ROT + 8]
    return (
        p00 * c00 + p10 * c10 + p20 * c20,
        p00 * c01 + p10 * c11 + p20 * c21,
        p00 * c02 + p10 * c12 + p20 * c22,
        p01 * c00 + p11 * c10 + p21 * c20,
        p01 * c01 + p11 * c11 + p21 * c21,
        p01 * c02 + p11 * c12 + p21 * c22,
        p02 * c00 + p12 * c10 + p22 * c20,
        p02 * c01 + p12 * c11 + p22 * c21,
        p02 * c02 + p12 * c12 + p22 * c22,
        p00 * d0 + p10 * d1 + p20 * d2,
        p01 * d0 + p11 * d1 + p21 * d2,
        p02 * d0 + p12 * d1 + p22 * d2,
    )


@njit_inline
def to_local(itree, ftree, ws, i):  # type: ignore[no-untyped-def]
    """Row i's ABA inputs in its joint's own axes, at its origin: W_IA from the model, W_S its axis.

    W_PA (the bias force) and W_C (the velocity-product acceleration) of pass 1 are turned by R_i^T.
    """
    local_inertia(ftree, ws, i)
    r00, r01, r02 = ws[i, W_ROT], ws[i, W_ROT + 1], ws[i, W_ROT + 2]
    r10, r11, r12 = ws[i, W_ROT + 3], ws[i, W_ROT + 4], ws[i, W_ROT + 5]
    r20, r21, r22 = ws[i, W_ROT + 6], ws[i, W_ROT + 7], ws[i, W_ROT + 8]
    for col in (W_PA, W_PA + 3, W_C, W_C + 3):
        x0, x1, x2 = ws[i, col], ws[i, col + 1], ws[i, col + 2]
        ws[i, col] = r00 * x0 + r10 * x1 + r20 * x2
        ws[i, col + 1] = r01 * x0 + r11 * x1 + r21 * x2
        ws[i, col + 2] = r02 * x0 + r12 * x1 + r22 * x2
    a0, a1, a2 = ftree[i, F_AXIS], ftree[i, F_AXIS + 1], ftree[i, F_AXIS + 2]
    if itree[i, 1] == PRISMATIC:
        ws[i, W_S], ws[i, W_S + 1], ws[i, W_S + 2], ws[i, W_S + 3], ws[i, W_S + 4], ws[i, W_S + 5] = (
            a0, a1, a2, 0.0, 0.0, 0.0
        )  # fmt: skip
    else:
        ws[i, W_S], ws[i, W_S + 1], ws[i, W_S + 2], ws[i, W_S + 3], ws[i, W_S + 4], ws[i, W_S + 5] = (
            0.0, 0.0, 0.0, a0, a1, a2
        )  # fmt: skip


@njit_inline
def pass_to_parent_local(itree, ws, i, par):  # type: ignore[no-untyped-def]
    """Add row i's ``W_IA`` and ``W_PA`` (its own axes, at its origin) to its parent's, in the parent's axes and origin.

    Turned by E (X = [A, B; B^T, C] -> [E A E^T, E B E^T; ..., E C E^T], f -> E f), then moved by r
    as :func:`pass_to_parent` moves (B' = B - A K, C' = C + K B' + (K B')^T + K A K with K = [r]x;
    n' = n + r x f), all in registers from the upper triangle of row i's W_IA. E and r are then
    kept in row i's ``W_FD`` columns (0-8, 9-11) for pass 3.
    """
    e00, e01, e02, e10, e11, e12, e20, e21, e22, r0, r1, r2 = frame(itree, ws, i, par)
    w = W_IA
    # A' = E A E^T (A symmetric: T = E A, then the upper triangle of T E^T)
    y00, y01, y02, y11, y12, y22 = ws[i, w], ws[i, w + 1], ws[i, w + 2], ws[i, w + 7], ws[i, w + 8], ws[i, w + 14]
    t00, t01, t02 = (
        e00 * y00 + e01 * y01 + e02 * y02,
        e00 * y01 + e01 * y11 + e02 * y12,
        e00 * y02 + e01 * y12 + e02 * y22,
    )
    t10, t11, t12 = (
        e10 * y00 + e11 * y01 + e12 * y02,
        e10 * y01 + e11 * y11 + e12 * y12,
        e10 * y02 + e11 * y12 + e12 * y22,
    )
    t20, t21, t22 = (
        e20 * y00 + e21 * y01 + e22 * y02,
        e20 * y01 + e21 * y11 + e22 * y12,
        e20 * y02 + e21 * y12 + e22 * y22,
    )
    a00, a01, a02 = (
        t00 * e00 + t01 * e01 + t02 * e02,
        t00 * e10 + t01 * e11 + t02 * e12,
        t00 * e20 + t01 * e21 + t02 * e22,
    )
    a11, a12 = t10 * e10 + t11 * e11 + t12 * e12, t10 * e20 + t11 * e21 + t12 * e22
    a22 = t20 * e20 + t21 * e21 + t22 * e22
    # C' = E C E^T
    y00, y01, y02 = ws[i, w + 21], ws[i, w + 22], ws[i, w + 23]
    y11, y12, y22 = ws[i, w + 28], ws[i, w + 29], ws[i, w + 35]
    t00, t01, t02 = (
        e00 * y00 + e01 * y01 + e02 * y02,
        e00 * y01 + e01 * y11 + e02 * y12,
        e00 * y02 + e01 * y12 + e02 * y22,
    )
    t10, t11, t12 = (
        e10 * y00 + e11 * y01 + e12 * y02,
        e10 * y01 + e11 * y11 + e12 * y12,
        e10 * y02 + e11 * y12 + e12 * y22,
    )
    t20, t21, t22 = (
        e20 * y00 + e21 * y01 + e22 * y02,
        e20 * y01 + e21 * y11 + e22 * y12,
        e20 * y02 + e21 * y12 + e22 * y22,
    )
    c00, c01, c02 = (
        t00 * e00 + t01 * e01 + t02 * e02,
        t00 * e10 + t01 * e11 + t02 * e12,
        t00 * e20 + t01 * e21 + t02 * e22,
    )
    c11, c12 = t10 * e10 + t11 * e11 + t12 * e12, t10 * e20 + t11 * e21 + t12 * e22
    c22 = t20 * e20 + t21 * e21 + t22 * e22
    # B' = E B E^T (B general)
    y00, y01, y02 = ws[i, w + 3], ws[i, w + 4], ws[i, w + 5]
    y10, y11, y12 = ws[i, w + 9], ws[i, w + 10], ws[i, w + 11]
    y20, y21, y22 = ws[i, w + 15], ws[i, w + 16], ws[i, w + 17]
    t00, t01, t02 = (
        e00 * y00 + e01 * y10 + e02 * y20,
        e00 * y01 + e01 * y11 + e02 * y21,
        e00 * y02 + e01 * y12 + e02 * y22,
    )
    t10, t11, t12 = (
        e10 * y00 + e11 * y10 + e12 * y20,
        e10 * y01 + e11 * y11 + e12 * y21,
        e10 * y02 + e11 * y12 + e12 * y22,
    )
    t20, t21, t22 = (
        e20 * y00 + e21 * y10 + e22 * y20,
        e20 * y01 + e21 * y11 + e22 * y21,
        e20 * y02 + e21 * y12 + e22 * y22,
    )
    b00, b01, b02 = (
        t00 * e00 + t01 * e01 + t02 * e02,
        t00 * e10 + t01 * e11 + t02 * e12,
        t00 * e20 + t01 * e21 + t02 * e22,
    )
    b10, b11, b12 = (
        t10 * e00 + t11 * e01 + t12 * e02,
        t10 * e10 + t11 * e11 + t12 * e12,
        t10 * e20 + t11 * e21 + t12 * e22,
    )
    b20, b21, b22 = (
        t20 * e00 + t21 * e01 + t22 * e02,
        t20 * e10 + t21 * e11 + t22 * e12,
        t20 * e20 + t21 * e21 + t22 * e22,
    )
    # the shift by r: row a of A K is (row a of A) x r
    k00, k01, k02 = a01 * r2 - a02 * r1, a02 * r0 - a00 * r2, a00 * r1 - a01 * r0
    k10, k11, k12 = a11 * r2 - a12 * r1, a12 * r0 - a01 * r2, a01 * r1 - a11 * r0
    k20, k21, k22 = a12 * r2 - a22 * r1, a22 * r0 - a02 * r2, a02 * r1 - a12 * r0
    b00, b01, b02 = b00 - k00, b01 - k01, b02 - k02
    b10, b11, b12 = b10 - k10, b11 - k11, b12 - k12
    b20, b21, b22 = b20 - k20, b21 - k21, b22 - k22
    # K (A K) and K B', column b = r x (column b); C' += K B' + (K B')^T + K A K (upper triangle)
    m00, m10, m20 = r1 * k20 - r2 * k10, r2 * k00 - r0 * k20, r0 * k10 - r1 * k00
    m11, m21 = r2 * k01 - r0 * k21, r0 * k11 - r1 * k01
    m22 = r0 * k12 - r1 * k02
    n00, n10, n20 = r1 * b20 - r2 * b10, r2 * b00 - r0 * b20, r0 * b10 - r1 * b00
    n01, n11, n21 = r1 * b21 - r2 * b11, r2 * b01 - r0 * b21, r0 * b11 - r1 * b01
    n02, n12, n22 = r1 * b22 - r2 * b12, r2 * b02 - r0 * b22, r0 * b12 - r1 * b02
    c00 += 2.0 * n00 + m00
    c01 += n01 + n10 + m10
    c02 += n02 + n20 + m20
    c11 += 2.0 * n11 + m11
    c12 += n12 + n21 + m21
    c22 += 2.0 * n22 + m22
    ws[par, w] += a00
    ws[par, w + 1] += a01
    ws[par, w + 2] += a02
    ws[par, w + 6] += a01
    ws[par, w + 7] += a11
    ws[par, w + 8] += a12
    ws[par, w + 12] += a02
    ws[par, w + 13] += a12
    ws[par, w + 14] += a22
    ws[par, w + 3] += b00
    ws[par, w + 4] += b01
    ws[par, w + 5] += b02
    ws[par, w + 9] += b10
    ws[par, w + 10] += b11
    ws[par, w + 11] += b12
    ws[par, w + 15] += b20
    ws[par, w + 16] += b21
    ws[par, w + 17] += b22
    ws[par, w + 18] += b00
    ws[par, w + 19] += b10
    ws[par, w + 20] += b20
    ws[par, w + 24] += b01
    ws[par, w + 25] += b11
    ws[par, w + 26] += b21
    ws[par, w + 30] += b02
    ws[par, w + 31] += b12
    ws[par, w + 32] += b22
    ws[par, w + 21] += c00
    ws[par, w + 22] += c01
    ws[par, w + 23] += c02
    ws[par, w + 27] += c01
    ws[par, w + 28] += c11
    ws[par, w + 29] += c12
    ws[par, w + 33] += c02
    ws[par, w + 34] += c12
    ws[par, w + 35] += c22
    # the force: f' = E f, n' = E n + r x f'
    x0, x1, x2 = ws[i, W_PA], ws[i, W_PA + 1], ws[i, W_PA + 2]
    f0, f1, f2 = e00 * x0 + e01 * x1 + e02 * x2, e10 * x0 + e11 * x1 + e12 * x2, e20 * x0 + e21 * x1 + e22 * x2
    x0, x1, x2 = ws[i, W_PA + 3], ws[i, W_PA + 4], ws[i, W_PA + 5]
    ws[par, W_PA] += f0
    ws[par, W_PA + 1] += f1
    ws[par, W_PA + 2] += f2
    ws[par, W_PA + 3] += e00 * x0 + e01 * x1 + e02 * x2 + r1 * f2 - r2 * f1
    ws[par, W_PA + 4] += e10 * x0 + e11 * x1 + e12 * x2 + r2 * f0 - r0 * f2
    ws[par, W_PA + 5] += e20 * x0 + e21 * x1 + e22 * x2 + r0 * f1 - r1 * f0
    b = W_FD
    ws[i, b], ws[i, b + 1], ws[i, b + 2], ws[i, b + 3], ws[i, b + 4], ws[i, b + 5] = e00, e01, e02, e10, e11, e12
    ws[i, b + 6], ws[i, b + 7], ws[i, b + 8], ws[i, b + 9], ws[i, b + 10], ws[i, b + 11] = e20, e21, e22, r0, r1, r2


@njit_inline
def parent_acceleration_local(ws, i, par):  # type: ignore[no-untyped-def]
    """The parent's ``W_A`` (its axes, at its origin) at row i's origin, in row i's axes: E^T [a + alpha x r; alpha].

    E and r as pass 2 left them in row i's ``W_FD`` (:func:`pass_to_parent_local`).
    """
    b = W_FD
    e00, e01, e02, e10, e11, e12 = ws[i, b], ws[i, b + 1], ws[i, b + 2], ws[i, b + 3], ws[i, b + 4], ws[i, b + 5]
    e20, e21, e22, r0, r1, r2 = ws[i, b + 6], ws[i, b + 7], ws[i, b + 8], ws[i, b + 9], ws[i, b + 10], ws[i, b + 11]
    a3, a4, a5 = ws[par, W_A + 3], ws[par, W_A + 4], ws[par, W_A + 5]
    b0 = ws[par, W_A] + a4 * r2 - a5 * r1
    b1 = ws[par, W_A + 1] + a5 * r0 - a3 * r2
    b2 = ws[par, W_A + 2] + a3 * r1 - a4 * r0
    return (
        e00 * b0 + e10 * b1 + e20 * b2,
        e01 * b0 + e11 * b1 + e21 * b2,
        e02 * b0 + e12 * b1 + e22 * b2,
        e00 * a3 + e10 * a4 + e20 * a5,
        e01 * a3 + e11 * a4 + e21 * a5,
        e02 * a3 + e12 * a4 + e22 * a5,
    )


@njit_inline
def root_gravity_local(ws, i, grav):  # type: ignore[no-untyped-def]
    """A root's -g [m/s^2] in its joint's own axes: -R_i^T g, the linear part of a_0 = (-g, 0) there."""
    return (
        -(ws[i, W_ROT] * grav[0] + ws[i, W_ROT + 3] * grav[1] + ws[i, W_ROT + 6] * grav[2]),
        -(ws[i, W_ROT + 1] * grav[0] + ws[i, W_ROT + 4] * grav[1] + ws[i, W_ROT + 7] * grav[2]),
        -(ws[i, W_ROT + 2] * grav[0] + ws[i, W_ROT + 5] * grav[1] + ws[i, W_ROT + 8] * grav[2]),
    )


@njit_inline
def _offset(ws, i, par):  # type: ignore[no-untyped-def]
    """O_i - o_parent [m] in world: from the parent's origin to row i's (both in ``W_POS``)."""
    return (
        ws[i, W_POS] - ws[par, W_POS],
        ws[i, W_POS + 1] - ws[par, W_POS + 1],
        ws[i, W_POS + 2] - ws[par, W_POS + 2],
    )
