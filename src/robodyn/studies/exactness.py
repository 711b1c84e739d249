"""Proof that a reduction is exact, and what it saves: the reduced model against the full one.

:func:`prove_exact` integrates the reduced model (ABA) and the full model with its locked
joints held by constraint (:func:`robodyn.model.reduce.locked_acceleration`) side by side with
the same integrator and step: exactness means their kept coordinates differ by round-off
(:class:`ExactnessReport`). :func:`compare_cost` times the dynamics calls (M, C, G, ABA) of
both models on the same seeded states (:class:`CostComparison`); :func:`time_calls` times one
model. Nothing here prints.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics, integrators
from robodyn.errors import DivergenceError, InputError
from robodyn.model.reduce import Reduction, locked_acceleration
from robodyn.robot import Robot

Array = NDArray[np.float64]


@dataclass(frozen=True)
class ExactnessReport:
    """A reduced trajectory against the full model's with the locked joints held by constraint.

    Arrays: ``t`` (n,) [s]; ``q_reduced`` (n, nq_red) and ``q_full`` (n, nq_full) with
    velocities ``v_reduced``, ``v_full``. Errors are max-abs over the run: ``q_error``
    [rad | m] and ``v_error`` [rad/s | m/s] between the kept coordinates; ``lock_drift``
    how far the locked coordinates moved from their held values; ``max_lock_torque``
    [N m | N] the largest torque the locks applied.
    """

    t: Array
    q_reduced: Array
    v_reduced: Array
    q_full: Array
    v_full: Array
    q_error: float
    v_error: float
    lock_drift: float
    max_lock_torque: float
    method: str
    dt: float
    wall_time_reduced_s: float
    wall_time_full_s: float

    def holds(self, tolerance: float) -> bool:
        """True when ``q_error``, ``v_error`` and ``lock_drift`` are all within ``tolerance`` (nan fails)."""
        return all(error <= tolerance for error in (self.q_error, self.v_error, self.lock_drift))


def prove_exact(
    reduction: Reduction,
    q0: ArrayLike,
    v0: ArrayLike,
    *,
    duration: float,
    dt: float,
    tau: ArrayLike | Callable[[float, Array, Array], ArrayLike] | None = None,
    method: str = "rk4",
) -> ExactnessReport:
    """Integrate the reduced model and the constrained full model side by side.

    Both use the integrator ``method`` with step ``dt`` [s] for ``duration`` [s], joint
    torques ``tau`` on the reduced joints [N m | N]: zero by default, a constant (nv_red,),
    or a controller tau(t, q_red, v_red) (the full model feeds it its kept coordinates),
    and each model's viscous damping (-damping * v). The reduced model runs on ABA; the full
    model on the KKT solve of :func:`locked_acceleration`. Exactness means the errors are
    round-off.
    """
    red, full = reduction.reduced, reduction.full
    q0_, v0_ = red.q_(q0), red.v_(v0)
    if callable(tau):
        controller = tau

        def torque_reduced(t: float, q: Array, v: Array) -> Array:
            return red.v_(controller(t, q, v), "tau")

    else:
        constant = np.zeros(red.nv) if tau is None else red.v_(tau, "tau")

        def torque_reduced(t: float, q: Array, v: Array) -> Array:
            return constant

    if not (np.isfinite(duration) and duration > 0):
        raise InputError(f"duration must be a positive number of seconds, got {duration!r}")
    if not (np.isfinite(dt) and dt > 0):
        raise InputError(f"dt must be a positive number of seconds, got {dt!r}")
    n_steps = max(1, round(duration / dt))
    damping_red, damping_full = red.damping, full.damping

    def accel_reduced(t: float, q: Array, v: Array) -> Array:
        if not (np.isfinite(q).all() and np.isfinite(v).all()):  # before a controller sees it: a blow-up, said so
            raise DivergenceError(
                f"the exactness proof's run diverged by t = {t:.6g} s ({method} at dt = {dt:g} s: its state is no "
                "longer finite); a smaller dt or gentler control gains keep it bounded",
                step=round(t / dt),
                time=t,
            )
        return dynamics.aba(red.model, red.data, q, v, torque_reduced(t, q, v) - damping_red * v)

    lock_torque = [0.0]

    def accel_full(t: float, q: Array, v: Array) -> Array:
        tau_full = np.zeros(full.nv)
        tau_full[reduction.kept_v] = torque_reduced(t, q[reduction.kept_q], v[reduction.kept_v])
        a, lam = locked_acceleration(reduction, q, v, tau_full - damping_full * v)
        lock_torque[0] = max(lock_torque[0], float(np.abs(lam).max(initial=0.0)))
        return a

    def problem(accel: object, robot: Robot) -> integrators.ArrayProblem:
        model = robot.model
        return integrators.ArrayProblem(
            accel,  # type: ignore[arg-type]
            robot.nq,
            robot.nv,
            integrate_fn=None if robot.nq_equals_nv else (lambda q, dq: dynamics.integrate(model, q, dq)),
        )

    start = time.perf_counter()
    sol_red = integrators.solve(problem(accel_reduced, red), q0_, v0_, dt=dt, n_steps=n_steps, method=method)
    mid = time.perf_counter()
    sol_full = integrators.solve(
        problem(accel_full, full), reduction.full_q(q0_), reduction.full_v(v0_), dt=dt, n_steps=n_steps, method=method
    )
    end = time.perf_counter()
    locked_q = np.setdiff1d(np.arange(full.nq), reduction.kept_q)
    dq = np.array(
        [dynamics.difference(red.model, a, b) for a, b in zip(sol_red.q, sol_full.q[:, reduction.kept_q], strict=True)]
    )
    return ExactnessReport(
        t=sol_red.t,
        q_reduced=sol_red.q,
        v_reduced=sol_red.v,
        q_full=sol_full.q,
        v_full=sol_full.v,
        q_error=float(np.abs(dq).max()),
        v_error=float(np.abs(sol_red.v - sol_full.v[:, reduction.kept_v]).max()),
        lock_drift=float(np.abs(sol_full.q[:, locked_q] - reduction.q_reference[locked_q]).max(initial=0.0)),
        max_lock_torque=lock_torque[0],
        method=method,
        dt=dt,
        wall_time_reduced_s=mid - start,
        wall_time_full_s=end - mid,
    )


@dataclass(frozen=True)
class CostComparison:
    """Mean wall time per dynamics call [s] on the full and the reduced model.

    ``full`` and ``reduced`` map "M", "C", "G", "ABA" to seconds per call, measured on
    ``repeat`` seeded random states each.
    """

    nv_full: int
    nv_reduced: int
    full: dict[str, float]
    reduced: dict[str, float]
    repeat: int

    def speedup(self, what: str) -> float:
        """How many times faster the reduced model computes ``what``."""
        return self.full[what] / self.reduced[what]


def time_calls(robot: Robot, *, repeat: int = 200, seed: int = 0) -> dict[str, float]:
    """Mean wall time [s] of one M (CRBA), C, G and ABA call of ``robot`` over ``repeat`` states."""
    if repeat < 1:
        raise InputError(f"repeat must be >= 1, got {repeat}")
    rng = np.random.default_rng(seed)
    model, data = robot.model, robot.data
    states = [robot.random_state(rng) for _ in range(repeat)]
    taus = [rng.uniform(-1.0, 1.0, robot.nv) for _ in range(repeat)]
    calls: dict[str, Callable[[Array, Array, Array], object]] = {
        "M": lambda q, v, tau: dynamics.mass_matrix(model, data, q),
        "C": lambda q, v, tau: dynamics.coriolis_matrix(model, data, q, v),
        "G": lambda q, v, tau: dynamics.gravity(model, data, q),
        "ABA": lambda q, v, tau: dynamics.aba(model, data, q, v, tau),
    }
    out = {}
    for name, call in calls.items():
        call(*states[0], taus[0])  # warm up (first-call allocations)
        start = time.perf_counter()
        for (q, v), tau in zip(states, taus, strict=True):
            call(q, v, tau)
        out[name] = (time.perf_counter() - start) / repeat
    return out


def compare_cost(reduction: Reduction, *, repeat: int = 200, seed: int = 0) -> CostComparison:
    """Time M, C, G and ABA on the full and the reduced model side by side."""
    full = time_calls(reduction.full, repeat=repeat, seed=seed)
    reduced = time_calls(reduction.reduced, repeat=repeat, seed=seed)
    return CostComparison(reduction.full.nv, reduction.reduced.nv, full, reduced, repeat)
