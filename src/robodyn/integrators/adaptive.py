"""Adaptive methods: embedded explicit Runge--Kutta pairs with error control (Dormand--Prince 5(4)).

An :class:`EmbeddedRungeKutta` advances over each output interval by as many error-controlled
steps as it needs, and lands exactly on the interval's end. Its stages are taken on the
configuration manifold as in :mod:`robodyn.integrators.explicit`, and the running integrals w
(the ledger's work) ride along in u = [v, w] but stay out of the error norm.

Two Dormand--Prince 5(4) implementations are registered on purpose: ``dopri5`` is robodyn's
own, retracting every stage onto the configuration manifold with ``problem.integrate``,
keeping the running integrals out of its error norm and stepping exactly onto every output
time (where it hands back the rates it already evaluated), while ``scipy_rk45`` is SciPy's
independent implementation of the same pair, which steps [x, v, w] in one chart
q = q0 (+) x, weighs w in its error norm and reads the samples from its dense output, and is
kept as a cross-check of ``dopri5``.

Its work is bounded (:class:`~robodyn.integrators.base.AdaptiveIntegrator`): every attempted
step, rejected ones included, counts against ``max_steps_per_interval`` and ``max_steps``, and
an error control that asks for a step below ``min_relative_step * max(|t|, output interval)``
(after a rejection, or after accepted steps that keep shrinking) stops the run: a one-line
:class:`StepError` instead of a run that spins.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from robodyn.integrators.base import AdaptiveIntegrator, StepBudget, Stepper
from robodyn.integrators.explicit import ExplicitRungeKutta
from robodyn.integrators.problem import Array, SecondOrderProblem
from robodyn.integrators.tableau import DORMAND_PRINCE_54, ButcherTableau


@dataclass(frozen=True)
class EmbeddedRungeKutta(AdaptiveIntegrator):
    """An embedded explicit Runge--Kutta pair with error control (Dormand--Prince 5(4)).

    Each ``advance`` over an output interval takes as many steps as the error estimate
    allows: the scaled RMS norm of the difference between the two solutions, with scale
    atol + rtol max(|y0|, |y1|) over (q, v) (running integrals excluded), must be <= 1.
    The next step is h * min(5, max(0.2, 0.9 err^(-1/5))), never beyond the interval's end.
    The work bounds (``max_steps_per_interval``, ``max_steps``, ``min_relative_step``) are
    :class:`~robodyn.integrators.base.AdaptiveIntegrator`'s keyword options.

    Raises:
        ValueError: the tableau has no embedded solution (``b_error``).
    """

    tableau: ButcherTableau = field(default=DORMAND_PRINCE_54)

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.tableau.b_error is None:
            raise ValueError(f"integrator {self.name!r} needs a tableau with an embedded solution (b_error)")

    def _stepper(
        self, problem: SecondOrderProblem, t0: float, q0: Array, u0: Array, t_end: float, rtol: float, atol: float
    ) -> Stepper:
        """A stepper that keeps its step size from interval to interval."""
        return _EmbeddedStepper(self, problem, rtol, atol)

    def fixed(self) -> ExplicitRungeKutta:
        """The same tableau's higher-order solution taken at a fixed step (to measure its order)."""
        t = self.tableau
        plain = ButcherTableau(name=t.name, a=t.a, b=t.b, c=t.c, order=t.order)
        return ExplicitRungeKutta(
            name=f"{self.name}-fixed",
            order=t.order,
            symplectic=False,
            adaptive=False,
            implicit=False,
            description=self.description,
            tableau=plain,
        )


class _EmbeddedStepper(Stepper):
    SAFETY = 0.9
    MIN_FACTOR = 0.2
    MAX_FACTOR = 5.0

    def __init__(self, method: EmbeddedRungeKutta, problem: SecondOrderProblem, rtol: float, atol: float) -> None:
        tableau = method.tableau
        self.problem = problem
        self.tableau = tableau
        self.budget = StepBudget(method, problem, sees_rejections=True)
        self.rtol = rtol
        self.atol = atol
        self.h: float | None = None
        self.k_first: Array | None = None
        self.exponent = -1.0 / (min(tableau.order, tableau.error_order or tableau.order) + 1)
        self.A = np.array(tableau.a)
        self.b = np.array(tableau.b)
        self.e = np.array(tableau.b) - np.array(tableau.b_error)  # type: ignore[arg-type]

    @property
    def steps(self) -> int:
        """Accepted steps so far in the run."""
        return self.budget.run_accepted

    @property
    def rejected(self) -> int:
        """Rejected steps so far in the run."""
        return self.budget.run_rejected

    def _attempt(self, t: float, q: Array, u: Array, h: float, k0: Array) -> tuple[Array, Array, float, Array]:
        p = self.problem
        nv = p.nv
        s = self.tableau.stages
        U = np.empty((s, u.size))
        K = np.empty((s, u.size))
        U[0] = u
        K[0] = k0
        for i in range(1, s):
            w = h * self.A[i, :i]
            U[i] = u + w @ K[:i]
            K[i] = p.rates(t + self.tableau.c[i] * h, p.integrate(q, w @ U[:i, :nv]), U[i])
        hb = h * self.b
        u1 = u + hb @ K
        q1 = p.integrate(q, hb @ U[:, :nv])
        he = h * self.e
        err_v = he @ K[:, :nv]
        err_q = he @ U[:, :nv]
        v0, v1 = u[:nv], u1[:nv]
        # q error in the tangent space: scaled by |q| on flat problems, by 1 on manifolds.
        sq = self.atol + self.rtol * (np.maximum(np.abs(q), np.abs(q1)) if p.flat else 1.0)
        sv = self.atol + self.rtol * np.maximum(np.abs(v0), np.abs(v1))
        err = float(np.sqrt((np.sum((err_q / sq) ** 2) + np.sum((err_v / sv) ** 2)) / (2 * nv)))
        k_last = K[-1] if self.tableau.fsal else p.rates(t + h, q1, u1)
        return q1, u1, err, k_last

    def _initial_step(self, t: float, q: Array, u: Array, k0: Array, h_max: float) -> float:
        """The first step's size [s]: within [the minimum step, h_max]."""
        nv = self.problem.nv
        scale = self.atol + self.rtol * np.abs(u[:nv])
        d1 = float(np.sqrt(np.mean((k0[:nv] / scale) ** 2)))
        d0 = float(np.sqrt(np.mean((u[:nv] / scale) ** 2)))
        h = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1  # NaN when the rates are: then h_max
        smallest = self.budget.method.min_relative_step * max(abs(t), h_max)
        return min(max(h, smallest), h_max) if np.isfinite(h) else h_max

    def advance(self, t: float, q: Array, u: Array, h_out: float) -> tuple[Array, Array, Array | None]:
        """Take error-controlled steps from t to exactly t + h_out [s].

        Raises:
            StepError: a bound of the integrator was hit (see :class:`StepBudget`).
        """
        t_end = t + h_out
        budget = self.budget
        budget.interval(t, h_out)
        k = self.k_first if self.k_first is not None else self.problem.rates(t, q, u)
        k_start = k
        h = self.h if self.h is not None else self._initial_step(t, q, u, k, h_out)
        while True:
            budget.take(t)  # at most max_steps_per_interval attempts: the loop ends
            remaining = t_end - t
            last = h >= remaining * (1.0 - 1e-12)
            step = remaining if last else h
            q1, u1, err, k1 = self._attempt(t, q, u, step, k)
            if err <= 1.0:  # accept (a NaN error compares False and is rejected)
                budget.accepted()
                factor = self.MAX_FACTOR if err == 0.0 else min(self.MAX_FACTOR, self.SAFETY * err**self.exponent)
                # A step clipped to the interval's end says little about the next one.
                h = max(h, step * factor) if last else step * factor
                q, u, k = q1, u1, k1
                if last:
                    break
                t = t + step
            else:
                budget.rejected()
                shrink = self.SAFETY * err**self.exponent if np.isfinite(err) else self.MIN_FACTOR
                h = step * min(1.0, max(self.MIN_FACTOR, shrink))
            # The step the error control asks for next: accepted steps shrink too (by up to 0.9
            # each) when the solution runs into a singularity.
            budget.check_step(t, h)
        self.h = h
        self.k_first = k
        return q, u, k_start
