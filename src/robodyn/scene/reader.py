"""Reading a scene file: TOML parsed and every table and key validated, each problem in one line."""

from __future__ import annotations

import math
import reprlib
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import SceneError
from robodyn.fileio import is_number, read_user_file, toml_module
from robodyn.sim.constraints import Constraints

if TYPE_CHECKING:
    pass

from robodyn.scene.model import (
    CONTROL_GAINS,
    CONTROL_KINDS,
    MAX_PORT,
    MAX_REPEAT,
    MAX_SAMPLES,
    MAX_SCENE_BYTES,
    MAX_SEED,
    TABLES,
    Scene,
)

Array = NDArray[np.float64]


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
    word = "whole number" if integer else "number"
    expected = f"a {word} > 0" if positive else f"a {word} >= {_shown(low)}" if low > -math.inf else f"a {word}"
    if low > -math.inf and high < math.inf:
        expected = f"a {word} from {_shown(low)} to {_shown(high)}"
    if not is_number(value, integer=integer, low=low, high=high) or (positive and value <= 0):
        raise _fail(path, f"[{table}] {key}", f"expected {expected}, got {reprlib.repr(value)}")
    return value


def _close(name: Any, choices: tuple[str, ...]) -> str:
    """``did you mean 'swing_up'? `` for a near miss, else nothing."""
    import difflib

    close = difflib.get_close_matches(name, choices, n=2, cutoff=0.6) if isinstance(name, str) else []
    return f"did you mean {' or '.join(repr(c) for c in close)}? " if close else ""


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
    if "\x00" in value:  # no file or name has one; os.stat would raise ValueError on it
        raise _fail(path, f"[{table}] {key}", f"expected a name without NUL characters, got {reprlib.repr(value)}")
    return value


def read_scene(path: str | Path) -> Scene:
    """Read and validate a scene file.

    Raises:
        SceneError: the file is missing, is not TOML, has an unknown table or key, a value
            of the wrong type or sign, or leaves out what a part it asks for needs.
    """
    path = Path(path)
    toml = toml_module("scene files")
    data = _parse(path, toml, _read_text(path))
    _check_tables(path, data)
    base = path.parent
    model = _read_model(path, data)
    initial = dict(data.get("initial", {}))
    for key in ("q", "v"):
        if key in initial:
            _joint_values(path, "initial", key, initial[key])
    control = _read_control(path, data)
    simulate = _read_simulate(path, data)
    check = _read_check(path, data, model, simulate)
    bench = dict(data["bench"]) if "bench" in data else None
    if bench is not None and "repeat" in bench:
        _number(path, "bench", "repeat", bench["repeat"], integer=True, low=1, high=MAX_REPEAT)
    view = _read_view(path, data, simulate)
    output = None
    if "output" in data and "dir" in data["output"]:
        output = base / _string(path, "output", "dir", data["output"]["dir"])
    constraints = _read_constraints(path, data)
    return Scene(path, model, initial, control, simulate, check, bench, view, output, constraints)


def _check_tables(path: Path, data: dict[str, Any]) -> None:
    """Every table is a known one holding known keys ([springs] names its own)."""
    for table, body in data.items():
        if table not in TABLES:
            raise _fail(path, f"[{table}]", f"unknown table; expected one of: {', '.join(TABLES)}")
        if not isinstance(body, dict):
            raise _fail(path, table, f"expected a table [{table}], got a value")
        for key in body:
            if key not in TABLES[table] and table != "springs":
                raise _fail(path, f"[{table}] {key}", f"unknown key; expected one of: {', '.join(TABLES[table])}")


def _read_model(path: Path, data: dict[str, Any]) -> dict[str, Any]:
    """[model]: exactly one of name and urdf, files resolved against the scene's folder, the reduction's keys."""
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
    for key in ("free_flyer", "mimic", "physics_check"):
        if key in model:
            _bool(path, "model", key, model[key])
    if "passive" in model:
        passive = model["passive"]
        if not isinstance(passive, list) or not all(isinstance(k, str) and k for k in passive):
            got = reprlib.repr(passive)
            raise _fail(path, "[model] passive", f'expected a list of joint names like ["joint2"], got {got}')
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
    return model


def _read_control(path: Path, data: dict[str, Any]) -> dict[str, Any]:
    """[control]: a known kind and the keys that kind takes."""
    control = dict(data.get("control", {}))
    if "kind" in control and control["kind"] not in CONTROL_KINDS:
        raise _fail(
            path,
            "[control] kind",
            f"unknown controller {reprlib.repr(control['kind'])}; {_close(control['kind'], CONTROL_KINDS)}"
            f"expected one of: {', '.join(CONTROL_KINDS)}",
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
    _read_controller(path, control, kind)
    return control


def _read_check(
    path: Path, data: dict[str, Any], model: dict[str, Any], simulate: dict[str, Any] | None
) -> dict[str, Any] | None:
    """[check]: samples, seed, the formula and closed-form files (from the scene's folder), exactness."""
    base = path.parent
    check = dict(data["check"]) if "check" in data else None
    if check is not None:
        if "samples" in check:
            _number(path, "check", "samples", check["samples"], integer=True, low=1, high=MAX_SAMPLES)
        if "seed" in check:
            _number(path, "check", "seed", check["seed"], integer=True, low=0, high=MAX_SEED)
        if "formula" in check:
            formula = _string(path, "check", "formula", check["formula"])
            if formula.endswith(".py") or "/" in formula or "\\" in formula:  # a file, read from the scene's folder
                check["formula"] = str(base / formula)
                if not Path(check["formula"]).is_file():
                    raise _fail(path, "[check] formula", f"no such file {check['formula']!r}")
        if "formula_timeout" in check:
            if "formula" not in check:
                raise _fail(path, "[check] formula_timeout", "needs formula (the file the time limit is for)")
            from robodyn.checker.sandbox import MAX_TIMEOUT  # the same bound as --formula-timeout

            _number(path, "check", "formula_timeout", check["formula_timeout"], positive=True, high=MAX_TIMEOUT)
        if "closed_form" in check:
            check["closed_form"] = base / _string(path, "check", "closed_form", check["closed_form"])
            if not check["closed_form"].is_file():
                raise _fail(path, "[check] closed_form", f"no such file {str(check['closed_form'])!r}")
            if simulate is None:
                raise _fail(
                    path, "[check] closed_form", "needs [simulate]: the closed form is compared with the motion"
                )
        if "closed_form_rtol" in check:
            if "closed_form" not in check:
                raise _fail(path, "[check] closed_form_rtol", "needs closed_form (the file the tolerance is for)")
            _number(path, "check", "closed_form_rtol", check["closed_form_rtol"], positive=True)
        if "exactness" in check:
            _bool(path, "check", "exactness", check["exactness"])
            if check["exactness"] and not (model.get("keep") or model.get("lock")):
                raise _fail(path, "[check] exactness", "needs a reduced model: [model] keep or lock")
            if check["exactness"] and simulate is None:
                raise _fail(
                    path, "[check] exactness", "needs [simulate] (duration, dt, integrator) to compare trajectories"
                )
    return check


def _read_view(path: Path, data: dict[str, Any], simulate: dict[str, Any] | None) -> dict[str, Any] | None:
    """[view]: needs [simulate]; open, html (from the scene's folder) and port."""
    base = path.parent
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
    return view


def _read_controller(path: Path, control: dict[str, Any], kind: str) -> None:
    """[control] of kind lqr, swing_up or file: each key belongs to the kind, gains are numbers or arrays.

    The gains' shapes and signs are checked when the controller is made for the model
    (:meth:`Scene.torque`), whose messages name the key too. ``path`` is resolved against the scene's folder.
    """
    for key in control:
        owners = [k for k, keys in CONTROL_GAINS.items() if key in keys]
        if owners and kind not in owners:
            takes = " or ".join(f'kind = "{k}"' for k in owners)
            raise _fail(path, f"[control] {key}", f'only {takes} takes {key}, not kind = "{kind}"')
    if kind == "file":
        if "path" not in control:
            raise _fail(path, "[control] path", 'missing: kind = "file" needs path = "my_controller.py"')
        name = _string(path, "control", "path", control["path"])
        if not name.endswith(".py"):
            raise _fail(path, "[control] path", f"expected a Python file NAME.py, got {reprlib.repr(name)}")
        control["path"] = path.parent / name
        if not control["path"].is_file():
            raise _fail(path, "[control] path", f"no such file {str(control['path'])!r}")
        gains = control.get("gains", {})
        if not isinstance(gains, Mapping):
            raise _fail(path, "[control] gains", f"expected a table of gain = value, got {reprlib.repr(gains)}")
        return
    if kind not in ("lqr", "swing_up"):
        return
    for key in CONTROL_GAINS[kind]:
        if key in control:
            _gain(path, key, control[key])


def _gain(path: Path, key: str, value: Any) -> None:
    """A gain: a number, or a (nested) list of numbers; the shape is the controller's to check."""
    if isinstance(value, list):
        for item in value:
            _gain(path, key, item)
        return
    _number(path, "control", key, value)


def _read_constraints(path: Path, data: dict[str, Any]) -> Constraints:
    """The [constraints] and [springs] tables as one spec; a bad entry is one line naming file, table and key."""
    springs = data.get("springs")
    Constraints.from_mapping(None, springs=springs, where=f"{path}: [springs]")  # its errors name [springs]
    return Constraints.from_mapping(data.get("constraints"), springs=springs, where=f"{path}: [constraints]")


def _read_text(path: Path) -> str:
    """The scene file's text: UTF-8 and at most :data:`MAX_SCENE_BYTES`, or one line saying what is wrong."""
    raw = read_user_file(path, what="scene", expected="a .toml scene file", limit=MAX_SCENE_BYTES, error=SceneError)
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
