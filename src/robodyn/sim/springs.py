"""Joint springs: tau = -k (q - rest) on one-coordinate joints, and their potential k (q - rest)^2 / 2.

A spring is conservative: its torque enters the dynamics with the other passive torques,
and its energy enters the potential V, so E = T + V_gravity + V_springs and the ledger
closes without a work term of its own (textbook Eq. 19.18, V = 1/2 k theta^2).

A spring on a coupled joint (q_f = r q_l + o) is the spring k r^2 on its leader with rest
(rest - o) / r: the same energy, 1/2 k (r q_l + o - rest)^2.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import InputError, UnknownNameError

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.sim.constraints import Spring

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Springs:
    """Springs on velocity indices ``iv`` (and coordinate indices ``iq``): stiffness (n,), rest (n,).

    ``names`` are the joints the user named; a follower's spring sits on its leader's index.
    """

    names: tuple[str, ...]
    iq: NDArray[np.intp]
    iv: NDArray[np.intp]
    stiffness: Array
    rest: Array

    @property
    def empty(self) -> bool:
        """True when there is no spring (or every stiffness is 0)."""
        return not bool(np.any(self.stiffness))

    def torque(self, q: Array, nv: int) -> Array:
        """-k (q - rest) on the sprung joints, zeros elsewhere [N m | N], shape (nv,)."""
        tau = np.zeros(nv)
        np.add.at(tau, self.iv, -self.stiffness * (q[self.iq] - self.rest))  # a leader may carry two springs
        return tau

    def energy(self, Q: Array) -> Array:
        """1/2 k (q - rest)^2 summed over the springs [J], for a batch Q (n, nq) -> (n,)."""
        if self.iq.size == 0:
            return np.zeros(Q.shape[0])
        stretch = Q[:, self.iq] - self.rest
        return 0.5 * (stretch**2) @ self.stiffness

    def describe(self) -> dict[str, dict[str, float]]:
        """Joint -> {stiffness, rest}, in the simulated coordinates."""
        return {
            n: {"stiffness": float(k), "rest": float(r)}
            for n, k, r in zip(self.names, self.stiffness, self.rest, strict=True)
        }


def no_springs() -> Springs:
    """No spring at all."""
    empty = np.zeros(0, dtype=np.intp)
    return Springs((), empty, empty.copy(), np.zeros(0), np.zeros(0))


def springs_on(
    robot: Robot, springs: Mapping[str, Spring], followers: Mapping[str, tuple[str, float, float]] | None = None
) -> Springs:
    """Resolve ``springs`` (joint name -> spring) on ``robot``'s one-coordinate joints.

    ``followers`` maps a coupled joint to (leader, ratio, offset): its spring moves onto the leader.

    Raises:
        UnknownNameError: a joint the robot does not have (with close matches).
        InputError: a joint with more than one coordinate (a ``continuous`` joint, a free
            flyer...), whose angle a linear spring cannot measure.
    """
    followers = dict(followers or {})
    names = [*robot.joint_names]
    rows: list[tuple[str, str, float, float]] = []  # (name, joint, stiffness, rest) in simulated coordinates
    for name, spring in springs.items():
        k, r0 = float(spring.stiffness), float(spring.rest)
        target = name
        if name in followers:
            target, ratio, offset = followers[name]
            k, r0 = k * ratio**2, (r0 - offset) / ratio
        if target not in names:
            raise UnknownNameError("joint (springs)", name, [n for n in names if robot.joint(n).nv > 0])
        joint = robot.joint(target)
        if not (joint.nq == 1 and joint.nv == 1):
            raise InputError(
                f"springs.{name}: joint {target!r} is a {joint.kind} with nq={joint.nq}, nv={joint.nv}; "
                "a spring needs a one-coordinate joint (revolute or prismatic)"
            )
        rows.append((name, target, k, r0))
    rows.sort(key=lambda row: robot.joint(row[1]).idx_v)
    return Springs(
        names=tuple(row[0] for row in rows),
        iq=np.array([robot.joint(row[1]).idx_q for row in rows], dtype=np.intp),
        iv=np.array([robot.joint(row[1]).idx_v for row in rows], dtype=np.intp),
        stiffness=np.array([row[2] for row in rows], dtype=np.float64),
        rest=np.array([row[3] for row in rows], dtype=np.float64),
    )
