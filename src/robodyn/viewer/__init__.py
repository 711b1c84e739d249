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
riding on the frame). The camera frames the robot over the motion (``fit``), follows it
when it travels far (``follow``), or frames robot and trace (``fixed``). Beside the 3D
pane, a panel of charts (energy, the ledger's works, power, joint torques against their
effort limits, constraint drift) has a cursor that moves with the animation; clicking a
chart seeks it. Up to 8 runs of one model play together as translucent ghosts, each in its
own colour with its own trace and curves.

The modules, in the order data flows through them:

* ``backend``: the lazy meshcat import and the scene-tree root; ``transforms``: 4 x 4 helpers;
* ``sampling``: the playback time grid (which trajectory rows become rendered frames);
* ``geometry``: the robot's shapes and their placements; ``trace``: the path of one frame;
* ``runs``: several runs checked, named, coloured and put on one time grid;
* ``springs``: a coil at each sprung revolute joint of a run with springs;
* ``palette``: the Okabe–Ito colours every curve, link, run and arrow takes;
* ``ground``: the optional ground slab at the base's plane (``build(..., ground=True)``) and what goes below it;
* ``forces``: force and torque arrows where they act, stop hits, the controller's mode in 3D;
* ``camera``: the framed box, the centring shift (animated in follow mode) and the camera;
* ``panel``: the chart panel's curves and units (drawn by ``assets/replay.js``);
* ``animation``: the one meshcat Animation; ``playback``: :func:`build` and :class:`Playback`;
* ``packing``: the commands in meshcat's wire format; ``html_export``: :func:`to_html`;
* ``server``: :func:`serve` and the server process (``python -m robodyn.viewer``);
* ``notebook``: :func:`show` and :class:`Replay`.

Only this package imports meshcat, and only inside functions: ``import robodyn`` stays
light, and dynamics-only work never loads geometry or parses meshes.
"""

from robodyn.viewer.backend import INSTALL_HINT, ROOT
from robodyn.viewer.camera import CAMERA_DIRECTION, CAMERA_FOV_DEG, CAMERA_MODES, FRAME_FRACTION, PANE_ASPECT
from robodyn.viewer.geometry import BASE_COLOR, LINK_COLORS, SceneObject
from robodyn.viewer.html_export import meshcat_javascript, to_html
from robodyn.viewer.notebook import Replay, show
from robodyn.viewer.packing import keyframes, packed_commands, scene_commands
from robodyn.viewer.panel import CURSOR_COLOR, ENERGY_COLORS, PANEL_WIDTH_PX, PLOT_MARGINS_PX
from robodyn.viewer.playback import Playback, build
from robodyn.viewer.runs import GHOST_OPACITY, MAX_RUNS, RUN_COLORS
from robodyn.viewer.sampling import DEFAULT_FPS, check_trajectory, render_samples
from robodyn.viewer.server import (
    CONNECT_TIMEOUT_MS,
    REPLY_TIMEOUT_MS,
    SERVER_START_TIMEOUT_S,
    Server,
    free_port,
    serve,
)
from robodyn.viewer.trace import DEFAULT_TRACE_WINDOW_S, MAX_TRACE_POINTS, TRACE_COLOR, frame_path_lengths

__all__ = [
    "BASE_COLOR",
    "CAMERA_DIRECTION",
    "CAMERA_FOV_DEG",
    "CAMERA_MODES",
    "CONNECT_TIMEOUT_MS",
    "CURSOR_COLOR",
    "DEFAULT_FPS",
    "DEFAULT_TRACE_WINDOW_S",
    "ENERGY_COLORS",
    "FRAME_FRACTION",
    "GHOST_OPACITY",
    "INSTALL_HINT",
    "LINK_COLORS",
    "MAX_RUNS",
    "MAX_TRACE_POINTS",
    "PANEL_WIDTH_PX",
    "PANE_ASPECT",
    "PLOT_MARGINS_PX",
    "REPLY_TIMEOUT_MS",
    "ROOT",
    "RUN_COLORS",
    "SERVER_START_TIMEOUT_S",
    "TRACE_COLOR",
    "Playback",
    "Replay",
    "SceneObject",
    "Server",
    "build",
    "check_trajectory",
    "frame_path_lengths",
    "free_port",
    "keyframes",
    "meshcat_javascript",
    "packed_commands",
    "render_samples",
    "scene_commands",
    "serve",
    "show",
    "to_html",
]
