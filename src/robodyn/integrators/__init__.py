"""Time integrators for second-order systems; they know nothing about robots.

Three things are kept apart (as in diffrax):

* **what is integrated** -- a :class:`SecondOrderProblem` (:mod:`.problem`): a configuration
  ``q`` on a manifold, ``u = [v, w]`` (velocity, then running integrals such as the work
  done by a torque), the rates ``du/dt`` and the retraction ``integrate(q, dq)``;
* **how a step is taken** -- an :class:`Integrator` (:mod:`.base`), which declares its
  ``order`` and whether it is ``symplectic``, ``adaptive``, ``implicit`` and ``fixed_step``:
  explicit Euler and the Runge--Kutta family (:mod:`.explicit`, coefficients in
  :mod:`.tableau`), kick-drift Euler, symplectic Euler and the implicit midpoint rule
  (:mod:`.symplectic`), the error-controlled Dormand--Prince 5(4) (:mod:`.adaptive`) and
  SciPy's ``solve_ivp`` methods (:mod:`.scipy_methods`);
* **what is recorded** -- the caller's business (:func:`robodyn.simulate`, or :func:`solve`
  for plain arrays, :mod:`.arrays`).

Every integrator is reached by name through :data:`INTEGRATORS` (``get("rk4")``;
``names(fixed_step=True)`` filters by property), in :mod:`.registry`. The stability theory of
the fixed-step methods (step matrices, stability regions, bisection, Lyapunov exponents) is
:mod:`.stability`.
"""

from __future__ import annotations

from robodyn.integrators.adaptive import EmbeddedRungeKutta
from robodyn.integrators.arrays import Solution, solve, step_count
from robodyn.integrators.base import (
    MAX_STEPS,
    MAX_STEPS_PER_INTERVAL,
    MIN_RELATIVE_STEP,
    AdaptiveIntegrator,
    FixedStepIntegrator,
    Integrator,
    StepBudget,
    Stepper,
)
from robodyn.integrators.explicit import ClassicRK4, ExplicitEuler, ExplicitRungeKutta
from robodyn.integrators.problem import Array, ArrayProblem, SecondOrderProblem, finite_difference_jacobian
from robodyn.integrators.registry import INTEGRATORS, get, names
from robodyn.integrators.scipy_methods import SCIPY_METHODS, ScipyIntegrator
from robodyn.integrators.symplectic import (
    NEWTON_MAX_ITER,
    NEWTON_RTOL,
    NEWTON_STALL,
    ImplicitMidpoint,
    SemiImplicitEuler,
    SymplecticEuler,
)
from robodyn.integrators.tableau import CLASSIC_RK4, DORMAND_PRINCE_54, HEUN, TABLEAU_TOL, ButcherTableau

__all__ = [
    "CLASSIC_RK4",
    "DORMAND_PRINCE_54",
    "HEUN",
    "INTEGRATORS",
    "MAX_STEPS",
    "MAX_STEPS_PER_INTERVAL",
    "MIN_RELATIVE_STEP",
    "NEWTON_MAX_ITER",
    "NEWTON_RTOL",
    "NEWTON_STALL",
    "SCIPY_METHODS",
    "TABLEAU_TOL",
    "AdaptiveIntegrator",
    "Array",
    "ArrayProblem",
    "ButcherTableau",
    "ClassicRK4",
    "EmbeddedRungeKutta",
    "ExplicitEuler",
    "ExplicitRungeKutta",
    "FixedStepIntegrator",
    "ImplicitMidpoint",
    "Integrator",
    "ScipyIntegrator",
    "SecondOrderProblem",
    "SemiImplicitEuler",
    "Solution",
    "StepBudget",
    "Stepper",
    "SymplecticEuler",
    "finite_difference_jacobian",
    "get",
    "names",
    "solve",
    "step_count",
]
