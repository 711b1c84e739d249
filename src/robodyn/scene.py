"""Scene files: one small TOML file that says everything a scene needs.

A scene names the model and the joints it moves (the rest are locked, so robodyn builds
the minimal model), the initial state, the torque or controller, how long and how to
integrate, and what to check, benchmark and show. :func:`read_scene` parses and validates
it (every problem is one line naming the file, the table and the key); ``robodyn run``
then builds the model and runs the parts asked for. Example::

    [model]
    name = "panda"                          # or: urdf = "path/to/robot.urdf"
    keep = ["panda_joint2", "panda_joint4", "panda_joint6"]
    reference = "default"                   # SRDF group state holding the locked joints

    [initial]
    q = { panda_joint2 = 0.3, panda_joint4 = -2.0 }   # by joint name, or a list of nq
    v = [0.0, 0.0, 0.0]

    [control]
    kind = "pd"                             # "none", "constant" or "pd"
    kp = 50.0
    kd = 5.0
    target = { panda_joint2 = 0.0 }
    gravity_compensation = true

    [simulate]                              # defaults as robodyn simulate: 2 s, 1e-3 s, rk4
    duration = 2.0                          # [s]
    dt = 1e-3                               # [s]
    integrator = "rk4"

    [check]                                 # structural identities (and a formula, if named)
    samples = 20
    exactness = true                        # reduced model == full model with locks held

    [bench]
    repeat = 200

    [view]
    html = "panda_arm.html"                 # write a standalone player (or: open = true)

Relative paths (``urdf``, ``srdf``, ``output``, ``view.html``) are read from the scene file's folder.
"""

from __future__ import annotations

import math
import reprlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import InputError, SceneError

if TYPE_CHECKING:
    from robodyn.model.reduce import Reduction
    from robodyn.robot import Robot

Array = NDArray[np.float64]

TABLES = {
    "model": ("name", "urdf", "srdf", "free_flyer", "mimic", "keep", "lock", "reference"),
    "initial": ("q", "v"),
    "control": ("kind", "torque", "kp", "kd", "target", "gravity_compensation"),
    "simulate": ("duration", "dt", "integrator", "backend"),
    "check": ("samples", "seed", "formula", "exactness"),
    "bench": ("repeat",),
    "view": ("open", "html", "port"),
    "output": ("dir",),
}
CONTROL_KINDS = ("none", "constant", "pd")

# Bounds on hostile input: a scene file is a few lines of TOML (a larger one is not parsed);
# [check] samples random states and [bench] repeat timed calls, each at most 100,000; [check]
# seed up to the largest TOML integer; [view] port a TCP port.
MAX_SCENE_BYTES = 1024 * 1024
MAX_SAMPLES = 100_000
MAX_REPEAT = 100_000
MAX_SEED = 2**63 - 1
MAX_PORT = 65535


@dataclass(frozen=True)
class Scene:
    """A validated scene file. Tables the file leaves out are None (not asked for)."""

    path: Path
    model: dict[str, Any]
    initial: dict[str, Any] = field(default_factory=dict)
    control: dict[str, Any] = field(default_factory=dict)
    simulate: dict[str, Any] | None = None
    check: dict[str, Any] | None = None
    bench: dict[str, Any] | None = None
    view: dict[str, Any] | None = None
    output: Path | None = None

    @property
    def name(self) -> str:
        """The scene's name: its file stem."""
        return self.path.stem

    def error(self, table: str, key: str, message: str) -> SceneError:
        """A :class:`SceneError` naming this file, ``[table]`` and ``key``."""
        return SceneError(f"{self.path}: [{table}] {key}: {message}")

    # ----------------------------------------------------------------- model
    def build(self) -> tuple[Robot, Reduction | None]:
        """Load the model and reduce it to the joints the scene keeps.

        Returns the robot to simulate (the reduced one when joints are locked) and the
        :class:`robodyn.model.reduce.Reduction`, or None when nothing is locked.
        """
        from robodyn.errors import UnknownNameError
        from robodyn.model.load import load, load_reduction

        m = self.model
        target = m.get("urdf") or m["name"]
        options = {"srdf": m.get("srdf"), "free_flyer": m.get("free_flyer", False), "mimic": m.get("mimic", False)}
        try:
            if not m.get("keep") and not m.get("lock"):
                return load(target, **options), None
            reduction = load_reduction(
                target, lock=m.get("lock"), keep=m.get("keep"), reference=m.get("reference"), **options
            )
        except UnknownNameError as exc:
            raise self.error("model", self._model_key(exc.what), str(exc)) from None
        except SceneError:
            raise
        except InputError as exc:
            raise self.error("model", self._model_key(str(exc)), str(exc)) from None
        return reduction.reduced, reduction

    def _model_key(self, what: str) -> str:
        """The [model] key an error about ``what`` comes from (keep, lock, reference or the model)."""
        m = self.model
        if "reference" in what:
            return "reference"
        if ("keep" in what or "kept" in what) and "keep" in m:
            return "keep"
        if "lock" in what and "lock" in m:
            return "lock"
        if "joint" in what:
            return "keep" if "keep" in m else "lock"
        return "name" if "name" in m else "urdf"

    def initial_state(self, robot: Robot, reduction: Reduction | None = None) -> tuple[Array, Array]:
        """(q0 (nq,), v0 (nv,)) of the scene for ``robot``, zero velocity by default.

        Joints the scene leaves out start at the reference configuration ([model]
        reference, an SRDF group state) or, without one, at Pinocchio's neutral.
        """
        if reduction is not None:
            default = reduction.reduced_q(reduction.q_reference)
        elif "reference" in self.model:
            from robodyn.model.reduce import reference_configuration

            default = reference_configuration(robot, self.model["reference"])
        else:
            default = robot.neutral()
        q = self._joint_vector(robot, "initial", "q", self.initial.get("q"), default, configuration=True)
        v = self._joint_vector(robot, "initial", "v", self.initial.get("v"), np.zeros(robot.nv), configuration=False)
        return q, v

    def _joint_vector(
        self, robot: Robot, table: str, key: str, value: Any, default: Array, *, configuration: bool
    ) -> Array:
        from robodyn.robot import joint_coordinates

        if value is None:
            return default.copy()
        size = robot.nq if configuration else robot.nv
        if isinstance(value, list):
            arr = np.asarray(value, dtype=np.float64)
            if arr.shape != (size,):
                raise self.error(
                    table, key, f"expected {size} numbers for {robot.name} ({robot.nv} DoF), got {arr.size}"
                )
            return arr
        out = default.copy()
        for name, entry in value.items():
            if name not in robot.joint_names:
                raise self.error(
                    table,
                    key,
                    f"no joint {reprlib.repr(name)} in the scene's model; joints: {', '.join(robot.joint_names)}",
                )
            joint = robot.joint(name)
            values = np.atleast_1d(np.asarray(entry, dtype=np.float64))
            if configuration:
                try:
                    out[joint.idx_q : joint.idx_q + joint.nq] = joint_coordinates(joint.kind, joint.nq, values)
                except InputError as exc:
                    raise self.error(table, f"{key}.{name}", str(exc)) from None
            else:
                if values.size != joint.nv:
                    raise self.error(table, f"{key}.{name}", f"expected {joint.nv} number(s), got {values.size}")
                out[joint.idx_v : joint.idx_v + joint.nv] = values
        return out

    # ----------------------------------------------------------------- control
    def torque(
        self, robot: Robot, reduction: Reduction | None = None
    ) -> Array | Callable[[float, Array, Array], Array] | None:
        """The input: None, a constant (nv,) vector [N m | N], or a controller tau(t, q, v).

        ``pd`` is tau = kp (q* - q) - kd v (+ G(q) with ``gravity_compensation``), on the
        actuated joints only (passive joints get zero). q* is ``target`` (the initial q
        by default).
        """
        c = self.control
        kind = c.get("kind", "constant" if "torque" in c else "none")
        if kind == "none":
            return None
        actuated = robot.actuated
        if kind == "constant":
            tau = self._joint_vector(
                robot, "control", "torque", c.get("torque"), np.zeros(robot.nv), configuration=False
            )
            if np.any(tau[~actuated] != 0):
                raise self.error(
                    "control", "torque", f"passive joints {', '.join(robot.passive_joints)} take no torque"
                )
            return tau
        q0, _ = self.initial_state(robot, reduction)
        target = self._joint_vector(robot, "control", "target", c.get("target"), q0, configuration=True)
        kp, kd = float(c.get("kp", 0.0)), float(c.get("kd", 0.0))
        compensate = bool(c.get("gravity_compensation", False))
        mask = actuated.astype(np.float64)

        def controller(t: float, q: Array, v: Array) -> Array:
            from robodyn import dynamics

            error = dynamics.difference(robot.model, q, target)
            tau = kp * error - kd * v
            if compensate:
                tau = tau + robot.G(q)
            return mask * tau

        return controller


def _fail(path: Path, where: str, message: str) -> SceneError:
    return SceneError(f"{path}: {where}: {message}")


def _number(
    path: Path,
    table: str,
    key: str,
    value: Any,
    *,
    positive: bool = False,
    integer: bool = False,
    low: float = -math.inf,
    high: float = math.inf,
) -> Any:
    """``value`` when it is a finite number (whole with ``integer``) in range, else a one-line SceneError.

    The range is ``low <= value <= high``, and ``value > 0`` with ``positive``; the message states it.
    """
    ok_type = isinstance(value, int) if integer else isinstance(value, (int, float))
    word = "whole number" if integer else "number"
    expected = f"a {word} > 0" if positive else f"a {word} >= {_shown(low)}" if low > -math.inf else f"a {word}"
    if low > -math.inf and high < math.inf:
        expected = f"a {word} from {_shown(low)} to {_shown(high)}"
    inside = ok_type and not isinstance(value, bool) and math.isfinite(value) and low <= value <= high
    if not inside or (positive and value <= 0):
        raise _fail(path, f"[{table}] {key}", f"expected {expected}, got {reprlib.repr(value)}")
    return value


def _shown(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


def _joint_values(path: Path, table: str, key: str, value: Any) -> Any:
    """A list of numbers, or a table joint name -> number (or list of numbers)."""
    if isinstance(value, list):
        for x in value:
            _number(path, table, key, x)
        return value
    if isinstance(value, Mapping):
        for name, x in value.items():
            for y in x if isinstance(x, list) else [x]:
                _number(path, table, f"{key}.{name}", y)
        return dict(value)
    raise _fail(
        path, f"[{table}] {key}", f"expected a list of numbers or a table of joint = value, got {reprlib.repr(value)}"
    )


def _bool(path: Path, table: str, key: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise _fail(path, f"[{table}] {key}", f"expected true or false, got {reprlib.repr(value)}")
    return value


def _string(path: Path, table: str, key: str, value: Any) -> str:
    if not isinstance(value, str) or not value:
        raise _fail(path, f"[{table}] {key}", f"expected a non-empty string, got {reprlib.repr(value)}")
    return value


def read_scene(path: str | Path) -> Scene:
    """Read and validate a scene file.

    Raises:
        SceneError: the file is missing, is not TOML, has an unknown table or key, a value
            of the wrong type or sign, or leaves out what a part it asks for needs.
    """
    path = Path(path)
    toml = _toml()
    data = _parse(path, toml, _read_text(path))
    for table, body in data.items():
        if table not in TABLES:
            raise _fail(path, f"[{table}]", f"unknown table; expected one of: {', '.join(TABLES)}")
        if not isinstance(body, dict):
            raise _fail(path, table, f"expected a table [{table}], got a value")
        for key in body:
            if key not in TABLES[table]:
                raise _fail(path, f"[{table}] {key}", f"unknown key; expected one of: {', '.join(TABLES[table])}")
    if "model" not in data:
        raise _fail(path, "[model]", 'missing: a scene needs a model (name = "panda" or urdf = "robot.urdf")')
    base = path.parent
    model = dict(data["model"])
    if ("name" in model) == ("urdf" in model):
        raise _fail(
            path, "[model]", "give exactly one of name (a built-in or example-robot-data robot) and urdf (a path)"
        )
    if "name" in model:
        _string(path, "model", "name", model["name"])
    for key in ("urdf", "srdf"):
        if key in model:
            model[key] = base / _string(path, "model", key, model[key])
            if not model[key].is_file():
                raise _fail(path, f"[model] {key}", f"no such file {str(model[key])!r}")
    for key in ("free_flyer", "mimic"):
        if key in model:
            _bool(path, "model", key, model[key])
    if "keep" in model:
        keep = model["keep"]
        if not isinstance(keep, list) or not keep or not all(isinstance(k, str) and k for k in keep):
            raise _fail(path, "[model] keep", f"expected a non-empty list of joint names, got {reprlib.repr(keep)}")
    if "lock" in model:
        lock = model["lock"]
        if not isinstance(lock, dict):
            raise _fail(path, "[model] lock", f"expected a table of joint = value, got {reprlib.repr(lock)}")
        _joint_values(path, "model", "lock", lock)
    if "reference" in model:
        _string(path, "model", "reference", model["reference"])
    initial = dict(data.get("initial", {}))
    for key in ("q", "v"):
        if key in initial:
            _joint_values(path, "initial", key, initial[key])
    control = dict(data.get("control", {}))
    if "kind" in control and control["kind"] not in CONTROL_KINDS:
        raise _fail(
            path,
            "[control] kind",
            f"unknown controller {reprlib.repr(control['kind'])}; expected one of: {', '.join(CONTROL_KINDS)}",
        )
    kind = control.get("kind", "constant" if "torque" in control else "none")
    if kind == "constant" and "torque" not in control:
        raise _fail(path, "[control] torque", 'missing: kind = "constant" needs torque = [...] or a table')
    if "torque" in control:
        if kind != "constant":
            raise _fail(path, "[control] torque", f'only kind = "constant" takes a torque, not kind = "{kind}"')
        _joint_values(path, "control", "torque", control["torque"])
    for key in ("kp", "kd"):
        if key in control:
            if kind != "pd":
                raise _fail(path, f"[control] {key}", f'only kind = "pd" takes gains, not kind = "{kind}"')
            _number(path, "control", key, control[key], low=0)
    if "target" in control:
        _joint_values(path, "control", "target", control["target"])
    if "gravity_compensation" in control:
        _bool(path, "control", "gravity_compensation", control["gravity_compensation"])
    simulate = _read_simulate(path, data)
    check = dict(data["check"]) if "check" in data else None
    if check is not None:
        if "samples" in check:
            _number(path, "check", "samples", check["samples"], integer=True, low=1, high=MAX_SAMPLES)
        if "seed" in check:
            _number(path, "check", "seed", check["seed"], integer=True, low=0, high=MAX_SEED)
        if "formula" in check:
            _string(path, "check", "formula", check["formula"])
        if "exactness" in check:
            _bool(path, "check", "exactness", check["exactness"])
            if check["exactness"] and not (model.get("keep") or model.get("lock")):
                raise _fail(path, "[check] exactness", "needs a reduced model: [model] keep or lock")
            if check["exactness"] and simulate is None:
                raise _fail(
                    path, "[check] exactness", "needs [simulate] (duration, dt, integrator) to compare trajectories"
                )
    bench = dict(data["bench"]) if "bench" in data else None
    if bench is not None and "repeat" in bench:
        _number(path, "bench", "repeat", bench["repeat"], integer=True, low=1, high=MAX_REPEAT)
    view = dict(data["view"]) if "view" in data else None
    if view is not None:
        if simulate is None:
            raise _fail(path, "[view]", "needs [simulate]: the viewer plays the simulated motion back")
        if "open" in view:
            _bool(path, "view", "open", view["open"])
        if "html" in view:
            view["html"] = base / _string(path, "view", "html", view["html"])
        if "port" in view:
            _number(path, "view", "port", view["port"], integer=True, low=1, high=MAX_PORT)
    output = None
    if "output" in data and "dir" in data["output"]:
        output = base / _string(path, "output", "dir", data["output"]["dir"])
    return Scene(path, model, initial, control, simulate, check, bench, view, output)


def _read_text(path: Path) -> str:
    """The scene file's text: UTF-8 and at most :data:`MAX_SCENE_BYTES`, or one line saying what is wrong."""
    try:
        with path.open("rb") as fh:
            raw = fh.read(MAX_SCENE_BYTES + 1)
    except FileNotFoundError:
        raise SceneError(f"{path}: no such scene file (expected a .toml file)") from None
    except IsADirectoryError:
        raise SceneError(f"{path}: is a folder (expected a .toml scene file)") from None
    except OSError as exc:
        raise SceneError(f"{path}: cannot read the scene file: {exc.strerror}") from None
    if len(raw) > MAX_SCENE_BYTES:
        raise SceneError(f"{path}: larger than {MAX_SCENE_BYTES // 1024} KiB; a scene file is a few lines of TOML")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise SceneError(
            f"{path}: not UTF-8 text: byte 0x{raw[exc.start]:02x} on line {line} (a scene file is UTF-8 TOML)"
        ) from None


def _parse(path: Path, toml: Any, text: str) -> dict[str, Any]:
    """The TOML document, or one line: not TOML, or nested deeper than a scene ever is."""
    try:
        return dict(toml.loads(text))
    except toml.TOMLDecodeError as exc:
        raise SceneError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:
        raise SceneError(
            f"{path}: arrays or tables nested too deeply to read; a scene nests a few levels at most"
        ) from None


def _toml() -> Any:
    """The stdlib TOML reader (Python >= 3.11), or tomli on Python 3.10."""
    try:
        import tomllib

        return tomllib
    except ModuleNotFoundError:
        try:
            import tomli  # type: ignore[import-not-found]

            return tomli
        except ModuleNotFoundError:
            from robodyn.errors import MissingDependencyError

            raise MissingDependencyError(
                "scene files need tomllib (Python >= 3.11) or tomli: pip install tomli"
            ) from None


# The defaults of ``robodyn simulate`` (--duration, --dt, --integrator). A backend left out
# stays out: simulate then picks it (aba, or crba on a model with mimic joints).
SIMULATE_DEFAULTS: dict[str, Any] = {"duration": 2.0, "dt": 1e-3, "integrator": "rk4"}


def _read_simulate(path: Path, data: dict[str, Any]) -> dict[str, Any] | None:
    """The [simulate] table with every key given checked, then the defaults of ``robodyn simulate`` filled in."""
    if "simulate" not in data:
        return None
    sim = dict(data["simulate"])
    for key in ("duration", "dt"):
        if key in sim:
            _number(path, "simulate", key, sim[key], positive=True)
    for key in ("integrator", "backend"):
        if key in sim:
            _string(path, "simulate", key, sim[key])
    if "integrator" in sim:
        from robodyn import integrators

        if sim["integrator"] not in integrators.names():
            raise _fail(
                path,
                "[simulate] integrator",
                f"unknown integrator {reprlib.repr(sim['integrator'])}; "
                f"expected one of: {', '.join(integrators.names())}",
            )
    given = set(sim)
    for key, default in SIMULATE_DEFAULTS.items():
        sim.setdefault(key, default)
    origin = " (the default)" if not given >= {"dt", "duration"} else ""
    if sim["dt"] > sim["duration"]:
        raise _fail(
            path,
            "[simulate] dt",
            f"the step {sim['dt']} s is longer than the duration {sim['duration']} s{origin}",
        )
    from robodyn.sim.simulation import MAX_STEPS

    if sim["duration"] / sim["dt"] > MAX_STEPS:
        raise _fail(
            path,
            "[simulate] duration",
            f"{sim['duration']} s in steps of {sim['dt']} s{origin} is {sim['duration'] / sim['dt']:.3g} steps; "
            f"at most {MAX_STEPS:.0e}",
        )
    return sim
