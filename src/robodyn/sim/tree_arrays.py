"""The compiled tree path's model: a Pinocchio model's tree read into the kernels' arrays.

:func:`extract` reads ``robot.model``'s data (parents, joint types and axes, joint placements,
inertias, armature, gravity) into a :class:`TreeModel` of three arrays in the layout of
:mod:`robodyn.engine.tree.layout`; it calls no Pinocchio algorithm. :func:`unsupported` says
which trees it cannot read. :mod:`robodyn.sim.tree` compiles and checks the kernels over them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.engine.tree.layout import (
    CONTINUOUS,
    F_ARM6,
    F_ARMATURE,
    F_AXIS,
    F_INERTIA,
    F_K,
    F_LEVER,
    F_LOCAL,
    F_MASS,
    F_N,
    F_POS,
    F_RA,
    F_ROT,
    F_TOTAL,
    FCOLS,
    FREEFLYER,
    PRISMATIC,
    REVOLUTE,
    flyer_of,
)
from robodyn.errors import AssumptionError

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

# Joint types of the kernels (tree_layout), by Pinocchio's shortname; a free flyer has no axis.
_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
_TYPES: dict[str, tuple[int, tuple[float, float, float] | None]] = {
    **{f"JointModelR{a}": (REVOLUTE, _AXES[a]) for a in "XYZ"},
    **{f"JointModelP{a}": (PRISMATIC, _AXES[a]) for a in "XYZ"},
    **{f"JointModelRUB{a}": (CONTINUOUS, _AXES[a]) for a in "XYZ"},
    "JointModelRevoluteUnaligned": (REVOLUTE, None),
    "JointModelPrismaticUnaligned": (PRISMATIC, None),
    "JointModelRevoluteUnboundedUnaligned": (CONTINUOUS, None),
    "JointModelFreeFlyer": (FREEFLYER, (0.0, 0.0, 0.0)),
}


@dataclass(frozen=True, eq=False)
class TreeModel:
    """A kinematic tree as arrays: ``itree`` (n, 4) int64, ``ftree`` (n, 58) float64, ``grav`` (3,) [m/s^2].

    Row i of ``itree``: parent row (-1 for the world), type (0 revolute, 1 prismatic, 2
    continuous, 3 free flyer), index in q, index in v. Row i of ``ftree``: unit joint axis (3),
    the joint placement in its parent's frame (rotation row-major (9), translation [m] (3)),
    mass [kg], lever (centre of mass in the joint frame) [m] (3), rotational inertia about the
    centre of mass [kg m^2] (9), armature [kg m^2 | kg], and from the placement R_p and the
    axis a: R_p [a]x (9), (R_p a) a^T (9) and R_p a (3), the terms of Rodrigues' formula the
    kernels turn the joint with; then a free flyer's six armatures [kg | kg m^2] (6) and its
    mass with every body below it [kg] (the whole tree: a free flyer is its root); last, the
    same on every row, 1 where the compiled ABA's passes 2 and 3 work in each joint's own axes,
    0 (as :func:`extract` leaves it) in world axes: a choice, not read from the model. A free
    flyer's row has no axis (zeros in the axis and Rodrigues columns) and armature 0 in the
    one-coordinate column.
    """

    name: str
    nq: int
    nv: int
    itree: NDArray[np.int64]
    ftree: Array
    grav: Array

    @property
    def flyer(self) -> bool | None:
        """The kernels' ``flyer`` argument: True when the root row is a free flyer, else None.

        With None the kernels compile no free-flyer code (:mod:`robodyn.engine.tree.algorithms`).
        """
        return flyer_of(self.itree)

    @property
    def local(self) -> bool:
        """Whether the compiled ABA's passes 2 and 3 work in each joint's own axes (else in world axes)."""
        return self.itree.shape[0] > 0 and bool(self.ftree[0, F_LOCAL])

    def with_local_passes(self) -> TreeModel:
        """This tree with the compiled ABA's passes 2 and 3 in each joint's own axes (``F_LOCAL`` set)."""
        ftree = self.ftree.copy()
        ftree[:, F_LOCAL] = 1.0
        return replace(self, ftree=ftree)

    def same_as(self, other: TreeModel) -> bool:
        """True when both hold the same numbers read from the model (a model edited since is not).

        The choice of the ABA's passes (``F_LOCAL``) is not read from the model: it is left out.
        """
        read = np.arange(FCOLS) != F_LOCAL
        return (
            self.nq == other.nq
            and np.array_equal(self.itree, other.itree)
            and np.array_equal(self.ftree[:, read], other.ftree[:, read])
            and np.array_equal(self.grav, other.grav)
        )


def unsupported(robot: Robot) -> str | None:
    """Why the compiled tree path cannot serve ``robot``, or None when it can."""
    parents = robot.model.parents
    for index, j in enumerate(robot.joints, start=1):
        if j.kind not in _TYPES:
            return (
                f"joint {j.name!r} is a {j.kind}; the compiled path takes revolute, prismatic and continuous "
                "joints, and a free flyer at the root"
            )
        if _TYPES[j.kind][0] == FREEFLYER:
            others = [k.name for n, k in enumerate(robot.joints, start=1) if n != index and int(parents[n]) == 0]
            if int(parents[index]) != 0 or others:
                where = (
                    f"below joint {robot.joints[int(parents[index]) - 1].name!r}"
                    if int(parents[index]) != 0
                    else f"beside the root joint {others[0]!r}"
                )
                return (
                    f"joint {j.name!r} is a free flyer {where}; the compiled path takes a free flyer only as "
                    "the root of the whole tree (parent: the world, every other joint below it)"
                )
    if robot.nv == 0:
        return "the model has no degree of freedom"
    return None


def _unaligned_axis(joint: Any) -> NDArray[np.float64]:
    """The unit axis of an unaligned joint, read from its motion subspace S at the neutral q.

    Pinocchio's binding of ``JointModelRevoluteUnboundedUnaligned`` has no ``axis`` (the
    aligned-free revolute and prismatic ones do), while S holds the axis for all three: the
    angular rows of a revolute joint, the linear rows of a prismatic one.
    """
    inner = joint.extract()
    if hasattr(inner, "axis"):
        return np.asarray(inner.axis, dtype=np.float64)
    data = joint.createData()
    q = np.zeros(joint.nq)
    q[0] = 1.0  # cos = 1, sin = 0: the neutral configuration of a continuous joint
    joint.calc(data, q)
    S = np.asarray(data.S, dtype=np.float64).reshape(6)
    return S[3:6] if np.linalg.norm(S[3:6]) > 0 else S[0:3]


def extract(robot: Robot) -> TreeModel:
    """Read ``robot.model``'s tree into arrays (no Pinocchio algorithm is called).

    Raises:
        AssumptionError: a joint the compiled path does not take (see :func:`unsupported`).
    """
    reason = unsupported(robot)
    if reason is not None:
        raise AssumptionError(f"{robot.name}: {reason}")
    model = robot.model
    n = model.njoints - 1
    itree = np.zeros((n, 4), dtype=np.int64)
    ftree = np.zeros((n, FCOLS))
    armature = np.asarray(model.armature, dtype=np.float64)
    for i in range(n):
        j = i + 1
        joint = model.joints[j]
        code, aligned = _TYPES[joint.shortname()]
        axis = np.asarray(aligned if aligned is not None else _unaligned_axis(joint), dtype=np.float64)
        placement = model.jointPlacements[j]
        inertia = model.inertias[j]
        itree[i] = (int(model.parents[j]) - 1, code, int(joint.idx_q), int(joint.idx_v))
        ftree[i, F_AXIS : F_AXIS + 3] = axis
        ftree[i, F_ROT : F_ROT + 9] = np.asarray(placement.rotation, dtype=np.float64).reshape(9)
        ftree[i, F_POS : F_POS + 3] = np.asarray(placement.translation, dtype=np.float64)
        ftree[i, F_MASS] = float(inertia.mass)
        ftree[i, F_LEVER : F_LEVER + 3] = np.asarray(inertia.lever, dtype=np.float64)
        ftree[i, F_INERTIA : F_INERTIA + 9] = np.asarray(inertia.inertia, dtype=np.float64).reshape(9)
        if code == FREEFLYER:
            ftree[i, F_ARM6 : F_ARM6 + 6] = armature[int(joint.idx_v) : int(joint.idx_v) + 6]
            ftree[i, F_TOTAL] = sum(float(model.inertias[k].mass) for k in range(j, model.njoints))
        else:
            ftree[i, F_ARMATURE] = armature[int(joint.idx_v)]
        # products of the placement with the axis (Rodrigues' formula of the joint's rotation)
        rot = ftree[i, F_ROT : F_ROT + 9].reshape(3, 3)
        cross = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
        ftree[i, F_K : F_K + 9] = (rot @ cross).reshape(9)
        ftree[i, F_N : F_N + 9] = np.outer(rot @ axis, axis).reshape(9)
        ftree[i, F_RA : F_RA + 3] = rot @ axis
    grav = np.asarray(model.gravity.linear, dtype=np.float64).copy()
    return TreeModel(robot.name, int(model.nq), int(model.nv), itree, ftree, grav)


def one_joint(flyer: bool = False) -> TreeModel:
    """A one-joint tree (a unit revolute about z), to load or compile the kernels with.

    With ``flyer``, the joint hangs below a free-flyer root (unit mass and inertia): the kernels'
    free-flyer variant.
    """
    rows = 2 if flyer else 1
    itree = np.array([[-1, FREEFLYER, 0, 0], [0, REVOLUTE, 7, 6]] if flyer else [[-1, REVOLUTE, 0, 0]], dtype=np.int64)
    ftree = np.zeros((rows, FCOLS))
    ftree[:, [F_ROT, F_ROT + 4, F_ROT + 8, F_MASS, F_INERTIA, F_INERTIA + 4, F_INERTIA + 8]] = 1.0
    ftree[-1, [F_AXIS + 2, F_RA + 2]] = 1.0  # the revolute's axis z; R_p = 1, so R_p a = a
    ftree[-1, F_K + 1], ftree[-1, F_K + 3], ftree[-1, F_N + 8] = -1.0, 1.0, 1.0  # R_p [z]x and (R_p z) z^T
    if flyer:
        ftree[0, F_TOTAL] = 2.0
    nq, nv = (8, 7) if flyer else (1, 1)
    return TreeModel("one joint", nq, nv, itree, ftree, np.array([0.0, 0.0, -9.81]))
