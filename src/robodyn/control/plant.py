"""What a controller knows about its robot: the upright and hanging states, wrapped errors, the limits.

The built-in kinds' conventions (see :mod:`robodyn.kinds.cart_pole` and :mod:`robodyn.kinds.pendubot`):

* cart-pole, q = (y [m], theta [rad]) with theta from the upward vertical: upright q = (0, 0),
  hanging q = (0, pi);
* Pendubot, q = (q1, q2) [rad] with q1 from the horizontal and q2 relative to link 1: upright
  q = (pi/2, 0), hanging q = (-pi/2, 0).

State errors x - x_eq wrap every revolute coordinate to [-pi, pi), so "upright" means upright
whatever the number of turns. The limits are read from the model: the effort limit of each
actuated joint (``model.effortLimit``; a URDF's effort="0", or no limit, reads as unlimited) and,
for an actuated prismatic joint with finite position limits (the cart's rail), the usable interval:
the limits less ``RAIL_MARGIN`` of the half-length at each end.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn.errors import InputError
from robodyn.kinds import catalog, params
from robodyn.robot import Robot

Array = NDArray[np.float64]

# The cart keeps this fraction of the rail's half-length clear of each end (0.2 m on a +-2 m rail):
# room to brake from the speeds the swing-up reaches, before the simulator's rail stop.
RAIL_MARGIN = 0.1


def controlled_kinds() -> tuple[str, ...]:
    """The built-in kinds a controller knows the upright and hanging states of (those with a ``Balance``)."""
    return tuple(kind.name for kind in catalog.kinds() if kind.balance is not None)


@dataclass(frozen=True, eq=False)
class Plant:
    """A robot as a controller sees it.

    ``kind`` is the built-in kind or None; ``angular`` (nq,) marks the revolute coordinates whose
    errors wrap; ``effort`` (n_act,) the effort limits [N m | N] (inf: none); ``rail`` the usable
    interval [m] of the actuated prismatic joint ``rail_index`` (into q), margin taken off, or None;
    ``rests`` the (upright, hanging) configurations of a built-in kind, read from the model's potential
    energy (:func:`rests`), or None.
    """

    robot: Robot
    kind: str | None
    angular: NDArray[np.bool_]
    effort: Array
    rail: tuple[float, float] | None
    rail_index: int | None
    rests: tuple[Array, Array] | None = None

    @property
    def n(self) -> int:
        """Degrees of freedom (nq == nv)."""
        return self.robot.nv

    @property
    def n_act(self) -> int:
        """Number of actuated joints (the columns of B)."""
        return int(self.effort.size)

    def upright(self) -> Array:
        """The upright configuration (nq,) of a built-in kind; InputError for other robots."""
        return self._seed_state("upright")

    def hanging(self) -> Array:
        """The hanging configuration (nq,) of a built-in kind (its stable rest); InputError for other robots."""
        return self._seed_state("hanging")

    def _seed_state(self, what: str) -> Array:
        if self.rests is None:
            raise InputError(
                f"{self.robot.name} is none of {', '.join(controlled_kinds())}: it has no known {what} state; "
                "give the equilibrium q_eq"
            )
        return (self.rests[0] if what == "upright" else self.rests[1]).copy()

    def error(self, q: ArrayLike, v: ArrayLike, q_eq: Array) -> Array:
        """The state error e = x - x_eq = [q - q_eq (revolute entries wrapped to [-pi, pi)), v].

        Shape (2n,), or (m, 2n) for a batch.
        """
        q_, v_ = np.asarray(q, dtype=np.float64), np.asarray(v, dtype=np.float64)
        dq = q_ - q_eq
        dq = np.where(self.angular, wrap(dq), dq)
        return np.concatenate([dq, v_], axis=-1)

    def saturate(self, u: Array) -> Array:
        """``u`` (n_act,) or (m, n_act) clipped to the effort limits."""
        return np.clip(u, -self.effort, self.effort)


def _not_plain(robot: Robot) -> str:
    """Which joints of ``robot`` have more coordinates than velocities, and what would give them one."""
    continuous = [j.name for j in robot.joints if j.nq == 2 and j.nv == 1]
    other = [f"{j.name} ({j.nq} coordinates)" for j in robot.joints if j.nq != j.nv and j.name not in continuous]
    said = []
    if continuous:
        said.append(
            f"{', '.join(continuous)} {'is' if len(continuous) == 1 else 'are'} continuous (cos, sin): declare "
            f'{"it" if len(continuous) == 1 else "them"} type="revolute" with wide limits '
            '(<limit lower="-1000" upper="1000" .../>) in the URDF'
        )
    if other:
        verb = "holds" if len(other) == 1 else "hold"
        said.append(f"{', '.join(other)} {verb} a quaternion (a free-flyer or spherical joint): none is taken")
    return f"{robot.name} has nq={robot.nq}, nv={robot.nv}: " + "; ".join(said)


def wrap(angle: ArrayLike) -> Array:
    """Angles [rad] wrapped to [-pi, pi)."""
    return np.asarray((np.asarray(angle, dtype=np.float64) + np.pi) % (2.0 * np.pi) - np.pi, dtype=np.float64)


def plant(robot: Robot) -> Plant:
    """The :class:`Plant` of ``robot``; InputError if nq != nv or nothing is actuated."""
    if not robot.nq_equals_nv:
        raise InputError(f"controllers need one coordinate per joint (nq == nv); {_not_plain(robot)}")
    mask = robot.actuated
    if not np.any(mask):
        where = f"its SRDF {robot.srdf_path.name} or --passive" if robot.srdf_path is not None else "--passive"
        raise InputError(
            f"{robot.name} has no actuated joint ({', '.join(robot.passive_joints)} declared passive by {where}): "
            "there is nothing to control"
        )
    kind = params.detect_kind(robot)
    kind = kind if kind in controlled_kinds() else None
    angular = np.zeros(robot.nq, dtype=bool)
    rail: tuple[float, float] | None = None
    rail_index: int | None = None
    lower = np.array(robot.model.lowerPositionLimit, dtype=np.float64)
    upper = np.array(robot.model.upperPositionLimit, dtype=np.float64)
    for joint in robot.joints:
        if joint.kind.startswith("JointModelR"):
            angular[joint.idx_q] = True
        elif joint.kind.startswith("JointModelP") and joint.actuated and rail is None:
            lo, hi = float(lower[joint.idx_q]), float(upper[joint.idx_q])
            if np.isfinite(lo) and np.isfinite(hi) and hi > lo:
                margin = RAIL_MARGIN * 0.5 * (hi - lo)
                rail, rail_index = (lo + margin, hi - margin), joint.idx_q
    effort = np.array(robot.model.effortLimit, dtype=np.float64)[mask]
    effort = np.where(np.isfinite(effort) & (effort > 0), effort, np.inf)
    return Plant(robot, kind, angular, effort, rail, rail_index, None if kind is None else rests(robot, kind, angular))


def rests(robot: Robot, kind: str, angular: NDArray[np.bool_]) -> tuple[Array, Array]:
    """(upright, hanging) q of a robot of the built-in ``kind``: the highest and lowest potential energy.

    The kind's convention (:class:`robodyn.kinds.kind.Balance`) names them for links whose centres of
    mass lie along the link from its joint (l > 0). A URDF that puts a centre of mass on the other
    side of its joint (a cart-pole's pole hanging at q = 0, l < 0) meets the kind's assumptions with
    its rests half a turn away: each revolute coordinate of the convention's upright is tried as given
    and turned by pi, and the configurations of highest and lowest potential energy are the upright
    and the hanging rest. The convention's own values are kept wherever they are those.
    """
    balance = catalog.kind(kind).balance
    assert balance is not None  # controlled_kinds() has a Balance
    up = np.array(balance.upright, dtype=np.float64)
    down = np.array(balance.hanging, dtype=np.float64)
    turns = [np.array(t, dtype=np.float64) * np.pi for t in itertools.product((0, 1), repeat=int(angular.sum()))]
    candidates = []
    for turn in turns:
        q = up.copy()
        q[angular] = wrap(up[angular] + turn)
        candidates.append(q)
    energy = np.array([robot.potential_energy(q) for q in candidates])
    tie = 1e-9 * max(float(np.max(np.abs(energy))), 1e-300)
    top = candidates[int(np.argmax(energy))]
    bottom = candidates[int(np.argmin(energy))]
    upright = up if energy[0] >= float(np.max(energy)) - tie else top  # candidates[0] is the convention's upright
    hanging = down if robot.potential_energy(down) <= float(np.min(energy)) + tie else bottom
    return upright, hanging
