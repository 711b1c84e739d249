"""The array layout the compiled tree kernels share: joint types, ``ftree`` and workspace columns.

Plain constants, without numba, so that :mod:`robodyn.sim.tree` can build the arrays without
loading the kernels. ``itree`` (n, 4) int64 rows: parent row (-1 for the world), joint type,
index in q, index in v. ``ftree`` (n, FCOLS) float64 rows: the ``F_*`` columns. The workspace
``ws`` (n, WCOLS) float64, one row per joint: the ``W_*`` columns, filled by the kernels (but
``W_LOCK``, which the caller sets to lock a joint held at a stop).
"""

from __future__ import annotations

from typing import Any

REVOLUTE, PRISMATIC, CONTINUOUS, FREEFLYER = 0, 1, 2, 3

# ftree columns
F_AXIS, F_ROT, F_POS, F_MASS, F_LEVER, F_INERTIA, F_ARMATURE = 0, 3, 12, 15, 16, 19, 28
F_K, F_N, F_RA = 29, 38, 47
F_ARM6 = 50  # a free flyer's six armatures [kg | kg m^2], zero on other rows
F_TOTAL = 56  # a free flyer's mass with all the bodies below it [kg], zero on other rows
# the model's choice of ABA passes 2 and 3, the same on every row: 0 in world axes, 1 in each joint's
# own axes (robodyn.engine.tree.local; robodyn.sim.tree.compiled_of sets it where world axes fail the check)
F_LOCAL = 57
FCOLS = 58

# workspace columns, one row per joint
W_ROT, W_POS, W_S, W_V, W_C, W_IA, W_PA, W_U, W_D, W_UU, W_A = 0, 9, 12, 18, 24, 30, 66, 72, 78, 79, 80
W_LOCK, W_LAMBDA = 86, 87
W_FD, W_FY, W_FB = 88, 124, 130  # a free flyer's 6 x 6 D (then its Cholesky factor), two 6-vectors
W_REF = 136  # a free flyer's position in world [m]: the point every world-frame vector is taken at
WCOLS = 139


def flyer_of(itree: Any) -> bool | None:
    """The kernels' ``flyer`` argument for ``itree`` (n, 4): True when its root row is a free flyer, else None.

    With None the kernels compile no free-flyer code (:mod:`robodyn.engine.tree.algorithms`).
    """
    return True if itree.shape[0] > 0 and int(itree[0, 1]) == FREEFLYER else None
