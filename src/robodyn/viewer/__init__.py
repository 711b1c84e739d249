"""Browser playback of a robot and its trajectory with meshcat.

The motion is baked, once, into one ``meshcat.animation.Animation``: one keyframe per
rendered sample, with the transforms Pinocchio computes for the sampled configurations.
The browser then plays it with meshcat's own time slider and play/pause; nothing pushes
transforms in a loop. Three ways to look at it, all from the same :class:`Playback`:

* :func:`to_html`: one self-contained HTML file (meshcat's JavaScript inlined) that replays
  offline, with a text overlay of the time and the total energy that follows the animation;
* :func:`serve`: a meshcat server on a free localhost port (or one already running), for
  ``robodyn view`` and ``simulate --view``;
* :func:`show`: an inline view in Jupyter (the same HTML in an iframe, no server, no loop).

Besides the links, the scene shows the path of a chosen frame (its trace, with a marker
riding on the frame) and a small chart of the energies T, V and E = T + V whose cursor
moves with the animation.

Only this module imports meshcat, and only inside functions: ``import robodyn`` stays
light, and dynamics-only work never loads geometry or parses meshes.
"""

from __future__ import annotations

import base64
import html
import json
import os
import re
import select
import socket
import subprocess
import sys
import tempfile
import time
import uuid
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.errors import InputError, MissingDependencyError, UnavailableError, UnknownNameError

if TYPE_CHECKING:
    import pinocchio as pin

    from robodyn.robot import Robot
    from robodyn.sim.trajectory import Trajectory

Array = NDArray[np.float64]

DEFAULT_FPS = 30.0
"""Rendered samples per second of playback (meshcat interpolates between them)."""

INSTALL_HINT = "pip install meshcat"
ROOT = ("meshcat", "robodyn")
"""Scene path under which everything robodyn draws lives (deleted before a new scene is sent)."""

# Colours: the static base in grey, then one colour per moving joint (URDF colours win).
BASE_COLOR = 0x5D6D7E
LINK_COLORS = (0xE67E22, 0x27AE60, 0xC0392B, 0x8E44AD, 0xF1C40F, 0x16A085, 0xD35400, 0x2E86C1)
TRACE_COLOR = 0xFFE135
# The chart's curves: hues apart from the first link colours, so neither can pass for the other.
ENERGY_COLORS = {"E": 0x7B1FA2, "T": 0x1E88E5, "V": 0xD81B60}
_PINOCCHIO_DEFAULT_RGBA = (0.9, 0.9, 0.9, 1.0)

# Camera: meshcat's perspective camera has a 75 degree vertical field of view and orbits the
# origin; robodyn shifts the scene so that what it draws is centred there.
CAMERA_FOV_DEG = 75.0
CAMERA_DIRECTION = np.array([0.15, -1.0, 0.3]) / np.linalg.norm([0.15, -1.0, 0.3])
_ASSUMED_ASPECT = 1.25  # the narrowest browser pane we fit the scene into (width / height)

SERVER_START_TIMEOUT_S = 30.0
REPLY_TIMEOUT_MS = 30_000  # robodyn's own server: big meshes take a while to pass through
CONNECT_TIMEOUT_MS = 10_000  # a server named by zmq_url: how long to wait for its first answer


# --------------------------------------------------------------------------- meshcat import
def _meshcat() -> Any:
    """Import meshcat, or raise :class:`MissingDependencyError` with the install command."""
    try:
        import meshcat
        import meshcat.animation
        import meshcat.commands
        import meshcat.geometry
        import meshcat.path
        import umsgpack  # noqa: F401  (meshcat's own dependency: the wire format)
    except ImportError as exc:
        raise MissingDependencyError(
            f"the viewer needs meshcat, which cannot be imported ({exc}); install it with: {INSTALL_HINT}"
        ) from None
    return meshcat


# --------------------------------------------------------------------------- sampling
def render_samples(t: Array, *, speed: float = 1.0, fps: float = DEFAULT_FPS) -> NDArray[np.int64]:
    """Indices of the trajectory samples shown, one per rendered frame.

    Playback time tau [s] runs from 0 to (t[-1] - t[0]) / speed; at each tau = k / fps the
    sample nearest to simulation time t[0] + speed * tau is taken (duplicates dropped), and
    the last sample is always kept so the animation ends on the final state.

    Args:
        t: sample times [s], shape (n,), non-decreasing.
        speed: playback speed (1 = real time, 2 = twice as fast).
        fps: rendered frames per second of playback.
    """
    t = np.asarray(t, dtype=np.float64)
    if len(t) == 1:
        return np.zeros(1, dtype=np.int64)
    duration = (t[-1] - t[0]) / speed
    count = int(np.floor(duration * fps + 1e-9)) + 1
    wanted = t[0] + np.arange(count) * (speed / fps)
    right = np.clip(np.searchsorted(t, wanted), 1, len(t) - 1)
    left = right - 1
    nearest = np.where(np.abs(t[left] - wanted) <= np.abs(t[right] - wanted), left, right)
    return np.unique(np.append(nearest, len(t) - 1)).astype(np.int64)


# --------------------------------------------------------------------------- the playback
@dataclass(frozen=True, eq=False)
class SceneObject:
    """One drawn object: its scene path, what it is, and its placements over the playback.

    ``placements`` has shape (k, 4, 4): the world (or parent-group) transform at each
    rendered sample; ``intrinsic`` (4, 4) is applied inside it (cylinder axis, mesh scale);
    ``corners`` (8, 3) are the corners of the shape's bounding box in its own frame [m].
    """

    path: tuple[str, ...]
    kind: str
    placements: Array
    intrinsic: Array
    corners: Array
    source: str = ""


@dataclass(frozen=True, eq=False)
class Playback:
    """A robot's scene and its motion, ready to be shown by meshcat.

    Attributes:
        robot_name: the model's name.
        objects: the link geometries, in Pinocchio's geometry order.
        commands: meshcat commands that build the static scene, in send order.
        animation: the whole motion as one ``meshcat.animation.Animation`` (None without a trajectory).
        loop: repeat the animation forever (else it plays once).
        sample_index: trajectory rows shown, one per rendered frame, shape (k,).
        times: simulation time of each rendered frame [s], shape (k,).
        playback_times: time of each rendered frame in the browser [s], (times - t[0]) / speed.
        kinetic, potential: T and V at the rendered frames [J], shape (k,) (empty without a trajectory).
        trace_frame: name of the frame whose path is drawn, or None.
        trace: that frame's world positions at every rendered frame [m], shape (k, 3).
        offset: translation applied to the whole drawing so that it is centred on the camera target [m].
        camera_position: meshcat camera position in world coordinates (z up) [m]; it looks at the origin.
        speed, fps: playback speed and rendered frames per second.
        skipped: names of geometries that could not be drawn (unsupported shape).
        chart: where the energy chart's legend, ticks and plot went (None without a chart).
    """

    robot_name: str
    objects: tuple[SceneObject, ...]
    commands: tuple[Any, ...]
    animation: Any
    loop: bool
    sample_index: NDArray[np.int64]
    times: Array
    playback_times: Array
    kinetic: Array
    potential: Array
    trace_frame: str | None
    trace: Array
    offset: Array
    camera_position: Array
    speed: float
    fps: float
    skipped: tuple[str, ...] = ()
    chart: ChartLayout | None = None

    @property
    def energy(self) -> Array:
        """Total mechanical energy T + V at the rendered frames [J], shape (k,)."""
        return self.kinetic + self.potential

    @property
    def duration(self) -> float:
        """Length of the playback in the browser [s]."""
        return float(self.playback_times[-1]) if len(self.playback_times) else 0.0

    @property
    def n_frames(self) -> int:
        """Number of rendered frames (keyframes of the animation)."""
        return len(self.sample_index)


def build(
    robot: Robot,
    trajectory: Trajectory | None = None,
    *,
    q: Any = None,
    speed: float = 1.0,
    fps: float = DEFAULT_FPS,
    trace_frame: str | None = None,
    trace: bool = True,
    energy_chart: bool = True,
    loop: bool = False,
    geometry: pin.GeometryModel | None = None,
) -> Playback:
    """Bake ``robot`` and, if given, ``trajectory`` into a :class:`Playback` (no server, no browser).

    Args:
        robot: the model; its visual geometry is loaded here (meshes are parsed only now).
        trajectory: the motion to play; its ``q`` must have ``robot.nq`` columns.
        q: without a trajectory, the configuration to show (default: neutral), shape (nq,).
        speed: playback speed (1 = real time).
        fps: rendered frames per second of playback.
        trace_frame: frame whose path is drawn; None picks the frame that travels farthest.
        trace: draw the trace at all.
        energy_chart: draw the small T, V, E chart with a cursor that follows the animation.
        loop: repeat the animation forever instead of playing it once.
        geometry: an already loaded visual ``GeometryModel`` (default: loaded from the URDF).

    Raises:
        InputError: a trajectory that does not fit the model, or a bad speed/fps.
        UnknownNameError: a ``trace_frame`` the model does not have.
        MissingDependencyError: meshcat is not installed.
    """
    mc = _meshcat()
    _check_rate("speed", speed)
    _check_rate("fps", fps)
    configurations, index, times, kinetic, potential = _samples(robot, trajectory, q, speed=speed, fps=fps)
    if geometry is None:
        from robodyn.model.load import load_geometry

        geometry = load_geometry(robot, kind="visual")
    objects, geoms, skipped = _geometry_objects(robot, geometry, configurations)
    frames = _frame_positions(robot, configurations)
    chosen = _choose_trace_frame(robot, frames, trace_frame) if trace and trajectory is not None else None
    trace_xyz = frames[chosen] if chosen is not None else np.zeros((0, 3))
    playback_times = (times - times[0]) / speed

    layout = _Layout.fit(objects, trace_xyz, with_chart=energy_chart and trajectory is not None)
    commands: list[Any] = [mc.commands.Delete(_path(mc, ROOT))]
    tracks: dict[tuple[str, ...], Array] = {}
    for obj, geom in zip(objects, geoms, strict=True):
        commands += _object_commands(mc, obj, geom, robot)
        tracks[obj.path] = obj.placements
    if chosen is not None:
        dense = _dense_path(robot, trajectory, chosen) if trajectory is not None else trace_xyz
        commands += _trace_commands(mc, dense, trace_xyz, layout.size)
        tracks[(*ROOT, "trace", "marker")] = _translations(trace_xyz)
    if layout.chart is not None:
        chart_commands, cursor, chart_layout = _chart_commands(mc, layout, playback_times, kinetic, potential)
        commands += chart_commands
        tracks[(*ROOT, "energy", "cursor")] = cursor
    else:
        chart_layout = None
    commands += _view_commands(mc, layout)
    animation = None
    if trajectory is not None:
        animation = _animation(mc, tracks, playback_times, fps=fps)
    return Playback(
        robot_name=robot.name,
        objects=tuple(objects),
        commands=tuple(commands),
        animation=animation,
        loop=loop,
        sample_index=index,
        times=times,
        playback_times=playback_times,
        kinetic=kinetic,
        potential=potential,
        trace_frame=chosen,
        trace=trace_xyz,
        offset=layout.offset,
        camera_position=layout.camera,
        speed=float(speed),
        fps=float(fps),
        skipped=tuple(skipped),
        chart=chart_layout,
    )


def _check_rate(name: str, value: float) -> None:
    if not (np.isfinite(value) and value > 0):
        raise InputError(f"{name} must be a positive number, got {value!r}")


def _samples(
    robot: Robot, trajectory: Trajectory | None, q: Any, *, speed: float, fps: float
) -> tuple[Array, NDArray[np.int64], Array, Array, Array]:
    """Configurations (k, nq), trajectory rows, times [s], T and V [J] of the rendered frames."""
    if trajectory is None:
        q0 = robot.neutral() if q is None else robot.q_(q)
        return q0[None, :], np.zeros(1, dtype=np.int64), np.zeros(1), np.zeros(0), np.zeros(0)
    check_trajectory(robot, trajectory)
    index = render_samples(trajectory.t, speed=speed, fps=fps)
    kinetic = np.asarray(trajectory.kinetic, dtype=np.float64)
    potential = np.asarray(trajectory.potential, dtype=np.float64)
    return (
        np.asarray(trajectory.q, dtype=np.float64)[index],
        index,
        np.asarray(trajectory.t, dtype=np.float64)[index],
        kinetic[index] if kinetic.shape == trajectory.t.shape else np.zeros(0),
        potential[index] if potential.shape == trajectory.t.shape else np.zeros(0),
    )


def check_trajectory(robot: Robot, trajectory: Trajectory) -> None:
    """Raise :class:`InputError` unless ``trajectory`` can be played on ``robot``."""
    t = np.asarray(trajectory.t, dtype=np.float64)
    q = np.asarray(trajectory.q, dtype=np.float64)
    if t.ndim != 1 or len(t) == 0:
        raise InputError(f"the trajectory has no samples (t has shape {t.shape})")
    if q.ndim != 2 or q.shape[1] != robot.nq:
        columns = q.shape[1] if q.ndim == 2 else q.shape
        raise InputError(
            f"the trajectory's q has {columns} columns but model {robot.name!r} has nq = {robot.nq} "
            f"(joints: {', '.join(robot.joint_names)}); was it simulated with another model?"
        )
    if q.shape[0] != len(t):
        raise InputError(f"the trajectory has {len(t)} times but {q.shape[0]} rows of q")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q))):
        raise InputError("the trajectory holds non-finite times or configurations")
    if np.any(np.diff(t) < 0):
        raise InputError("the trajectory's times decrease somewhere; expected t sorted in time")


# --------------------------------------------------------------------------- geometry
def _geometry_objects(
    robot: Robot, geometry: pin.GeometryModel, configurations: Array
) -> tuple[list[SceneObject], list[Any], list[str]]:
    """Every drawable geometry with its world placements (k, 4, 4); the names of those skipped."""
    placements = np.array(
        [dynamics.geometry_placements(robot.model, robot.data, geometry, qk) for qk in configurations]
    ).reshape(len(configurations), len(geometry.geometryObjects), 4, 4)
    objects: list[SceneObject] = []
    geoms: list[Any] = []
    skipped: list[str] = []
    used: set[str] = set()
    for i, geom in enumerate(geometry.geometryObjects):
        kind, intrinsic = _shape(geom)
        if kind == "":
            skipped.append(str(geom.name))
            continue
        name = _unique(str(geom.name).replace("/", "_") or f"geometry_{i}", used)
        objects.append(
            SceneObject(
                (*ROOT, "robot", name), kind, placements[:, i], intrinsic, _box_corners(geom), str(geom.meshPath)
            )
        )
        geoms.append(geom)
    return objects, geoms, skipped


def _unique(name: str, used: set[str]) -> str:
    candidate, n = name, 1
    while candidate in used:
        n += 1
        candidate = f"{name}_{n}"
    used.add(candidate)
    return candidate


_MESH_FORMATS = {".stl": "stl", ".dae": "dae", ".obj": "obj"}


def _shape(geom: Any) -> tuple[str, Array]:
    """(kind, intrinsic transform) of a Pinocchio geometry object; kind "" if it cannot be drawn."""
    shape = type(geom.geometry).__name__
    if shape in ("Box", "Sphere", "Ellipsoid"):
        return shape.lower(), np.eye(4)
    if shape in ("Cylinder", "Capsule"):
        # meshcat draws cylinders along y, URDF along z: turn by +90 degrees about x.
        return shape.lower(), _rotation_x(np.pi / 2)
    suffix = Path(str(geom.meshPath)).suffix.lower()
    if suffix in _MESH_FORMATS and Path(str(geom.meshPath)).is_file():
        scale = np.ones(4)
        scale[:3] = np.asarray(geom.meshScale, dtype=np.float64)
        return "mesh", np.diag(scale)
    return "", np.eye(4)


def _rotation_x(angle: float) -> Array:
    c, s = np.cos(angle), np.sin(angle)
    m = np.eye(4)
    m[1:3, 1:3] = [[c, -s], [s, c]]
    return m


def _meshcat_geometry(mc: Any, geom: Any, kind: str) -> Any:
    g = geom.geometry
    if kind == "box":
        return mc.geometry.Box(list(2.0 * np.asarray(g.halfSide, dtype=float)))
    if kind == "sphere":
        return mc.geometry.Sphere(float(g.radius))
    if kind == "ellipsoid":
        return mc.geometry.Ellipsoid(list(np.asarray(g.radii, dtype=float)))
    if kind == "cylinder":
        return mc.geometry.Cylinder(2.0 * float(g.halfLength), float(g.radius))
    if kind == "capsule":  # drawn as its cylindrical hull: meshcat 0.3 has no capsule
        return mc.geometry.Cylinder(2.0 * float(g.halfLength) + 2.0 * float(g.radius), float(g.radius))
    path = str(geom.meshPath)
    loader = {
        "stl": mc.geometry.StlMeshGeometry,
        "dae": mc.geometry.DaeMeshGeometry,
        "obj": mc.geometry.ObjMeshGeometry,
    }[_MESH_FORMATS[Path(path).suffix.lower()]]
    return loader.from_file(path)


def _color(geom: Any, robot: Robot) -> tuple[int, float]:
    rgba = tuple(float(x) for x in np.asarray(geom.meshColor).ravel()[:4])
    if len(rgba) == 4 and not np.allclose(rgba, _PINOCCHIO_DEFAULT_RGBA):
        r, g, b = (round(255 * min(max(c, 0.0), 1.0)) for c in rgba[:3])
        return (r << 16) | (g << 8) | b, rgba[3]
    joint = int(geom.parentJoint)
    if joint == 0:
        return BASE_COLOR, 1.0
    return LINK_COLORS[(joint - 1) % len(LINK_COLORS)], 1.0


def _object_commands(mc: Any, obj: SceneObject, geom: Any, robot: Robot) -> list[Any]:
    color, opacity = _color(geom, robot)
    material = mc.geometry.MeshLambertMaterial(color=color, opacity=opacity)
    path = _path(mc, obj.path)
    return [
        mc.commands.SetObject(_meshcat_geometry(mc, geom, obj.kind), material, path),
        mc.commands.SetTransform(obj.placements[0], path),
        mc.commands.SetTransform(obj.intrinsic, _path(mc, (*obj.path, "<object>"))),
    ]


def _box_corners(geom: Any) -> Array:
    """Corners (8, 3) of the shape's axis-aligned bounding box in its own frame [m]."""
    g = geom.geometry
    try:
        g.computeLocalAABB()
        low, high = np.asarray(g.aabb_local.min_, dtype=float), np.asarray(g.aabb_local.max_, dtype=float)
    except (AttributeError, RuntimeError):
        low = high = np.zeros(3)
    return np.array(
        [[(low, high)[i][0], (low, high)[j][1], (low, high)[k][2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    )


# --------------------------------------------------------------------------- trace
def _frame_positions(robot: Robot, configurations: Array) -> dict[str, Array]:
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


def _choose_trace_frame(robot: Robot, frames: dict[str, Array], wanted: str | None) -> str | None:
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


def _translations(xyz: Array) -> Array:
    out = np.tile(np.eye(4), (len(xyz), 1, 1))
    out[:, :3, 3] = xyz
    return out


MAX_TRACE_POINTS = 4000
"""The trace's line goes through at most this many trajectory samples (evenly spread)."""


def _dense_path(robot: Robot, trajectory: Trajectory, frame: str) -> Array:
    """World positions (m, 3) [m] of ``frame`` at up to MAX_TRACE_POINTS samples of the trajectory."""
    q = np.asarray(trajectory.q, dtype=np.float64)
    rows = np.unique(np.linspace(0, len(q) - 1, min(len(q), MAX_TRACE_POINTS)).round().astype(np.int64))
    index = [str(f.name) for f in robot.model.frames].index(frame)
    return np.array([dynamics.frame_placements(robot.model, robot.data, q[i])[index][:3, 3] for i in rows])


def _trace_commands(mc: Any, dense: Array, xyz: Array, size: float) -> list[Any]:
    """The path as a line through ``dense`` (m, 3), dots at the rendered frames ``xyz`` (k, 3), a marker."""
    line = np.ascontiguousarray(dense.T, dtype=np.float32)
    points = np.ascontiguousarray(xyz.T, dtype=np.float32)
    marker = mc.geometry.Mesh(mc.geometry.Sphere(0.02 * size), mc.geometry.MeshLambertMaterial(color=TRACE_COLOR))
    return [
        mc.commands.SetObject(
            mc.geometry.Line(
                mc.geometry.PointsGeometry(line), mc.geometry.LineBasicMaterial(color=TRACE_COLOR, linewidth=2)
            ),
            path=_path(mc, (*ROOT, "trace", "path")),
        ),
        mc.commands.SetObject(
            mc.geometry.Points(
                mc.geometry.PointsGeometry(points, color=np.tile(_rgb(TRACE_COLOR), (len(xyz), 1)).T),
                mc.geometry.PointsMaterial(size=0.012 * size),
            ),
            path=_path(mc, (*ROOT, "trace", "dots")),
        ),
        mc.commands.SetObject(marker, path=_path(mc, (*ROOT, "trace", "marker"))),
        mc.commands.SetTransform(_translations(xyz[:1])[0], _path(mc, (*ROOT, "trace", "marker"))),
    ]


def _rgb(color: int) -> NDArray[np.float32]:
    return np.array([(color >> 16) & 255, (color >> 8) & 255, color & 255], dtype=np.float32) / 255.0


# --------------------------------------------------------------------------- layout
@dataclass(frozen=True)
class _Chart:
    origin: Array  # lower-left corner of the panel, robot coordinates [m]
    width: float
    height: float


@dataclass(frozen=True)
class _Layout:
    """Where things go: the chart beside the robot, the shift that centres it all, the camera."""

    size: float
    chart: _Chart | None
    offset: Array
    camera: Array

    @staticmethod
    def fit(objects: list[SceneObject], trace: Array, *, with_chart: bool) -> _Layout:
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
            chart = _Chart(origin, width, height)
            high = np.maximum(high, origin + np.array([width, 0.0, height]))
            low = np.minimum(low, origin)
        centre = 0.5 * (low + high)
        half = 0.5 * (high - low)
        tan_half = np.tan(np.radians(CAMERA_FOV_DEG / 2))
        distance = half[1] + 1.35 * max(half[2] / tan_half, half[0] / (tan_half * _ASSUMED_ASPECT), 0.05)
        return _Layout(size, chart, -centre, distance * CAMERA_DIRECTION)


def _view_commands(mc: Any, layout: _Layout) -> list[Any]:
    shift = np.eye(4)
    shift[:3, 3] = layout.offset
    x, y, z = layout.camera
    return [
        mc.commands.SetTransform(shift, _path(mc, ROOT)),
        mc.commands.SetTransform(shift, mc.path.Path(("Grid",))),
        mc.commands.SetTransform(shift, mc.path.Path(("Axes",))),
        # The camera lives in meshcat's y-up frame: world (x, y, z) is (x, z, -y) there.
        mc.commands.SetProperty("position", [float(x), float(z), float(-y)], _camera_path(mc)),
    ]


def _camera_path(mc: Any) -> Any:
    return mc.path.Path(("Cameras", "default", "rotated", "<object>"))


# --------------------------------------------------------------------------- energy chart
class _PlaneGeometry:
    """three.js PlaneGeometry (meshcat 0.3 has none); lowered like meshcat's own geometries."""

    field = "geometries"

    def __init__(self, width: float, height: float) -> None:
        self.uuid = str(uuid.uuid1())
        self.width, self.height = width, height

    def intrinsic_transform(self) -> Array:
        return np.eye(4)

    def lower_in_object(self, object_data: dict[str, Any]) -> str:
        object_data.setdefault(self.field, []).append(
            {"uuid": self.uuid, "type": "PlaneGeometry", "width": self.width, "height": self.height}
        )
        return self.uuid


_CANVAS_PX = 256  # meshcat draws text textures on a 256 x 256 canvas
_TEXT_FONT_PX = 32


class _TextTexture:
    """meshcat's ``_text`` canvas texture: black text centred on a 256 x 256 canvas."""

    field = "textures"

    def __init__(self, text: str, font_size: int = 40) -> None:
        self.uuid = str(uuid.uuid1())
        self.text, self.font_size = text, font_size

    def lower_in_object(self, object_data: dict[str, Any]) -> str:
        object_data.setdefault(self.field, []).append(
            {
                "uuid": self.uuid,
                "type": "_text",
                "text": self.text,
                "font_size": self.font_size,
                "font_face": "sans-serif",
            }
        )
        return self.uuid


# The chart's legend: (key, label), drawn left to right in the top band of the panel.
CHART_LEGEND = (("E", "E = T + V"), ("T", "T kinetic"), ("V", "V potential"))

# Average advance of a sans-serif character, in ems: the width estimate that places text
# beside a swatch or against an axis (Chromium's sans-serif measured 0.45 em on "V potential").
_EM_PER_CHAR = 0.5


@dataclass(frozen=True)
class ChartLabel:
    """One text of the energy chart: what it says and the box it covers, chart frame [m].

    ``box`` is (x_min, y_min, x_max, y_max) in the panel's plane (origin at its lower-left
    corner, x along time, y along energy), from the text's estimated width and its em height.
    """

    key: str
    text: str
    box: tuple[float, float, float, float]


@dataclass(frozen=True)
class ChartLayout:
    """Where the energy chart put its parts (chart frame [m]), for tests and for the legend's colours.

    ``frame`` maps chart coordinates (x, y, 0) to robot coordinates (before ``Playback.offset``).
    """

    frame: Array
    width: float
    height: float
    plot: tuple[float, float, float, float]  # left, bottom, right, top of the plotting area
    labels: tuple[ChartLabel, ...]
    swatches: dict[str, tuple[float, float]]  # legend key -> centre of its colour swatch

    def to_world(self, xy: tuple[float, float]) -> Array:
        """Chart point (x, y) -> robot coordinates [m] (add ``Playback.offset`` for the drawing)."""
        return (self.frame @ np.array([xy[0], xy[1], 0.0, 1.0]))[:3]


def _text_box(key: str, text: str, centre: tuple[float, float], em: float) -> ChartLabel:
    half = 0.5 * _EM_PER_CHAR * em * len(text)
    x, y = centre
    return ChartLabel(key, text, (x - half, y - 0.5 * em, x + half, y + 0.5 * em))


def _chart_commands(
    mc: Any, layout: _Layout, tau: Array, kinetic: Array, potential: Array
) -> tuple[list[Any], Array, ChartLayout]:
    """The chart's commands, the cursor's placements (k, 4, 4) in the chart's frame, and where things went.

    The panel has a legend band at the top (a colour swatch and a name per curve, at fixed
    places: no label can land on another or on a curve), the plotting area below it, the
    energy ticks in joules left of the axis and the time ticks in seconds under it.
    """
    chart = layout.chart
    if chart is None:
        raise ValueError("the layout has no chart")
    w, h = chart.width, chart.height
    em = 0.07 * h  # text height [m]
    left, right, bottom, top = 0.22 * w, 0.95 * w, 0.2 * h, 0.76 * h
    lines = {"E": kinetic + potential, "T": kinetic, "V": potential} if len(kinetic) else {}
    values = np.concatenate(list(lines.values())) if lines else np.zeros(1)
    lo, hi = float(values.min()), float(values.max())
    pad = max(0.05 * (hi - lo), 1e-6 * max(abs(lo), abs(hi), 1.0))
    lo, hi = lo - pad, hi + pad
    span_t = float(tau[-1]) if tau[-1] > 0 else 1.0

    def to_xy(tk: Array, e: Array) -> Array:
        return np.column_stack([left + (right - left) * tk / span_t, bottom + (top - bottom) * (e - lo) / (hi - lo)])

    frame = _rotation_x(np.pi / 2)  # chart x -> world x, chart y -> world z, chart normal -> world -y
    frame[:3, 3] = chart.origin
    base = (*ROOT, "energy")
    lift = 0.004 * layout.size
    panel = mc.geometry.Mesh(_PlaneGeometry(w, h), mc.geometry.MeshBasicMaterial(color=0xFFFFFF))
    commands: list[Any] = [
        mc.commands.SetTransform(frame, _path(mc, base)),
        mc.commands.SetObject(panel, path=_path(mc, (*base, "panel"))),
        mc.commands.SetTransform(_translation([w / 2, h / 2, 0.0]), _path(mc, (*base, "panel"))),
    ]
    axes = np.array([[left, top, lift], [left, bottom, lift], [left, bottom, lift], [right, bottom, lift]])
    commands.append(_line(mc, (*base, "axes"), axes, 0x333333, segments=True))
    for name, series in lines.items():
        xy = to_xy(tau, series)
        commands.append(_line(mc, (*base, name), np.column_stack([xy, np.full(len(xy), lift)]), ENERGY_COLORS[name]))

    labels: list[ChartLabel] = []
    swatches: dict[str, tuple[float, float]] = {}
    # One fixed slot per entry, a third of the width each: a swatch, then its name.
    legend_y, swatch_w, swatch_h, gap = 0.88 * h, 0.05 * w, 0.6 * em, 0.015 * w
    for i, (key, text) in enumerate(CHART_LEGEND if lines else ()):
        slot = 0.03 * w + i * 0.32 * w
        centre = (slot + swatch_w / 2, legend_y)
        swatches[key] = centre
        swatch = mc.geometry.Mesh(
            _PlaneGeometry(swatch_w, swatch_h), mc.geometry.MeshBasicMaterial(color=ENERGY_COLORS[key])
        )
        commands += [
            mc.commands.SetObject(swatch, path=_path(mc, (*base, f"legend_{key}_swatch"))),
            mc.commands.SetTransform(_translation([*centre, lift]), _path(mc, (*base, f"legend_{key}_swatch"))),
        ]
        text_w = _EM_PER_CHAR * em * len(text)
        labels.append(_text_box(f"legend_{key}", text, (slot + swatch_w + gap + text_w / 2, legend_y), em))
    tick_em = 0.9 * em
    for key, text, anchor in (
        ("e_max", f"{hi:.3g} J", top),
        ("e_min", f"{lo:.3g} J", bottom),
    ):
        text_w = _EM_PER_CHAR * tick_em * len(text)
        labels.append(_text_box(key, text, (left - 0.03 * w - text_w / 2, anchor), tick_em))
    labels.append(_text_box("t_min", "0 s", (left, bottom - 0.09 * h), tick_em))
    labels.append(_text_box("t_max", f"{span_t:.3g} s", (right - 0.04 * w, bottom - 0.09 * h), tick_em))
    labels.append(_text_box("t_axis", "t [s]", (0.5 * (left + right), bottom - 0.09 * h), tick_em))
    for label in labels:
        x0, y0, x1, y1 = label.box
        commands += _text(mc, (*base, label.key), label.text, [0.5 * (x0 + x1), 0.5 * (y0 + y1), lift], y1 - y0)
    cursor_xy = to_xy(tau, kinetic + potential) if lines else np.zeros((len(tau), 2))
    cursor = _translations(np.column_stack([cursor_xy, np.full(len(tau), 2 * lift)]))
    sphere = mc.geometry.Mesh(mc.geometry.Sphere(0.03 * h), mc.geometry.MeshBasicMaterial(color=ENERGY_COLORS["E"]))
    commands += [
        mc.commands.SetObject(sphere, path=_path(mc, (*base, "cursor"))),
        mc.commands.SetTransform(cursor[0], _path(mc, (*base, "cursor"))),
    ]
    where = ChartLayout(frame, w, h, (left, bottom, right, top), tuple(labels), swatches)
    return commands, cursor, where


def _translation(xyz: Any) -> Array:
    m = np.eye(4)
    m[:3, 3] = xyz
    return m


def _line(mc: Any, path: tuple[str, ...], xyz: Array, color: int, *, segments: bool = False) -> Any:
    kind = mc.geometry.LineSegments if segments else mc.geometry.Line
    geometry = mc.geometry.PointsGeometry(np.ascontiguousarray(xyz.T, dtype=np.float32))
    return mc.commands.SetObject(kind(geometry, mc.geometry.LineBasicMaterial(color=color)), path=_path(mc, path))


def _text(mc: Any, path: tuple[str, ...], text: str, centre: list[float], glyph: float) -> list[Any]:
    """A label ``glyph`` [m] high (its em), centred on ``centre`` (chart frame).

    meshcat draws the text on a 256 px canvas and shrinks the font when the text is wider;
    the font is chosen here so that it fits, and the plane scaled so the em stays ``glyph``.
    """
    font_px = max(8, min(_TEXT_FONT_PX, int(0.95 * _CANVAS_PX / (_EM_PER_CHAR * max(len(text), 1) * 1.1))))
    size = glyph * _CANVAS_PX / font_px
    # The canvas draws on its middle line (alphabetic baseline): lower the plane by a third of an em.
    x, y, z = centre
    material = mc.geometry.MeshBasicMaterial(
        color=0xFFFFFF, map=_TextTexture(text, font_px), transparent=True, depthWrite=False
    )
    return [
        mc.commands.SetObject(mc.geometry.Mesh(_PlaneGeometry(size, size), material), path=_path(mc, path)),
        mc.commands.SetTransform(_translation([x, y - 0.35 * glyph, z]), _path(mc, path)),
    ]


# --------------------------------------------------------------------------- animation
def _animation(mc: Any, tracks: dict[tuple[str, ...], Array], tau: Array, *, fps: float) -> Any:
    """One meshcat Animation: for each path, position and quaternion keyframes at ``tau * fps``."""
    from meshcat.animation import Animation, AnimationClip, AnimationTrack, js_quaternion

    frames = [float(x) for x in tau * fps]
    animation = Animation(default_framerate=fps)
    for path, placements in tracks.items():
        positions = [[float(c) for c in m[:3, 3]] for m in placements]
        quaternions = [[float(c) for c in js_quaternion(m)] for m in placements]
        position = AnimationTrack("position", "vector3", list(frames), positions)
        quaternion = AnimationTrack("quaternion", "quaternion", list(frames), quaternions)
        animation.clips[_path(mc, path)] = AnimationClip(
            tracks={"position": position, "quaternion": quaternion}, fps=fps, name="default"
        )
    return animation


def _path(mc: Any, entries: tuple[str, ...]) -> Any:
    return mc.path.Path(tuple(entries))


def _set_animation(mc: Any, playback: Playback) -> Any:
    repetitions = float("inf") if playback.loop else 1
    return mc.commands.SetAnimation(playback.animation, play=True, repetitions=repetitions)


def scene_commands(playback: Playback) -> list[Any]:
    """Every meshcat command, in order: the static scene, then the one animation."""
    mc = _meshcat()
    commands = list(playback.commands)
    if playback.animation is not None:
        commands.append(_set_animation(mc, playback))
    return commands


def packed_commands(playback: Playback) -> list[tuple[str, str, bytes]]:
    """(type, path, msgpack bytes) for each command: meshcat's wire format."""
    _meshcat()
    import umsgpack

    out = []
    for command in scene_commands(playback):
        lowered = command.lower()
        out.append((str(lowered["type"]), str(lowered["path"]), umsgpack.packb(lowered)))
    return out


def keyframes(playback: Playback, path: tuple[str, ...]) -> tuple[Array, Array]:
    """The animation's keyframes for ``path``: playback times (k,) [s] and transforms (k, 4, 4).

    Reads the lowered animation back, as the browser receives it.
    """
    if playback.animation is None:
        raise InputError("this playback has no animation (no trajectory was given)")
    lowered = {entry["path"]: entry["clip"] for entry in playback.animation.lower()}
    clip = lowered["/" + "/".join(path)]
    tracks = {track["name"]: track["keys"] for track in clip["tracks"]}
    times = np.array([key["time"] for key in tracks[".position"]], dtype=np.float64) / clip["fps"]
    out = np.tile(np.eye(4), (len(times), 1, 1))
    for k, (pos, quat) in enumerate(zip(tracks[".position"], tracks[".quaternion"], strict=True)):
        x, y, z, w = quat["value"]
        out[k, :3, :3] = _quaternion_matrix(w, x, y, z)
        out[k, :3, 3] = pos["value"]
    return times, out


def _quaternion_matrix(w: float, x: float, y: float, z: float) -> Array:
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


# --------------------------------------------------------------------------- HTML export
def meshcat_javascript() -> str:
    """The text of meshcat's bundled viewer, ``meshcat/viewer/dist/main.min.js``."""
    mc = _meshcat()
    path = Path(mc.__file__).parent / "viewer" / "dist" / "main.min.js"
    if not path.is_file():
        raise MissingDependencyError(f"meshcat is installed without its viewer ({path} is missing): {INSTALL_HINT}")
    return path.read_text(encoding="utf-8")


def _asset(name: str) -> str:
    return resources.files("robodyn.viewer").joinpath("assets", name).read_text(encoding="utf-8")


def _script_safe(text: str) -> str:
    """Text that can sit inside a <script> element (no closing tag, no HTML comment opener)."""
    return text.replace("</", "<\\/").replace("<!--", "<\\!--")


def to_html(playback: Playback, *, title: str | None = None) -> str:
    """One self-contained HTML page that replays ``playback`` offline (no server, no network).

    The page inlines meshcat's JavaScript and the scene commands; meshcat's panel (Open
    Controls -> Animations) has play, pause and the time slider. A text overlay shows the
    simulation time and the total energy in step with the animation. Open the file with
    ``#t=1.5`` appended to its URL to start paused at t = 1.5 s of simulation time.
    """
    commands = [base64.b64encode(data).decode("ascii") for _, _, data in packed_commands(playback)]
    info = {
        "robot": playback.robot_name,
        "t0": float(playback.times[0]) if len(playback.times) else 0.0,
        "speed": playback.speed,
        "tau": [round(float(x), 9) for x in playback.playback_times],
        "energy": [float(x) for x in playback.energy] if len(playback.kinetic) else [],
        "traceFrame": playback.trace_frame,
        "animated": playback.animation is not None,
    }
    fields = {
        "TITLE": html.escape(title or f"robodyn: {playback.robot_name}"),
        "MESHCAT_JS": _script_safe(meshcat_javascript()),
        "COMMANDS_JSON": _script_safe(json.dumps(commands)),
        "INFO_JSON": _script_safe(json.dumps(info)),
        "REPLAY_JS": _script_safe(_asset("replay.js")),
    }
    # One pass, so that nothing inserted is scanned for placeholders again.
    return re.sub(r"\{\{([A-Z_]+)\}\}", lambda m: fields[m.group(1)], _asset("replay.html"))


# --------------------------------------------------------------------------- notebooks
@dataclass(frozen=True, eq=False)
class Replay:
    """What :func:`show` returns: displays itself inline in Jupyter; ``html`` is the standalone page."""

    playback: Playback
    html: str
    height: int = 420
    url: str | None = None

    def _repr_html_(self) -> str:
        if self.url is not None:
            source = f'src="{html.escape(self.url, quote=True)}"'
        else:
            source = f'srcdoc="{html.escape(self.html, quote=True)}"'
        return (
            f'<div style="height: {self.height}px; width: 100%; resize: both; overflow: hidden">'
            f'<iframe {source} style="width: 100%; height: 100%; border: none"></iframe></div>'
        )


def show(
    robot: Robot,
    trajectory: Trajectory | None = None,
    *,
    q: Any = None,
    speed: float = 1.0,
    fps: float = DEFAULT_FPS,
    trace_frame: str | None = None,
    trace: bool = True,
    loop: bool = False,
    zmq_url: str | None = None,
    height: int = 420,
) -> Replay:
    """Show ``robot`` (playing ``trajectory`` if given) inline in a Jupyter notebook.

    Without ``zmq_url`` nothing is started: the returned :class:`Replay` renders the
    self-contained page in an iframe (meshcat's static inline display), so it works offline
    and in exported notebooks. With ``zmq_url`` the scene is also sent to that running
    meshcat server and the iframe shows the server's page. Never blocks.
    """
    playback = build(robot, trajectory, q=q, speed=speed, fps=fps, trace_frame=trace_frame, trace=trace, loop=loop)
    url = None
    if zmq_url is not None:
        client = _Client(zmq_url, timeout_ms=CONNECT_TIMEOUT_MS)
        try:
            url = client.web_url()
            client.send_playback(playback)
        finally:
            client.close()
    return Replay(playback, to_html(playback), height=height, url=url)


# --------------------------------------------------------------------------- live server
class _Client:
    """A ZeroMQ request socket speaking meshcat's protocol, with timeouts."""

    def __init__(self, zmq_url: str, *, timeout_ms: int = REPLY_TIMEOUT_MS) -> None:
        _meshcat()
        import zmq

        self.url = zmq_url
        self.timeout_ms = timeout_ms
        self.socket: Any = zmq.Context.instance().socket(zmq.REQ)
        self.socket.setsockopt(zmq.LINGER, 0)
        self.socket.setsockopt(zmq.RCVTIMEO, timeout_ms)
        self.socket.setsockopt(zmq.SNDTIMEO, timeout_ms)
        try:
            self.socket.connect(zmq_url)
        except zmq.ZMQError as exc:
            self.socket.close()
            raise InputError(f"bad --zmq-url {zmq_url!r} ({exc}); expected e.g. tcp://127.0.0.1:6000") from None

    def _request(self, frames: list[bytes]) -> bytes:
        import zmq

        try:
            self.socket.send_multipart(frames)
            return bytes(self.socket.recv())
        except zmq.Again:
            raise UnavailableError(
                f"no meshcat server answered at {self.url} within {self.timeout_ms / 1000:g} s "
                "(start one with meshcat-server, or leave out --zmq-url to let robodyn start its own)"
            ) from None

    def web_url(self) -> str:
        return self._request([b"url"]).decode("utf-8")

    def send_playback(self, playback: Playback) -> None:
        for kind, path, data in packed_commands(playback):
            reply = self._request([kind.encode(), path.encode(), data])
            if reply != b"ok":
                raise UnavailableError(f"the meshcat server at {self.url} refused a {kind} command: {reply!r}")

    def close(self) -> None:
        self.socket.close()


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _check_port_free(port: int) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("127.0.0.1", port))
        except OSError as exc:
            raise UnavailableError(
                f"port {port} on 127.0.0.1 is in use ({exc.strerror}); pick another --port or leave it out"
            ) from None


class Server:
    """A meshcat server showing a :class:`Playback`: started by robodyn, or one already running.

    Use as a context manager, or call :meth:`close`; ``url`` is the page to open.
    """

    def __init__(self, process: subprocess.Popen[bytes] | None, client: _Client, url: str, log: Any) -> None:
        self.process = process
        self.client = client
        self.url = url
        self._log = log

    @property
    def owned(self) -> bool:
        """True when robodyn started this server (and stops it on :meth:`close`)."""
        return self.process is not None

    def wait(self) -> int:
        """Block until the server process ends (Ctrl-C raises KeyboardInterrupt); return its exit code."""
        if self.process is None:
            return 0
        return int(self.process.wait())

    def close(self) -> None:
        """Disconnect; stop the server if robodyn started it (SIGTERM, then SIGKILL after 5 s)."""
        self.client.close()
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        if self._log is not None:
            self._log.close()
            self._log = None

    def __enter__(self) -> Server:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def serve(playback: Playback, *, zmq_url: str | None = None, port: int | None = None) -> Server:
    """Show ``playback`` in a meshcat server and return it (the animation is sent once).

    Args:
        playback: what to show.
        zmq_url: a running meshcat server's ZeroMQ address (e.g. ``tcp://127.0.0.1:6000``);
            None starts a new server on 127.0.0.1.
        port: the web port of the new server (default: a free one).

    Raises:
        UnavailableError: ``port`` is in use, the server does not start, or nobody answers at ``zmq_url``.
    """
    if zmq_url is not None:
        client = _Client(zmq_url, timeout_ms=CONNECT_TIMEOUT_MS)
        try:
            url = client.web_url()
            client.send_playback(playback)
        except BaseException:
            client.close()
            raise
        return Server(None, client, url, None)
    process, zmq_address, url, log = _start_server(port)
    client = _Client(zmq_address)
    server = Server(process, client, url, log)
    try:
        client.send_playback(playback)
    except BaseException:
        server.close()
        raise
    return server


def _start_server(port: int | None) -> tuple[subprocess.Popen[bytes], str, str, Any]:
    _meshcat()
    web_port = free_port() if port is None else port
    _check_port_free(web_port)
    zmq_port = free_port()
    log = tempfile.TemporaryFile()
    command = [sys.executable, "-u", "-m", "robodyn.viewer", "--zmq-port", str(zmq_port), "--port", str(web_port)]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=log, start_new_session=True)
    lines: list[str] = []
    deadline = time.monotonic() + SERVER_START_TIMEOUT_S
    stdout = cast(IO[bytes], process.stdout)  # stdout=PIPE above
    while len(lines) < 2 and time.monotonic() < deadline:
        ready, _, _ = select.select([stdout], [], [], 0.2)
        if ready:
            line = stdout.readline().decode("utf-8", "replace").strip()
            if line:
                lines.append(line)
            elif process.poll() is not None:
                break
        elif process.poll() is not None:
            break
    urls = dict(line.split("=", 1) for line in lines if "=" in line)
    if "zmq_url" not in urls or "web_url" not in urls:
        if process.poll() is None:
            process.kill()
        process.wait()
        log.seek(0)
        last = [x for x in log.read().decode("utf-8", "replace").splitlines() if x.strip()]
        log.close()
        reason = last[-1] if last else f"no answer within {SERVER_START_TIMEOUT_S:g} s"
        if "in use" in reason.lower():
            raise UnavailableError(f"port {web_port} on 127.0.0.1 is in use; pick another --port or leave it out")
        raise UnavailableError(f"the meshcat server did not start: {reason}")
    stdout.close()
    return process, urls["zmq_url"], urls["web_url"], log


def _run_server(zmq_port: int, web_port: int) -> None:
    """Entry point of the server process: meshcat's bridge on 127.0.0.1, stopping with its parent."""
    from meshcat.servers.zmqserver import ZMQWebSocketBridge
    from tornado.ioloop import PeriodicCallback

    bridge = ZMQWebSocketBridge(zmq_url=f"tcp://127.0.0.1:{zmq_port}", host="127.0.0.1", port=web_port)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    parent = os.getppid()

    def stop_if_orphaned() -> None:
        if os.getppid() != parent:
            bridge.ioloop.stop()

    PeriodicCallback(stop_if_orphaned, 1000).start()
    try:
        bridge.run()
    except KeyboardInterrupt:
        pass
