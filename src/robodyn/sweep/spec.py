"""The sweep file: a TOML description of many independent runs, read and checked into a :class:`SweepSpec`.

A sweep file names a model (or a scene) and the axes of the runs; every axis with more than one
value is crossed with every other (a full grid)::

    model = "pendubot"            # a built-in name, an example-robot-data name or a URDF path
    # or: scene = "../cart_pole_swing_up.toml"   (a scene file: see below)
    duration = 5.0                # [s] of every run
    dt = 1e-3                     # [s]; a list makes it an axis
    integrator = "rk4"            # or a list: an axis
    controller = "lqr"            # optional; "none", a name, a list, or a controller file
    passive = ["joint2"]          # optional: joints without an actuator, besides the SRDF's
    measure = ["final_state", "time_to_balance", "wall_time", "my_measures.py:peak"]
    chunk = 1000                  # runs per Dask task
    seed = 0                      # the Lyapunov twins' seed (the run's index is added)
    device = "cpu"                # or "cuda": the runs on an NVIDIA GPU (a kind's closed form, else the tree)
    precision = "float64"         # or "float32" (device "cuda", a built-in kind, no Lyapunov)

    [q0]                          # initial configuration: joint -> value, list or grid
    joint1 = { from = -3.14, to = 3.14, n = 101 }
    joint2 = 0.0
    [v0]
    joint1 = [0.0, 1.0]
    [params]                      # built-in kind parameters (robodyn params --set), each value an axis
    m2 = [0.8, 1.0, 1.2]
    [gains.lqr]                   # a controller's gains
    R = 1.0

Joints left out start at 0. Names (keys, joints, parameters, measures, integrators,
controllers) are checked against what exists, and a miss names the close matches; the checks
that need the model happen in :func:`check_against`.

**A scene** (``scene = "path.toml"``, a ``robodyn run`` scene file) instead of ``model`` supplies
what the sweep file leaves out: the model (its ``[model]``, reduced to the joints it keeps), the
initial state (joints without a ``[q0]``/``[v0]`` axis start at the scene's ``[initial]``), the
duration, dt and integrator (``[simulate]``, when the sweep gives none), the constraints and
springs, and the controller (``[control]``, the controller named ``"scene"``, the default when
the sweep gives no ``controller``). Every key the sweep file gives overrides the scene's.
Relative paths (``scene``, ``model``, controller and measure files) are read from the sweep
file's folder.
"""

from __future__ import annotations

import hashlib
import math
import reprlib
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.errors import InputError, UnknownNameError
from robodyn.fileio import is_number, read_user_file
from robodyn.user_import import real_path

TOP_KEYS = (
    "chunk",
    "controller",
    "device",
    "dt",
    "duration",
    "gains",
    "integrator",
    "measure",
    "model",
    "params",
    "passive",
    "physics_check",
    "precision",
    "q0",
    "scene",
    "seed",
    "v0",
)
# A grid of more than this many points on one axis is a typo, not a sweep.
MAX_AXIS_POINTS = 10_000_000
MAX_CHUNK = 1_000_000
# The most runs in one sweep: a hundred times the basin example; the plan holds every run's state in memory.
MAX_RUNS = 1_000_000
# The most steps of all runs together: 10^11 is hours on a 16-core machine on the compiled paths, and more than a
# day on the simulate path (~20 us a step); a sweep past it is a typo in duration, dt or a grid, not a plan.
MAX_TOTAL_STEPS = 10**11
# A sweep file is a few lines of TOML, like a scene file.
MAX_SWEEP_BYTES = 2**20
DEFAULT_CHUNK = 1000
NO_CONTROLLER = "none"
# The controller name that means the scene's own [control].
SCENE_CONTROLLER = "scene"
# Defaults of the keys a sweep file may leave to its scene's [simulate] (or to these, without a scene).
DEFAULT_DURATION = 5.0
DEFAULT_DT = 1e-3
DEFAULT_INTEGRATOR = "rk4"
# Where the runs are computed: "cuda" runs the built-in kinds' closed form (under the lqr or swing_up
# controller too), or the compiled tree algorithms of any other robot they take, on an NVIDIA GPU.
DEVICES = ("cpu", "cuda")
# What the runs compute in: float32 only on request, and only on device "cuda".
PRECISIONS = ("float64", "float32")


@dataclass(frozen=True)
class SweepSpec:
    """A checked sweep: the model or scene, each axis's values (tuples of floats or names) and what to measure.

    ``q0`` and ``v0`` map joint names to their values [rad | m] and [rad/s | m/s]; ``params`` a
    built-in kind's parameter name to its values (SI units); ``base`` is the folder that relative paths
    in the file are read from; ``digest`` identifies everything that decides a run's numbers.
    ``scene`` is the scene file's path ("" without one; ``model`` is then "" until the scene is
    read); ``given`` the top-level keys the file gave (the rest may come from the scene); ``passive``
    the joints declared unactuated besides the SRDF's (added to a scene's [model] passive).
    """

    source: str
    model: str
    duration: float
    dts: tuple[float, ...]
    integrators: tuple[str, ...]
    controllers: tuple[str, ...]
    gains: Mapping[str, Mapping[str, Any]]
    measures: tuple[str, ...]
    q0: Mapping[str, tuple[float, ...]]
    v0: Mapping[str, tuple[float, ...]]
    params: Mapping[str, tuple[float, ...]]
    chunk: int = DEFAULT_CHUNK
    seed: int = 0
    base: Path = field(default_factory=Path.cwd)
    digest: str = ""
    scene: str = ""
    given: frozenset[str] = frozenset()
    physics_check: bool = True  # False: the model's file is loaded with its numbers as written
    passive: tuple[str, ...] = ()
    device: str = "cpu"  # "cuda": the chunks run on an NVIDIA GPU (robodyn.engine.cuda.batch)
    precision: str = "float64"  # "float32": the cuda path steps in single precision


def load(source: str | Path | Mapping[str, Any]) -> SweepSpec:
    """Read a sweep file (path) or a mapping of the same keys into a :class:`SweepSpec`.

    Raises:
        InputError: an unreadable file, a wrong type or value (naming the key).
        UnknownNameError: an unknown top-level key or measure (with close matches).
    """
    if isinstance(source, Mapping):
        return parse(source, name="sweep", base=Path.cwd())
    path = Path(source)
    raw = read_user_file(path, what="sweep", expected="a .toml sweep file", limit=MAX_SWEEP_BYTES)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{path}: is not UTF-8 text (expected a .toml sweep file)") from None
    toml = _toml()
    try:
        data = toml.loads(text)
    except toml.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(f"{path}: arrays or tables nested too deeply to read (a sweep file nests a few)") from None
    return parse(data, name=str(path), base=real_path(path).parent)


def parse(data: Mapping[str, Any], *, name: str, base: Path) -> SweepSpec:
    """Check the keys and values of a sweep mapping (no model needed); see :func:`load`."""
    for key in data:
        if key not in TOP_KEYS:
            raise _unknown("key", str(key), TOP_KEYS, name)
    if ("model" in data) == ("scene" in data):
        raise InputError(
            f"{name}: give exactly one of 'model' (a built-in name, an example-robot-data name or a URDF path) "
            "and 'scene' (a scene file)"
        )
    model = _text(data["model"], f"{name}: model") if "model" in data else ""
    scene = _text(data["scene"], f"{name}: scene") if "scene" in data else ""
    if scene and not scene.endswith(".toml"):
        raise InputError(f"{name}: scene must be a scene file NAME.toml, got {scene!r}")
    duration = _positive(data.get("duration", DEFAULT_DURATION), f"{name}: duration [s]")
    dts = tuple(_positive(x, f"{name}: dt [s]") for x in _given(data, "dt", DEFAULT_DT, name))
    integrators = tuple(_text(x, f"{name}: integrator") for x in _given(data, "integrator", DEFAULT_INTEGRATOR, name))
    controllers = tuple(_text(x, f"{name}: controller") for x in _given(data, "controller", NO_CONTROLLER, name))
    measures = tuple(_text(x, f"{name}: measure") for x in _given(data, "measure", "final_state", name))
    gains = _table(data.get("gains", {}), f"{name}: gains")
    for controller, table in gains.items():
        if controller not in controllers:
            raise _unknown("controller in [gains]", controller, controllers, name)
        _table(table, f"{name}: gains.{controller}")
    chunk = _whole(data.get("chunk", DEFAULT_CHUNK), f"{name}: chunk", 1, MAX_CHUNK)
    seed = _whole(data.get("seed", 0), f"{name}: seed", 0, 2**32 - 1)
    physics_check = data.get("physics_check", True)
    if not isinstance(physics_check, bool):
        raise InputError(f"{name}: physics_check must be true or false, got {physics_check!r}")
    q0 = {k: _axis(v, f"{name}: q0.{k}") for k, v in _table(data.get("q0", {}), f"{name}: q0").items()}
    v0 = {k: _axis(v, f"{name}: v0.{k}") for k, v in _table(data.get("v0", {}), f"{name}: v0").items()}
    params = {k: _axis(v, f"{name}: params.{k}") for k, v in _table(data.get("params", {}), f"{name}: params").items()}
    device = data.get("device", "cpu")
    if device not in DEVICES:
        raise InputError(f"{name}: device must be one of {', '.join(map(repr, DEVICES))}, got {device!r}")
    precision = data.get("precision", "float64")
    if precision not in PRECISIONS:
        raise InputError(f"{name}: precision must be one of {', '.join(map(repr, PRECISIONS))}, got {precision!r}")
    passive = data.get("passive", [])
    if not isinstance(passive, list) or not all(isinstance(x, str) and x.strip() for x in passive):
        raise InputError(f'{name}: passive must be a list of joint names like ["joint2"], got {passive!r}')
    for label, values in (("dt", dts), ("integrator", integrators), ("controller", controllers), ("measure", measures)):
        if len(set(values)) != len(values):
            raise InputError(f"{name}: {label} lists a value twice: {list(values)}")
    spec = SweepSpec(
        source=name,
        model=model,
        duration=duration,
        dts=dts,
        integrators=integrators,
        controllers=controllers,
        gains={k: dict(v) for k, v in gains.items()},
        measures=measures,
        q0=q0,
        v0=v0,
        params=params,
        chunk=chunk,
        seed=seed,
        base=base,
        scene=scene,
        given=frozenset(str(k) for k in data),
        physics_check=physics_check,
        passive=tuple(dict.fromkeys(x.strip() for x in passive)),
        device=device,
        precision=precision,
    )
    return spec


def with_digest(spec: SweepSpec, files: Mapping[str, bytes]) -> SweepSpec:
    """``spec`` with its digest: every number-deciding entry, plus the bytes of the files it reads.

    ``files`` maps a label (model, a user measure or controller file) to its content, so that an
    edited model or measure file makes every chunk new.
    """
    h = hashlib.sha256()
    parts: tuple[str, ...] = (
        spec.model,
        spec.scene,
        repr(spec.duration),
        repr(spec.measures),
        repr(sorted((k, sorted(v.items())) for k, v in spec.gains.items())),
        repr(spec.seed),
        *(() if spec.physics_check else ("physics as written",)),  # absent by default: old digests hold
    )
    if spec.precision != "float64":  # only when asked: float64 sweeps keep their digests (and folders)
        parts = (*parts, "precision=" + spec.precision)
    if spec.passive:  # only when given: the digests (and resumable folders) of other sweeps stay as they were
        parts = (*parts, "passive=" + ",".join(sorted(spec.passive)))
    for part in parts:
        h.update(part.encode() + b"\0")
    for label in sorted(files):
        h.update(label.encode() + b"\0" + hashlib.sha256(files[label]).digest())
    return SweepSpec(**{**spec.__dict__, "digest": h.hexdigest()})


def check_against(spec: SweepSpec, joint_names: tuple[str, ...], measure_names: tuple[str, ...]) -> None:
    """Check the joint and measure names of ``spec`` against the model's joints and the known measures.

    Raises:
        UnknownNameError: an unknown joint or measure, with the close matches.
    """
    for label, table in (("q0", spec.q0), ("v0", spec.v0)):
        for joint in table:
            if joint not in joint_names:
                raise _unknown(f"joint in [{label}]", joint, joint_names, spec.source)
    for measure in spec.measures:
        if ":" not in measure and measure not in measure_names:
            raise _unknown("measure", measure, measure_names, spec.source)


def resolve(spec: SweepSpec, name: str) -> str:
    """A path named in the sweep file, made absolute against the file's folder (names pass through)."""
    looks_like_path = name.endswith((".urdf", ".py", ".toml")) or "/" in name or "\\" in name
    if not looks_like_path:
        return name
    path = Path(name)
    return str(path if path.is_absolute() else real_path(spec.base / path))


# ----------------------------------------------------------------------------- values


def _unknown(what: str, name: str, choices: tuple[str, ...] | Any, source: str = "") -> UnknownNameError:
    """UnknownNameError with the close matches, its message led by the sweep file's name."""
    error = UnknownNameError(what, name, tuple(choices))
    if source:
        error.args = (f"{source}: {error.args[0]}",)
    return error


def _given(data: Mapping[str, Any], key: str, default: Any, name: str) -> list[Any]:
    """The values of ``key`` (one, or a list: an axis), ``default`` when left out; an empty list is refused."""
    values = _listed(data.get(key, default))
    if not values:
        raise InputError(f"{name}: {key} lists no value (expected one value, or a list of them: an axis)")
    return values


def check_bounds(spec: SweepSpec) -> int:
    """Refuse a sweep past the documented bounds before anything is submitted; return its number of runs.

    Each dt must cut the duration into a whole number of at most :data:`MAX_STEPS` steps (``robodyn simulate``'s
    bound), the grid must hold at most :data:`MAX_RUNS` runs, and all of them at most :data:`MAX_TOTAL_STEPS` steps.

    Raises:
        InputError: naming the sweep file, the key and the bound.
    """
    from robodyn.integrators import step_count
    from robodyn.sim.simulation import MAX_STEPS

    steps = 0
    for dt in spec.dts:
        if dt > spec.duration:
            raise InputError(f"{spec.source}: dt {dt:g} s is longer than the duration {spec.duration:g} s")
        if spec.duration / dt > MAX_STEPS:
            raise InputError(
                f"{spec.source}: duration {spec.duration:g} s in steps of dt = {dt:g} s is "
                f"{spec.duration / dt:.3g} steps a run; at most {MAX_STEPS:.0e} (as robodyn simulate)"
            )
        try:
            steps = max(steps, step_count(spec.duration, dt))
        except InputError as exc:
            raise InputError(f"{spec.source}: {exc} (every run of a sweep takes whole steps)") from None
    sizes = [len(v) for v in (*spec.q0.values(), *spec.v0.values(), *spec.params.values())]
    sizes += [len(spec.dts), len(spec.integrators), len(spec.controllers)]
    runs = math.prod(sizes)
    if runs > MAX_RUNS:
        shown = " x ".join(str(n) for n in sizes if n > 1)
        raise InputError(f"{spec.source}: the grid has {shown} = {runs:.3g} runs; at most {MAX_RUNS:.0e}")
    if runs * steps > MAX_TOTAL_STEPS:
        raise InputError(
            f"{spec.source}: {runs:,} runs of up to {steps:,} steps are {runs * steps:.3g} steps; at most "
            f"{MAX_TOTAL_STEPS:.0e} in one sweep (fewer runs, a shorter duration or a larger dt)"
        )
    return runs


def _listed(value: Any) -> list[Any]:
    return list(value) if isinstance(value, list) else [value]


def _text(value: Any, label: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise InputError(f"{label} must be a non-empty string, got {value!r}")
    return value.strip()


def _number(value: Any, label: str) -> float:
    if not is_number(value):
        raise InputError(f"{label} must be a finite number, got {reprlib.repr(value)}")
    return float(value)


def _positive(value: Any, label: str) -> float:
    x = _number(value, label)
    if x <= 0:
        raise InputError(f"{label} must be > 0, got {value!r}")
    return x


def _whole(value: Any, label: str, low: int, high: int) -> int:
    if not is_number(value, integer=True, low=low, high=high):
        raise InputError(f"{label} must be a whole number in [{low}, {high}], got {reprlib.repr(value)}")
    return value


def _table(value: Any, label: str) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise InputError(f"{label} must be a table (joint = value), got {value!r}")
    return dict(value)


def _axis(value: Any, label: str) -> tuple[float, ...]:
    """A number, a list of numbers, or a grid ``{ from = a, to = b, n = k }`` (k points, ends included)."""
    if isinstance(value, Mapping):
        keys = set(value)
        if keys != {"from", "to", "n"}:
            extra = sorted(keys - {"from", "to", "n"})
            what = f"unknown key {extra[0]!r}" if extra else f"missing {sorted({'from', 'to', 'n'} - keys)}"
            raise InputError(f"{label}: a grid is {{ from = A, to = B, n = N }}; {what}")
        lo, hi = _number(value["from"], f"{label}.from"), _number(value["to"], f"{label}.to")
        n = _whole(value["n"], f"{label}.n", 1, MAX_AXIS_POINTS)
        return tuple(float(x) for x in np.linspace(lo, hi, n))
    values = tuple(_number(x, label) for x in _listed(value))
    if not values:
        raise InputError(f"{label} lists no value")
    if len(set(values)) != len(values):
        raise InputError(f"{label} lists a value twice: {list(values)}")
    return values


def _toml() -> Any:
    """The stdlib TOML reader (Python >= 3.11), or tomli on Python 3.10."""
    if sys.version_info >= (3, 11):
        import tomllib

        return tomllib
    import tomli  # pragma: no cover - Python 3.10 only

    return tomli
