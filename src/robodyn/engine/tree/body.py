"""One body's world-frame inertia, bias force and energies, for the compiled tree kernels.

Shared by the kernels' pass 1 (:mod:`robodyn.engine.tree.algorithms`) and the free-flyer root
(:mod:`robodyn.engine.tree.flyer`); inlined into both in numba's IR (an LLVM call there cost the
Panda's pass 1 40 %, measured).
"""

from __future__ import annotations

from robodyn.engine import jit
from robodyn.engine.tree.layout import (
    F_INERTIA,
    F_LEVER,
    F_MASS,
    W_IA,
    W_PA,
)

njit_inline = jit.njit(nogil=True, error_model="numpy", inline="always")


@njit_inline
def body(ftree, grav, ws, i, r00, r01, r02, r10, r11, r12, r20, r21, r22, ox, oy, oz, l0, l1, l2, g0, g1, g2):  # type: ignore[no-untyped-def]
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
