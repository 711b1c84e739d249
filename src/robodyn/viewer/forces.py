"""What acts on the robot, drawn where it acts: force and torque arrows, stop impacts, the controller's mode.

* An **arrow** on every single-DoF joint whose applied torque is not zero over the run: a
  straight arrow along a prismatic joint's axis from the joint's origin (the cart-pole's push on
  its cart), of length :data:`ARROW_FRACTION` of the framed size at the run's largest |F|; a
  curved arrow about a revolute joint's axis (a motor's torque), of radius
  :data:`TORQUE_RADIUS_FRACTION` of the framed size, sweeping :data:`MAX_SWEEP_DEG` at the run's
  largest |τ|. Both point the way the force or torque acts; the page writes the value beside it.
* An **impact** at every sample where the ledger's W_limits steps down (an inelastic hit on a
  stop): the joint at its limit there and the energy the stop took, flashed on that joint for
  :data:`IMPACT_FLASH_S` seconds of playback.
* The controller's **mode** (swing-up or LQR balance, when the run records it) written above the
  robot, in the mode chart's colour.

Positions are in the model's world frame [m], one per rendered frame; the page
(``assets/replay.js``) projects them through meshcat's camera, like the labels.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.viewer.palette import BLACK, ORANGE, REDDISH_PURPLE

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.viewer.runs import Run

Array = NDArray[np.float64]

ARROW_FRACTION = 0.45
"""A force arrow at the run's largest |F| is this fraction of the framed size long."""
TORQUE_RADIUS_FRACTION = 0.09
"""Radius of a torque's curved arrow, as a fraction of the framed size (smaller than an angle's arc)."""
MAX_SWEEP_DEG = 300.0
"""A torque's arrow sweeps this much at the run's largest |τ|: most of a turn, never a closed ring."""
ARC_POINTS = 20
"""Points of a torque's curved arrow."""
IMPACT_FLASH_S = 0.3
"""How long an impact stays drawn on its joint [s of playback]: long enough to see at real time."""
FORCE_COLOR = BLACK
"""Arrows in black with a white halo: they read on the sky and on every link colour."""
TORQUE_COLOR = BLACK
IMPACT_COLOR = ORANGE
MODE_TEXT_COLOR = REDDISH_PURPLE


@dataclass(frozen=True, eq=False)
class Arrow:
    """A joint's applied force or torque at the rendered frames.

    Attributes:
        joint: the joint's name.
        kind: "force" (prismatic, [N]) or "torque" (revolute, [N m]).
        points: the arrow's polyline (k, m, 3), world [m], ending at its head.
        values: the force [N] or torque [N m] at each rendered frame, shape (k,).
    """

    joint: str
    kind: str
    points: Array
    values: Array


@dataclass(frozen=True)
class Impact:
    """A hit on a stop: rendered frame (fractional), the joint at its limit, where it is [m], the energy taken [J]."""

    frame: float
    joint: str
    xyz: Array
    energy: float


def _perpendicular(axis: Array) -> tuple[Array, Array]:
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(axis, u)


def _arrow_points(kind: str, origin: Array, axis: Array, share: float, size: float) -> Array:
    """The polyline (ARC_POINTS, 3) of one arrow whose value is ``share`` (-1..1) of the run's largest."""
    if kind == "force":
        end = origin + share * ARROW_FRACTION * size * axis
        return np.linspace(origin, end, ARC_POINTS)
    u, w = _perpendicular(axis)
    radius = TORQUE_RADIUS_FRACTION * size
    angle = np.radians(MAX_SWEEP_DEG) * share * np.linspace(0.0, 1.0, ARC_POINTS) - np.pi / 2
    return origin + radius * (np.cos(angle)[:, None] * u + np.sin(angle)[:, None] * w)


def joint_arrows(robot: Robot, run: Run, configurations: Array, size: float) -> list[Arrow]:
    """An arrow per single-DoF joint whose torque column of ``run`` is not all zero (see the module)."""
    tau = np.asarray(getattr(run.trajectory, "tau", np.zeros((0, 0))), dtype=np.float64)
    if tau.ndim != 2 or tau.shape[1] != robot.nv or not np.all(np.isfinite(tau)):
        return []
    shown = tau[run.index]
    placements = [dynamics.joint_frames(robot.model, robot.data, qk) for qk in configurations]
    arrows: list[Arrow] = []
    for j in range(1, robot.model.njoints):
        joint = robot.model.joints[j]
        if int(joint.nv) != 1:
            continue
        column = tau[:, int(joint.idx_v)]
        largest = float(np.max(np.abs(column)))
        if largest == 0.0:
            continue
        linear = np.linalg.norm(placements[0][j - 1][1]) > 0.5
        kind = "force" if linear else "torque"
        values = shown[:, int(joint.idx_v)]
        points = np.array(
            [
                _arrow_points(kind, frames[j - 1][0][:3, 3], frames[j - 1][1 if linear else 2], v / largest, size)
                for frames, v in zip(placements, values, strict=True)
            ]
        )
        arrows.append(Arrow(str(robot.model.names[j]), kind, points, values))
    return arrows


def stop_impacts(robot: Robot, run: Run, configurations: Array) -> list[Impact]:
    """The run's hits on its stops (where W_limits steps down), each on the joint nearest its limit then."""
    work = getattr(run.trajectory, "work_limits", None)
    q = np.asarray(run.trajectory.q, dtype=np.float64)
    if work is None or robot.nq != robot.nv:
        return []
    w = np.asarray(work, dtype=np.float64)
    if w.shape != (len(q),) or not np.all(np.isfinite(w)):
        return []
    lower, upper = np.asarray(robot.model.lowerPositionLimit), np.asarray(robot.model.upperPositionLimit)
    span = np.where(np.isfinite(upper - lower) & (upper > lower), upper - lower, np.inf)
    impacts: list[Impact] = []
    for k in np.flatnonzero(np.diff(w) < 0) + 1:
        gap = np.minimum(np.abs(q[k] - lower), np.abs(upper - q[k])) / span
        j = _joint_of(robot, int(np.argmin(gap)))
        frame = float(np.searchsorted(run.index, k))
        nearest = min(int(np.searchsorted(run.index, k)), len(configurations) - 1)
        origin = dynamics.joint_frames(robot.model, robot.data, configurations[nearest])[j - 1][0][:3, 3]
        impacts.append(Impact(frame, str(robot.model.names[j]), origin, float(w[k] - w[k - 1])))
    return impacts


def _joint_of(robot: Robot, coordinate: int) -> int:
    """The index of the joint that owns configuration coordinate ``coordinate``."""
    for j in range(1, robot.model.njoints):
        start = int(robot.model.joints[j].idx_q)
        if start <= coordinate < start + int(robot.model.joints[j].nq):
            return j
    return 1


def forces_info(arrows: list[Arrow], impacts: list[Impact], mode: dict[str, Any] | None) -> dict[str, Any]:
    """What the page draws (JSON-ready): arrows, impacts, the mode's text per rendered frame."""
    return {
        "arrows": [
            {
                "joint": a.joint,
                "kind": a.kind,
                "unit": "N" if a.kind == "force" else "N m",
                "symbol": "F" if a.kind == "force" else "τ",
                "color": f"#{FORCE_COLOR if a.kind == 'force' else TORQUE_COLOR:06x}",
                "points": np.round(a.points, 5).tolist(),
                "values": [float(f"{x:.5g}") for x in a.values],
            }
            for a in arrows
        ],
        "impacts": [
            {"frame": i.frame, "joint": i.joint, "xyz": np.round(i.xyz, 5).tolist(), "energy": float(f"{i.energy:.4g}")}
            for i in impacts
        ],
        "flash": IMPACT_FLASH_S,
        "impactColor": f"#{IMPACT_COLOR:06x}",
        "mode": mode,
    }


def mode_marks(run: Run, centres: Array, half: Array) -> dict[str, Any] | None:
    """The controller's mode name at each rendered frame, and where to write it: above the framed box [m]."""
    controller = (getattr(run.trajectory, "meta", None) or {}).get("controller")
    if not isinstance(controller, dict):
        return None
    mode, names = controller.get("mode"), controller.get("modes")
    if not isinstance(mode, list) or len(mode) != len(run.trajectory.t) or not isinstance(names, list):
        return None
    shown = [int(mode[k]) for k in run.index]
    above = centres + np.array([0.0, 0.0, 1.1 * half[2]])
    return {
        "names": [str(n) for n in names],
        "values": shown,
        "xyz": np.round(above, 5).tolist(),
        "color": f"#{MODE_TEXT_COLOR:06x}",
    }
