"""One chunk of runs, computed in one call (one Dask task): the fastest path that applies to all of them.

The path is chosen per chunk (all its runs share a setting):

* ``fast``: a built-in kind without controller, integrator ``rk4`` or ``semi_implicit_euler``: the
  compiled closed-form loop of :class:`robodyn.sim.fast.FastDynamics`, run by run (a run that
  reaches a URDF position limit is computed again by ``simulate``, which stops it there);
* ``closed_loop``: an LQR, or a swing-up handing over to one (:mod:`robodyn.sweep.policy`), with
  ``rk4`` and only final state, energy drift, time to balance or wall time asked: one vectorised
  RK4 over the chunk (as :mod:`robodyn.control.rollout`), accelerations from the compiled closed
  form (built-in kinds) or ABA, balance tracked every step. A run that reaches a URDF position limit
  (where :func:`robodyn.simulate` would stop it) is computed again by ``simulate``;
* ``batch``: any other torque-free lossless robot without position limits, with an explicit
  fixed-step method and only final state, energy drift or wall time asked:
  :func:`robodyn.sim.batch.rollout` (one thread). It has no stops and returns final states only,
  so it cannot see a run pass a limit on the way: a robot with finite limits goes to ``simulate``;
* ``cuda`` (the sweep's ``device = "cuda"``): the runs on an NVIDIA GPU, one thread a run
  (:mod:`robodyn.sweep.cuda_chunk`: a built-in kind from its arrays, measures on the device; any
  other robot the compiled tree kernels take; an LQR or a swing-up to LQR of a built-in kind);
* ``simulate``: anything else, :func:`robodyn.simulate` run by run: a user's controller file, a
  scene's constant torque or PD law, a scene with constraints or springs beyond the URDF's stops
  and efforts, or a scene that picks its dynamics backend.

Every path applies :func:`robodyn.simulate`'s divergence test: a run whose energy error
|E - E0 - W| (W the work of its torques and damping) passes ``max_energy_growth`` (1) times its
energy scale, or whose state is not finite, is ``diverged``. The ``fast`` and ``closed_loop`` paths
test every step (``batch`` and ``cuda``, which keep final states only, test the last) and hand such a run to
``simulate``, whose row (status, measures up to the failing step) is then the run's.

Every operation in the vectorised paths acts on each run's row alone (no matrix product across
runs), so a run's numbers do not depend on its chunk: a chunk of one gives the same bits.
Workers keep the loaded robot, compiled dynamics and controllers of the last few settings.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from robodyn import dynamics
from robodyn.errors import InputError
from robodyn.integrators import FixedStepIntegrator, get, step_count
from robodyn.sim import batch
from robodyn.sim.fast import METHODS
from robodyn.sweep import cuda_chunk
from robodyn.sweep import measures as ms
from robodyn.sweep.plan import Chunk
from robodyn.sweep.runs import (  # Job and the model's helpers are also reached from here
    Array,
    Job,
    columns_of,
    controller_of,
    energy_bounds,
    energy_parts,
    fast_of,
    one_run,
    past_bound,
    plain,
    policy_of,
    redone,
    robot_of,
    rows_of,
    stopped,
    upright_of,
    with_inputs,
)

__all__ = [
    "Job",
    "controller_of",
    "energy_bounds",
    "execute",
    "fast_of",
    "path_of",
    "policy_of",
    "robot_of",
    "upright_of",
]


def path_of(chunk: Chunk, job: Job) -> str:
    """The path that computes this chunk (see the module docstring)."""
    robot = robot_of(chunk.model)
    s = chunk.setting
    wanted = set(job.measures)
    controller = controller_of(chunk.model, s.controller, job.gains)
    if job.device == "cuda":
        refusal = cuda_chunk.refusal(chunk.model, s.integrator, controller, job.measures, job.precision)
        if refusal:
            raise InputError(f"device cuda: {refusal}")
        return "cuda"
    if not plain(chunk.model):
        return "simulate"
    if controller is None:
        if s.integrator in METHODS and fast_of(chunk.model) is not None:
            return "fast"
        method = get(s.integrator)
        explicit = isinstance(method, FixedStepIntegrator) and not method.implicit and not method.symplectic
        lossless = not np.any(robot.damping) and not np.any(robot.friction)
        free = (
            not np.isfinite(robot.model.lowerPositionLimit).any()
            and not np.isfinite(robot.model.upperPositionLimit).any()
        )
        if wanted <= ms.BATCH_MEASURES and explicit and lossless and free and robot.nq_equals_nv:
            return "batch"
        return "simulate"
    closed = s.integrator == "rk4" and wanted <= ms.CLOSED_LOOP_MEASURES
    if closed and policy_of(chunk.model, s.controller, job.gains) is not None:
        return "closed_loop"
    return "simulate"


def execute(chunk: Chunk, job: Job) -> dict[str, Any]:
    """Compute every run of ``chunk``: columns ``run``, ``status``, the inputs and the measures, one row a run."""
    path = path_of(chunk, job)
    if path == "cuda":
        return cuda_chunk.execute(chunk, job)
    if path == "closed_loop":
        rows = _closed_loop(chunk, job)
    elif path == "batch":
        rows = _batch(chunk, job)
    else:
        rows = [one_run(chunk, job, k, path) for k in range(chunk.runs.size)]
    paths = [row.pop("path", path) for row in rows]
    return with_inputs(chunk, job, paths, columns_of(rows))


def _batch(chunk: Chunk, job: Job) -> list[dict[str, Any]]:
    """The torque-free chunk through Pinocchio's batch ABA, one thread."""
    s = chunk.setting
    result = batch.rollout(
        robot_of(chunk.model), chunk.q0, chunk.v0, duration=job.duration, dt=s.dt, integrator=s.integrator, threads=1
    )
    rows = rows_of(chunk, job, result.q, result.v, None, result.wall_time_s)
    return redone(chunk, job, rows, np.flatnonzero(past_bound(chunk, result.q, result.v)))


def _closed_loop(chunk: Chunk, job: Job) -> list[dict[str, Any]]:
    """The chunk under its controller's batch form: classical RK4, torque at every stage, balance tracked.

    Runs that reach a URDF position limit are computed again one by one by ``simulate`` (which stops them there).
    """
    s = chunk.setting
    robot = robot_of(chunk.model)
    policy = policy_of(chunk.model, s.controller, job.gains)
    assert policy is not None  # path_of chose "closed_loop" because there is one
    fast = fast_of(chunk.model)
    upright = upright_of(robot)
    actuated = np.flatnonzero(robot.actuated)
    dt, steps = s.dt, step_count(job.duration, s.dt)

    def accel(q: Array, v: Array, tau: Array) -> Array:
        if fast is not None:
            return np.asarray(fast.acceleration(q, v, tau), dtype=np.float64).reshape(q.shape)
        out = np.full(q.shape, np.nan)
        for k in range(q.shape[0]):
            if np.isfinite(q[k]).all() and np.isfinite(v[k]).all() and np.isfinite(tau[k]).all():
                out[k] = dynamics.aba(robot.model, robot.data, q[k], v[k], tau[k] - robot.damping * v[k])
        return out

    def rates(q: Array, v: Array) -> tuple[Array, Array]:
        """(accelerations (n, nv), power of the torques and damping (n,) [W])."""
        tau = np.zeros_like(v)
        tau[:, actuated] = policy(q, v)
        return accel(q, v, tau), np.sum((tau - robot.damping * v) * v, axis=1)

    Q, V = chunk.q0.copy(), chunk.v0.copy()
    K0, P0 = energy_parts(chunk, Q, V)
    bound = energy_bounds(robot, K0, P0)
    W = np.zeros(Q.shape[0])  # work of the torques and damping [J], integrated with the state (simulate's ledger)
    diverged = np.zeros(Q.shape[0], dtype=bool)
    q_min, q_max = Q.copy(), Q.copy()
    start = time.perf_counter()
    last_out = np.full(Q.shape[0], -1, dtype=np.int64)
    with np.errstate(all="ignore"):  # a state that blows up is kept as NaN, not raised on
        for step in range(steps + 1):
            if upright is not None:
                last_out[~ms.inside_upright(Q, *upright)] = step
            if step == steps:
                break
            (k1v, p1), k1q = rates(Q, V), V
            (k2v, p2), k2q = rates(Q + 0.5 * dt * k1q, V + 0.5 * dt * k1v), V + 0.5 * dt * k1v
            (k3v, p3), k3q = rates(Q + 0.5 * dt * k2q, V + 0.5 * dt * k2v), V + 0.5 * dt * k2v
            (k4v, p4), k4q = rates(Q + dt * k3q, V + dt * k3v), V + dt * k3v
            Q = Q + dt / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q)
            V = V + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
            W = W + dt / 6.0 * (p1 + 2.0 * p2 + 2.0 * p3 + p4)
            bad = ~np.isfinite(Q).all(axis=1) | ~np.isfinite(V).all(axis=1)
            Q[bad], V[bad] = np.nan, np.nan
            K, P = energy_parts(chunk, Q, V)
            diverged |= ~(np.abs(K + P - (K0 + P0) - W) <= bound)  # NaN (a blown-up state) counts
            np.fmin(q_min, Q, out=q_min)
            np.fmax(q_max, Q, out=q_max)
    wall = time.perf_counter() - start
    balance = np.where(last_out == steps, np.nan, (last_out + 1) * dt) if upright is not None else None
    rows = rows_of(chunk, job, Q, V, balance, wall)
    return redone(chunk, job, rows, np.union1d(stopped(robot, q_min, q_max), np.flatnonzero(diverged)))
