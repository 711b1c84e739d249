"""A robot's scene and its motion baked into a :class:`Playback`: what every way of showing it sends.

:func:`build` samples the trajectories (one run, or up to eight overlaid as ghosts) on the
playback grid, places the robot's shapes at every rendered frame, draws the traces, frames
the robot with the camera (fit, follow or fixed), computes the chart panel's curves, and
bakes the motion into one meshcat animation. Nothing is sent anywhere: the HTML export, the server
and the notebook view all show the same :class:`Playback`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.viewer.animation import bake_animation
from robodyn.viewer.backend import ROOT, import_meshcat, scene_path
from robodyn.viewer.camera import Framing, follow_tracks, frame_motion, view_commands
from robodyn.viewer.forces import Arrow, Impact, joint_arrows, mode_marks, stop_impacts
from robodyn.viewer.geometry import SceneObject, geometry_objects, object_commands
from robodyn.viewer.ground import Ground, below_ground, ground_commands, ground_slab
from robodyn.viewer.labels import AngleMark, PointLabel, angle_marks, point_labels
from robodyn.viewer.panel import Chart, panel_charts
from robodyn.viewer.runs import GHOST_OPACITY, RUN_COLORS, Run, check_runs, common_frames, mark_identical, run_names
from robodyn.viewer.sampling import DEFAULT_FPS, check_rate
from robodyn.viewer.springs import Coil, coil_commands, spring_coils
from robodyn.viewer.trace import (
    DEFAULT_TRACE_WINDOW_S,
    MARKER_PATH,
    TRACE_COLOR,
    choose_trace_frame,
    dense_path,
    dense_rows,
    frame_positions,
    trace_commands,
)
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
        objects: the link geometries of the first run, in Pinocchio's geometry order.
        commands: meshcat commands that build the static scene, in send order.
        animation: the whole motion as one ``meshcat.animation.Animation`` (None without a trajectory).
        loop: repeat the animation forever (else it plays once).
        sample_index: the first run's trajectory rows shown, one per rendered frame, shape (k,).
        times: simulation time of each rendered frame [s], shape (k,).
        playback_times: time of each rendered frame in the browser [s], (times - times[0]) / speed.
        kinetic, potential: the first run's T and V at the rendered frames [J], shape (k,) (empty without).
        trace_frame: name of the frame whose path is drawn, or None.
        trace: that frame's world positions at every rendered frame (first run) [m], shape (k, 3).
        offsets: translation applied to the whole drawing at each rendered frame [m], shape (k, 3):
            constant but in follow mode, where it keeps the robot at the camera's target.
        camera_position: meshcat camera position in world coordinates (z up) [m]; it looks at the origin.
        framing: the camera mode and the box it frames.
        speed, fps: playback speed and rendered frames per second.
        skipped: names of geometries that could not be drawn (unsupported shape).
        runs: every run (name, colour, rows shown); one for a single trajectory, none for a still pose.
        ghosts: the objects of every run (``ghosts[0]`` is ``objects``).
        traces: every run's traced positions (k, 3) [m].
        charts: the chart panel's charts (empty without a trajectory or with ``charts=False``).
        ground: the ground slab under the robot, its top face at the base's plane (None unless asked).
        trace_window: simulation time of trace the page keeps behind the cursor [s] (None: the whole trace).
        trace_times: every run's trace-line points' playback times [s], shape (m,) each.
        springs: the first run's sprung revolute joints, each drawn as a coil riding on its frame.
        labels: texts written beside frames of the first run (e.g. a textbook figure's A, B, C).
        angles: joint angles of the first run drawn as arcs from their zero direction, with their texts.
        arrows: the first run's applied forces and torques, drawn where they act (viewer.forces).
        impacts: the first run's hits on its stops, flashed on the joint that hit.
        mode: the controller's mode per rendered frame and where the page writes it (None without a record).
        notes: sentences the page adds to its overlay (what passes through the ground plane).
        axes: meshcat's world axes are shown (off by default: they run through the robot).
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
    offsets: Array
    camera_position: Array
    framing: Framing
    speed: float
    fps: float
    skipped: tuple[str, ...] = ()
    runs: tuple[Run, ...] = ()
    ghosts: tuple[tuple[SceneObject, ...], ...] = ()
    traces: tuple[Array, ...] = ()
    charts: tuple[Chart, ...] = ()
    ground: Ground | None = None
    trace_window: float | None = DEFAULT_TRACE_WINDOW_S
    trace_times: tuple[Array, ...] = ()
    springs: tuple[Coil, ...] = ()
    labels: tuple[PointLabel, ...] = ()
    angles: tuple[AngleMark, ...] = ()
    arrows: tuple[Arrow, ...] = ()
    impacts: tuple[Impact, ...] = ()
    mode: dict[str, Any] | None = None
    notes: tuple[str, ...] = ()
    axes: bool = False

    @property
    def offset(self) -> Array:
        """The drawing's shift at the first rendered frame [m], shape (3,) (see ``offsets``)."""
        return self.offsets[0]

    @property
    def camera_mode(self) -> str:
        """The camera mode: fit, follow or fixed."""
        return self.framing.mode

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


def _as_runs(trajectory: Trajectory | Sequence[Trajectory] | None) -> list[Trajectory]:
    if trajectory is None:
        return []
    if isinstance(trajectory, (list, tuple)):
        return list(trajectory)
    return [trajectory]  # type: ignore[list-item]


def build(
    robot: Robot,
    trajectory: Trajectory | Sequence[Trajectory] | None = None,
    *,
    q: Any = None,
    speed: float = 1.0,
    fps: float = DEFAULT_FPS,
    trace_frame: str | None = None,
    trace: bool = True,
    charts: bool = True,
    camera: str | None = None,
    names: Sequence[str] | None = None,
    loop: bool = False,
    geometry: pin.GeometryModel | None = None,
    ground: bool = False,
    trace_window: float | None = DEFAULT_TRACE_WINDOW_S,
    labels: Mapping[str, str] | None = None,
    angles: Mapping[str, str] | None = None,
    axes: bool = False,
) -> Playback:
    """Bake ``robot`` and, if given, its motion into a :class:`Playback` (no server, no browser).

    Args:
        robot: the model; its visual geometry is loaded here (meshes are parsed only now).
        trajectory: the motion to play, or a list of up to 8 runs of the same model (overlaid
            as translucent ghosts, each in its own colour, on the union of their time spans);
            each ``q`` must have ``robot.nq`` columns.
        q: without a trajectory, the configuration to show (default: neutral), shape (nq,).
        speed: playback speed (1 = real time).
        fps: rendered frames per second of playback.
        trace_frame: frame whose path is drawn; None picks the frame that travels farthest.
        trace: draw the trace at all.
        trace_window: the replay page shows only this much simulation time [s] of the trace, up
            to the animation's time and fading behind it; None draws the whole trace (meshcat's
            own page, on a live server, always draws the whole trace).
        charts: compute the chart panel (energy, ledger, power, torques, drift) the page shows.
        camera: "fit" (the robot over the motion), "follow" (the camera moves with the robot),
            "fixed" (the robot and its trace); None: follow when the robot travels more than
            5 times its size, else fit.
        names: the runs' names in the legend (default: each run's integrator).
        loop: repeat the animation forever instead of playing it once.
        geometry: an already loaded visual ``GeometryModel`` (default: loaded from the URDF).
        ground: draw a translucent ground slab whose top face is the base's plane (z = 0 of the
            model's world frame), wide enough to lie under the robot over the whole motion.
        labels: text -> frame name: the page writes each text beside its frame (the first run's),
            e.g. ``{"A": "joint_a", "B": "joint_b", "C": "collar"}``; shown by the ``--html`` page.
        angles: text -> revolute joint: the page draws the joint's angle as an arc from the
            direction its child points at zero angle (a dashed ray) to where it points now,
            with the text beside it, e.g. ``{"θ": "joint_a"}``; shown by the ``--html`` page.
        axes: show meshcat's world axes (hidden by default: they run through the robot).

    Raises:
        InputError: a trajectory that does not fit the model, runs of different models, more
            than 8 runs, or a bad speed/fps.
        UnknownNameError: a ``trace_frame`` or label's frame or angle's joint the model does not
            have, or an unknown camera mode.
        MissingDependencyError: meshcat is not installed.
    """
    mc = import_meshcat()
    _check_rates(speed, fps, trace_window)
    trajectories, runs, times, configurations = _runs(robot, trajectory, q, names, speed=speed, fps=fps)
    ghost_objects, ghost_geoms, skipped = _geometry(robot, geometry, configurations)
    frames = [frame_positions(robot, configs) for configs in configurations]
    chosen = choose_trace_frame(frames[0], trace_frame) if trace and trajectories else None
    traces = [f[chosen] if chosen is not None else np.zeros((0, 3)) for f in frames]
    playback_times = (times - times[0]) / speed
    shapes = [obj for objs in ghost_objects for obj in objs]
    framing = frame_motion(shapes, np.concatenate([*traces, np.zeros((0, 3))]), len(times), mode=camera)

    commands, tracks = _object_commands(mc, runs, ghost_objects, ghost_geoms)
    trace_times = _add_traces(mc, robot, runs, chosen, traces, framing, (times[0], speed), commands, tracks)
    coils = _add_coils(mc, robot, runs, configurations[0], framing.size, commands, tracks)
    marks = (point_labels(robot, labels, frames[0]), angle_marks(robot, angles, configurations[0], framing.size))
    slab = ground_slab(framing.centres, framing.half, framing.size) if ground else None
    if slab is not None:
        commands += ground_commands(mc, slab)
    commands += view_commands(mc, framing, axes=axes)
    tracks.update(follow_tracks(framing))
    animation = bake_animation(mc, tracks, playback_times, fps=fps) if trajectories else None
    first = runs[0] if runs else None
    chart_list = panel_charts(robot, runs) if charts and runs else []
    arrows, impacts, mode, notes = _physics_marks(robot, runs, configurations, frames, framing, ground=slab is not None)
    return Playback(
        robot_name=robot.name,
        objects=tuple(ghost_objects[0]),
        commands=tuple(commands),
        animation=animation,
        loop=loop,
        sample_index=first.index if first is not None else np.zeros(1, dtype=np.int64),
        times=times,
        playback_times=playback_times,
        kinetic=_energy_rows(first, "kinetic"),
        potential=_energy_rows(first, "potential"),
        trace_frame=chosen,
        trace=traces[0],
        offsets=framing.offsets,
        camera_position=framing.camera,
        framing=framing,
        speed=float(speed),
        fps=float(fps),
        skipped=tuple(skipped),
        runs=tuple(runs),
        ghosts=tuple(tuple(objs) for objs in ghost_objects),
        traces=tuple(traces),
        charts=tuple(chart_list),
        ground=slab,
        trace_window=None if trace_window is None else float(trace_window),
        trace_times=tuple(trace_times),
        springs=tuple(coils),
        labels=tuple(marks[0]),
        angles=tuple(marks[1]),
        arrows=tuple(arrows),
        impacts=tuple(impacts),
        mode=mode,
        notes=tuple(notes),
        axes=axes,
    )


def _check_rates(speed: float, fps: float, trace_window: float | None) -> None:
    """Refuse a non-positive or non-finite speed, frame rate or trace window (InputError)."""
    check_rate("speed", speed)
    if trace_window is not None:
        check_rate("trace_window", trace_window)
    check_rate("fps", fps)


def _physics_marks(
    robot: Robot, runs: list[Run], configurations: Any, frames: Any, framing: Any, *, ground: bool
) -> tuple[list[Any], list[Any], Any, Any]:
    """The first run's physics drawn: force arrows, stop impacts, the controller's mode, what passes the ground."""
    if not runs:
        return [], [], None, ()
    arrows = joint_arrows(robot, runs[0], configurations[0], framing.size)
    impacts = stop_impacts(robot, runs[0], configurations[0])
    mode = mode_marks(runs[0], framing.centres, framing.half)
    notes = below_ground(frames[0]) if ground else ()
    return arrows, impacts, mode, notes


def _energy_rows(run: Run | None, name: str) -> Array:
    """The run's T or V at its rendered rows [J], or empty when it does not carry one per sample."""
    if run is None:
        return np.zeros(0)
    values = np.asarray(getattr(run.trajectory, name), dtype=np.float64)
    return values[run.index] if values.shape == np.shape(run.trajectory.t) else np.zeros(0)


def _runs(
    robot: Robot, trajectory: Any, q: Any, names: Sequence[str] | None, *, speed: float, fps: float
) -> tuple[list[Trajectory], list[Run], Array, list[Array]]:
    """(the trajectories, their runs, the frames' simulation times, each run's configuration per frame)."""
    trajectories = _as_runs(trajectory)
    run_labels = run_names(trajectories, names)
    if trajectories:
        check_runs(robot, trajectories, run_labels)
        times, indices = common_frames(trajectories, speed=speed, fps=fps)
        colors = [TRACE_COLOR] if len(trajectories) == 1 else list(RUN_COLORS)
        shown = mark_identical(trajectories, run_labels)
        runs = [Run(n, c, tr, ix) for n, c, tr, ix in zip(shown, colors, trajectories, indices, strict=False)]
        configurations = [np.asarray(run.trajectory.q, dtype=np.float64)[run.index] for run in runs]
    else:
        runs = []
        q0 = robot.neutral() if q is None else robot.q_(q)
        times, configurations = np.zeros(1), [q0[None, :]]
    return trajectories, runs, times, configurations


def _geometry(robot: Robot, geometry: Any, configurations: list[Array]) -> tuple[list[Any], list[Any], list[str]]:
    """Each run's scene objects and geometries (the first the robot, the others ghosts), and the shapes skipped."""
    ghost_objects: list[list[SceneObject]] = []
    ghost_geoms: list[list[Any]] = []
    skipped: list[str] = []
    for r, configs in enumerate(configurations):
        objects, geoms, skipped = geometry_objects(robot, geometry, configs, group="robot" if r == 0 else f"ghost{r}")
        ghost_objects.append(objects)
        ghost_geoms.append(geoms)
    return ghost_objects, ghost_geoms, skipped


def _add_traces(
    mc: Any,
    robot: Robot,
    runs: list[Run],
    chosen: str | None,
    traces: list[Array],
    framing: Any,
    clock: tuple[float, float],
    commands: list[Any],
    tracks: dict[tuple[str, ...], Array],
) -> list[Array]:
    """Add each run's trace (its commands, its marker's track); return the traces' playback times."""
    start, speed = clock
    trace_times: list[Array] = []
    if chosen is not None:
        for r, run in enumerate(runs):
            t = np.asarray(run.trajectory.t, dtype=np.float64)
            trace_times.append((t[dense_rows(len(t))] - start) / speed)
            dense = dense_path(robot, run.trajectory, chosen)
            group = "trace" if r == 0 else f"trace{r}"
            commands += trace_commands(mc, dense, traces[r], framing.size, color=run.color, group=group)
            tracks[MARKER_PATH if r == 0 else (*ROOT, group, "marker")] = translations(traces[r])
    return trace_times


def _object_commands(
    mc: Any, runs: list[Run], ghost_objects: list[list[Any]], ghost_geoms: list[list[Any]]
) -> tuple[list[Any], dict[tuple[str, ...], Array]]:
    """(the commands that clear the scene and set each run's objects, tinted when there are ghosts; their tracks)."""
    commands: list[Any] = [mc.commands.Delete(scene_path(mc, ROOT))]
    tracks: dict[tuple[str, ...], Array] = {}
    for r, (objects, geoms) in enumerate(zip(ghost_objects, ghost_geoms, strict=True)):
        tint = (runs[r].color, GHOST_OPACITY) if len(runs) > 1 else None
        for obj, geom in zip(objects, geoms, strict=True):
            commands += object_commands(mc, obj, geom, tint=tint)
            tracks[obj.path] = obj.placements
    return commands, tracks


def _add_coils(
    mc: Any,
    robot: Robot,
    runs: list[Run],
    configurations: Array,
    size: float,
    commands: list[Any],
    tracks: dict[tuple[str, ...], Array],
) -> list[Any]:
    """Add the first run's springs as coils (commands and tracks); return the coils."""
    meta = runs[0].trajectory.meta if runs and isinstance(runs[0].trajectory.meta, dict) else {}
    coils = spring_coils(robot, meta.get("springs"), configurations, size) if runs else []
    for coil in coils:
        commands += coil_commands(mc, coil)
        tracks[coil.path] = coil.placements
    return coils
