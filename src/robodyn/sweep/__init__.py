"""Sweeps: many independent runs described by one TOML file, run in chunks on Dask, stored as Parquet.

::

    import robodyn.sweep
    result = robodyn.sweep.run("examples/sweeps/pendubot_basin.toml", out="basin")
    table = result.table()              # a pyarrow Table, one row a run, in run order

Modules, one concept each: :mod:`~robodyn.sweep.spec` (the sweep file), :mod:`~robodyn.sweep.plan`
(axes -> runs -> chunks), :mod:`~robodyn.sweep.measures`, :mod:`~robodyn.sweep.chunk` (one task's
work), :mod:`~robodyn.sweep.engine` (Dask), :mod:`~robodyn.sweep.store` (Parquet + manifest),
:mod:`~robodyn.sweep.progress`, :mod:`~robodyn.sweep.plots` (matplotlib, imported only to draw).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from robodyn import integrators
from robodyn.errors import InputError
from robodyn.kinds.edit import check_changes, write_params
from robodyn.kinds.params import detect_kind
from robodyn.model.load import load as load_model
from robodyn.sweep import measures
from robodyn.sweep.chunk import Job, controller_of, upright_of
from robodyn.sweep.engine import run_chunks
from robodyn.sweep.plan import Chunk, Plan, Setting, make_plan, settings
from robodyn.sweep.spec import NO_CONTROLLER, SweepSpec, check_against, load, resolve, with_digest
from robodyn.sweep.store import Store

__all__ = ["Prepared", "SweepResult", "SweepSpec", "load", "prepare", "run"]

MODELS = "models"


@dataclass(frozen=True, eq=False)
class Prepared:
    """A checked sweep ready to run: its spec (with digest), plan, the job every chunk shares, its folder."""

    spec: SweepSpec
    plan: Plan
    job: Job
    out: Path


@dataclass(frozen=True, eq=False)
class SweepResult:
    """What :func:`run` did: the folder, how many chunks it computed and skipped, and the plan."""

    out: Path
    computed: int
    skipped: int
    plan: Plan
    store: Store

    def table(self) -> Any:
        """Every run's row (pyarrow Table), sorted by run number."""
        return self.store.table()


def prepare(source: str | Path | Mapping[str, Any] | SweepSpec, out: str | Path) -> Prepared:
    """Read and check the sweep against its model, write each parameter setting's URDF once, plan the chunks.

    Raises:
        InputError, UnknownNameError: a bad value or an unknown name (with close matches).
        ModelError: a model that cannot be loaded or modified.
    """
    spec = source if isinstance(source, SweepSpec) else load(source)
    out = Path(out)
    model = resolve(spec, spec.model)
    robot = load_model(model)
    if not robot.nq_equals_nv:
        raise InputError(f"{spec.source}: model {spec.model} has nq={robot.nq} != nv={robot.nv}; sweeps need nq == nv")
    resolved_measures = tuple(
        f"{resolve(spec, m.rpartition(':')[0])}:{m.rpartition(':')[2]}" if measures.is_user(m) else m
        for m in spec.measures
    )
    controllers = tuple(resolve(spec, c) for c in spec.controllers)
    gains = {resolve(spec, c): dict(g) for c, g in spec.gains.items()}
    spec = SweepSpec(
        **{**spec.__dict__, "model": model, "measures": resolved_measures, "controllers": controllers, "gains": gains}
    )
    check_against(spec, robot.joint_names, measures.MEASURES)
    for name in spec.integrators:
        integrators.get(name)
    if "time_to_balance" in spec.measures and upright_of(robot) is None:
        raise InputError(f"{spec.source}: time_to_balance needs a cart_pole or pendubot; {robot.name} has no upright")
    kind = _check_params(spec, robot)
    files = measures.user_files(spec.measures)
    if Path(model).is_file():
        files["model"] = Path(model).read_bytes()
    for c in controllers:
        if c != NO_CONTROLLER and Path(c).is_file():
            files[f"controller:{c}"] = Path(c).read_bytes()
    spec = with_digest(spec, files)
    gains_json = json.dumps(gains, sort_keys=True)
    for c in controllers:  # build each once here: unknown names and gains are refused before any task
        controller_of(model, c, gains_json)
    for m in spec.measures:
        if measures.is_user(m):
            measures.load_user_measure(m)
    models = _models(spec, robot, kind, out)
    job = Job(spec.duration, spec.measures, gains_json, spec.seed, robot.joint_names)
    return Prepared(spec, make_plan(spec, robot.joint_names, models), job, out)


def run(
    source: str | Path | Mapping[str, Any] | SweepSpec,
    *,
    out: str | Path,
    scheduler: str | None = None,
    workers: int | None = None,
    client: Any = None,
    progress: TextIO | None = None,
    on_chunk: Callable[[Chunk], None] | None = None,
) -> SweepResult:
    """Run the sweep into ``out`` (resuming: chunks already written are skipped) and return what it did.

    ``scheduler`` is a Dask scheduler's address (``tcp://host:8786``); without it a LocalCluster
    of ``workers`` processes (default: one per CPU) is started and stopped. ``client`` is an
    existing ``distributed.Client`` to use instead. ``progress`` is a stream for the progress bar.
    """
    prepared = prepare(source, out)
    store = Store(prepared.out, prepared.spec.digest, prepared.spec.source)
    computed = run_chunks(
        prepared.plan,
        prepared.job,
        store,
        client=client,
        scheduler=scheduler,
        workers=workers,
        progress=progress,
        on_chunk=on_chunk,
    )
    return SweepResult(prepared.out, computed, len(prepared.plan.chunks) - computed, prepared.plan, store)


def _check_params(spec: SweepSpec, robot: Any) -> str | None:
    if not spec.params:
        return None
    kind = detect_kind(robot)
    if kind is None:
        raise InputError(f"{spec.source}: [params] needs a seed-kind model (pendubot, cart_pole, geared_arm)")
    for name, values in spec.params.items():
        for value in values:
            check_changes(kind, [(name, value)])
    return kind


def _models(spec: SweepSpec, robot: Any, kind: str | None, out: Path) -> dict[Setting, str]:
    """Each setting's model: the sweep's own, or a URDF with its parameters written once per value set."""
    written: dict[tuple[tuple[str, float], ...], str] = {}
    models = {}
    for setting in settings(spec):
        if not setting.params or kind is None:
            models[setting] = spec.model
            continue
        if setting.params not in written:
            tag = hashlib.sha256((spec.model + repr(setting.params)).encode()).hexdigest()[:16]
            path = out / MODELS / f"{robot.name}-{tag}.urdf"
            if not path.is_file():
                path.parent.mkdir(parents=True, exist_ok=True)
                write_params(robot, kind, dict(setting.params), path)
            written[setting.params] = str(path.resolve())
        models[setting] = written[setting.params]
    return models
