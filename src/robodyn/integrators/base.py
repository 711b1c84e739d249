"""How a step is taken: the :class:`Integrator` base classes and the :class:`Stepper` of one run.

An :class:`Integrator` is an immutable description that declares its ``order`` and whether it
is ``symplectic``, ``adaptive`` and ``implicit``; it is fixed-step exactly when it is a
:class:`FixedStepIntegrator` (which is checked against ``adaptive``). A run starts with
:meth:`Integrator.start`, which returns a :class:`Stepper`; its ``advance`` moves the state
from ``t`` to ``t + h`` -- one step for the fixed-step methods, as many error-controlled steps
as needed for the adaptive ones -- and also returns the rates at the start of the interval when
the method evaluated them there anyway (so a recorder gets the acceleration at every sample
for free).
"""

from __future__ import annotations

import abc
import functools
from dataclasses import dataclass
from typing import Any

from robodyn.errors import InputError
from robodyn.integrators.problem import Array, SecondOrderProblem


class Stepper(abc.ABC):
    """One run of an integrator on one problem: call :meth:`advance` interval by interval."""

    problem: SecondOrderProblem

    @abc.abstractmethod
    def advance(self, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array | None]:
        """Move (q, u) from t to t + h [s]; return (q1, u1, rates at t or None)."""


@dataclass(frozen=True)
class Integrator(abc.ABC):
    """How a step is taken. Subclasses declare what they are; instances are immutable.

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
