"""SciPy's ``solve_ivp`` methods (RK45, DOP853, Radau, BDF, LSODA) as robodyn integrators.

They are independent implementations, kept as references and cross-checks of robodyn's own
methods, and for stiff problems (the implicit ones). The module is not called ``scipy`` so
that it cannot shadow the SciPy package; SciPy itself is imported only when a run starts.

Their work is bounded like robodyn's own (:class:`~robodyn.integrators.base.AdaptiveIntegrator`):
each ``solver.step()`` counts against ``max_steps_per_interval`` and ``max_steps``, and a step
taken below ``min_relative_step * max(|t|, output interval)`` and smaller than the step before
it stops the run with a one-line :class:`StepError` (SciPy bounds the rejected attempts
inside one ``step()`` itself: it fails once the step falls below ten spacings of floating-point
numbers at t).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from robodyn.errors import StepError
from robodyn.integrators.base import AdaptiveIntegrator, StepBudget, Stepper
from robodyn.integrators.problem import Array, SecondOrderProblem

# solve_ivp method -> (highest order, implicit, description).
SCIPY_METHODS = {
    "RK45": (
        5,
        False,
        "scipy RK45: SciPy's independent Dormand-Prince 5(4) (chart around q0, dense output), "
        "kept to cross-check dopri5",
    ),
    "DOP853": (8, False, "scipy DOP853: Dormand-Prince 8(5,3), error control"),
    "Radau": (5, True, "scipy Radau IIA: implicit, order 5, for stiff problems"),
    "BDF": (5, True, "scipy BDF: implicit multistep, variable order 1-5"),
    "LSODA": (12, True, "scipy LSODA: switches between Adams (order <= 12) and BDF"),
}


@dataclass(frozen=True)
class ScipyIntegrator(AdaptiveIntegrator):
    """One of scipy's ``solve_ivp`` methods, stepped through its ``OdeSolver`` class.

    The state is y = [x, v, w] with q = q0 (+) x: x is a chart of the configuration
    manifold around q0 (exact for revolute, prismatic and continuous joints). Output
    samples come from the solver's dense output. Implicit methods get the analytical
    Jacobian from ``problem.jacobian``. ``order`` is the method's highest order.

    ``forced_step`` [s] (explicit methods only) turns error control off and takes steps of
    exactly that size -- how the tests measure the order of RK45 and DOP853.

    The work bounds (``max_steps_per_interval``, ``max_steps``, ``min_relative_step``) are
    :class:`~robodyn.integrators.base.AdaptiveIntegrator`'s keyword options.

    Raises:
        ValueError: ``forced_step`` given to an implicit method, or not > 0.
    """

    method: str = "RK45"
    forced_step: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.forced_step is not None and (self.implicit or not self.forced_step > 0):
            raise ValueError(f"{self.name}: forced_step needs an explicit method and a step > 0")

    def _stepper(
        self, problem: SecondOrderProblem, t0: float, q0: Array, u0: Array, t_end: float, rtol: float, atol: float
    ) -> Stepper:
        """Create the scipy solver for the whole run [t0, t_end]."""
        return _ScipyStepper(self, problem, t0, q0, u0, t_end, rtol, atol)


class _ScipyStepper(Stepper):
    def __init__(
        self,
        method: ScipyIntegrator,
        problem: SecondOrderProblem,
        t0: float,
        q0: Array,
        u0: Array,
        t_end: float,
        rtol: float,
        atol: float,
    ) -> None:
        from scipy import integrate as sp_integrate

        self.problem = problem
        self.name = method.name
        self.budget = StepBudget(method, problem, sees_rejections=False)
        self.q0 = np.array(q0, dtype=np.float64)
        nv = problem.nv
        self.nv = nv
        y0 = np.concatenate([np.zeros(nv), u0])
        cls = getattr(sp_integrate, method.method)
        options: dict[str, Any] = {"rtol": rtol, "atol": atol}
        if method.forced_step is not None:  # every step accepted, none longer than forced_step
            options = {"rtol": 1e10, "atol": 1e10, "first_step": method.forced_step, "max_step": method.forced_step}
        if method.implicit:
            options["jac"] = self._jac
        self.solver = cls(self._fun, t0, y0, t_end, **options)
        self.dense: Any = None
        self.last_step = 0.0  # the last step taken [s]; 0 before the first, which is never checked

    def _q(self, x: Array) -> Array:
        return self.problem.integrate(self.q0, x)

    def _fun(self, t: float, y: Array) -> Array:
        nv = self.nv
        u = y[nv:]
        return np.concatenate([u[:nv], self.problem.rates(t, self._q(y[:nv]), u)])

    def _jac(self, t: float, y: Array) -> Array:
        nv = self.nv
        n = y.size
        da_dq, da_dv = self.problem.jacobian(t, self._q(y[:nv]), y[nv:])
        J = np.zeros((n, n))
        J[:nv, nv : 2 * nv] = np.eye(nv)
        J[nv : 2 * nv, :nv] = da_dq
        J[nv : 2 * nv, nv : 2 * nv] = da_dv
        return J

    def advance(self, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array | None]:
        """Step the scipy solver past t + h and read the state there from dense output.

        Raises:
            StepError: the solver failed, or a bound of the integrator was hit (see :class:`StepBudget`).
        """
        target = t + h
        solver = self.solver
        budget = self.budget
        budget.interval(t, h)
        while solver.t < target and solver.status == "running":
            budget.take(solver.t)  # at most max_steps_per_interval steps: the loop ends
            message = solver.step()
            self.dense = None
            if solver.status == "failed":
                what = f"{self.name} (scipy {type(solver).__name__}) failed at t = {solver.t:.6g} s: {message}"
                raise StepError(f"{what}; {budget.advice}", time=solver.t, reason=what)
            taken = float(solver.step_size)
            # Only a step the error control shrank is a verdict: a small first step (LSODA starts
            # near 1e-16 s under a large torque and holds it for a few steps) is the solver's
            # guess, and the last one may be clipped to t_end.
            if solver.status == "running" and taken < self.last_step:
                budget.check_step(solver.t, taken)
            self.last_step = taken
        if solver.t == target:
            y = solver.y.copy()
        else:  # the last step went past the target: read it from that step's interpolant
            if self.dense is None:
                self.dense = solver.dense_output()
            y = self.dense(target)
        nv = self.nv
        return self._q(y[:nv]), y[nv:].copy(), None
