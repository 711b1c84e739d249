"""How a step is taken: the :class:`Integrator` base classes and the :class:`Stepper` of one run.

An :class:`Integrator` is an immutable description that declares its ``order`` and whether it
is ``symplectic``, ``adaptive`` and ``implicit``; it is fixed-step exactly when it is a
:class:`FixedStepIntegrator` (which is checked against ``adaptive``). A run starts with
:meth:`Integrator.start`, which returns a :class:`Stepper`; its ``advance`` moves the state
from ``t`` to ``t + h`` -- one step for the fixed-step methods, as many error-controlled steps
as needed for the adaptive ones -- and also returns the rates at the start of the interval when
the method evaluated them there anyway (so a recorder gets the acceleration at every sample
for free).

An :class:`AdaptiveIntegrator` bounds its work: at most ``max_steps_per_interval`` steps between
two output times, ``max_steps`` in a run, and no step below ``min_relative_step`` times
max(|t|, output interval). Its stepper counts them in a :class:`StepBudget`, which stops a run
that cannot make progress with a one-line :class:`~robodyn.errors.StepError` naming the bound.
"""

from __future__ import annotations

import abc
import functools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robodyn.errors import InputError, StepError
from robodyn.integrators.problem import Array, SecondOrderProblem
from robodyn.wording import count


class Stepper(abc.ABC):
    """One run of an integrator on one problem: call :meth:`advance` interval by interval."""

    problem: SecondOrderProblem

    @abc.abstractmethod
    def advance(self, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array | None]:
        """Move (q, u) from t to t + h [s]; return (q1, u1, rates at t or None)."""


@dataclass(frozen=True, kw_only=True)
class Integrator(abc.ABC):
    """How a step is taken. Subclasses declare what they are, by keyword; instances are immutable.

    Raises:
        ValueError: ``adaptive`` disagrees with the class (a :class:`FixedStepIntegrator`
            never adapts its step; every other integrator does), or ``order`` < 1.
    """

    name: str
    order: int
    symplectic: bool
    adaptive: bool
    implicit: bool
    description: str

    def __post_init__(self) -> None:
        if self.order < 1:
            raise ValueError(f"integrator {self.name!r}: order must be >= 1, got {self.order}")
        if self.adaptive == self.fixed_step:
            raise ValueError(
                f"integrator {self.name!r}: adaptive={self.adaptive} but {type(self).__name__} "
                f"{'takes' if self.fixed_step else 'does not take'} fixed steps"
            )

    @property
    def fixed_step(self) -> bool:
        """True for a :class:`FixedStepIntegrator`: one step of exactly the requested size."""
        return isinstance(self, FixedStepIntegrator)

    def start(
        self,
        problem: SecondOrderProblem,
        t0: float,
        q0: Array,
        u0: Array,
        *,
        t_end: float,
        rtol: float = 1e-9,
        atol: float = 1e-12,
    ) -> Stepper:
        """Begin a run on ``problem`` from (t0, q0, u0) towards ``t_end`` [s].

        Raises:
            InputError: an adaptive method got ``rtol`` or ``atol`` <= 0.
        """
        if self.adaptive and not (rtol > 0 and atol > 0):
            raise InputError(f"rtol and atol must be > 0, got rtol={rtol!r}, atol={atol!r}")
        return self._stepper(problem, t0, q0, u0, t_end, rtol, atol)

    @abc.abstractmethod
    def _stepper(
        self, problem: SecondOrderProblem, t0: float, q0: Array, u0: Array, t_end: float, rtol: float, atol: float
    ) -> Stepper:
        """The :class:`Stepper` of one run (tolerances already checked)."""

    def summary(self) -> dict[str, Any]:
        """Name, order and properties as a plain dict."""
        return {
            "name": self.name,
            "order": self.order,
            "symplectic": self.symplectic,
            "adaptive": self.adaptive,
            "implicit": self.implicit,
            "fixed_step": self.fixed_step,
            "description": self.description,
        }


class FixedStepIntegrator(Integrator):
    """A method that takes exactly one step of the requested size."""

    @abc.abstractmethod
    def step(self, problem: SecondOrderProblem, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array]:
        """One step of size h [s] from (t, q, u); return (q1, u1, rates at (t, q, u))."""

    def _stepper(
        self, problem: SecondOrderProblem, t0: float, q0: Array, u0: Array, t_end: float, rtol: float, atol: float
    ) -> Stepper:
        """A stepper whose ``advance`` is one :meth:`step`."""
        return _FixedStepper(self, problem)


class _FixedStepper(Stepper):
    def __init__(self, method: FixedStepIntegrator, problem: SecondOrderProblem) -> None:
        self.problem = problem
        # advance(t, q, u, h) is step(problem, t, q, u, h): bound once, no wrapper call per step.
        self.advance = functools.partial(method.step, problem)  # type: ignore[method-assign]

    def advance(self, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array | None]:
        """One step of size h [s] (replaced per instance by a partial of ``step``)."""
        return self.advance(t, q, u, h)  # pragma: no cover


# Bounds on an adaptive run's work (the defaults of AdaptiveIntegrator's keyword options).
# Steps per output interval (ODEPACK's default is 500 a call): the most measured in the tests
# is 180 (scipy_radau, 1 s intervals at rtol 1e-11), in the README's dopri5 example 11, in
# `robodyn bench` 598 (scipy_radau at rtol 1e-11 through the stiff geared arm's first 20 ms).
# 1,000 lets dopri5 at rtol 1e-9 cover output intervals of about 2 s on the 7-joint panda, and
# stops the Pendubot under 1e6 N m (10 ms took 148,598 evaluations) after 12,764 evaluations.
MAX_STEPS_PER_INTERVAL = 1_000
# Steps per run: twice simulate's cap on the number of output intervals (5e7), so that a run
# taking up to two steps an interval never meets it; lower it to cap a long run's cost.
MAX_STEPS = 100_000_000
# A step below this fraction of max(|t|, output interval) is no progress: at 1e-12 it would
# take 1e12 steps to cross the interval (and 1e-12 is ~4500 ulp of t, far above round-off).
MIN_RELATIVE_STEP = 1e-12
# Below 4 ulp of t a step may not change t at all: the smallest min_relative_step accepted.
SMALLEST_RELATIVE_STEP = 4 * float(np.finfo(np.float64).eps)


def _is_count(value: object) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool) and int(value) >= 1


@dataclass(frozen=True)
class AdaptiveIntegrator(Integrator):
    """An error-controlled method whose work is bounded per output interval and per run.

    Every bound, when hit, stops the run with a one-line :class:`~robodyn.errors.StepError`
    that names the bound, the time and the numbers (:func:`robodyn.simulate` turns it into a
    :class:`~robodyn.errors.DivergenceError` that keeps the trajectory up to that interval).
    Change a bound with ``dataclasses.replace(integrators.get("dopri5"), max_steps_per_interval=5000)``.

    Attributes:
        max_steps_per_interval: most steps between two output times (default
            ``MAX_STEPS_PER_INTERVAL`` = 1,000). A step is one attempt of the error-controlled
            step, rejected ones included, for robodyn's own methods, and one ``step()`` of the
            SciPy solver for SciPy's (whose rejected attempts inside it SciPy bounds itself).
        max_steps: most steps in a run, counted as above (default ``MAX_STEPS`` = 1e8); None
            leaves only the per-interval bound.
        min_relative_step: a step below ``min_relative_step * max(|t|, output interval)`` [s]
            is no progress (default ``MIN_RELATIVE_STEP`` = 1e-12): for robodyn's own methods
            the next step the error control asks for, for SciPy's a step it took
            that is smaller than the one before (a small first step is only the solver's guess).

    Raises:
        InputError: a step bound that is not a whole number >= 1, or ``min_relative_step``
            outside [``SMALLEST_RELATIVE_STEP``, 1).
    """

    max_steps_per_interval: int = field(default=MAX_STEPS_PER_INTERVAL, kw_only=True)
    max_steps: int | None = field(default=MAX_STEPS, kw_only=True)
    min_relative_step: float = field(default=MIN_RELATIVE_STEP, kw_only=True)

    def __post_init__(self) -> None:
        super().__post_init__()
        if not _is_count(self.max_steps_per_interval):
            raise InputError(
                f"integrator {self.name!r}: max_steps_per_interval must be a whole number >= 1, "
                f"got {self.max_steps_per_interval!r}"
            )
        if self.max_steps is not None and not _is_count(self.max_steps):
            raise InputError(
                f"integrator {self.name!r}: max_steps must be a whole number >= 1 or None, got {self.max_steps!r}"
            )
        r = self.min_relative_step
        if not (isinstance(r, (int, float, np.floating)) and SMALLEST_RELATIVE_STEP <= r < 1):
            raise InputError(
                f"integrator {self.name!r}: min_relative_step must be a number in "
                f"[{SMALLEST_RELATIVE_STEP:.3g}, 1), got {r!r}"
            )

    def summary(self) -> dict[str, Any]:
        """Name, order, properties and the work bounds as a plain dict."""
        return {
            **super().summary(),
            "max_steps_per_interval": self.max_steps_per_interval,
            "max_steps": self.max_steps,
            "min_relative_step": self.min_relative_step,
        }


class StepBudget:
    """One run's steps counted against its :class:`AdaptiveIntegrator`'s bounds.

    The stepper calls :meth:`interval` when an output interval begins, :meth:`take` before
    every step (which refuses the step once a count bound is reached, so neither count is
    ever exceeded), :meth:`accepted` or :meth:`rejected` after it (``sees_rejections``: the
    stepper sees its rejected attempts) and :meth:`check_step` with the step size it is about
    to use or has just used. A hit raises :class:`StepError` whose
    message is one line: the bound, the time, the numbers, and what to try; its ``reason``
    leaves out what to try.
    """

    def __init__(self, method: AdaptiveIntegrator, problem: SecondOrderProblem, *, sees_rejections: bool) -> None:
        self.method = method
        self.problem = problem
        self.sees_rejections = sees_rejections  # False for SciPy: its rejected attempts stay inside step()
        if method.implicit:
            self.advice = "the motion is probably blowing up (check the torque and the initial state)"
        else:
            self.advice = (
                "the motion is probably blowing up (check the torque) or too stiff for an explicit method: "
                "try scipy_radau"
            )
        self.run_steps = 0  # attempted, in the run
        self.run_accepted = 0
        self.run_rejected = 0
        self.interval(0.0, 0.0)

    def interval(self, t: float, h_out: float) -> None:
        """An output interval [t, t + h_out] [s] begins: its counts start from zero."""
        self.t0, self.h_out = t, h_out
        self.steps = 0
        self.rejections = 0
        self.in_a_row = 0
        self.evaluations0 = int(self.problem.evaluations)

    def take(self, t: float) -> None:
        """Count a step from t [s]; raise if the interval's or the run's bound is reached."""
        method = self.method
        if self.steps >= method.max_steps_per_interval:
            end = self.t0 + self.h_out
            self._fail(
                t,
                f"{method.name} hit max_steps_per_interval = {method.max_steps_per_interval:,} at t = {t:.6g} s, "
                f"{end - t:.3g} s short of the end of the output interval [{self.t0:.6g}, {end:.6g}] s: "
                f"{self._steps_taken()} ({count(self._evaluations(), 'evaluation', thousands=True)})",
                "or raise max_steps_per_interval",
            )
        if method.max_steps is not None and self.run_steps >= method.max_steps:
            self._fail(
                t,
                f"{method.name} hit max_steps = {method.max_steps:,} at t = {t:.6g} s: "
                f"{count(self.run_steps, 'step', thousands=True)} in this run",
                "or raise max_steps",
            )
        self.steps += 1
        self.run_steps += 1

    def accepted(self) -> None:
        """The last step was accepted."""
        self.in_a_row = 0
        self.run_accepted += 1

    def rejected(self) -> None:
        """The last step was rejected by the error control."""
        self.rejections += 1
        self.in_a_row += 1
        self.run_rejected += 1

    def check_step(self, t: float, h: float) -> None:
        """Raise if the step h [s] at t [s] is below ``min_relative_step * max(|t|, output interval)``."""
        smallest = self.method.min_relative_step * max(abs(t), self.h_out)
        if h >= smallest:  # False for NaN too
            return
        after = (
            f"after {count(self.in_a_row, 'rejected step', thousands=True)} in a row"
            if self.in_a_row
            else f"after {count(self.steps, 'step', thousands=True)} in this output interval"
        )
        self._fail(
            t,
            f"{self.method.name} made no progress at t = {t:.6g} s: step {h:.2g} s below the minimum "
            f"{smallest:.2g} s (min_relative_step {self.method.min_relative_step:g} x max(|t|, output interval "
            f"{self.h_out:g} s)) {after}",
            "",
        )

    def _steps_taken(self) -> str:
        if self.sees_rejections:
            return f"{count(self.steps, 'step', thousands=True)}, {self.rejections:,} of them rejected"
        return count(self.steps, "solver step", thousands=True)

    def _evaluations(self) -> int:
        return int(self.problem.evaluations) - self.evaluations0

    def _fail(self, t: float, reason: str, escape: str) -> None:
        advice = f"{self.advice}, {escape}" if escape else self.advice
        raise StepError(f"{reason}; {advice}", time=t if math.isfinite(t) else self.t0, reason=reason)
