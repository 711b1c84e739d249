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

The modules, in the order data flows through them:

* ``backend``: the lazy meshcat import and the scene-tree root; ``transforms``: 4 x 4 helpers;
* ``sampling``: the playback time grid (which trajectory rows become rendered frames);
* ``geometry``: the robot's shapes and their placements; ``trace``: the path of one frame;
* ``layout``: the chart's place, the centring shift and the camera; ``chart3d``: the energy chart;
* ``animation``: the one meshcat Animation; ``playback``: :func:`build` and :class:`Playback`;
* ``packing``: the commands in meshcat's wire format; ``html_export``: :func:`to_html`;
* ``server``: :func:`serve` and the server process (``python -m robodyn.viewer``);
* ``notebook``: :func:`show` and :class:`Replay`.

Only this package imports meshcat, and only inside functions: ``import robodyn`` stays
light, and dynamics-only work never loads geometry or parses meshes.
"""

from robodyn.viewer.backend import INSTALL_HINT, ROOT
from robodyn.viewer.chart3d import CHART_LEGEND, ENERGY_COLORS, ChartLabel, ChartLayout
from robodyn.viewer.geometry import BASE_COLOR, LINK_COLORS, SceneObject
from robodyn.viewer.html_export import meshcat_javascript, to_html
from robodyn.viewer.layout import CAMERA_DIRECTION, CAMERA_FOV_DEG
from robodyn.viewer.notebook import Replay, show
from robodyn.viewer.packing import keyframes, packed_commands, scene_commands
from robodyn.viewer.playback import Playback, build
from robodyn.viewer.sampling import DEFAULT_FPS, check_trajectory, render_samples
from robodyn.viewer.server import (
    CONNECT_TIMEOUT_MS,
    REPLY_TIMEOUT_MS,
    SERVER_START_TIMEOUT_S,
    Server,
    free_port,
    serve,
)
from robodyn.viewer.trace import MAX_TRACE_POINTS, TRACE_COLOR, frame_path_lengths

__all__ = [
    "BASE_COLOR",
    "CAMERA_DIRECTION",
    "CAMERA_FOV_DEG",
    "CHART_LEGEND",
    "CONNECT_TIMEOUT_MS",
    "DEFAULT_FPS",
    "ENERGY_COLORS",
    "INSTALL_HINT",
    "LINK_COLORS",
    "MAX_TRACE_POINTS",
    "REPLY_TIMEOUT_MS",
    "ROOT",
    "SERVER_START_TIMEOUT_S",
    "TRACE_COLOR",
    "ChartLabel",
    "ChartLayout",
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
