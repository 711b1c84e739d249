"""Many initial states at once: Pinocchio's threaded ABA inside the integrators' own step.

A batch of n states of a robot with nq == nv is presented to an integrator from
:mod:`robodyn.integrators` as one flat problem of size n * nv (states laid out one after the
other), whose acceleration is one call of :func:`robodyn.dynamics.aba_batch` (Pinocchio's
``abaInParallel``: C++ threads, no Python per state). The method is the same code that
:func:`robodyn.simulate` uses, so a batch run equals n single runs up to round-off.
Torque-free and lossless-joint models only (the batch has no ledger).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics, integrators
from robodyn.errors import InputError

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class BatchResult:
    """Final states q (n, nq), v (n, nv) after ``steps`` steps of ``dt`` [s]; cost of the run."""

    q: Array
    v: Array
    dt: float
    steps: int
    integrator: str
    threads: int
    wall_time_s: float
    evaluations: int

    @property
    def state_steps_per_second(self) -> float:
        """Throughput: states times steps advanced per wall-clock second."""
        return self.q.shape[0] * self.steps / self.wall_time_s


def rollout(
    robot: Robot,
    q0: ArrayLike,
    v0: ArrayLike,
    *,
    duration: float,
    dt: float,
    integrator: str = "rk4",
    threads: int | None = None,
) -> BatchResult:
    """Advance every state of the batch (q0 (n, nq), v0 (n, nv)) by ``duration`` [s] in steps of ``dt``.

    ``threads`` defaults to the number of CPUs. Only fixed-step explicit integrators apply.
    """
    import pinocchio as pin  # the pool type only; every algorithm call goes through robodyn.dynamics

    if not robot.nq_equals_nv:
        raise InputError(f"{robot.name}: the batch path needs nq == nv, got nq={robot.nq}, nv={robot.nv}")
    if np.any(robot.damping) or np.any(robot.friction):
        raise InputError(f"{robot.name}: the batch path has no joint losses; damping or friction is set")
    Q = np.atleast_2d(np.asarray(q0, dtype=np.float64))
    V = np.atleast_2d(np.asarray(v0, dtype=np.float64))
    if Q.shape[1] != robot.nq or V.shape != Q.shape:
        raise InputError(f"q0 and v0 must both have shape (n, {robot.nq}), got {Q.shape} and {V.shape}")
    method = integrators.get(integrator)
    if not isinstance(method, integrators.FixedStepIntegrator) or method.implicit or method.symplectic:
        raise InputError(
            f"integrator {integrator!r}: the batch path takes explicit fixed-step methods (rk4, heun, euler)"
        )
    steps = integrators.step_count(duration, dt)
    n, nv = Q.shape
    threads = threads or os.cpu_count() or 1
    pool = pin.ModelPool(robot.model, threads)
    tau = np.zeros((n, nv))

    def accel(t: float, q: Array, v: Array) -> Array:
        return dynamics.aba_batch(pool, q.reshape(n, nv), v.reshape(n, nv), tau, threads=threads).reshape(-1)

    problem = integrators.ArrayProblem(accel, n * nv)
    q, u = Q.reshape(-1).copy(), V.reshape(-1).copy()
    start = time.perf_counter()
    for k in range(steps):
        q, u, _ = method.step(problem, k * dt, q, u, dt)
    wall = time.perf_counter() - start
    return BatchResult(q.reshape(n, nv), u.reshape(n, nv), dt, steps, method.name, threads, wall, problem.evaluations)
