"""The camera: which box it frames (the robot over the motion, or the robot as it travels) and from where.

meshcat's perspective camera has a 75 degree vertical field of view and orbits the origin;
robodyn shifts everything it draws (and meshcat's grid and axes) so that the framed box is
centred there, and backs the camera off until that box spans :data:`FRAME_FRACTION` of the
3D pane. Three modes, chosen with ``camera=`` (``robodyn view --camera``):

* ``fit``: the bounding box of the robot's moving shapes over the whole motion (not its trace,
  nor the static scenery such as a cart's long rail: the robot fills the view);
* ``follow``: a box the size of the largest the robot occupies at any one frame, centred on
  the robot at every frame: the shift is animated with the robot, so the robot stays in view
  while the ground (meshcat's grid, shifted by the remainder of its cell) and the trace
  scroll past;
* ``fixed``: the robot and its trace over the whole motion, still (robodyn's first framing).

By default (``camera=None``) the mode is ``follow`` when the robot travels more than
:data:`FOLLOW_RATIO` times its own size (the range of its box's centre against the largest
side of its box at one frame), else ``fit``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import UnknownNameError
from robodyn.viewer.backend import ROOT, scene_path
from robodyn.viewer.geometry import SceneObject
from robodyn.viewer.transforms import translations

Array = NDArray[np.float64]

CAMERA_MODES = ("fit", "fixed", "follow")
CAMERA_FOV_DEG = 75.0
CAMERA_DIRECTION = np.array([0.15, -1.0, 0.3]) / np.linalg.norm([0.15, -1.0, 0.3])
PANE_ASPECT = 1.0
"""Width / height of the 3D pane the framing is computed for (the page keeps the pane at least this wide)."""
FRAME_FRACTION = 0.7
"""The framed box, projected, spans this fraction of the pane's height or width (the larger of the two)."""
FOLLOW_RATIO = 5.0
"""Default mode: follow when the robot's travel exceeds this many times its own size."""
GRID_CELL = 0.5
"""meshcat's grid: 20 m square in 40 cells; follow mode shifts it by the remainder of a cell."""
GRID_PATH = ("Grid",)
AXES_PATH = ("Axes",)
_MIN_SIZE = 0.2  # [m]: the smallest box framed (a still point robot still gets a view)


@dataclass(frozen=True)
class Framing:
    """What the camera frames, and the shift that puts it at the origin, per rendered frame.

    Attributes:
        mode: "fit", "follow" or "fixed".
        centres: centre of the framed box at each rendered frame (world [m]), shape (k, 3).
        half: half-sides of the framed box [m], shape (3,).
        camera: camera position (world, z up) [m]; it looks at the origin.
        size: scale of markers and dots [m] (the largest side of the robot's box, at least 0.2 m).
    """

    mode: str
    centres: Array
    half: Array
    camera: Array
    size: float

    @property
    def offsets(self) -> Array:
        """The shift applied to the drawing at each rendered frame [m], shape (k, 3)."""
        return -self.centres

    @property
    def animated(self) -> bool:
        """True when the shift changes over the playback (follow mode on a moving robot)."""
        return bool(np.ptp(self.centres, axis=0).max() > 0) if len(self.centres) > 1 else False


def robot_boxes(objects: list[SceneObject], k: int) -> tuple[Array, Array]:
    """The robot's axis-aligned box at each rendered frame: low and high corners (k, 3) [m]."""
    low, high = np.full((k, 3), np.inf), np.full((k, 3), -np.inf)
    for obj in objects:
        corners = np.einsum("kij,cj->kci", obj.placements[:, :3, :3], obj.corners) + obj.placements[:, None, :3, 3]
        low, high = np.minimum(low, corners.min(axis=1)), np.maximum(high, corners.max(axis=1))
    if not np.all(np.isfinite(low)):
        low, high = np.full((k, 3), -0.1), np.full((k, 3), 0.1)
    return low, high


def default_mode(low: Array, high: Array) -> str:
    """``follow`` when the box centre travels more than FOLLOW_RATIO box sizes, else ``fit``."""
    size = max(float(np.max(high - low)), _MIN_SIZE)
    travel = float(np.max(np.ptp(0.5 * (low + high), axis=0)))
    return "follow" if travel > FOLLOW_RATIO * size else "fit"


def frame_motion(objects: list[SceneObject], trace: Array, k: int, *, mode: str | None) -> Framing:
    """Frame ``objects`` over their ``k`` rendered placements (and the ``trace`` (m, 3) in fixed mode).

    Raises:
        UnknownNameError: a ``mode`` other than fit, follow, fixed or None.
    """
    moving = [obj for obj in objects if len(obj.placements) > 1 and np.ptp(obj.placements, axis=0).max() > 0]
    low, high = robot_boxes(moving or objects, k)
    if mode is None:
        mode = default_mode(low, high)
    if mode not in CAMERA_MODES:
        raise UnknownNameError("camera mode", mode, CAMERA_MODES)
    size = max(float(np.max(high - low)), _MIN_SIZE)
    if mode == "follow":
        half = np.maximum(0.5 * np.max(high - low, axis=0), 0.5 * _MIN_SIZE)
        centres = 0.5 * (low + high)
    else:
        lo, hi = low.min(axis=0), high.max(axis=0)
        if mode == "fixed" and len(trace):
            lo, hi = np.minimum(lo, trace.min(axis=0)), np.maximum(hi, trace.max(axis=0))
            size = max(size, float(np.max(hi - lo)))
        half = np.maximum(0.5 * (hi - lo), 0.5 * _MIN_SIZE)
        centres = np.tile(0.5 * (lo + hi), (k, 1))
    return Framing(mode, centres, half, camera_distance(half) * CAMERA_DIRECTION, size)


def project_ndc(eye: Array, points: Array, *, aspect: float = PANE_ASPECT) -> Array:
    """Normalised device coordinates (m, 2) of ``points`` (m, 3), seen from ``eye`` looking at the origin."""
    forward = -eye / np.linalg.norm(eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.asarray(points) - eye
    depth = d @ forward
    tan_half = np.tan(np.radians(CAMERA_FOV_DEG / 2))
    return np.column_stack([(d @ right) / (depth * tan_half * aspect), (d @ up) / (depth * tan_half)])


def box_corners(half: Array) -> Array:
    """The 8 corners (8, 3) of the box of half-sides ``half`` centred on the origin."""
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=np.float64)
    return signs * half


def camera_distance(half: Array) -> float:
    """Distance along CAMERA_DIRECTION at which the box (centred on the origin) spans FRAME_FRACTION.

    The span is the larger of the projected box's height and width over the pane's; it
    shrinks as the camera backs off, so a bisection finds the distance.
    """
    corners = box_corners(half)
    near, far = float(np.linalg.norm(half)) * 1.001, float(np.linalg.norm(half)) * 1e3
    for _ in range(100):
        mid = 0.5 * (near + far)
        ndc = project_ndc(mid * CAMERA_DIRECTION, corners)
        span = max(float(np.ptp(ndc[:, 0])), float(np.ptp(ndc[:, 1]))) / 2
        near, far = (mid, far) if span > FRAME_FRACTION else (near, mid)
    return 0.5 * (near + far)


def view_commands(mc: Any, framing: Framing, *, axes: bool = False) -> list[Any]:
    """The commands that shift the drawing (and meshcat's grid and axes) at the first frame and place the camera.

    meshcat's world axes are hidden unless ``axes``: at the origin they run through the robot
    (through the linkage's angle label, up a Pendubot's link like a target line).
    """
    shift = np.eye(4)
    shift[:3, 3] = framing.offsets[0]
    x, y, z = framing.camera
    return [
        mc.commands.SetTransform(shift, scene_path(mc, ROOT)),
        mc.commands.SetTransform(grid_shifts(framing.offsets[:1])[0], mc.path.Path(GRID_PATH)),
        mc.commands.SetTransform(shift, mc.path.Path(AXES_PATH)),
        mc.commands.SetProperty("visible", bool(axes), mc.path.Path(AXES_PATH)),
        # The camera lives in meshcat's y-up frame: world (x, y, z) is (x, z, -y) there.
        mc.commands.SetProperty("position", [float(x), float(z), float(-y)], _camera_path(mc)),
    ]


def grid_shifts(offsets: Array) -> Array:
    """The grid's placements (k, 4, 4): the vertical shift, and the horizontal one modulo a cell."""
    shifted = np.array(offsets, dtype=np.float64)
    shifted[:, :2] = np.remainder(shifted[:, :2] + GRID_CELL / 2, GRID_CELL) - GRID_CELL / 2
    return translations(shifted)


def follow_tracks(framing: Framing) -> dict[tuple[str, ...], Array]:
    """The animated placements that make the camera follow: the drawing's shift and the grid's."""
    if not framing.animated:
        return {}
    shifts = translations(framing.offsets)
    return {ROOT: shifts, GRID_PATH: grid_shifts(framing.offsets), AXES_PATH: shifts}


def _camera_path(mc: Any) -> Any:
    return mc.path.Path(("Cameras", "default", "rotated", "<object>"))
