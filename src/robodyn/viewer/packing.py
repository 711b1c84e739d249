"""A :class:`~robodyn.viewer.playback.Playback` as meshcat receives it: ordered commands, msgpack-packed.

The static scene first, then the one ``SetAnimation``; each command lowered and packed as
meshcat's ZeroMQ server and its JavaScript viewer expect. :func:`keyframes` reads the
animation back from that wire form, which is how the tests check what the browser gets.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import InputError
from robodyn.viewer.animation import read_keyframes, set_animation_command
from robodyn.viewer.backend import import_meshcat

if TYPE_CHECKING:
    from robodyn.viewer.playback import Playback

Array = NDArray[np.float64]


def scene_commands(playback: Playback) -> list[Any]:
    """Every meshcat command, in order: the static scene, then the one animation."""
    mc = import_meshcat()
    commands = list(playback.commands)
    if playback.animation is not None:
        commands.append(set_animation_command(mc, playback.animation, loop=playback.loop))
    return commands


def packed_commands(playback: Playback) -> list[tuple[str, str, bytes]]:
    """(type, path, msgpack bytes) for each command: meshcat's wire format."""
    import_meshcat()
    import umsgpack

    out = []
    for command in scene_commands(playback):
        lowered = command.lower()
        out.append((str(lowered["type"]), str(lowered["path"]), umsgpack.packb(lowered)))
    return out


def keyframes(playback: Playback, path: tuple[str, ...]) -> tuple[Array, Array]:
    """The animation's keyframes for ``path``: playback times (k,) [s] and transforms (k, 4, 4).

    Reads the lowered animation back, as the browser receives it.

    Raises:
        InputError: the playback has no animation (it shows a still pose).
    """
    if playback.animation is None:
        raise InputError("this playback has no animation (no trajectory was given)")
    return read_keyframes(playback.animation, path)
