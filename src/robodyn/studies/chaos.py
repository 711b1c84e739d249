"""Chaos on a robot: its largest Lyapunov exponent and when two runs one ulp apart part ways.

The robot-free estimators (:func:`~robodyn.integrators.stability.lyapunov`,
:func:`~robodyn.integrators.stability.separation_time`) are run here on the compiled RK4 of
:mod:`robodyn.sim.fast`. Results are frozen dataclasses; nothing here prints or plots.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from robodyn.integrators.stability import Lyapunov, lyapunov, separation_time

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

# Benettin renormalises the twin every RENORMALISE_S [s]: short against the Pendubot's
# divergence time (1 / lambda ~ 0.3-0.5 s), so the separation stays linear in between.
RENORMALISE_S = 0.1
# Two runs have parted when their configurations differ by this much [rad]: no longer a small
# perturbation, still far from the O(1) difference of unrelated states.
SEPARATION_RAD = 0.1


@dataclass(frozen=True, eq=False)
class Chaos:
    """The chaotic case: Lyapunov estimate and the measured separation of runs one ulp apart."""

    model: str
    q0: Array
    v0: Array
    lyapunov: Lyapunov
    separation_time_s: float
    gap_t: Array
    gap: Array


def chaos(robot: Robot, q0: Array, v0: Array, *, duration: float, dt: float = 1e-3, seed: int = 0) -> Chaos:
    """Lyapunov exponent (compiled RK4 at ``dt`` [s], renormalised every RENORMALISE_S) and the one-ulp separation.

    ``seed`` picks the twin's random start direction; ``duration`` [s] is the length of both the
    Lyapunov estimate and the two separation runs.
    """
    from robodyn.sim.fast import FastDynamics

    fast = FastDynamics.from_robot(robot)

    def step_run(q: Array, v: Array, T: float) -> tuple[Array, Array]:
        traj = fast.simulate(q, v, duration=T, dt=dt)
        return traj.q[-1].copy(), traj.v[-1].copy()

    def run(q: Array, v: Array) -> tuple[Array, Array]:
        traj = fast.simulate(q, v, duration=duration, dt=dt)
        return traj.t, traj.q

    lyap = lyapunov(step_run, q0, v0, duration=duration, interval=RENORMALISE_S, seed=seed)
    when, t, gap = separation_time(run, q0, v0=v0, threshold=SEPARATION_RAD)
    stride = max(1, t.size // 2000)
    return Chaos(robot.name, np.asarray(q0), np.asarray(v0), lyap, when, t[::stride], gap[::stride])
