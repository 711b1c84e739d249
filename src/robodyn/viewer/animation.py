"""The motion as one meshcat ``Animation``: baked from placement tracks, and read back from its wire form.

Every moving thing (each link geometry, the trace marker, the chart cursor) is one clip of
position and quaternion keyframes, one keyframe per rendered frame; the browser plays the
whole animation with meshcat's own time slider, so nothing pushes transforms in a loop.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.viewer.backend import scene_path
from robodyn.viewer.transforms import quaternion_matrix

Array = NDArray[np.float64]


def bake_animation(mc: Any, tracks: dict[tuple[str, ...], Array], tau: Array, *, fps: float) -> Any:
    """One meshcat Animation: for each path, position and quaternion keyframes at ``tau * fps``.

    Args:
        mc: the meshcat module.
        tracks: scene path -> placements (k, 4, 4) at the rendered frames.
        tau: playback time of each rendered frame [s], shape (k,).
        fps: rendered frames per second (the animation's frame rate).
    """
    from meshcat.animation import Animation, AnimationClip, AnimationTrack, js_quaternion

    frames = [float(x) for x in tau * fps]
    animation = Animation(default_framerate=fps)
    for path, placements in tracks.items():
        positions = [[float(c) for c in m[:3, 3]] for m in placements]
        quaternions = [[float(c) for c in js_quaternion(m)] for m in placements]
        position = AnimationTrack("position", "vector3", list(frames), positions)
        quaternion = AnimationTrack("quaternion", "quaternion", list(frames), quaternions)
        animation.clips[scene_path(mc, path)] = AnimationClip(
            tracks={"position": position, "quaternion": quaternion}, fps=fps, name="default"
        )
    return animation


def set_animation_command(mc: Any, animation: Any, *, loop: bool) -> Any:
    """The command that starts ``animation`` in the browser: once, or forever with ``loop``."""
    repetitions = float("inf") if loop else 1
    return mc.commands.SetAnimation(animation, play=True, repetitions=repetitions)


def read_keyframes(animation: Any, path: tuple[str, ...]) -> tuple[Array, Array]:
    """The keyframes of ``path`` in ``animation``: playback times (k,) [s] and transforms (k, 4, 4).

    Reads the lowered animation back, as the browser receives it.
    """
    lowered = {entry["path"]: entry["clip"] for entry in animation.lower()}
    clip = lowered["/" + "/".join(path)]
    tracks = {track["name"]: track["keys"] for track in clip["tracks"]}
    times = np.array([key["time"] for key in tracks[".position"]], dtype=np.float64) / clip["fps"]
    out = np.tile(np.eye(4), (len(times), 1, 1))
    for k, (pos, quat) in enumerate(zip(tracks[".position"], tracks[".quaternion"], strict=True)):
        x, y, z, w = quat["value"]
        out[k, :3, :3] = quaternion_matrix(w, x, y, z)
        out[k, :3, 3] = pos["value"]
    return times, out
