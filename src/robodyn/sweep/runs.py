"""A sweep chunk's runs: the model a worker loads, the measures of one run, the columns of a chunk.

What every path of :mod:`robodyn.sweep.chunk` (and the GPU's, :mod:`robodyn.sweep.cuda_chunk`)
shares: the :class:`Job`, the robot, compiled closed form and controller of a model (cached: a
worker keeps the last few settings), :func:`one_run` (a run through :func:`robodyn.simulate` or
the compiled loop, its row of measures), the energies of a batch of states, the divergence bound,
the runs that left the URDF's position limits, and a chunk's columns (:func:`with_inputs`).
"""

from __future__ import annotations

import inspect
import json
import math
import time
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.control import make, plant
from robodyn.errors import DivergenceError, StepError
from robodyn.integrators.stability import lyapunov
from robodyn.model.load import load
from robodyn.robot import Robot
from robodyn.sim.energy import reference_energy
from robodyn.sim.fast import KINDS, FastDynamics
from robodyn.sim.simulation import DEFAULT_MAX_ENERGY_GROWTH, simulate
from robodyn.sim.trajectory import Trajectory
from robodyn.sweep import measures as ms
from robodyn.sweep.plan import Chunk
from robodyn.sweep.policy import Policy, batch_policy
from robodyn.sweep.source import Model, ModelFile, SceneSource
from robodyn.sweep.spec import NO_CONTROLLER, SCENE_CONTROLLER

Array = NDArray[np.float64]

# What the cuda path computes: from the final states, and Benettin's twins stepped on the GPU.
CUDA_MEASURES = ms.BATCH_MEASURES | {"lyapunov"}
# The twins' starting distance: lyapunov()'s own default, which the other paths use.
LYAPUNOV_D0: float = inspect.signature(lyapunov).parameters["d0"].default


@dataclass(frozen=True)
class Job:
    """What every chunk of a sweep shares: duration [s], measures, controller gains (JSON), seed, joints, device.

    ``precision`` is what the ``cuda`` path steps in ("float64", or "float32" on request).
    """

    duration: float
    measures: tuple[str, ...]
    gains: str
    seed: int
    joint_names: tuple[str, ...]
    device: str = "cpu"
    precision: str = "float64"


@lru_cache(maxsize=8)
def built_of(model: Model) -> tuple[Robot, Any]:
    """(robot, reduction or None): the loaded model, or the scene's (cached per worker process)."""
    if isinstance(model, (SceneSource, ModelFile)):
        return model.build()
    return load(model), None


def robot_of(model: Model) -> Robot:
    """The loaded model (cached per worker process)."""
    return built_of(model)[0]


@lru_cache(maxsize=8)
def fast_of(model: Model) -> FastDynamics | None:
    """The compiled closed form of a built-in kind's model (checked against ABA), or None."""
    robot = robot_of(model)
    from robodyn.kinds.params import detect_kind

    kind = detect_kind(robot)
    if kind not in KINDS or np.any(robot.friction != 0.0):
        return None
    return FastDynamics.from_robot(robot, kind)


@lru_cache(maxsize=8)
def controller_of(model: Model, name: str, gains: str) -> Any:
    """The controller ``name`` for the model, with its gains from the JSON text (cached).

    ``"scene"`` is the scene's own [control]: None, a constant torque or a controller.
    """
    if name == NO_CONTROLLER:
        return None
    if name == SCENE_CONTROLLER and isinstance(model, SceneSource):
        robot, reduction = built_of(model)
        return model.scene.torque(robot, reduction)
    return make(name, robot_of(model), **json.loads(gains).get(name, {}))


@lru_cache(maxsize=8)
def policy_of(model: Model, name: str, gains: str) -> Policy | None:
    """The batch form of the controller (:func:`robodyn.sweep.policy.batch_policy`), or None (cached)."""
    return batch_policy(controller_of(model, name, gains), fast_of(model))


def plain(model: Model) -> bool:
    """True unless a scene asks for more than the URDF's stops and efforts, or picks its backend."""
    return not isinstance(model, SceneSource) or (model.constraints.is_default and model.backend is None)


def upright_of(robot: Robot) -> tuple[Array, NDArray[np.bool_]] | None:
    """(upright q, revolute mask) of a cart-pole or Pendubot, else None."""
    try:
        p = plant(robot)
        return p.upright(), p.angular
    except Exception:  # a robot without an upright state has no time to balance
        return None


def with_inputs(chunk: Chunk, job: Job, paths: list[str], measured: dict[str, Any]) -> dict[str, Any]:
    """The columns: ``run``, ``path``, the inputs (parameters, integrator, dt, controller, q0, v0), the measures."""
    columns: dict[str, Any] = {"run": chunk.runs.copy(), "path": paths}
    for name, value in chunk.setting.params:
        columns[f"params.{name}"] = np.full(chunk.runs.size, value)
    columns["integrator"] = [chunk.setting.integrator] * chunk.runs.size
    columns["dt"] = np.full(chunk.runs.size, chunk.setting.dt)
    columns["controller"] = [chunk.setting.controller] * chunk.runs.size
    for j, joint in enumerate(job.joint_names):
        columns[f"q0.{joint}"] = chunk.q0[:, j].copy()
        columns[f"v0.{joint}"] = chunk.v0[:, j].copy()
    columns.update(measured)
    return columns


def columns_of(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The rows' measures as columns: ``status`` a list, the rest float64 arrays."""
    keys = list(rows[0]) if rows else []
    columns: dict[str, Any] = {}
    for key in keys:
        values = [row[key] for row in rows]
        columns[key] = values if key == "status" else np.asarray(values, dtype=np.float64)
    return columns


def _single(chunk: Chunk, job: Job, path: str) -> Any:
    """run(q0, v0, T) -> Trajectory on the chunk's setting: the compiled loop or robodyn.simulate."""
    s = chunk.setting
    robot = robot_of(chunk.model)
    if path == "fast":
        fast = fast_of(chunk.model)
        assert fast is not None  # path_of chose "fast" because there is one
        return lambda q, v, T: fast.simulate(q, v, duration=T, dt=s.dt, method=s.integrator)
    controller = controller_of(chunk.model, s.controller, job.gains)
    if isinstance(chunk.model, SceneSource):
        constraints, backend = chunk.model.constraints, chunk.model.backend
        return lambda q, v, T: simulate(
            robot,
            q,
            v,
            duration=T,
            dt=s.dt,
            integrator=s.integrator,
            torque=controller,
            constraints=constraints,
            backend=backend,
        )
    return lambda q, v, T: simulate(robot, q, v, duration=T, dt=s.dt, integrator=s.integrator, torque=controller)


def one_run(chunk: Chunk, job: Job, k: int, path: str) -> dict[str, Any]:
    """One run on the ``fast`` or ``simulate`` path, every measure from its trajectory."""
    robot = robot_of(chunk.model)
    run = _single(chunk, job, path)
    q0, v0 = chunk.q0[k], chunk.v0[k]
    start = time.perf_counter()
    try:
        trajectory: Trajectory = run(q0, v0, job.duration)
    except (DivergenceError, StepError):
        trajectory = None  # type: ignore[assignment]
    wall = time.perf_counter() - start
    if path == "fast" and trajectory is not None:  # the compiled loop has no stops: simulate applies them
        finite = trajectory.q[np.isfinite(trajectory.q).all(axis=1)]
        if finite.size and stopped(robot, finite.min(axis=0)[None, :], finite.max(axis=0)[None, :]).size:
            return {**one_run(chunk, job, k, "simulate"), "path": "simulate"}
        if trajectory.status != "ok" or _diverges(robot, trajectory):  # simulate says where, as it does alone
            return {**one_run(chunk, job, k, "simulate"), "path": "simulate"}
    user = {m: ms.load_user_measure(m) for m in job.measures if ms.is_user(m)}
    row: dict[str, Any] = {"status": "diverged" if trajectory is None else trajectory.status}
    if trajectory is not None:
        upright = upright_of(robot) if "time_to_balance" in job.measures else None
        row.update(ms.from_trajectory(trajectory, job.measures, job.joint_names, upright=upright, user=user))
    else:
        row.update(_nan_row(job, robot))
    if "lyapunov" in job.measures:
        row["lyapunov"] = _lyapunov(run, q0, v0, job, int(chunk.runs[k]))
    if "wall_time" in job.measures:
        row["wall_time"] = wall
    return row


def energy_bounds(robot: Robot, kinetic0: Array, potential0: Array) -> Array:
    """The bound of simulate on |E - E0 - W| [J] for runs starting with these energies (n,): growth x energy scale."""
    scale = np.maximum(kinetic0 + np.abs(potential0), reference_energy(robot))
    return np.asarray(DEFAULT_MAX_ENERGY_GROWTH * scale, dtype=np.float64)


def _diverges(robot: Robot, trajectory: Trajectory) -> bool:
    """True when the run's energy error |E - E0 - W_input - W_damping| passes simulate's bound at some sample."""
    energy = trajectory.kinetic + trajectory.potential
    with np.errstate(all="ignore"):
        residual = energy - energy[0] - trajectory.work_input - trajectory.work_damping
        bound = energy_bounds(robot, trajectory.kinetic[:1], trajectory.potential[:1])[0]
        return bool(np.any(~(np.abs(residual) <= bound)))


def stopped(robot: Robot, q_min: Array, q_max: Array) -> NDArray[np.intp]:
    """The rows whose coordinate range [q_min, q_max] (m, nq) leaves the URDF position limits, where simulate stops."""
    lower = np.asarray(robot.model.lowerPositionLimit, dtype=np.float64)
    upper = np.asarray(robot.model.upperPositionLimit, dtype=np.float64)
    return np.flatnonzero(np.any((q_min < lower) | (q_max > upper), axis=1))


def _nan_row(job: Job, robot: Robot) -> dict[str, float]:
    out: dict[str, float] = {}
    for name in job.measures:
        if name == "final_state":
            for joint in job.joint_names:
                out[f"q.{joint}"] = out[f"v.{joint}"] = math.nan
        elif name in ("energy_drift", "time_to_balance"):
            out[name] = math.nan
    return out


def _lyapunov(run: Any, q0: Array, v0: Array, job: Job, run_index: int) -> float:
    """Benettin's estimate over the run's duration; NaN when a twin blows up."""

    def step_run(q: Array, v: Array, T: float) -> tuple[Array, Array]:
        trajectory = run(q, v, T)
        return trajectory.q[-1].copy(), trajectory.v[-1].copy()

    interval = min(ms.LYAPUNOV_INTERVAL, job.duration)
    try:
        estimate = lyapunov(step_run, q0, v0, duration=job.duration, interval=interval, seed=job.seed + run_index)
    except Exception:  # a twin that diverges or stops has no exponent
        return math.nan
    return estimate.exponent


def energies(chunk: Chunk, Q: Array, V: Array) -> Array:
    """E = K + V [J] of each state (n,), the closed form when compiled, else Pinocchio's."""
    kinetic, potential = energy_parts(chunk, Q, V)
    return kinetic + potential


def energy_parts(chunk: Chunk, Q: Array, V: Array) -> tuple[Array, Array]:
    """(K (n,), V (n,)) [J] of each state, NaN where the state is not finite; the closed form when compiled."""
    fast = fast_of(chunk.model)
    finite = np.isfinite(Q).all(axis=1) & np.isfinite(V).all(axis=1)
    if fast is not None:
        with np.errstate(all="ignore"):
            kinetic, potential = fast.energies_batch(Q, V)
        return np.where(finite, kinetic, np.nan), np.where(finite, potential, np.nan)
    robot = robot_of(chunk.model)
    kinetic, potential = np.full(Q.shape[0], np.nan), np.full(Q.shape[0], np.nan)
    for k in np.flatnonzero(finite):
        kinetic[k], potential[k] = robot.kinetic_energy(Q[k], V[k]), robot.potential_energy(Q[k])
    return kinetic, potential


def past_bound(chunk: Chunk, Q: Array, V: Array) -> NDArray[np.bool_]:
    """Runs whose final energy error |E(T) - E0| passes simulate's bound (torque-free and lossless: W = 0).

    Paths that keep final states only test the last sample; NaN (a blown-up state) counts as past.
    """
    robot = robot_of(chunk.model)
    K0, P0 = energy_parts(chunk, chunk.q0, chunk.v0)
    with np.errstate(all="ignore"):
        return ~(np.abs(energies(chunk, Q, V) - (K0 + P0)) <= energy_bounds(robot, K0, P0))


Rows = list[dict[str, Any]]


def redone(chunk: Chunk, job: Job, rows: Rows, runs: NDArray[np.intp]) -> Rows:
    """``rows``, each of ``runs`` computed again by ``simulate`` (a stop changes the motion, a divergence ends it)."""
    for k in runs:
        rows[k] = {**one_run(chunk, job, int(k), "simulate"), "path": "simulate"}
    return rows


def rows_of(chunk: Chunk, job: Job, Q: Array, V: Array, balance: Array | None, wall: float) -> list[dict[str, Any]]:
    """Per-run measures of a vectorised chunk from its final states."""
    E0, E1 = energies(chunk, chunk.q0, chunk.v0), energies(chunk, Q, V)
    rows = []
    for k in range(Q.shape[0]):
        finite = bool(np.isfinite(Q[k]).all() and np.isfinite(V[k]).all())
        row: dict[str, Any] = {"status": "ok" if finite else "diverged"}
        for name in job.measures:
            if name == "final_state":
                for j, joint in enumerate(job.joint_names):
                    row[f"q.{joint}"], row[f"v.{joint}"] = float(Q[k, j]), float(V[k, j])
            elif name == "energy_drift":
                row["energy_drift"] = float(E1[k] - E0[k])
            elif name == "time_to_balance":
                row["time_to_balance"] = float(balance[k]) if balance is not None and finite else math.nan
            elif name == "wall_time":
                row["wall_time"] = wall / Q.shape[0]
        rows.append(row)
    return rows
