"""The springs of a run drawn in the 3D view: a flat coil (a clock spring) at each sprung revolute joint.

A run with springs (its trajectory's ``meta["springs"]``: joint name -> stiffness and rest)
shows, at each sprung revolute joint, a spiral of :data:`COIL_TURNS` turns in the plane
normal to the joint's axis, in the teal of the "V spring" curve, riding on the joint's frame
(one animation track). Prismatic springs are not drawn.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.viewer.backend import ROOT, scene_path
from robodyn.viewer.panel import SPRING

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

COIL_TURNS = 3.0
"""Turns of each coil: enough to read as a spring at a glance."""
COIL_POINTS = 120
COIL_RADIUS_FRACTION = (0.02, 0.07)
"""Inner and outer radius of a coil, as fractions of the framed size."""
_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


@dataclass(frozen=True, eq=False)
class Coil:
    """One drawn spring: its joint, scene path, points in the joint's frame (m, 3) [m], placements (k, 4, 4)."""

    joint: str
    path: tuple[str, ...]
    points: Array
    placements: Array


def revolute_axis(joint: Any) -> Array | None:
    """The unit axis of a revolute joint model in its own frame, or None for another kind."""
    name = str(joint.shortname())
    if name.startswith("JointModelR") and name[-1] in _AXES and "Unaligned" not in name:
        return np.array(_AXES[name[-1]])
    if "RevoluteUnaligned" in name or "RevoluteUnboundedUnaligned" in name:
        axis = np.asarray(joint.extract().axis, dtype=np.float64)
        return axis / np.linalg.norm(axis)
    return None


def coil_points(axis: Array, inner: float, outer: float) -> Array:
    """A flat spiral (COIL_POINTS, 3) [m] about the origin, in the plane normal to ``axis``."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    s = np.linspace(0.0, 1.0, COIL_POINTS)
    angle = 2.0 * np.pi * COIL_TURNS * s
    radius = inner + (outer - inner) * s
    return (radius * np.cos(angle))[:, None] * u + (radius * np.sin(angle))[:, None] * w


def spring_coils(robot: Robot, springs: Any, configurations: Array, size: float) -> list[Coil]:
    """A coil at each sprung revolute joint named in ``springs``, placed at its frame for each configuration."""
    if not isinstance(springs, dict):
        return []
    model = robot.model
    frame_names = [str(f.name) for f in model.frames]
    coils: list[Coil] = []
    for name in springs:
        if name not in list(model.names) or name not in frame_names:
            continue
        axis = revolute_axis(model.joints[model.getJointId(name)])
        if axis is None:
            continue
        index = frame_names.index(name)
        placements = np.array(
            [dynamics.frame_placements(model, robot.data, qk)[index] for qk in configurations], dtype=np.float64
        )
        inner, outer = (f * size for f in COIL_RADIUS_FRACTION)
        coils.append(Coil(str(name), (*ROOT, "springs", str(name)), coil_points(axis, inner, outer), placements))
    return coils


def coil_commands(mc: Any, coil: Coil) -> list[Any]:
    """Draw ``coil`` as a teal line at its first placement."""
    path = scene_path(mc, coil.path)
    line = mc.geometry.Line(
        mc.geometry.PointsGeometry(np.ascontiguousarray(coil.points.T, dtype=np.float32)),
        mc.geometry.LineBasicMaterial(color=SPRING, linewidth=2),
    )
    return [mc.commands.SetObject(line, path=path), mc.commands.SetTransform(coil.placements[0], path)]
