"""Playback sampling: which trajectory rows become rendered frames, on a time grid of ``fps``.

The browser shows ``fps`` frames per second of playback; playback time runs ``speed`` times
faster than simulation time. Each rendered frame takes the trajectory sample nearest to its
time (meshcat interpolates between keyframes), and the last sample is always kept.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import InputError

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.sim.trajectory import Trajectory

Array = NDArray[np.float64]

DEFAULT_FPS = 30.0
"""Rendered samples per second of playback (meshcat interpolates between them)."""


def render_samples(t: Array, *, speed: float = 1.0, fps: float = DEFAULT_FPS) -> NDArray[np.int64]:
    """Indices of the trajectory samples shown, one per rendered frame.

    Playback time tau [s] runs from 0 to (t[-1] - t[0]) / speed; at each tau = k / fps the
    sample nearest to simulation time t[0] + speed * tau is taken (duplicates dropped), and
    the last sample is always kept so the animation ends on the final state.

    Args:
        t: sample times [s], shape (n,), non-decreasing.
        speed: playback speed (1 = real time, 2 = twice as fast).
        fps: rendered frames per second of playback.
    """
    t = np.asarray(t, dtype=np.float64)
    if len(t) == 1:
        return np.zeros(1, dtype=np.int64)
    duration = (t[-1] - t[0]) / speed
    count = int(np.floor(duration * fps + 1e-9)) + 1
    wanted = t[0] + np.arange(count) * (speed / fps)
    right = np.clip(np.searchsorted(t, wanted), 1, len(t) - 1)
    left = right - 1
    nearest = np.where(np.abs(t[left] - wanted) <= np.abs(t[right] - wanted), left, right)
    return np.unique(np.append(nearest, len(t) - 1)).astype(np.int64)


def check_rate(name: str, value: float) -> None:
    """Raise :class:`InputError` unless ``value`` (a speed or an fps) is a positive number."""
    if not (np.isfinite(value) and value > 0):
        raise InputError(f"{name} must be a positive number, got {value!r}")


def check_trajectory(robot: Robot, trajectory: Trajectory) -> None:
    """Raise :class:`InputError` unless ``trajectory`` can be played on ``robot``."""
    t = np.asarray(trajectory.t, dtype=np.float64)
    q = np.asarray(trajectory.q, dtype=np.float64)
    if t.ndim != 1 or len(t) == 0:
        raise InputError(f"the trajectory has no samples (t has shape {t.shape})")
    if q.ndim != 2 or q.shape[1] != robot.nq:
        columns = q.shape[1] if q.ndim == 2 else q.shape
        raise InputError(
            f"the trajectory's q has {columns} columns but model {robot.name!r} has nq = {robot.nq} "
            f"(joints: {', '.join(robot.joint_names)}); was it simulated with another model?"
        )
    if q.shape[0] != len(t):
        raise InputError(f"the trajectory has {len(t)} times but {q.shape[0]} rows of q")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q))):
        raise InputError("the trajectory holds non-finite times or configurations")
    if np.any(np.diff(t) < 0):
        raise InputError("the trajectory's times decrease somewhere; expected t sorted in time")


def rendered_frames(
    robot: Robot, trajectory: Trajectory | None, q: Any, *, speed: float, fps: float
) -> tuple[Array, NDArray[np.int64], Array, Array, Array]:
    """Configurations (k, nq), trajectory rows (k,), times [s], T and V [J] of the rendered frames.

    Without a trajectory: one frame at ``q`` (default: neutral), time 0, and no energies.
    T and V are empty when the trajectory does not carry them sample by sample.
    """
    if trajectory is None:
        q0 = robot.neutral() if q is None else robot.q_(q)
        return q0[None, :], np.zeros(1, dtype=np.int64), np.zeros(1), np.zeros(0), np.zeros(0)
    check_trajectory(robot, trajectory)
    index = render_samples(trajectory.t, speed=speed, fps=fps)
    kinetic = np.asarray(trajectory.kinetic, dtype=np.float64)
    potential = np.asarray(trajectory.potential, dtype=np.float64)
    return (
        np.asarray(trajectory.q, dtype=np.float64)[index],
        index,
        np.asarray(trajectory.t, dtype=np.float64)[index],
        kinetic[index] if kinetic.shape == trajectory.t.shape else np.zeros(0),
        potential[index] if potential.shape == trajectory.t.shape else np.zeros(0),
    )
