"""The optional ground plane: a thin, wide slab whose top face is the plane of the robot's base.

A fixed-base model is fixed at the origin of its world frame, so the base's plane is z = 0:
with the ground drawn, a hand that falls below it visibly goes through the floor (the
simulation has no contact; the plane only shows where the base stands). The slab spans the
framed box over the whole playback and :data:`GROUND_MARGIN` of its size on every side, so
that it stays under the robot in follow mode too.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.viewer.backend import ROOT, scene_path
from robodyn.viewer.transforms import translation

Array = NDArray[np.float64]

GROUND_PATH = (*ROOT, "ground")
GROUND_COLOR = 0x8D8D8D
GROUND_OPACITY = 0.45
"""Translucent: a link that sinks below the base's plane stays visible through it."""
GROUND_MARGIN = 1.0
"""Extra width on every side, in framed-box sizes: the plane reads as a floor, not as a tile."""
GROUND_THICKNESS_FRACTION = 0.01
"""Slab thickness as a fraction of the framed size: thin enough to read as a plane."""


@dataclass(frozen=True)
class Ground:
    """The slab: the height of its top face (the base's plane) [m], its centre and sides [m], shape (3,)."""

    height: float
    centre: Array
    sides: Array


def ground_slab(centres: Array, half: Array, size: float, *, height: float = 0.0) -> Ground:
    """The slab under every framed box (centres (k, 3), half-sides (3,) [m]), top face at ``height`` [m]."""
    lo = centres[:, :2].min(axis=0) - half[:2] - GROUND_MARGIN * size
    hi = centres[:, :2].max(axis=0) + half[:2] + GROUND_MARGIN * size
    thickness = GROUND_THICKNESS_FRACTION * size
    centre = np.array([*(0.5 * (lo + hi)), height - 0.5 * thickness])
    return Ground(float(height), centre, np.array([*(hi - lo), thickness]))


def ground_commands(mc: Any, ground: Ground) -> list[Any]:
    """Draw the slab under ``ROOT/ground`` (it shifts with the drawing in follow mode)."""
    path = scene_path(mc, GROUND_PATH)
    material = mc.geometry.MeshLambertMaterial(color=GROUND_COLOR, opacity=GROUND_OPACITY)
    return [
        mc.commands.SetObject(mc.geometry.Box([float(s) for s in ground.sides]), material, path),
        mc.commands.SetTransform(translation(ground.centre), path),
    ]


BELOW_GROUND_TOLERANCE_M = 1e-3
"""A frame this far below the plane goes through it (less is the base's own frames sitting on it)."""


def below_ground(frames: dict[str, Array], *, height: float = 0.0) -> tuple[str, ...]:
    """One sentence naming the frame that goes deepest below the plane (z = ``height``), or none.

    ``frames`` maps each frame's name to its world positions (k, 3) [m]. The plane only shows
    where a floor would be: the model has none, and the sentence says so.
    """

    # the deepest frame; of frames as deep (a joint's frame and its body's), a body's name before a joint's
    def depth_then_kind(item: tuple[str, Array]) -> tuple[float, bool]:
        return round(float(item[1][:, 2].min()), 6), "joint" in item[0]

    deepest = min(frames.items(), key=depth_then_kind, default=None)
    if deepest is None:
        return ()
    name, xyz = deepest
    depth = height - float(xyz[:, 2].min())
    if depth <= BELOW_GROUND_TOLERANCE_M:
        return ()
    return (f"{name} goes {depth:.2f} m below the ground plane: the model has no floor (nothing collides with it)",)
