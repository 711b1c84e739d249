"""Which two runs of a bench sweep to replay side by side: the fastest hit and the cheapest miss of an accuracy.

A run *meets* an accuracy ``rtol`` when it did not diverge and its ``error`` (the bench's
relative state error against the DOP853 reference over the error horizon, see
:mod:`robodyn.studies.bench`) is at most ``rtol``. Cost is the bench's: wall time per
simulated second [s/s], ties broken by the number of dynamics evaluations. Of the runs that
meet the accuracy, :func:`pick_pair` takes the fastest; of those that do not (diverged
runs included: they fail it too), the cheapest. When one side is empty the pair says so
and holds one run; nothing is made up.

:func:`rerun` runs one result again (the same integrator, backend, step or tolerance,
start state and horizon as the sweep) for the replay and measures its error again on the
sweep's reference: the arithmetic is the same, so it must equal the recorded error.
Nothing here prints, plots or writes files.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from robodyn.errors import InputError
from robodyn.studies.bench import BenchResult, Sweep, error_against, run_one

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.sim.trajectory import Trajectory

DEFAULT_ACCURACY = 1e-6
"""The accuracy ``robodyn bench --view`` replays at: a relative state error of 1e-6, the middle of the
report's accuracy levels (1e-2 to 1e-10), which the methods of order 4 and up reach at the bench's steps
and the first-order ones do not."""


def meets(result: BenchResult, accuracy: float) -> bool:
    """Whether ``result`` did not diverge and its relative state error is at most ``accuracy``."""
    return not result.diverged and math.isfinite(result.error) and result.error <= accuracy


def _cost(result: BenchResult) -> tuple[float, int]:
    return (result.wall_time_s, result.evaluations)


@dataclass(frozen=True)
class ReplayPair:
    """The runs a replay compares at ``accuracy`` (relative state error).

    ``met``: the fastest run that meets it (None when none does); ``missed``: the cheapest
    run that does not (None when every run meets it); ``horizon``: the time [s] over which
    the error was measured, when known.
    """

    model: str
    accuracy: float
    met: BenchResult | None
    missed: BenchResult | None
    horizon: float | None = None

    @property
    def runs(self) -> tuple[BenchResult, ...]:
        """The runs that exist, the one that meets the accuracy first."""
        return tuple(r for r in (self.met, self.missed) if r is not None)

    def name(self, result: BenchResult) -> str:
        """The run's name in the replay's legend: whether it meets the accuracy, then :func:`run_label`."""
        verdict = "meets" if meets(result, self.accuracy) else "misses"
        return f"{verdict} {self.accuracy:g}: {run_label(result)}"

    def describe(self) -> str:
        """One line: the accuracy and the two runs, or which side is empty."""
        over = f" over the first {self.horizon:g} s" if self.horizon is not None else ""
        head = f"{self.model} at accuracy {self.accuracy:g} (largest relative state error{over}, against DOP853)"
        if self.met is not None and self.missed is not None:
            text = (
                f"{head}: fastest run that meets it {run_label(self.met)}; "
                f"cheapest run that does not {run_label(self.missed)}"
            )
            if self.missed.wall_time_s >= self.met.wall_time_s > 0:
                ratio = self.missed.wall_time_s / self.met.wall_time_s
                text += f" (it costs {ratio:.3g} times as much: missing the accuracy saves nothing here)"
            return text
        if self.met is not None:
            return f"{head}: every run meets it; replaying the fastest alone, {run_label(self.met)}"
        if self.missed is not None:
            return f"{head}: no run meets it; replaying the cheapest alone, {run_label(self.missed)}"
        return f"{head}: the sweep has no runs"


def pick_pair(
    model: str, results: Sequence[BenchResult], accuracy: float, *, horizon: float | None = None
) -> ReplayPair:
    """The fastest run of ``results`` that meets ``accuracy`` and the cheapest that does not.

    ``horizon`` [s] is the error horizon the errors were measured over (it is only reported).

    Raises:
        InputError: ``accuracy`` is not a finite number > 0.
    """
    if not (math.isfinite(accuracy) and accuracy > 0):
        raise InputError(f"accuracy must be a finite relative error > 0, got {accuracy!r}")
    good = [r for r in results if meets(r, accuracy)]
    bad = [r for r in results if not meets(r, accuracy)]
    return ReplayPair(
        model=model,
        accuracy=accuracy,
        met=min(good, key=_cost) if good else None,
        missed=min(bad, key=_cost) if bad else None,
        horizon=horizon,
    )


def _seconds(value: float) -> str:
    """A wall time per simulated second in the unit that reads best (ms or µs per s)."""
    if value >= 1.0:
        return f"{value:.3g} s"
    if value >= 1e-3:
        return f"{value * 1e3:.3g} ms"
    return f"{value * 1e6:.3g} µs"


def run_label(result: BenchResult) -> str:
    """``rk4/aba dt 0.005 s, error 3.1e-08, 0.52 ms per simulated s``: how the legend names a run."""
    step = f"dt {result.dt:g} s" if result.dt is not None else f"rtol {result.rtol:g}"
    error = f"error {result.error:.2g}" if math.isfinite(result.error) else "error inf"
    if result.diverged:
        error += f" (diverged at t = {result.duration:.3g} s)"
    return f"{result.label} {step}, {error}, {_seconds(result.wall_time_s)} per simulated s"


@dataclass(frozen=True, eq=False)
class Replayed:
    """A run of the sweep run again: its result, the trajectory, and its error measured again."""

    result: BenchResult
    trajectory: Trajectory
    error: float


def rerun(robot: Robot, sweep: Sweep, result: BenchResult) -> Replayed:
    """Run ``result`` of ``sweep`` again on ``robot`` over the sweep's energy horizon, as the sweep ran it.

    Raises:
        InputError: ``result`` is not a run of ``sweep``'s model.
    """
    from robodyn.sim import energy

    if result.model != sweep.model or robot.name != sweep.model:
        raise InputError(f"run {result.label} is of model {result.model!r}, the sweep of {sweep.model!r}")
    fast = None
    if result.backend == "fast":
        from robodyn.sim.fast import FastDynamics

        fast = FastDynamics.from_robot(robot, sweep.kind)
    plan = sweep.plan
    q0, v0 = sweep.q0, sweep.v0
    scale = energy.energy_scale(robot, robot.kinetic_energy(q0, v0), robot.potential_energy(q0))
    step = result.dt if result.dt is not None else plan.sample_interval
    trajectory, diverged = run_one(
        robot,
        fast,
        result.integrator,
        result.backend,
        q0,
        v0,
        dt=step,
        rtol=result.rtol,
        duration=plan.energy_horizon,
        scale=scale,
    )
    ended_early = diverged and trajectory.t[-1] < plan.error_horizon
    error = float("inf") if ended_early else error_against(trajectory, sweep.reference, step)
    return Replayed(result, trajectory, error)
