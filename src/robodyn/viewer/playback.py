"""A robot's scene and its motion baked into a :class:`Playback`: what every way of showing it sends.

:func:`build` samples the trajectory on the playback grid, places the robot's shapes at
every rendered frame, draws the trace and the energy chart, frames the whole, and bakes the
motion into one meshcat animation. Nothing is sent anywhere: the HTML export, the server
and the notebook view all show the same :class:`Playback`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.viewer.animation import bake_animation
from robodyn.viewer.backend import ROOT, import_meshcat, scene_path
from robodyn.viewer.chart3d import CURSOR_PATH, ChartLayout, chart_commands
from robodyn.viewer.geometry import SceneObject, geometry_objects, object_commands
from robodyn.viewer.layout import Layout, view_commands
from robodyn.viewer.sampling import DEFAULT_FPS, check_rate, rendered_frames
from robodyn.viewer.trace import MARKER_PATH, choose_trace_frame, dense_path, frame_positions, trace_commands
from robodyn.viewer.transforms import translations

if TYPE_CHECKING:
    import pinocchio as pin

    from robodyn.robot import Robot
    from robodyn.sim.trajectory import Trajectory

Array = NDArray[np.float64]


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
    mc = import_meshcat()
    check_rate("speed", speed)
    check_rate("fps", fps)
    configurations, index, times, kinetic, potential = rendered_frames(robot, trajectory, q, speed=speed, fps=fps)
    objects, geoms, skipped = geometry_objects(robot, geometry, configurations)
    frames = frame_positions(robot, configurations)
    chosen = choose_trace_frame(frames, trace_frame) if trace and trajectory is not None else None
    trace_xyz = frames[chosen] if chosen is not None else np.zeros((0, 3))
    playback_times = (times - times[0]) / speed

    layout = Layout.fit(objects, trace_xyz, with_chart=energy_chart and trajectory is not None)
    commands: list[Any] = [mc.commands.Delete(scene_path(mc, ROOT))]
    tracks: dict[tuple[str, ...], Array] = {}
    for obj, geom in zip(objects, geoms, strict=True):
        commands += object_commands(mc, obj, geom)
        tracks[obj.path] = obj.placements
    if chosen is not None:
        dense = dense_path(robot, trajectory, chosen) if trajectory is not None else trace_xyz
        commands += trace_commands(mc, dense, trace_xyz, layout.size)
        tracks[MARKER_PATH] = translations(trace_xyz)
    if layout.chart is not None:
        chart_part, cursor, chart_layout = chart_commands(mc, layout, playback_times, kinetic, potential)
        commands += chart_part
        tracks[CURSOR_PATH] = cursor
    else:
        chart_layout = None
    commands += view_commands(mc, layout)
    animation = None
    if trajectory is not None:
        animation = bake_animation(mc, tracks, playback_times, fps=fps)
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
