"""Compile the kernels first, or take the Python pipeline: a run's choice on a machine whose kernels are not built.

Compiling the compiled loop's kernels costs about 20 s of CPU once per machine, and about a
minute more for the stop events (:data:`robodyn.sim.tree.COMPILE_S`), while a short run costs
far less than that in the Python pipeline (the Panda's 2 s, stops and all: about 1 s). So a run
left to its default (``backend`` None) whose kernels are not in numba's cache takes the rule of
renting before buying:

* the Python loop's time is estimated (:func:`python_estimate`: the run's evaluations, each timed
  at q0, times ``MARGIN`` for the trial steps of the stop events);
* a run estimated over what the compile would cost (less the Python-loop time earlier such runs
  of this process have spent) compiles, as before;
* any other run takes the Python loop with that cost as its budget; one that runs past it
  (a stop chattering, a slow torque law) is abandoned and starts again in the compiled loop.

A run so never costs much more than twice what the better of the two would have cost, and a
short first run costs what the Python loop does. Which loop ran, and why, is in the
trajectory's metadata and the summary line.

``ROBODYN_COMPILE=always`` compiles at the first run whatever its length, for a test suite or a
benchmark that measures the compiled loop itself; ``robodyn warmup`` builds every kernel ahead.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import numpy as np

from robodyn.engine import jit
from robodyn.errors import InputError
from robodyn.sim import tree
from robodyn.sim.run import Progress, Run
from robodyn.sim.system import RobotSystem

ENV = "ROBODYN_COMPILE"
CHOICES = ("auto", "always")

# The Python loop's time over its evaluations' (timed at q0): the event stepper's trial steps
# and holds (the Panda's 2 s from its neutral pose: 5x; Talos: 9x; a run with no stop: about 1x).
MARGIN = 4.0
# Evaluations timed for the estimate (after one untimed).
TIMED = 5


class OverBudgetError(Exception):
    """The Python loop ran past what compiling the kernels would have cost: the run compiles instead."""


@dataclass(frozen=True)
class Rent:
    """A run that takes the Python loop: its budget of wall time [s], and why (for the summary)."""

    budget: float
    reason: str


# Python-loop wall time [s] spent in this process by runs that did not compile.
_SPENT = [0.0]


def mode() -> str:
    """``ROBODYN_COMPILE``: ``"auto"`` (the default) or ``"always"``.

    Raises:
        InputError: any other value.
    """
    value = os.environ.get(ENV, "auto").strip().lower() or "auto"
    if value not in CHOICES:
        raise InputError(f"{ENV}={value!r}: expected one of {', '.join(CHOICES)}")
    return value


# The variants (flyer, tableau, events) found built in this process: a cache's files stay, so every later
# run of the process skips reading numba's index files again (about 2 ms, as much as a short run's steps).
_BUILT: set[tuple[bool, bool, bool]] = set()


def built(flyer: bool, tableau: bool, *, events: bool = False) -> bool:
    """Whether a whole run's kernels are in numba's cache on this machine: a run would compile nothing.

    ``flyer`` and ``tableau`` as :func:`robodyn.sim.tree.step_kernels`'s; ``events``: the stop
    events' too. Imports the kernels' modules (numba with them) but compiles and loads nothing;
    a variant found built is remembered for the process.
    """
    if (flyer, tableau, events) in _BUILT:
        return True
    from robodyn.engine.tree import events as ev
    from robodyn.engine.tree import steps

    variant = tree.run_variant(flyer, tableau)
    if (flyer, tableau, False) not in _BUILT:
        if not all(jit.is_cached(f, tree.variant(flyer)) for f in tree.run_kernels(steps)):
            return False
        if not jit.is_cached(ev.run_steps, variant):
            return False
        _BUILT.add((flyer, tableau, False))
    if events and not jit.is_cached(ev.run_events, variant):
        return False
    _BUILT.add((flyer, tableau, events))
    return True


def compile_cost(system: RobotSystem, tableau: bool) -> float:
    """What this run would compile, about [s of CPU]: 0 when its kernels are built on this machine."""
    flyer = any(j.kind == "JointModelFreeFlyer" for j in system.robot.joints)  # as the tree path takes it
    steps_s, events_s = tree.COMPILE_S
    cost = 0.0 if built(flyer, tableau) else steps_s
    if not system.stops.empty and not built(flyer, tableau, events=True):
        cost += events_s  # a run with stops is likely to meet one
    return cost


def python_estimate(system: RobotSystem, run: Run, stages: int) -> float:
    """The Python loop's wall time for ``run``, about [s]: its evaluations, one timed at q0, times ``MARGIN``.

    The torque law is left out (it costs the same in either loop, and a controller keeps state).
    """
    nv = system.nv
    q, v, tau = run.Q[0].copy(), run.U[0, :nv].copy(), np.zeros(nv)
    evaluations = system.evaluations
    with np.errstate(all="ignore"):
        system.acceleration(float(run.t[0]), q, v, tau)
        start = time.perf_counter()
        for _ in range(TIMED):
            system.acceleration(float(run.t[0]), q, v, tau)
        each = (time.perf_counter() - start) / TIMED
    system.evaluations = evaluations
    return (run.t.size - 1) * stages * each * MARGIN


def choose(system: RobotSystem, run: Run, stages: int, tableau: bool) -> Rent | None:
    """A :class:`Rent` when ``run`` should take the Python loop; None: it compiles (or finds its kernels built)."""
    if mode() == "always":
        return None
    cost = compile_cost(system, tableau)
    if cost == 0.0:
        return None
    budget = cost - _SPENT[0]
    estimate = python_estimate(system, run, stages)
    if estimate > budget:
        return None
    return Rent(
        budget,
        f"the compiled loop's kernels are not built on this machine (about {cost:.0f} s of CPU, once: "
        f"`robodyn warmup`), more than this run takes without them (about {_seconds(estimate)})",
    )


def _seconds(x: float) -> str:
    return f"{x:.1g} s" if x < 1.0 else f"{x:.0f} s"


def budgeted(progress: Progress | None, budget: float) -> Progress:
    """``progress`` (or nothing) with a clock: :class:`OverBudgetError` once ``budget`` [s] has passed."""
    deadline = time.perf_counter() + budget

    def watch(t: float) -> None:
        if progress is not None:
            progress(t)
        if time.perf_counter() > deadline:
            raise OverBudgetError

    return watch


def book(seconds: float) -> None:
    """Add a run's Python-loop time to this process's rent."""
    _SPENT[0] += seconds
