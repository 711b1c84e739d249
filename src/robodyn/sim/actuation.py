"""Actuation: the commanded torque (none, constant or a controller callable), clamped at the joints' efforts.

The torque source is validated against the robot's actuated joints (a passive joint gets
none). The commanded torque is then clamped entry by entry at the URDF ``effort`` limit of
its joint, |tau_i| <= effort_i; an effort of 0 (or none) means "no limit declared", not "no
torque" (a passive joint is refused torque by the passive check, not by a zero effort).
The clamped torque is the one applied, recorded and booked as input work.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn.errors import InputError

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]
TorqueFn = Callable[[float, Array, Array], ArrayLike]

# A torque on a passive joint is refused when its magnitude exceeds this [N m | N]; exact
# zeros are what a well-formed controller returns there.
PASSIVE_TORQUE_TOL = 0.0


@dataclass(frozen=True)
class TorqueSource:
    """The input torque: none, a constant vector, or a callable tau(t, q, v).

    ``constant`` is the full (nv,) vector for a constant input (zeros for none); ``fn`` the
    callable, whose result may have nv entries or one per actuated joint.
    """

    kind: str  # "none" | "constant" | "callable"
    constant: Array
    fn: TorqueFn | None = None

    def describe(self) -> str:
        """One line for the metadata: 'none', the vector, or the callable's name."""
        if self.kind == "callable":
            return f"callable {getattr(self.fn, '__qualname__', type(self.fn).__name__)}"
        if self.kind == "constant":
            return "constant " + np.array2string(self.constant, separator=",")
        return "none"


def torque_source(robot: Robot, torque: ArrayLike | TorqueFn | None) -> TorqueSource:
    """Validate ``torque`` against ``robot``'s actuated joints.

    Args:
        robot: the robot.
        torque: None, a vector with nv entries or one per actuated joint [N m | N], or a
            callable tau(t [s], q (nq,), v (nv,)) returning either size.

    Raises:
        InputError: wrong length, non-finite values, or a torque on a passive joint.
    """
    nv = robot.nv
    if torque is None:
        return TorqueSource("none", np.zeros(nv))
    if callable(torque):
        return TorqueSource("callable", np.zeros(nv), torque)
    tau = expand_torque(robot, torque, where="torque")
    if not np.any(tau):
        return TorqueSource("none", np.zeros(nv))
    return TorqueSource("constant", tau)


def expand_torque(robot: Robot, value: ArrayLike, *, where: str) -> Array:
    """``value`` as a full (nv,) torque; one entry per actuated joint is spread over them."""
    mask = robot.actuated
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"{where} must be a vector of numbers, got {value!r}") from None
    n_act = int(mask.sum())
    if arr.size == robot.nv:
        tau = arr.copy()
    elif arr.size == n_act:
        tau = np.zeros(robot.nv)
        tau[mask] = arr
    else:
        sizes = f"{robot.nv} (one per velocity)" + (
            f" or {n_act} (one per actuated joint)" if n_act != robot.nv else ""
        )
        raise InputError(f"{where} must have {sizes} entries for {robot.name}, got {arr.size}")
    if not np.all(np.isfinite(tau)):
        raise InputError(f"{where} must be finite, got {tau}")
    check_passive(robot, tau, where=where)
    return tau


def check_passive(robot: Robot, tau: Array, *, where: str) -> None:
    """Raise :class:`InputError` if ``tau`` pushes on a joint that has no actuator."""
    for j in robot.joints:
        if not j.actuated:
            value = tau[j.idx_v : j.idx_v + j.nv]
            if np.any(np.abs(value) > PASSIVE_TORQUE_TOL):
                raise InputError(
                    f"{where} applies {np.array2string(value, precision=6)} to joint {j.name!r} of {robot.name}, "
                    f"which is passive (no actuator); actuated joints: "
                    f"{', '.join(x.name for x in robot.joints if x.actuated) or 'none'}"
                )


@dataclass(frozen=True, eq=False)
class EffortLimits:
    """|tau_i| <= effort_i on the velocity indices ``index``; every other entry passes unclamped.

    A non-finite command (a controller's inf or NaN) is passed on, not clamped: the run then
    stops on a non-finite state and blames the torque callable, instead of hiding the bug.
    """

    index: NDArray[np.intp]
    effort: Array

    @property
    def empty(self) -> bool:
        """True when no entry is clamped."""
        return self.index.size == 0

    def clamp(self, tau: Array) -> Array:
        """``tau`` (nv,) with the limited entries clipped to [-effort, effort] (a new array)."""
        if self.index.size == 0:
            return tau
        out = tau.copy()
        x = tau[self.index]
        out[self.index] = np.where(np.isfinite(x), np.clip(x, -self.effort, self.effort), x)
        return out

    def clamp_batch(self, tau: Array) -> Array:
        """A batch of torques (n, nv) with the limited entries clipped (a new array)."""
        out = tau.copy()
        if self.index.size:
            x = tau[:, self.index]
            out[:, self.index] = np.where(np.isfinite(x), np.clip(x, -self.effort, self.effort), x)
        return out

    def clamped(self, tau: Array) -> NDArray[np.bool_]:
        """For a batch of commanded torques (n, nv): True where some entry exceeds its effort."""
        if self.index.size == 0:
            return np.zeros(tau.shape[0], dtype=bool)
        return np.any(np.abs(tau[:, self.index]) > self.effort, axis=1)

    def describe(self, names: list[str]) -> dict[str, float]:
        """Velocity name -> effort [N m | N] of every clamped entry."""
        return {names[i]: float(e) for i, e in zip(self.index, self.effort, strict=True)}


def effort_limits(robot: Robot, *, enabled: bool = True) -> EffortLimits:
    """The URDF efforts of ``robot``'s actuated joints; an effort of 0 or inf declares no limit."""
    effort = np.asarray(robot.model.effortLimit, dtype=np.float64).reshape(-1)
    if not enabled or effort.size != robot.nv:
        return EffortLimits(np.zeros(0, dtype=np.intp), np.zeros(0))
    limited = robot.actuated & np.isfinite(effort) & (effort > 0)
    index = np.flatnonzero(limited).astype(np.intp)
    return EffortLimits(index, effort[index].copy())
