"""Couplings: q_follower = ratio * q_leader + offset, as Pinocchio mimic joints.

Rolling without slipping (x = R phi) and gear trains (theta_m = n theta_l) are holonomic
couplings of two joints. :func:`couple` turns each follower into a mimic joint of its leader
(:func:`robodyn.constrained.couple`), so the follower leaves q and v and the coupled robot has
one coordinate per leader; its forward dynamics is CRBA (ABA refuses mimic joints). A chain
(a follows b follows c) is composed into one coupling on c; a cycle is refused when the spec
is built (:class:`robodyn.sim.constraints.Constraints`).

What the user gives in the uncoupled coordinates is mapped through the coupling's Jacobian
G = dq_full / dq_coupled: a torque on a follower acts on its leader through the coupling,
tau_coupled = G^T tau (virtual work: tau_f dq_f = tau_f ratio dq_l); a full q0 or v0 must
satisfy the coupling (its followers are then dropped). A follower's stops become stops of its
leader: [(lower - offset) / ratio, (upper - offset) / ratio], met with the leader's own.
A URDF ``<mimic>`` tag is a coupling too: ``robodyn.load(..., mimic=True)`` builds the same model.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import constrained
from robodyn.errors import InputError, UnknownNameError
from robodyn.robot import Robot

if TYPE_CHECKING:
    from robodyn.sim.constraints import Coupling

Array = NDArray[np.float64]

# A full q0 (or v0) satisfies a coupling when |q_f - (ratio q_l + offset)| is below this
# [rad | m | rad/s | m/s]: a value written with ~12 significant digits.
CONSISTENCY_TOL = 1e-9


@dataclass(frozen=True, eq=False)
class CouplingMap:
    """The uncoupled robot, the coupled one, and G = dq_full / dq_coupled (nv_full, nv_coupled).

    ``followers`` maps each follower to (leader, ratio, offset) with chains composed.
    """

    full: Robot
    coupled: Robot
    followers: dict[str, tuple[str, float, float]]
    G: Array

    def torque(self, tau: Array) -> Array:
        """A full (nv_full,) torque as the coupled robot's (nv_coupled,): G^T tau [N m | N]."""
        return self.G.T @ tau

    def state(self, q0: ArrayLike, v0: ArrayLike) -> tuple[ArrayLike, ArrayLike, bool]:
        """(q0, v0) in the coupled coordinates when given in the full ones (checked), else as given.

        Returns the pair and whether it was mapped.

        Raises:
            InputError: a full q0 or v0 whose follower breaks its coupling (by how much).
        """
        full, coupled = self.full, self.coupled
        q = np.asarray(q0, dtype=np.float64).reshape(-1) if not callable(q0) else None
        if q is None or q.size != full.nq or full.nq == coupled.nq:
            return q0, v0, False
        v = np.asarray(v0, dtype=np.float64).reshape(-1)
        if v.size != full.nv:
            raise InputError(f"v0 must have {full.nv} entries (like q0, the uncoupled coordinates), got {v.size}")
        for name, (leader, ratio, offset) in self.followers.items():
            jf, jl = full.joint(name), full.joint(leader)
            for what, x, idx_f, idx_l, shift in (
                ("q0", q, jf.idx_q, jl.idx_q, offset),
                ("v0", v, jf.idx_v, jl.idx_v, 0),
            ):
                off = float(x[idx_f] - (ratio * x[idx_l] + shift))
                if abs(off) > CONSISTENCY_TOL:
                    raise InputError(
                        f"{what}: joint {name!r} = {x[idx_f]:.10g} breaks its coupling {name} = {ratio:g} * {leader} "
                        f"+ {shift:g} by {off:.3g}; give the leader's value only ({coupled.nq} coordinates)"
                    )
        keep_q = np.concatenate(
            [np.arange(j.idx_q, j.idx_q + j.nq) for j in full.joints if j.name not in self.followers]
        )
        keep_v = np.concatenate(
            [np.arange(j.idx_v, j.idx_v + j.nv) for j in full.joints if j.name not in self.followers]
        )
        return q[keep_q.astype(np.intp)], v[keep_v.astype(np.intp)], True

    def describe(self) -> list[str]:
        """One line per coupling: ``spin = 3.03 * slide + 0``."""
        return [f"{f} = {r:g} * {lead} + {o:g}" for f, (lead, r, o) in self.followers.items()]


def _compose(couplings: tuple[Coupling, ...]) -> dict[str, tuple[str, float, float]]:
    """Follower -> (root leader, ratio, offset), chains composed.

    a = r1 b + o1 and b = r2 c + o2 give a = r1 r2 c + (r1 o2 + o1).
    """
    direct = {c.joint: (c.leader, float(c.ratio), float(c.offset)) for c in couplings}
    out = {}
    for follower in direct:
        leader, ratio, offset = direct[follower]
        while leader in direct:  # no cycle: Constraints refused them
            nxt, r2, o2 = direct[leader]
            leader, ratio, offset = nxt, ratio * r2, ratio * o2 + offset
        out[follower] = (leader, ratio, offset)
    return out


def _refuse_follower_first(
    robot: Robot, couplings: tuple[Coupling, ...], followers: dict[str, tuple[str, float, float]]
) -> None:
    """Refuse a follower that comes before its (root) leader in Pinocchio's joint order.

    Pinocchio's mimic joints need the leader first; the same constraint written the other way
    round, q_leader = (q_joint - offset) / ratio, is what to give instead.
    """
    order = robot.model.getJointId
    for c in couplings:
        leader = followers[c.joint][0]
        if int(order(c.joint)) < int(order(leader)):
            ratio, offset = float(c.ratio), float(c.offset)
            swapped = {
                "joint": c.leader,
                "leader": c.joint,
                "ratio": 1.0 / ratio,
                "offset": -offset / ratio + 0.0,
            }  # no -0.0
            raise InputError(
                f"coupling {c.joint!r} -> {c.leader!r}: the follower {c.joint!r} comes before its leader "
                f"{leader!r} in the tree, and a follower must come after its leader; write it the other way round: "
                f"{json.dumps(swapped)}"
            )


def couple(robot: Robot, couplings: tuple[Coupling, ...]) -> CouplingMap | None:
    """The coupled robot of ``robot`` (None when there are no couplings).

    Raises:
        UnknownNameError: a joint or leader the robot does not have (with close matches).
        InputError: a joint already coupled (a mimic joint), a follower whose configuration
            size differs from its leader's, or a follower that comes before its leader in the tree.
    """
    if not couplings:
        return None
    names = robot.joint_names
    movable = [j.name for j in robot.joints if j.nv > 0]
    for i, c in enumerate(couplings):
        for key, name in (("joint", c.joint), ("leader", c.leader)):
            if name not in names:
                raise UnknownNameError(f"joint (couplings[{i}].{key})", name, movable)
            if robot.joint(name).nv == 0:
                raise InputError(f"couplings[{i}]: joint {name!r} is already a mimic joint (coupled in the URDF)")
    followers = _compose(couplings)
    _refuse_follower_first(robot, couplings, followers)
    model = robot.model
    lower = np.array(model.lowerPositionLimit, dtype=np.float64)
    upper = np.array(model.upperPositionLimit, dtype=np.float64)
    bounds: dict[str, tuple[float, float]] = {}
    for name, (leader, ratio, offset) in followers.items():
        jf, jl = robot.joint(name), robot.joint(leader)
        if (jf.nq, jf.nv) != (jl.nq, jl.nv) or jf.nv != 1:
            raise InputError(
                f"coupling {name!r} -> {leader!r}: both joints need one coordinate (got nq={jf.nq} and nq={jl.nq}); "
                "a continuous joint cannot be coupled"
            )
        lo, hi = sorted(((lower[jf.idx_q] - offset) / ratio, (upper[jf.idx_q] - offset) / ratio))
        old = bounds.get(leader, (lower[jl.idx_q], upper[jl.idx_q]))
        bounds[leader] = (max(old[0], lo), min(old[1], hi))
    for name, (leader, ratio, offset) in followers.items():
        model = constrained.couple(
            model, int(robot.model.getJointId(leader)), int(robot.model.getJointId(name)), ratio, offset
        )
    lower_c = np.array(model.lowerPositionLimit, dtype=np.float64)
    upper_c = np.array(model.upperPositionLimit, dtype=np.float64)
    for leader, (lo, hi) in bounds.items():
        j = model.joints[int(model.getJointId(leader))]
        lower_c[j.idx_q], upper_c[j.idx_q] = lo, hi
    model.lowerPositionLimit, model.upperPositionLimit = lower_c, upper_c
    coupled = Robot.from_model(
        model,
        name=robot.name,
        urdf_path=robot.urdf_path,
        srdf_path=robot.srdf_path,
        passive_joints=robot.passive_joints,
    )
    G = np.zeros((robot.nv, coupled.nv))
    for j in robot.joints:
        if j.nv == 0:
            continue
        if j.name in followers:
            leader, ratio, _ = followers[j.name]
            G[j.idx_v, coupled.joint(leader).idx_v] = ratio
        else:
            G[j.idx_v, coupled.joint(j.name).idx_v] = 1.0
    return CouplingMap(robot, coupled, followers, G)
