"""The notebook view: :func:`show` returns a :class:`Replay` that Jupyter displays inline.

Nothing is started and nothing blocks: the replay is the self-contained HTML page in an
iframe (meshcat's static inline display), so it works offline and in exported notebooks.
Given a running server's ``zmq_url``, the scene is also sent there and the iframe shows it.
Outside a notebook the replay prints as one line (model, runs, duration, frames, where the
page is), not as the page itself; :meth:`Replay.save` writes the page to a file.
"""

from __future__ import annotations

import html
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robodyn.fileio import write_text_atomically
from robodyn.viewer.html_export import to_html
from robodyn.viewer.playback import Playback, build
from robodyn.viewer.sampling import DEFAULT_FPS
from robodyn.viewer.server import serve
from robodyn.viewer.trace import DEFAULT_TRACE_WINDOW_S

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.sim.trajectory import Trajectory


@dataclass(frozen=True, eq=False)
class Replay:
    """What :func:`show` returns: displays itself inline in Jupyter; ``html`` is the standalone page."""

    playback: Playback
    html: str
    height: int = 560
    url: str | None = None

    def __repr__(self) -> str:
        """One line: model, runs, duration, frames and where the page is (never the page itself)."""
        playback = self.playback
        runs = playback.runs
        if not runs:
            what = "still pose"
        elif len(runs) == 1:
            what = f"1 run ({runs[0].name})"
        else:
            what = f"{len(runs)} runs ({', '.join(run.name for run in runs)})"
        size = len(self.html.encode("utf-8")) / 1e6
        where = f"served at {self.url}" if self.url is not None else "in memory"
        frames = f"{playback.n_frames} frame{'s' if playback.n_frames != 1 else ''}"
        return (
            f"<Replay {playback.robot_name}: {what}, {playback.duration:.2f} s, {frames}; "
            f"HTML page {size:.1f} MB {where}: .save(PATH) writes it, a notebook shows it inline>"
        )

    def save(self, path: str | Path) -> Path:
        """Write the self-contained page to ``path`` (replaced atomically); return the path."""
        target = Path(path)
        write_text_atomically(target, self.html)
        return target

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
    trajectory: Trajectory | Sequence[Trajectory] | None = None,
    *,
    q: Any = None,
    speed: float = 1.0,
    fps: float = DEFAULT_FPS,
    trace_frame: str | None = None,
    trace: bool = True,
    loop: bool = False,
    camera: str | None = None,
    names: Sequence[str] | None = None,
    zmq_url: str | None = None,
    height: int = 560,
    ground: bool = False,
    trace_window: float | None = DEFAULT_TRACE_WINDOW_S,
    labels: Mapping[str, str] | None = None,
    angles: Mapping[str, str] | None = None,
) -> Replay:
    """Show ``robot`` (playing ``trajectory`` if given) inline in a Jupyter notebook.

    Without ``zmq_url`` nothing is started: the returned :class:`Replay` renders the
    self-contained page in an iframe (meshcat's static inline display), so it works offline
    and in exported notebooks, with the chart panel beside the 3D view. A list of up to 8
    trajectories plays them together as ghosts (see :func:`~robodyn.viewer.build`, which
    also documents ``camera``, ``names``, ``ground``, ``trace_window``, ``labels`` and ``angles``). With ``zmq_url``
    the scene is also sent to that running meshcat server and the iframe shows the server's
    page. Never blocks.
    """
    playback = build(
        robot,
        trajectory,
        q=q,
        speed=speed,
        fps=fps,
        trace_frame=trace_frame,
        trace=trace,
        camera=camera,
        names=names,
        loop=loop,
        ground=ground,
        trace_window=trace_window,
        labels=labels,
        angles=angles,
    )
    url = None
    if zmq_url is not None:
        with serve(playback, zmq_url=zmq_url) as server:  # a running server: closing only disconnects
            url = server.url
    return Replay(playback, to_html(playback), height=height, url=url)
