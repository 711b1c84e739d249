"""The tip trace: the path of one frame, drawn as a line with a dot per rendered frame and a marker.

The frame is the one asked for, or else the one that travels farthest over the rendered
frames. The line follows the trajectory densely (up to :data:`MAX_TRACE_POINTS` samples);
the marker rides on the frame (its placements are one animation track).

The line carries one colour per vertex, so that the replay page (``assets/replay.js``) can
show only its last :data:`DEFAULT_TRACE_WINDOW_S` seconds up to the animation's time,
fading to white towards the older end: a whole trace drawn from t = 0 makes a tangle. Its
points' playback times go to the page with it (:func:`dense_rows`). meshcat's own page (the
live server) has no such hook and draws the whole trace.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.errors import UnknownNameError
from robodyn.viewer.backend import ROOT, scene_path
from robodyn.viewer.palette import YELLOW
from robodyn.viewer.transforms import translations

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.sim.trajectory import Trajectory

Array = NDArray[np.float64]

TRACE_COLOR = YELLOW
"""Okabe–Ito yellow: bright on the sky-blue background, far in hue from the first links' colours."""
MARKER_PATH = (*ROOT, "trace", "marker")
"""Scene path of the marker that rides on the traced frame (animated)."""

MAX_TRACE_POINTS = 4000
"""The trace's line goes through at most this many trajectory samples (evenly spread)."""
DEFAULT_TRACE_WINDOW_S = 2.0
"""Simulation time the replay page keeps of the trace behind the cursor [s]: a swing or two of a pendulum."""


def frame_positions(robot: Robot, configurations: Array) -> dict[str, Array]:
    """World position (k, 3) of every named frame of the model at each configuration [m]."""
    names = [str(f.name) for f in robot.model.frames]
    xyz = np.array(
        [[m[:3, 3] for m in dynamics.frame_placements(robot.model, robot.data, qk)] for qk in configurations]
    )
    positions: dict[str, Array] = {}
    for i, name in enumerate(names):
        positions.setdefault(name, xyz[:, i])
    return positions


def frame_path_lengths(frames: dict[str, Array]) -> dict[str, float]:
    """Length of the polyline each frame traces through the rendered samples [m]."""
    return {name: float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))) for name, p in frames.items()}


def choose_trace_frame(frames: dict[str, Array], wanted: str | None) -> str | None:
    """``wanted`` if the model has it, else the frame that travels farthest (None if nothing moves).

    Raises:
        UnknownNameError: ``wanted`` is not one of the model's frames.
    """
    if wanted is not None:
        if wanted not in frames:
            raise UnknownNameError("frame", wanted, frames)
        return wanted
    lengths = frame_path_lengths(frames)
    longest = max(lengths.values())
    if longest <= 1e-9:
        return None
    # Ties (a fixed joint's frame and its child body's frame) go to the later frame: the body.
    return [name for name, length in lengths.items() if length >= longest * (1 - 1e-9)][-1]


def dense_rows(n: int) -> NDArray[np.int64]:
    """The rows (m,) of an n-sample trajectory that the trace's line goes through (at most MAX_TRACE_POINTS)."""
    return np.unique(np.linspace(0, n - 1, min(n, MAX_TRACE_POINTS)).round().astype(np.int64))


def dense_path(robot: Robot, trajectory: Trajectory, frame: str) -> Array:
    """World positions (m, 3) [m] of ``frame`` at the trajectory's :func:`dense_rows`."""
    q = np.asarray(trajectory.q, dtype=np.float64)
    rows = dense_rows(len(q))
    index = [str(f.name) for f in robot.model.frames].index(frame)
    return np.array([dynamics.frame_placements(robot.model, robot.data, q[i])[index][:3, 3] for i in rows])


def trace_commands(
    mc: Any, dense: Array, xyz: Array, size: float, *, color: int = TRACE_COLOR, group: str = "trace"
) -> list[Any]:
    """The path as a line through ``dense`` (m, 3), dots at the rendered frames ``xyz`` (k, 3), a marker.

    Drawn in ``color`` under ``ROOT/group`` (a run of a replay of several has its own).
    """
    marker_path = (*ROOT, group, "marker")
    line = np.ascontiguousarray(dense.T, dtype=np.float32)
    # Vertex colours (white material times the run's colour): the page fades the older part by rewriting them.
    line_colors = np.ascontiguousarray(np.tile(_rgb(color), (len(dense), 1)).T)
    points = np.ascontiguousarray(xyz.T, dtype=np.float32)
    marker = mc.geometry.Mesh(mc.geometry.Sphere(0.02 * size), mc.geometry.MeshLambertMaterial(color=color))
    return [
        mc.commands.SetObject(
            mc.geometry.Line(
                mc.geometry.PointsGeometry(line, color=line_colors),
                mc.geometry.LineBasicMaterial(color=0xFFFFFF, linewidth=2, vertexColors=True),
            ),
            path=scene_path(mc, (*ROOT, group, "path")),
        ),
        mc.commands.SetObject(
            mc.geometry.Points(
                mc.geometry.PointsGeometry(points, color=np.tile(_rgb(color), (len(xyz), 1)).T),
                mc.geometry.PointsMaterial(size=0.012 * size),
            ),
            path=scene_path(mc, (*ROOT, group, "dots")),
        ),
        mc.commands.SetObject(marker, path=scene_path(mc, marker_path)),
        mc.commands.SetTransform(translations(xyz[:1])[0], scene_path(mc, marker_path)),
    ]


def _rgb(color: int) -> NDArray[np.float32]:
    return np.array([(color >> 16) & 255, (color >> 8) & 255, color & 255], dtype=np.float32) / 255.0
