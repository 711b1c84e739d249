"""HTML export: one self-contained page that replays a playback offline (no server, no network).

The page (``assets/replay.html``) inlines meshcat's bundled JavaScript, the packed scene
commands (base64, as JSON), the chart panel's curves and ``assets/replay.js``, which feeds
the commands to meshcat's viewer, keeps a text overlay of the time and the total energy in
step with the animation, and draws the charts beside the 3D pane with a cursor at the
animation's time (a click on a chart seeks there). The camera's mode (fit, follow, fixed)
is baked into the commands: the page works offline.
"""

from __future__ import annotations

import base64
import html
import json
import re
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from robodyn.errors import InputError, MissingDependencyError
from robodyn.viewer.backend import INSTALL_HINT, ROOT, import_meshcat
from robodyn.viewer.forces import forces_info
from robodyn.viewer.labels import labels_info
from robodyn.viewer.packing import packed_commands
from robodyn.viewer.panel import panel_info

if TYPE_CHECKING:
    from robodyn.viewer.playback import Playback

BACKGROUND_TOP = (135 / 255, 206 / 255, 250 / 255)
BACKGROUND_BOTTOM = (25 / 255, 25 / 255, 112 / 255)
"""meshcat's default background, a vertical gradient (light sky blue above, midnight blue below)."""


def meshcat_javascript() -> str:
    """The text of meshcat's bundled viewer, ``meshcat/viewer/dist/main.min.js``."""
    mc = import_meshcat()
    path = Path(mc.__file__).parent / "viewer" / "dist" / "main.min.js"
    if not path.is_file():
        raise MissingDependencyError(f"meshcat is installed without its viewer ({path} is missing): {INSTALL_HINT}")
    return path.read_text(encoding="utf-8")


def _asset(name: str) -> str:
    return resources.files("robodyn.viewer").joinpath("assets", name).read_text(encoding="utf-8")


def _script_safe(text: str) -> str:
    """Text that can sit inside a <script> element (no closing tag, no HTML comment opener)."""
    return text.replace("</", "<\\/").replace("<!--", "<\\!--")


def _run_energies(playback: Playback) -> list[dict[str, object]]:
    """Each run's own E = T + V at its rendered rows [J], with its name and colour (runs without T, V left out)."""
    out: list[dict[str, object]] = []
    for run in playback.runs:
        n = len(run.trajectory.t)
        kinetic, potential = np.asarray(run.trajectory.kinetic), np.asarray(run.trajectory.potential)
        if kinetic.shape == (n,) and potential.shape == (n,):
            energy = (kinetic + potential)[run.index]
            out.append({"name": run.name, "color": f"#{run.color:06x}", "energy": [float(x) for x in energy]})
    return out


def to_html(playback: Playback, *, title: str | None = None) -> str:
    """One self-contained HTML page that replays ``playback`` offline (no server, no network).

    The page inlines meshcat's JavaScript and the scene commands; meshcat's panel (Open
    Controls -> Animations) has play, pause and the time slider. A text overlay shows the
    simulation time and the total energy in step with the animation; the chart panel at the
    right shows the curves with a cursor at the animation's time (click a chart to seek). Open the file with
    ``#t=1.5`` appended to its URL to start paused at t = 1.5 s of simulation time.

    Raises:
        InputError: the playback's times, energies or curves hold NaN or infinities (the page would be blank).
    """
    commands = [base64.b64encode(data).decode("ascii") for _, _, data in packed_commands(playback)]
    info = {
        "robot": playback.robot_name,
        "t0": float(playback.times[0]) if len(playback.times) else 0.0,
        "speed": playback.speed,
        "tau": [round(float(x), 9) for x in playback.playback_times],
        "energy": [float(x) for x in playback.energy] if len(playback.kinetic) else [],
        "runEnergies": _run_energies(playback) if len(playback.runs) > 1 else [],
        "traceFrame": playback.trace_frame,
        "animated": playback.animation is not None,
        "camera": playback.camera_mode,
        "panel": panel_info(playback.charts, playback.runs),
        # The fading trace: each run's line (scene path and its points' playback times) and dots;
        # the page keeps traceWindow seconds of playback behind the cursor (null: the whole trace).
        "traceWindow": None if playback.trace_window is None else playback.trace_window / playback.speed,
        "traces": [
            {
                "line": [*ROOT, "trace" if r == 0 else f"trace{r}", "path"],
                "dots": [*ROOT, "trace" if r == 0 else f"trace{r}", "dots"],
                "tau": [round(float(x), 9) for x in tau],
            }
            for r, tau in enumerate(playback.trace_times)
        ],
        # Texts on frames and joint angles as arcs (world [m], one entry per rendered frame), drawn over the 3D pane.
        "root": list(ROOT),
        "labels": labels_info(playback.labels, playback.angles),
        # Forces and torques where they act, stop impacts flashed on their joints, the controller's mode.
        "forces": forces_info(list(playback.arrows), list(playback.impacts), playback.mode),
        "notes": list(playback.notes),
        # meshcat's background gradient (top, bottom; sRGB 0..1): the trace fades into it.
        "background": [list(BACKGROUND_TOP), list(BACKGROUND_BOTTOM)],
    }
    try:  # JavaScript's JSON.parse refuses NaN and Infinity: such a page would show nothing at all
        info_json = json.dumps(info, allow_nan=False)
    except ValueError:
        raise InputError(
            f"robodyn: {playback.robot_name}: the replay's times, energies or charts hold NaN or infinite numbers; "
            "no page written (a page with them shows nothing)"
        ) from None
    fields = {
        "TITLE": html.escape(title or f"robodyn: {playback.robot_name}"),
        "MESHCAT_JS": _script_safe(meshcat_javascript()),
        "COMMANDS_JSON": _script_safe(json.dumps(commands)),
        "INFO_JSON": _script_safe(info_json),
        "REPLAY_JS": _script_safe(_asset("replay.js")),
    }
    # One pass, so that nothing inserted is scanned for placeholders again.
    return re.sub(r"\{\{([A-Z_]+)\}\}", lambda m: fields[m.group(1)], _asset("replay.html"))
