"""``robodyn view URDF_OR_NAME [TRAJ.npz ...]``: the robot, or its motion, in the browser (meshcat).

With a trajectory the motion is baked into one meshcat animation and sent once; the
browser plays it with meshcat's own time slider and play/pause, beside a panel of charts
(energy, works, power, torques, drift) whose cursor follows the animation. Several
trajectories of one model (up to 8) play together as translucent ghosts, each named by its
file stem. ``--camera`` frames the robot over the motion (fit), follows it (follow) or frames
robot and trace (fixed); by default it follows when the robot travels more than 5 times its
size. ``--html`` writes one
self-contained file that replays offline; otherwise a meshcat server is started on a free
localhost port (or ``--zmq-url`` names a running one) and the command waits for Ctrl-C.

The playback renders (duration / speed) x fps frames: at most :data:`MAX_FRAMES`, refused in
one line before anything is built. The ``--html`` page never goes over the trajectory, the
model's files or any other input.
"""

from __future__ import annotations

import argparse
import sys
import webbrowser
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from robodyn.cli._common import add_model_arguments, file_path, float_list, load_robot, number_in, positive_float
from robodyn.cli._output import check_output_file, refuse_clobbering, writable_path
from robodyn.errors import InputError, UnavailableError
from robodyn.fileio import write_text_atomically
from robodyn.wording import count

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.sim.trajectory import Trajectory
    from robodyn.viewer import Playback


def add_parser(sub: Any) -> None:
    """Register ``robodyn view``."""
    p = sub.add_parser(
        "view",
        help="show a robot, or play a simulated trajectory back, in the browser (meshcat)",
        description="Show a robot in meshcat, or play a trajectory written by 'robodyn simulate --out' back as one "
        "meshcat animation (time slider, play/pause) with the path of a frame and a panel of charts (energy, works, "
        "power, torques, constraint drift; click one to seek). Several trajectories of one model play as ghosts. "
        "--html writes one self-contained HTML file that replays offline; otherwise a meshcat server runs on "
        "127.0.0.1 until Ctrl-C. Exit codes: 0 ok, 2 bad input, 4 meshcat missing, 5 port in use or no server.",
    )
    add_model_arguments(p)
    p.add_argument(
        "trajectory",
        nargs="*",
        type=file_path,
        default=[],
        metavar="TRAJ.npz",
        help="trajectory to play (from robodyn simulate --out); several (at most 8, same model) play together as "
        "ghosts named by their file stems; without one the robot is shown still",
    )
    p.add_argument(
        "--camera",
        choices=("fit", "follow", "fixed"),
        default=None,
        help="fit: frame the robot over the motion; follow: the camera moves with the robot; fixed: frame robot and "
        "trace (default: follow when the robot travels more than 5 times its size, else fit)",
    )
    p.add_argument("--speed", type=positive_float, default=1.0, help="playback speed, 1 = real time (default 1)")
    p.add_argument(
        "--fps",
        type=positive_float,
        default=30.0,
        help=f"rendered frames per second of playback (default 30; at most {MAX_FRAMES:,} frames in all)",
    )
    p.add_argument("--q", type=float_list, default=None, metavar="Q1,Q2,...", help="pose to show without a trajectory")
    p.add_argument(
        "--trace", metavar="FRAME", default=None, help="frame whose path is drawn (default: the one that moves most)"
    )
    p.add_argument("--no-trace", action="store_true", help="draw no frame path")
    p.add_argument(
        "--trace-window",
        type=positive_float,
        default=2.0,
        metavar="S",
        help="the --html page shows the last S seconds of the path, fading behind the cursor (default 2)",
    )
    p.add_argument("--full-trace", action="store_true", help="draw the whole path from the start, not the window")
    add_ground_argument(p)
    p.add_argument(
        "--label",
        type=text_on_name,
        action="append",
        default=[],
        metavar="TEXT=FRAME",
        help="write TEXT beside FRAME in the 3D view of the --html page, e.g. --label A=joint_a (repeatable)",
    )
    p.add_argument(
        "--angle",
        type=text_on_name,
        action="append",
        default=[],
        metavar="TEXT=JOINT",
        help="draw the revolute JOINT's angle as an arc from its zero direction, named TEXT, in the --html page, "
        "e.g. --angle theta=joint_a (repeatable)",
    )
    p.add_argument("--loop", action="store_true", help="repeat the animation forever instead of playing it once")
    p.add_argument(
        "--html", type=file_path, default=None, metavar="OUT.html", help="write a self-contained HTML replay; no server"
    )
    p.add_argument("--open", action="store_true", help="open the page (or the --html file) in the web browser")
    p.add_argument(
        "--zmq-url", default=None, metavar="URL", help="send to a running meshcat server, e.g. tcp://127.0.0.1:6000"
    )
    p.add_argument(
        "--port", type=port_number, default=None, help="web port of the server robodyn starts, 1-65535 (default: free)"
    )
    p.add_argument(
        "--axes", action="store_true", help="show meshcat's world axes (hidden by default: they run through the robot)"
    )
    p.set_defaults(handler=run)


def add_ground_argument(p: Any) -> None:
    """Register ``--ground`` (shared by ``view``, ``simulate --view`` and ``bench --view``)."""
    p.add_argument(
        "--ground",
        action="store_true",
        help="draw a translucent ground plane at the base's height (z = 0) under the robot; nothing collides with it",
    )


def text_on_name(value: str) -> tuple[str, str]:
    """Argparse type: ``TEXT=NAME`` (a label and the frame or joint it is written on)."""
    text, sep, name = value.partition("=")
    if not sep or not text.strip() or not name.strip():
        raise argparse.ArgumentTypeError(f"expected TEXT=NAME (e.g. A=joint_a), got {value!r}")
    return text.strip(), name.strip()


port_number = number_in(integer=True, low=1, high=65535, low_open=False, noun="port number")
"""Argparse type: a TCP port, a whole number from 1 to 65535."""

MAX_FRAMES = 100_000
"""Rendered frames of one playback at most: 55 minutes at 30 fps; each frame holds a pose of every link."""


def check_frame_count(
    duration: float, *, speed: float, fps: float | None, what: str, hint: str = "lower --fps or raise --speed"
) -> None:
    """Raise :class:`InputError` when ``duration`` [s] of motion at ``speed`` and ``fps`` renders too many frames.

    ``fps`` None is the viewer's default; ``what`` names the input that sets the duration and
    ``hint`` says what to change.
    """
    if fps is None:
        from robodyn.viewer.sampling import DEFAULT_FPS

        fps = DEFAULT_FPS
    frames = float(np.floor(duration / speed * fps + 1e-9)) + 1  # as robodyn.viewer.sampling counts them
    if frames > MAX_FRAMES:
        raise InputError(
            f"{what}: {duration:g} s of motion at speed x{speed:g} and {fps:g} frames per second renders "
            f"{frames:.3g} frames; at most {MAX_FRAMES:,} ({hint})"
        )


def open_in_browser(target: str, *, by_hand: str) -> bool:
    """Open ``target`` (a URL) in the web browser; when none opens, say so on stderr and return False.

    ``by_hand`` is what the user should open instead (the URL, or the file's path).
    """
    try:
        opened = webbrowser.open(target)
    except webbrowser.Error:
        opened = False
    if not opened:
        print(f"robodyn: note: no web browser could be opened; open {by_hand} by hand", file=sys.stderr, flush=True)
    return opened


def run(args: argparse.Namespace) -> int:
    """Build the scene, then write the HTML file or serve it until Ctrl-C."""
    from robodyn import viewer
    from robodyn.sim.trajectory import Trajectory
    from robodyn.sim.trajectory_file import check_fits

    if args.html is not None and (args.zmq_url is not None or args.port is not None):
        raise InputError("--html writes a file and starts no server; leave out --zmq-url and --port")
    if args.zmq_url is not None and args.port is not None:
        raise InputError("--port is for the server robodyn starts; with --zmq-url the running server keeps its own")
    from robodyn.viewer.runs import MAX_RUNS

    files: list[Path] = list(args.trajectory)
    if len(files) > MAX_RUNS:
        raise InputError(f"{len(files)} trajectory files given; one replay shows at most {MAX_RUNS} runs")
    given = Path(args.model)
    inputs = [*(("a trajectory", f) for f in files), ("the model", given if given.is_file() else None)]
    refuse_clobbering([("--html", args.html)], [*inputs, ("--srdf", args.srdf)])
    if args.html is not None:
        check_output_file(args.html)  # before the work: a bad path fails in a moment, not after the baking
    loaded = [Trajectory.load(f) for f in files]
    if loaded and args.q is not None:
        raise InputError("--q shows a still pose; leave it out when playing a trajectory")
    if loaded:
        start, end = min(float(tr.t[0]) for tr in loaded), max(float(tr.t[-1]) for tr in loaded)
        what = str(files[0]) if len(files) == 1 else f"{len(files)} runs"
        check_frame_count(end - start, speed=args.speed, fps=args.fps, what=what)
    trajectory = loaded if len(loaded) > 1 else (loaded[0] if loaded else None)
    robot = load_robot(args)
    refuse_clobbering([("--html", args.html)], [("the model's URDF", robot.urdf_path), ("its SRDF", robot.srdf_path)])
    for file, run in zip(files, loaded, strict=True):
        check_fits(run, robot, file)
    playback = viewer.build(
        robot,
        trajectory,
        q=args.q,
        speed=args.speed,
        fps=args.fps,
        trace_frame=args.trace,
        trace=not args.no_trace,
        camera=args.camera,
        names=_stems(files) if len(files) > 1 else None,
        loop=args.loop,
        ground=args.ground,
        axes=args.axes,
        trace_window=None if args.full_trace else args.trace_window,
        labels=dict(args.label),
        angles=dict(args.angle),
    )
    for file, run in zip(files, loaded, strict=True):  # notes once the input is known good: a refusal stays one line
        _note_trajectory(robot, run, file)
    _describe(playback)
    if args.html is not None:
        write_html(playback, args.html, open_browser=args.open)
        return 0
    return serve_playback(playback, open_browser=args.open, zmq_url=args.zmq_url, port=args.port)


def _stems(files: list[Path]) -> list[str]:
    """The runs' names in the legend: the file stems, with the folder when two stems repeat."""
    stems = [f.stem for f in files]
    if len(set(stems)) < len(stems):
        return [str(f.with_suffix("")) for f in files]
    return stems


def serve_and_play(
    robot: Robot,
    trajectory: Trajectory,
    *,
    speed: float = 1.0,
    open_browser: bool = False,
    zmq_url: str | None = None,
    trace_frame: str | None = None,
    ground: bool = False,
) -> int:
    """Play ``trajectory`` in meshcat and block until Ctrl-C; return the exit code (0).

    Starts a meshcat server on a free localhost port (stopped cleanly on Ctrl-C), or sends
    the animation to the running server at ``zmq_url`` and returns at once.

    Raises:
        UnavailableError: the server does not start or nobody answers at ``zmq_url`` (exit 5).
        MissingDependencyError: meshcat is not installed (exit 4).
    """
    from robodyn import viewer

    span = float(trajectory.t[-1] - trajectory.t[0])
    check_frame_count(span, speed=speed, fps=None, what="the trajectory", hint="play a shorter one")
    playback = viewer.build(robot, trajectory, speed=speed, trace_frame=trace_frame, ground=ground)
    _describe(playback)
    return serve_playback(playback, open_browser=open_browser, zmq_url=zmq_url, port=None)


def write_html(playback: Playback, html: Path, *, open_browser: bool) -> Path:
    """Write the self-contained replay page to ``html``, say so, and open it if asked; return its path."""
    from robodyn import viewer

    path = writable_path(html)
    write_text_atomically(path, viewer.to_html(playback))
    print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB): open it in a browser, no server needed")
    if open_browser:
        open_in_browser(path.resolve().as_uri(), by_hand=str(path))
    return path


def serve_playback(playback: Playback, *, open_browser: bool, zmq_url: str | None, port: int | None) -> int:
    """Serve ``playback`` (a server of our own on ``port``, or the one at ``zmq_url``) until Ctrl-C; exit code."""
    from robodyn import viewer

    server = viewer.serve(playback, zmq_url=zmq_url, port=port)
    try:
        print(f"meshcat: open {server.url}", flush=True)
        if open_browser:
            open_in_browser(server.url, by_hand=server.url)
        if not server.owned:
            print(f"sent to the meshcat server at {zmq_url}; it keeps the scene", flush=True)
            return 0
        print("serving; press Ctrl-C to stop", flush=True)
        code = server.wait()
        raise UnavailableError(f"the meshcat server stopped by itself (exit code {code})")
    except KeyboardInterrupt:
        print("stopped the meshcat server", file=sys.stderr, flush=True)
        return 0
    finally:
        server.close()


def _note_trajectory(robot: Robot, trajectory: Trajectory, path: Path) -> None:
    """One line on stderr when the file names another model (its joints are the model's) or ended early."""
    recorded = trajectory.meta.get("model") if isinstance(trajectory.meta, dict) else None
    if isinstance(recorded, dict):
        recorded = recorded.get("name")
    if isinstance(recorded, str) and recorded not in (robot.name, str(robot.urdf_path)):
        print(
            f"robodyn view: note: {path} was simulated with model {recorded!r}, shown on {robot.name!r}",
            file=sys.stderr,
        )
    if trajectory.diverged:
        print(f"robodyn view: note: {path} stops early: {trajectory.message}", file=sys.stderr)


def _describe(playback: Playback) -> None:
    if playback.skipped:
        print(f"robodyn view: note: not drawn (unsupported shape): {', '.join(playback.skipped)}", file=sys.stderr)
    if playback.animation is not None:
        trace = f", tracing frame {playback.trace_frame!r}" if playback.trace_frame else ""
        runs = f", {len(playback.runs)} runs" if len(playback.runs) > 1 else ""
        print(
            f"{playback.robot_name}: {count(playback.n_frames, 'frame')}, {playback.duration:.2f} s of playback "
            f"at x{playback.speed:g}{trace}{runs}, camera {playback.camera_mode}",
            flush=True,
        )
