"""Sweeps: many independent runs described by one TOML file, run in chunks on Dask, stored as Parquet.

::

    import robodyn.sweep
    result = robodyn.sweep.run("examples/sweeps/pendubot_basin.toml", out="basin")
    table = result.table()              # a pyarrow Table, one row a run, in run order

    robodyn.sweep.run("examples/sweeps/cart_pole_swing_up.toml", out="swing")   # a sweep over a scene

Modules, one concept each: :mod:`~robodyn.sweep.spec` (the sweep file), :mod:`~robodyn.sweep.plan`
(axes -> runs -> chunks), :mod:`~robodyn.sweep.measures`, :mod:`~robodyn.sweep.chunk` (one task's
work), :mod:`~robodyn.sweep.engine` (Dask), :mod:`~robodyn.sweep.store` (Parquet + manifest),
:mod:`~robodyn.sweep.progress`, :mod:`~robodyn.sweep.plots` (matplotlib, imported only to draw),
:mod:`~robodyn.sweep.source` (a model or a scene), :mod:`~robodyn.sweep.policy` (controllers over a batch).

A sweep that names a scene reads it with :func:`robodyn.scene.read_scene` (the sweep sits above
the scene package in robodyn's layers); ``read_scene`` replaces that reader.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np
from numpy.typing import NDArray

from robodyn import integrators
from robodyn.errors import InputError, UnknownNameError
from robodyn.kinds import catalog
from robodyn.kinds.edit import check_changes, write_params
from robodyn.kinds.params import detect_kind
from robodyn.model.load import PASSIVE_JOINT
from robodyn.model.load import load as load_model
from robodyn.sweep import measures
from robodyn.sweep.cuda_chunk import refusal as cuda_refusal
from robodyn.sweep.engine import check_cluster, run_chunks
from robodyn.sweep.plan import Chunk, Plan, Setting, make_plan, settings
from robodyn.sweep.runs import Job, controller_of, upright_of
from robodyn.sweep.source import (
    AsWritten,
    Model,
    ModelFile,
    SceneReader,
    SceneSource,
    has_control,
    scene_source,
    simulate_defaults,
)
from robodyn.sweep.spec import (
    NO_CONTROLLER,
    SCENE_CONTROLLER,
    SweepSpec,
    check_against,
    check_bounds,
    load,
    resolve,
    with_digest,
)
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


def prepare(
    source: str | Path | Mapping[str, Any] | SweepSpec, out: str | Path, *, read_scene: SceneReader | None = None
) -> Prepared:
    """Read and check the sweep against its model, write each parameter setting's URDF once, plan the chunks.

    ``read_scene`` reads the scene file a sweep may name (default :func:`robodyn.scene.read_scene`).

    Raises:
        InputError, UnknownNameError: a bad value or an unknown name (with close matches).
        SceneError: a scene file that is missing or wrong (an InputError).
        ModelError: a model that cannot be loaded or modified.
    """
    spec = source if isinstance(source, SweepSpec) else load(source)
    out = Path(out)
    scene = _scene(spec, read_scene)
    model_name = ""
    if scene is not None:
        spec = _with_scene_defaults(spec, scene)
    check_bounds(spec)  # before loading anything: a grid or a duration past the bounds is a typo
    if spec.precision != "float64" and spec.device != "cuda":
        raise InputError(
            f"{spec.source}: precision {spec.precision} runs on device cuda only (the CPU paths compute in float64); "
            "add --device cuda or drop precision"
        )
    if scene is not None:
        scene = scene.with_passive(spec.passive)
        robot, reduction = scene.build()
        model: Model = scene
        q_default, v_default = scene.scene.initial_state(robot, reduction)
    else:
        model_name = resolve(spec, spec.model)
        if not spec.physics_check:
            model = AsWritten(model_name, spec.passive)
        else:
            model = ModelFile(model_name, spec.passive) if spec.passive else model_name
        robot = _robot_named(spec, model)
    if not robot.nq_equals_nv:
        raise InputError(f"{spec.source}: model {robot.name} has nq={robot.nq} != nv={robot.nv}; sweeps need nq == nv")
    if scene is None:
        q_default, v_default = np.zeros(robot.nq), np.zeros(robot.nv)
    resolved_measures = tuple(
        f"{resolve(spec, m.rpartition(':')[0])}:{m.rpartition(':')[2]}" if measures.is_user(m) else m
        for m in spec.measures
    )
    controllers = tuple(resolve(spec, c) for c in spec.controllers)
    gains = {resolve(spec, c): dict(g) for c, g in spec.gains.items()}
    spec = SweepSpec(
        **{
            **spec.__dict__,
            "model": model.scene.path.as_posix() if isinstance(model, SceneSource) else str(model),
            "measures": resolved_measures,
            "controllers": controllers,
            "gains": gains,
        }
    )
    check_against(spec, robot.joint_names, measures.MEASURES)
    for name in spec.integrators:
        integrators.get(name)
    if SCENE_CONTROLLER in controllers and scene is None:
        raise InputError(f"{spec.source}: controller 'scene' is the scene's [control]; this sweep names no scene")
    if SCENE_CONTROLLER in gains:
        raise InputError(
            f"{spec.source}: [gains.scene]: the scene's controller takes its gains from its [control] table"
        )
    if "time_to_balance" in spec.measures and upright_of(robot) is None:
        raise InputError(f"{spec.source}: time_to_balance needs a cart_pole or pendubot; {robot.name} has no upright")
    kind = _check_params(spec, scene.full() if scene is not None and spec.params else robot)
    spec = with_digest(spec, _input_files(spec, model, model_name, np.concatenate([q_default, v_default])))
    gains_json = json.dumps(gains, sort_keys=True)
    _build_once(spec, model, gains_json)
    models = _models(spec, model, robot, kind, out)
    job = Job(spec.duration, spec.measures, gains_json, spec.seed, robot.joint_names, spec.device, spec.precision)
    if spec.device == "cuda":
        _check_cuda(spec, models, gains_json)
    return Prepared(spec, make_plan(spec, robot.joint_names, models, defaults=(q_default, v_default)), job, out)


def _input_files(spec: SweepSpec, model: Model, model_name: str, initial: NDArray[np.float64]) -> dict[str, bytes]:
    """The bytes of every file the sweep reads (and its initial state), for the digest that keys its results."""
    files = measures.user_files(spec.measures)
    if isinstance(model, SceneSource):
        files["scene"] = model.key.encode()
    elif Path(model_name).is_file():
        files["model"] = Path(model_name).read_bytes()
    for c in spec.controllers:
        if c not in (NO_CONTROLLER, SCENE_CONTROLLER) and Path(c).is_file():
            files[f"controller:{c}"] = Path(c).read_bytes()
    files["initial"] = initial.astype("<f8").tobytes()
    return files


def _build_once(spec: SweepSpec, model: Model, gains_json: str) -> None:
    """Build each controller and load each user measure once: unknown names and gains are refused before any task."""
    for c in spec.controllers:
        try:
            controller_of(model, c, gains_json)
        except (InputError, UnknownNameError) as exc:  # named with the file and key it comes from
            if not str(exc.args[0]).startswith(spec.source):
                exc.args = (f"{spec.source}: controller {exc.args[0]}",)
            raise
    for m in spec.measures:
        if measures.is_user(m):
            measures.load_user_measure(m)


def run(
    source: str | Path | Mapping[str, Any] | SweepSpec,
    *,
    out: str | Path,
    scheduler: str | None = None,
    workers: int | None = None,
    client: Any = None,
    progress: TextIO | None = None,
    on_chunk: Callable[[Chunk], None] | None = None,
    read_scene: SceneReader | None = None,
) -> SweepResult:
    """Run the sweep into ``out`` (resuming: chunks already written are skipped) and return what it did.

    ``scheduler`` is a Dask scheduler's address (``tcp://host:8786``); without it a LocalCluster
    of ``workers`` processes (default: one per CPU) is started and stopped. ``client`` is an
    existing ``distributed.Client`` to use instead. ``progress`` is a stream for the progress bar.
    ``read_scene`` reads the scene file a sweep may name (default :func:`robodyn.scene.read_scene`).
    A ``device = "cuda"`` sweep without ``client`` or ``scheduler`` runs its chunks in this process on
    its GPU (refused at once without one); with them, on the workers' GPUs.
    """
    if client is None:
        check_cluster(scheduler=scheduler, workers=workers)  # before reading anything, let alone submitting
    fresh = not Path(out).exists()  # a folder this sweep makes is removed again if it ends with nothing in it
    prepared = prepare(source, out, read_scene=read_scene)
    if prepared.job.device == "cuda" and client is None and scheduler is None:  # this process's GPU runs the chunks
        from robodyn.engine.cuda import batch as cuda_batch

        cuda_batch.cuda_module()  # no GPU (exit 5) or no numba CUDA target (exit 4): one line, before any work
    store = Store(prepared.out, prepared.spec.digest, prepared.spec.source, fresh=fresh)
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


def _check_cuda(spec: SweepSpec, models: Mapping[Setting, Model], gains: str) -> None:
    """Refuse a ``device = "cuda"`` sweep that has a setting the GPU path cannot run, before any work.

    Raises:
        InputError: naming the setting's integrator or controller and what the GPU path takes.
    """
    for setting, model in models.items():
        refusal = cuda_refusal(
            model, setting.integrator, controller_of(model, setting.controller, gains), spec.measures, spec.precision
        )
        if refusal:
            raise InputError(f"{spec.source}: device cuda: {refusal}")


def _scene(spec: SweepSpec, read_scene: SceneReader | None) -> SceneSource | None:
    """The scene the sweep names, read by ``read_scene``; None without one."""
    if not spec.scene:
        return None
    reader: SceneReader
    if read_scene is None:
        from robodyn.scene import read_scene as reader
    else:
        reader = read_scene
    path = Path(resolve(spec, spec.scene))
    scene = reader(path)
    if not spec.physics_check:  # the sweep's physics_check = false reaches the model of its scene
        scene = dataclasses.replace(scene, model={**scene.model, "physics_check": False})  # type: ignore[type-var]
    return scene_source(scene)


def _with_scene_defaults(spec: SweepSpec, scene: SceneSource) -> SweepSpec:
    """``spec`` with what it leaves out taken from the scene: duration, dt, integrator, controller."""
    table = simulate_defaults(scene.scene)
    changes: dict[str, Any] = {}
    if "duration" not in spec.given and "duration" in table:
        changes["duration"] = float(table["duration"])
    if "dt" not in spec.given and "dt" in table:
        changes["dts"] = (float(table["dt"]),)
    if "integrator" not in spec.given and "integrator" in table:
        changes["integrators"] = (str(table["integrator"]),)
    if "controller" not in spec.given and has_control(scene.scene):
        changes["controllers"] = (SCENE_CONTROLLER,)
    return SweepSpec(**{**spec.__dict__, **changes})


def _robot_named(spec: SweepSpec, model: str | ModelFile) -> Any:
    """The sweep's robot, its ``passive`` joints (if any) checked against the model's joints."""
    if isinstance(model, str):
        try:
            return load_model(model)
        except UnknownNameError as exc:  # named with the file and key it comes from
            raise InputError(f"{spec.source}: model: {exc}") from None
    try:
        robot, _ = model.build()
    except UnknownNameError as exc:
        if exc.what != PASSIVE_JOINT:
            raise
        raise InputError(f"{spec.source}: passive: {exc}") from None
    return robot


def _check_params(spec: SweepSpec, robot: Any) -> str | None:
    if not spec.params:
        return None
    kind = detect_kind(robot)
    if kind is None:
        raise InputError(f"{spec.source}: [params] needs a model of a built-in kind ({catalog.listed()})")
    for name, values in spec.params.items():
        for value in values:
            try:
                check_changes(kind, [(name, value)])
            except (InputError, UnknownNameError) as exc:  # named with the file and table it comes from
                exc.args = (f"{spec.source}: [params] {exc.args[0]}",)
                raise
    return kind


def _models(spec: SweepSpec, model: Model, robot: Any, kind: str | None, out: Path) -> dict[Setting, Model]:
    """Each setting's model: the sweep's own, or a URDF with its parameters written once per value set.

    With a scene, the written URDF replaces the scene's model file (its joints kept or locked as before).
    """
    written: dict[tuple[tuple[str, float], ...], Model] = {}
    models: dict[Setting, Model] = {}
    full = model.full() if isinstance(model, SceneSource) and spec.params else robot
    tag_of = model.key if isinstance(model, SceneSource) else str(model)
    if isinstance(model, ModelFile) and model.passive:  # a passive set of its own: URDFs of their own
        tag_of += "|passive=" + ",".join(model.passive)
    created: list[Path] = []  # what this call wrote (folders first): removed again if a later value set is refused
    try:
        for setting in settings(spec):
            models[setting] = _model_of(setting, model, full, kind, out, tag_of, written, created)
    except BaseException:
        for path in reversed(created):
            with contextlib.suppress(OSError):
                path.rmdir() if path.is_dir() else path.unlink()
        raise
    return models


def _model_of(
    setting: Setting,
    model: Model,
    full: Any,
    kind: str | None,
    out: Path,
    tag_of: str,
    written: dict[tuple[tuple[str, float], ...], Model],
    created: list[Path],
) -> Model:
    """One setting's model (see :func:`_models`); a URDF written into ``out/models`` is noted in ``created``."""
    if not setting.params or kind is None:
        return model
    if setting.params not in written:
        tag = hashlib.sha256((tag_of + repr(setting.params)).encode()).hexdigest()[:16]
        path = out / MODELS / f"{full.name}-{tag}.urdf"
        if not path.is_file():
            missing = [p for p in (path.parent, *path.parent.parents) if not p.exists()]
            path.parent.mkdir(parents=True, exist_ok=True)
            created += reversed(missing)
            files = write_params(full, kind, dict(setting.params), path)
            created += [f for f in (files.urdf, files.srdf) if f is not None]
        resolved = path.resolve()
        if isinstance(model, SceneSource):
            written[setting.params] = model.with_urdf(resolved)
        elif isinstance(model, ModelFile):  # AsWritten too: the same passive joints, the same physics check
            written[setting.params] = dataclasses.replace(model, name=str(resolved))
        else:
            written[setting.params] = str(resolved)
    return written[setting.params]
