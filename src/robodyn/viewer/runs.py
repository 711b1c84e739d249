"""Several runs in one replay: checked to be of one model, named, coloured, and put on one time grid.

One run plays as before: the rendered frames are the trajectory samples nearest to each
frame time (:func:`~robodyn.viewer.sampling.render_samples`). Several runs share one grid
over the union of their time spans: frame k is at t = t_min + k * speed / fps (and the
latest end), and each run shows its own sample nearest to that time; a run that starts
later holds its first pose until then, one that ends earlier holds its last. Each run is a
translucent "ghost" robot in its own colour, with its own trace and its own curves.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import InputError
from robodyn.viewer.palette import BLACK, BLUE, BLUISH_GREEN, ORANGE, REDDISH_PURPLE, SKY_BLUE, VERMILLION, YELLOW
from robodyn.viewer.sampling import check_trajectory, render_samples

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.sim.trajectory import Trajectory

Array = NDArray[np.float64]

MAX_RUNS = 8
"""Runs in one replay at most: each is a whole robot drawn again, and eight colours stay apart."""
RUN_COLORS = (VERMILLION, BLUISH_GREEN, ORANGE, REDDISH_PURPLE, BLUE, SKY_BLUE, YELLOW, BLACK)
"""One colour per run, Okabe–Ito (viewer.palette): vermillion, bluish green, orange, reddish purple, blue, ...

The first four are far in hue from the sky-blue background and tell apart for colour-blind
viewers (vermillion against bluish green, not red against green); none is the cursor's magenta.
"""
GHOST_OPACITY = 0.55
"""Opacity of each run's robot when several are overlaid: both stay visible where they cross."""


@dataclass(frozen=True, eq=False)
class Run:
    """One trajectory of the replay: its name in the legend, its colour, the rows shown at each frame."""

    name: str
    color: int
    trajectory: Trajectory
    index: NDArray[np.int64]


def check_runs(robot: Robot, trajectories: Sequence[Trajectory], names: Sequence[str]) -> None:
    """Raise :class:`InputError` unless the runs can share a replay of ``robot``.

    Each must fit the model (nq columns of q, times sorted); those that record their joint
    names must record the same ones; at most :data:`MAX_RUNS` runs.
    """
    if len(trajectories) > MAX_RUNS:
        raise InputError(f"{len(trajectories)} runs given; one replay shows at most {MAX_RUNS}")
    if len(trajectories) == 0:
        raise InputError("no trajectory given; pass one, or a list of up to 8")
    first: tuple[str, tuple[str, ...]] | None = None
    for name, trajectory in zip(names, trajectories, strict=True):
        try:
            check_trajectory(robot, trajectory)
        except InputError as exc:
            raise InputError(f"run {name!r}: {exc}") from None
        joints = trajectory.meta.get("joint_names") if isinstance(trajectory.meta, dict) else None
        if isinstance(joints, list):
            here = tuple(str(j) for j in joints)
            if first is None:
                first = (name, here)
            elif here != first[1]:
                raise InputError(
                    f"run {name!r} names joints {', '.join(here)} but run {first[0]!r} names "
                    f"{', '.join(first[1])}: runs of different models cannot share a replay"
                )


def run_names(trajectories: Sequence[Trajectory], names: Sequence[str] | None) -> list[str]:
    """The legend's names: those given, else each run's integrator (numbered when they repeat)."""
    if names is not None:
        if len(names) != len(trajectories):
            raise InputError(f"{len(names)} names given for {len(trajectories)} runs; expected one name per run")
        return [str(n) for n in names]
    out: list[str] = []
    for k, trajectory in enumerate(trajectories):
        meta = trajectory.meta if isinstance(trajectory.meta, dict) else {}
        base = str(meta.get("integrator") or f"run {k + 1}")
        name, n = base, 1
        while name in out:
            n += 1
            name = f"{base} ({n})"
        out.append(name)
    return out


def mark_identical(trajectories: Sequence[Trajectory], names: Sequence[str]) -> list[str]:
    """The names, each run that repeats an earlier one sample for sample (same t and q) saying so.

    Two identical runs draw one ghost over the other and one curve over the other: the
    legend says "(identical to NAME)" so that the hidden one is not taken for missing.
    """
    out: list[str] = []
    for k, (trajectory, name) in enumerate(zip(trajectories, names, strict=True)):
        t, q = np.asarray(trajectory.t), np.asarray(trajectory.q)
        twin = next(
            (
                names[j]
                for j in range(k)
                if np.array_equal(np.asarray(trajectories[j].t), t) and np.array_equal(np.asarray(trajectories[j].q), q)
            ),
            None,
        )
        out.append(name if twin is None else f"{name} (identical to {twin})")
    return out


def common_frames(
    trajectories: Sequence[Trajectory], *, speed: float, fps: float
) -> tuple[Array, list[NDArray[np.int64]]]:
    """Simulation times (k,) [s] of the rendered frames, and each run's rows (k,) shown at them."""
    if len(trajectories) == 1:
        t = np.asarray(trajectories[0].t, dtype=np.float64)
        index = render_samples(t, speed=speed, fps=fps)
        return t[index], [index]
    spans = [np.asarray(tr.t, dtype=np.float64) for tr in trajectories]
    start, end = min(float(t[0]) for t in spans), max(float(t[-1]) for t in spans)
    count = int(np.floor((end - start) / speed * fps + 1e-9)) + 1
    times: Array = start + np.arange(count, dtype=np.float64) * (speed / fps)
    if times[-1] < end:
        times = np.append(times, end)
    return times, [_nearest(t, times) for t in spans]


def _nearest(t: Array, wanted: Array) -> NDArray[np.int64]:
    """Index of the sample of ``t`` nearest to each of ``wanted`` (clipped to the ends)."""
    if len(t) == 1:
        return np.zeros(len(wanted), dtype=np.int64)
    right = np.clip(np.searchsorted(t, wanted), 1, len(t) - 1)
    left = right - 1
    return np.where(np.abs(t[left] - wanted) <= np.abs(t[right] - wanted), left, right).astype(np.int64)
