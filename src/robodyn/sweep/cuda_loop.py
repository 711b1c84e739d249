"""The sweep's ``cuda`` path with a controller: an LQR or a swing-up to LQR on the cart-pole or the Pendubot.

:func:`rows` runs a chunk through :func:`robodyn.sim.cuda_batch.closed_loop`, one GPU thread a run:
the ``closed_loop`` path's RK4 (torque at every stage), law (:mod:`robodyn.sim.torque_laws`, the
controller packed by :func:`robodyn.control.compiled.law_of`), energy ledger (torques and joint
damping, the divergence bound tested every step) and balance test, so only each run's final state,
time to balance and flags come back. Runs that reach a URDF position limit or diverge are computed
again by ``simulate`` (as on the CPU paths).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from robodyn.control.compiled import law_of
from robodyn.integrators import step_count
from robodyn.sim import cuda_batch
from robodyn.sim.fast import FastDynamics
from robodyn.sweep import chunk as ch
from robodyn.sweep import measures as ms
from robodyn.sweep.plan import Chunk

# What it computes: the closed loop's measures, time to balance counted on the GPU.
MEASURES = ms.CLOSED_LOOP_MEASURES


def refusal(controller: Any, fast: FastDynamics | None, integrator: str, measures: tuple[str, ...]) -> str:
    """Why a chunk under ``controller`` cannot run on the GPU ("" when it can)."""
    if fast is None or law_of(controller, fast) is None:
        return (
            "the controllers lqr and swing_up of the cart-pole and the Pendubot only "
            "(a controller file, a scene's constant torque or PD law runs with device cpu)"
        )
    if integrator != "rk4":
        return f"integrator rk4 only with a controller, got {integrator!r}"
    other = [m for m in measures if m not in MEASURES]
    return f"measures {', '.join(sorted(MEASURES))} only, got {', '.join(other)}" if other else ""


def rows(chunk: Chunk, job: ch.Job) -> list[dict[str, Any]]:
    """The chunk under its controller on the GPU (``_closed_loop``'s step, law, ledger and balance, a run a thread).

    Runs that reach a URDF position limit or diverge are computed again one by one by ``simulate``.
    """
    s = chunk.setting
    robot = ch.robot_of(chunk.model)
    fast = ch.fast_of(chunk.model)
    found = law_of(ch.controller_of(chunk.model, s.controller, job.gains), fast)
    assert fast is not None and found is not None  # cuda_refusal let this chunk through
    name, c = found
    upright = ch.upright_of(robot)
    up, angular = (upright[0], upright[1].astype(np.float64)) if upright is not None else (np.zeros(2), np.zeros(2))
    K0, P0 = ch._energy_parts(chunk, chunk.q0, chunk.v0)
    damping = np.zeros(2)
    damping[: fast.nv] = fast.damping
    q, v, q_min, q_max, balance, diverged, wall = cuda_batch.closed_loop(
        fast.kind,
        name,
        fast.param_vector,
        damping,
        c,
        chunk.q0,
        chunk.v0,
        upright=up,
        angular=angular,
        tol=ms.BALANCE_TOL,
        bound=ch.energy_bounds(robot, K0, P0),
        offset=fast.potential_offset,
        dt=s.dt,
        steps=step_count(job.duration, s.dt),
    )
    out = ch._rows(chunk, job, q, v, balance if upright is not None else None, wall)
    for k in np.union1d(ch.stopped(robot, q_min, q_max), np.flatnonzero(diverged)):
        out[k] = {**ch._one(chunk, job, int(k), "simulate"), "path": "simulate"}
    return out
