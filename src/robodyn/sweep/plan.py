"""The plan of a sweep: its axes crossed into runs, and the runs cut into chunks (one Dask task each).

Runs are numbered in one fixed order: the *settings* (parameters, integrator, dt, controller,
crossed in that order) on the outside, the initial *states* (q0 then v0 axes, joints in the
model's order, the last axis fastest) inside. A chunk holds consecutive runs of one setting, so
each task loads one model and one controller. A chunk's id is a hash of the sweep's digest, its
setting, its run numbers and its states' bytes: the same runs of the same sweep give the same
id, which is how a resumed sweep knows what it already has.
"""

from __future__ import annotations

import hashlib
import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodyn.sweep.source import Model
from robodyn.sweep.spec import SweepSpec

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Setting:
    """What is shared by a chunk's runs: parameter values, integrator, dt [s], controller name."""

    params: tuple[tuple[str, float], ...]
    integrator: str
    dt: float
    controller: str


@dataclass(frozen=True, eq=False)
class Chunk:
    """Runs ``runs`` (m,) of one ``setting``, from states q0 (m, nq), v0 (m, nv); ``model`` is what to load."""

    id: str
    index: int
    setting: Setting
    model: Model
    runs: NDArray[np.int64]
    q0: Array
    v0: Array


@dataclass(frozen=True, eq=False)
class Plan:
    """Every chunk in run order, and the axes (name -> values) that vary."""

    chunks: tuple[Chunk, ...]
    n_runs: int
    axes: dict[str, tuple[float | str, ...]]
    settings: tuple[Setting, ...]


def settings(spec: SweepSpec) -> tuple[Setting, ...]:
    """Every setting, parameters outermost, then integrator, dt, controller."""
    names = tuple(spec.params)
    grids = [spec.params[n] for n in names]
    out = []
    for values in itertools.product(*grids):
        for integrator, dt, controller in itertools.product(spec.integrators, spec.dts, spec.controllers):
            out.append(Setting(tuple(zip(names, values, strict=True)), integrator, dt, controller))
    return tuple(out)


def states(
    spec: SweepSpec, joint_names: tuple[str, ...], defaults: tuple[Array, Array] | None = None
) -> tuple[Array, Array]:
    """The initial states q0 (n, nq), v0 (n, nv): the grid of every q0 and v0 axis (last fastest).

    A joint without an axis starts at ``defaults`` (q (nq,), v (nv,): a scene's initial state), else at 0.
    """
    nq = len(joint_names)
    q_default, v_default = defaults if defaults is not None else (np.zeros(nq), np.zeros(nq))
    axes = [spec.q0.get(j, (float(q_default[i]),)) for i, j in enumerate(joint_names)]
    axes += [spec.v0.get(j, (float(v_default[i]),)) for i, j in enumerate(joint_names)]
    mesh = np.meshgrid(*[np.asarray(a, dtype=np.float64) for a in axes], indexing="ij")
    flat = np.stack([m.reshape(-1) for m in mesh], axis=1)
    return np.ascontiguousarray(flat[:, :nq]), np.ascontiguousarray(flat[:, nq:])


def make_plan(
    spec: SweepSpec,
    joint_names: tuple[str, ...],
    models: dict[Setting, Model],
    *,
    defaults: tuple[Array, Array] | None = None,
) -> Plan:
    """Cut the sweep into chunks of at most ``spec.chunk`` runs; ``models`` gives each setting's model to load.

    ``defaults`` (q (nq,), v (nv,)) is where joints without an axis start (0 without).
    """
    all_settings = settings(spec)
    q0, v0 = states(spec, joint_names, defaults)
    n_states = q0.shape[0]
    chunks: list[Chunk] = []
    for s_index, setting in enumerate(all_settings):
        for start in range(0, n_states, spec.chunk):
            stop = min(start + spec.chunk, n_states)
            runs = np.arange(s_index * n_states + start, s_index * n_states + stop, dtype=np.int64)
            q, v = q0[start:stop], v0[start:stop]
            chunk_id = chunk_digest(spec.digest, setting, runs, q, v)
            chunks.append(Chunk(chunk_id, len(chunks), setting, models[setting], runs, q, v))
    axes: dict[str, tuple[float | str, ...]] = {}
    for j in joint_names:
        for label, table in (("q0", spec.q0), ("v0", spec.v0)):
            if len(table.get(j, ())) > 1:
                axes[f"{label}.{j}"] = table[j]
    for name, grid in spec.params.items():
        if len(grid) > 1:
            axes[f"params.{name}"] = grid
    for label, values in (("integrator", spec.integrators), ("dt", spec.dts), ("controller", spec.controllers)):
        if len(values) > 1:
            axes[label] = tuple(values)
    return Plan(tuple(chunks), n_states * len(all_settings), axes, all_settings)


def chunk_digest(sweep_digest: str, setting: Setting, runs: NDArray[np.int64], q0: Array, v0: Array) -> str:
    """The chunk's identity: sha256 of the sweep digest, the setting, the run numbers and the states' bytes."""
    h = hashlib.sha256()
    h.update(sweep_digest.encode() + b"\0" + repr(setting).encode() + b"\0")
    for array in (runs.astype("<i8"), q0.astype("<f8"), v0.astype("<f8")):
        h.update(str(array.shape).encode())
        h.update(np.ascontiguousarray(array).tobytes())
    return h.hexdigest()[:24]
