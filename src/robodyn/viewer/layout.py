"""Framing the scene: where the energy chart's panel goes, the shift that centres it all, the camera.

meshcat's perspective camera has a 75 degree vertical field of view and orbits the origin;
robodyn shifts everything it draws (and meshcat's grid and axes) so that the bounding box of
the robot over the whole motion, its trace and the chart is centred there, and backs the
camera off until that box fits the narrowest pane it expects.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.viewer.backend import ROOT, scene_path
from robodyn.viewer.geometry import SceneObject

Array = NDArray[np.float64]

CAMERA_FOV_DEG = 75.0
CAMERA_DIRECTION = np.array([0.15, -1.0, 0.3]) / np.linalg.norm([0.15, -1.0, 0.3])
_ASSUMED_ASPECT = 1.25  # the narrowest browser pane we fit the scene into (width / height)


@dataclass(frozen=True)
class ChartPanel:
    """The energy chart's panel: lower-left corner (robot coordinates [m]) and size [m]."""

    origin: Array
    width: float
    height: float


@dataclass(frozen=True)
class Layout:
    """Where things go: the chart beside the robot, the shift that centres it all, the camera.

    ``size`` [m] is the largest extent of what is drawn (at least 0.2 m): the scale of
    markers, dots and text.
    """

    size: float
    chart: ChartPanel | None
    offset: Array
    camera: Array

    @staticmethod
    def fit(objects: list[SceneObject], trace: Array, *, with_chart: bool) -> Layout:
        """Frame ``objects`` over all their placements, the ``trace`` (k, 3) [m] and, if asked, a chart."""
        low, high = np.full(3, np.inf), np.full(3, -np.inf)
        for obj in objects:
            corners = np.einsum("kij,cj->kci", obj.placements[:, :3, :3], obj.corners) + obj.placements[:, None, :3, 3]
            low, high = np.minimum(low, corners.min(axis=(0, 1))), np.maximum(high, corners.max(axis=(0, 1)))
        if len(trace):
            low, high = np.minimum(low, trace.min(axis=0)), np.maximum(high, trace.max(axis=0))
        if not np.all(np.isfinite(low)):
            low, high = -0.1 * np.ones(3), 0.1 * np.ones(3)
        size = max(float(np.max(high - low)), 0.2)
        chart = None
        if with_chart:
            width, height = 0.75 * size, 0.4 * size  # wide enough for the legend's three entries in a row
            origin = np.array([high[0] + 0.15 * size, 0.5 * (low[1] + high[1]), 0.5 * (low[2] + high[2]) - height / 2])
            chart = ChartPanel(origin, width, height)
            high = np.maximum(high, origin + np.array([width, 0.0, height]))
            low = np.minimum(low, origin)
        centre = 0.5 * (low + high)
        half = 0.5 * (high - low)
        tan_half = np.tan(np.radians(CAMERA_FOV_DEG / 2))
        distance = half[1] + 1.35 * max(half[2] / tan_half, half[0] / (tan_half * _ASSUMED_ASPECT), 0.05)
        return Layout(size, chart, -centre, distance * CAMERA_DIRECTION)


def view_commands(mc: Any, layout: Layout) -> list[Any]:
    """The commands that shift the drawing (and meshcat's grid and axes) and place the camera."""
    shift = np.eye(4)
    shift[:3, 3] = layout.offset
    x, y, z = layout.camera
    return [
        mc.commands.SetTransform(shift, scene_path(mc, ROOT)),
        mc.commands.SetTransform(shift, mc.path.Path(("Grid",))),
        mc.commands.SetTransform(shift, mc.path.Path(("Axes",))),
        # The camera lives in meshcat's y-up frame: world (x, y, z) is (x, z, -y) there.
        mc.commands.SetProperty("position", [float(x), float(z), float(-y)], _camera_path(mc)),
    ]


def _camera_path(mc: Any) -> Any:
    return mc.path.Path(("Cameras", "default", "rotated", "<object>"))
