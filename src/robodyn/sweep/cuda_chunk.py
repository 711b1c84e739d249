"""The sweep's ``cuda`` path: which chunks a GPU takes, and how each kind of chunk runs there.

:func:`refusal` says why a setting cannot run on the GPU ("" when it can), before any work.
:func:`execute` computes a chunk (:func:`robodyn.sweep.chunk.execute` hands ``cuda`` chunks here):

* a built-in kind without controller, ``rk4``: from the model's arrays alone (:func:`device_task`,
  :func:`robodyn.engine.cuda.sweep.run_task`: NumPy and numba, no Pinocchio, so a Dask worker with a
  GPU needs no robodyn model), the measures computed on the device, the columns built by
  :func:`finish_device` without a per-run loop;
* any other robot the compiled tree kernels take (:mod:`robodyn.engine.cuda.tree`), and a kind with
  heun or euler: final states on the GPU, energies checked on the host (:func:`_tree_rows`);
* an LQR or a swing-up to LQR of the cart-pole or the Pendubot: :func:`robodyn.engine.cuda.closed_loop.closed_loop`,
  one GPU thread a run: the ``closed_loop`` path's RK4 (torque at every stage), law
  (:mod:`robodyn.engine.torque_laws`, the controller packed by :func:`robodyn.control.compiled.law_of`),
  energy ledger (torques and joint damping, the divergence bound tested every step) and balance
  test, so only each run's final state, time to balance and flags come back (:func:`_loop_rows`).

Runs that reach a URDF position limit or diverge are computed again by ``simulate`` (as on the CPU
paths). The helpers it shares with the CPU paths are :mod:`robodyn.sweep.runs`'.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

import numpy as np

from robodyn.control.compiled import law_of
from robodyn.engine.cuda import closed_loop as cuda_closed
from robodyn.errors import InputError
from robodyn.integrators import step_count
from robodyn.sim import batch
from robodyn.sim.energy import reference_energy
from robodyn.sim.fast import FastDynamics
from robodyn.sim.simulation import DEFAULT_MAX_ENERGY_GROWTH
from robodyn.sweep import measures as ms
from robodyn.sweep import runs as ch
from robodyn.sweep.plan import Chunk
from robodyn.sweep.source import Model


def execute(chunk: Chunk, job: ch.Job) -> dict[str, Any]:
    """The columns of a ``cuda`` chunk (see the module docstring for the three ways it runs)."""
    if on_arrays(chunk, job):
        from robodyn.engine.cuda import sweep as cuda_sweep

        return finish_device(chunk, job, cuda_sweep.run_task(device_task(chunk, job)))
    if ch.controller_of(chunk.model, chunk.setting.controller, job.gains) is not None:
        rows = _loop_rows(chunk, job)
    else:
        rows = _tree_rows(chunk, job)
    paths = [row.pop("path", "cuda") for row in rows]
    return ch.with_inputs(chunk, job, paths, ch.columns_of(rows))


def refusal(
    model: Model, integrator: str, controller: Any, measures: tuple[str, ...], precision: str = "float64"
) -> str:
    """Why the ``cuda`` path cannot compute runs of this setting ("" when it can)."""
    if not ch.plain(model):
        return "a scene's constraints, springs or backend have no GPU kernel"
    robot = ch.robot_of(model)
    if controller is not None:  # an LQR or a swing-up to LQR
        if precision == "float32":
            return "precision float32 runs without a controller only; the closed loop on the GPU is float64"
        return _loop_refusal(controller, ch.fast_of(model), integrator, measures)
    if ch.fast_of(model) is None or integrator != "rk4":  # the compiled tree algorithms (robodyn.engine.cuda.tree)
        other = [m for m in measures if m not in ms.BATCH_MEASURES]
        why = batch.cuda_tree_refusal(robot, integrator)
        if not why and precision == "float32":
            why = "precision float32 runs a built-in kind's closed form with rk4 only; the tree kernels are float64"
        if not why and other:
            why = f"measures {', '.join(sorted(ms.BATCH_MEASURES))} only (lyapunov: kinds, rk4), got {', '.join(other)}"
        return why
    if np.any(robot.damping):
        return "lossless runs only; the model has joint damping"
    other = [m for m in measures if m not in ch.CUDA_MEASURES]
    if other:
        return f"measures {', '.join(sorted(ch.CUDA_MEASURES))} only, got {', '.join(other)}"
    if precision == "float32" and "lyapunov" in measures:
        return "precision float32 has no Lyapunov estimate (its twins start 1e-8 apart, below float32's resolution)"
    return ""


def _tree_rows(chunk: Chunk, job: ch.Job) -> list[dict[str, Any]]:
    """A torque-free chunk on the GPU by the compiled tree kernels; runs past a limit or the bound: ``simulate``."""
    s = chunk.setting
    robot = ch.robot_of(chunk.model)
    steps = step_count(job.duration, s.dt)
    q, v, q_min, q_max, wall = batch.cuda_tree_rollout(
        robot, chunk.q0, chunk.v0, dt=s.dt, steps=steps, integrator=s.integrator
    )
    rows = ch.rows_of(chunk, job, q, v, None, wall)
    again = np.union1d(ch.stopped(robot, q_min, q_max), np.flatnonzero(ch.past_bound(chunk, q, v)))
    return ch.redone(chunk, job, rows, again)


def on_arrays(chunk: Chunk, job: ch.Job) -> bool:
    """True when a ``cuda`` chunk runs from arrays alone (:func:`device_task`): a built-in kind's closed form, rk4."""
    s = chunk.setting
    free = ch.controller_of(chunk.model, s.controller, job.gains) is None
    return job.device == "cuda" and free and s.integrator == "rk4" and ch.fast_of(chunk.model) is not None


@lru_cache(maxsize=8)
def device_model_of(model: Model) -> Any:
    """The arrays a GPU worker needs of a built-in kind's model (:class:`robodyn.engine.cuda.sweep.DeviceModel`)."""
    from robodyn.engine.cuda.sweep import DeviceModel

    robot, fast = ch.robot_of(model), ch.fast_of(model)
    assert fast is not None  # only the cuda path, which has a closed form, asks
    return DeviceModel(
        fast.kind,
        fast.param_vector,
        fast.damping,
        np.asarray(robot.model.lowerPositionLimit, dtype=np.float64),
        np.asarray(robot.model.upperPositionLimit, dtype=np.float64),
        fast.potential_offset,
        float(reference_energy(robot)),
        float(DEFAULT_MAX_ENERGY_GROWTH),
    )


def device_task(chunk: Chunk, job: ch.Job) -> Any:
    """What a GPU worker computes of a ``cuda`` chunk, as arrays (:class:`robodyn.engine.cuda.sweep.DeviceTask`).

    Built where robodyn and Pinocchio are (the sweep's own process): the model's arrays, the
    states, the step and each run's twin stream. The worker runs it with
    :func:`robodyn.engine.cuda.sweep.run_task`, which needs NumPy and numba alone.

    Raises:
        InputError: the chunk's setting is one the GPU path does not take.
    """
    from robodyn.engine.cuda import batch as cuda_batch
    from robodyn.engine.cuda import sweep as cuda_sweep

    s = chunk.setting
    controller = ch.controller_of(chunk.model, s.controller, job.gains)
    why = refusal(chunk.model, s.integrator, controller, job.measures, job.precision)
    if why or not on_arrays(chunk, job):
        raise InputError(f"device cuda: {why or 'this chunk is not a built-in kind without controller with rk4'}")
    streams = cuda_batch.streams_of(job.seed, chunk.runs) if "lyapunov" in job.measures else None
    return cuda_sweep.DeviceTask(
        device_model_of(chunk.model),
        chunk.q0,
        chunk.v0,
        chunk.setting.dt,
        step_count(job.duration, chunk.setting.dt),
        streams,
        ms.LYAPUNOV_INTERVAL,
        ch.LYAPUNOV_D0,
        job.precision,
    )


def finish_device(chunk: Chunk, job: ch.Job, measured: Any) -> dict[str, Any]:
    """A ``cuda`` chunk's columns from what its worker computed (:class:`robodyn.engine.cuda.sweep.DeviceMeasures`).

    The host builds the columns from the arrays (:func:`robodyn.engine.cuda.sweep.columns`, no
    per-run loop) and computes again, one by one with ``simulate``, only the runs the device
    flagged (a position limit passed, or the divergence bound).
    """
    from robodyn.engine.cuda import sweep as cuda_sweep

    columns = cuda_sweep.columns(measured, job.measures, job.joint_names)
    paths = ["cuda"] * chunk.runs.size
    for k in measured.again:
        row = ch.one_run(chunk, job, int(k), "simulate")
        paths[k] = "simulate"
        for key, values in columns.items():
            values[k] = row.get(key, math.nan)
    return ch.with_inputs(chunk, job, paths, columns)


# What the closed loop computes: its measures, time to balance counted on the GPU.
LOOP_MEASURES = ms.CLOSED_LOOP_MEASURES


def _loop_refusal(controller: Any, fast: FastDynamics | None, integrator: str, measures: tuple[str, ...]) -> str:
    """Why a chunk under ``controller`` cannot run on the GPU ("" when it can)."""
    if fast is None or law_of(controller, fast) is None:
        return (
            "the controllers lqr and swing_up of the cart-pole and the Pendubot only "
            "(a controller file, a scene's constant torque or PD law runs with device cpu)"
        )
    if integrator != "rk4":
        return f"integrator rk4 only with a controller, got {integrator!r}"
    other = [m for m in measures if m not in LOOP_MEASURES]
    return f"measures {', '.join(sorted(LOOP_MEASURES))} only, got {', '.join(other)}" if other else ""


def _loop_rows(chunk: Chunk, job: ch.Job) -> list[dict[str, Any]]:
    """The chunk under its controller on the GPU (``_closed_loop``'s step, law, ledger and balance, a run a thread).

    Runs that reach a URDF position limit or diverge are computed again one by one by ``simulate``.
    """
    s = chunk.setting
    robot = ch.robot_of(chunk.model)
    fast = ch.fast_of(chunk.model)
    found = law_of(ch.controller_of(chunk.model, s.controller, job.gains), fast)
    assert fast is not None and found is not None  # refusal let this chunk through
    name, c = found
    upright = ch.upright_of(robot)
    up, angular = (upright[0], upright[1].astype(np.float64)) if upright is not None else (np.zeros(2), np.zeros(2))
    K0, P0 = ch.energy_parts(chunk, chunk.q0, chunk.v0)
    damping = np.zeros(2)
    damping[: fast.nv] = fast.damping
    q, v, q_min, q_max, balance, diverged, wall = cuda_closed.closed_loop(
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
    out = ch.rows_of(chunk, job, q, v, balance if upright is not None else None, wall)
    return ch.redone(chunk, job, out, np.union1d(ch.stopped(robot, q_min, q_max), np.flatnonzero(diverged)))
