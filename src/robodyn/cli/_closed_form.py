"""A scene's ``[check] closed_form``: the simulated motion against the book's closed form, sample by sample.

The file (a path relative to the scene) is a user's Python module with the interface of
``examples/textbook/*/closed_form.py``: ``parameters(scene_path) -> dict``,
``closed_form(t, q, v, params) -> {quantity: (n,) array}`` (the book's prediction) and
``simulated(t, q, v, params) -> {quantity: (n,) array}`` (the same quantities read off the motion),
where ``t`` is (n,) [s] and ``q``, ``v`` map each one-coordinate joint's name to its (n,) series
(a coupled joint's from its leader: ratio q_leader + offset). :func:`compare` computes the worst
deviation of each quantity along the whole motion, max |closed form - simulated| / max |closed form|
(:func:`robodyn.kinds.deviation.worst_deviation`), prints it and fails (exit 1) above ``closed_form_rtol``.
A quantity that is inf or NaN is an overflow of the run, not a mismatch: one line, exit 3.
A file that cannot be imported or breaks its interface is one line naming it (exit 2).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from robodyn.errors import EXIT_MISMATCH, EXIT_OK, DivergenceError, InputError, SceneError
from robodyn.kinds.deviation import worst_deviation
from robodyn.scene import DEFAULT_CLOSED_FORM_RTOL, Scene
from robodyn.user_import import at_line, import_user_file
from robodyn.wording import count

FUNCTIONS = ("parameters", "closed_form", "simulated")


def compare(
    scene: Scene, robot: Any, trajectory: Any, summary: dict[str, Any], module: ModuleType | None = None
) -> int:
    """Print and record the worst deviation of ``trajectory`` from the scene's closed form; 0 within tolerance, 1 not.

    Raises:
        SceneError: the closed-form file fails to import, lacks a function, raises, or returns
            something other than {name: number}; one line naming the scene, ``[check] closed_form`` and the file.
        DivergenceError: a quantity is inf or NaN (the run overflowed).
    """
    assert scene.check is not None  # the caller's condition
    path = Path(scene.check["closed_form"])
    rtol = float(scene.check.get("closed_form_rtol", DEFAULT_CLOSED_FORM_RTOL))
    module = load(scene, path) if module is None else module
    q, v = joint_series(robot, trajectory, scene.constraints)
    params = read_parameters(scene, path, module)
    expected = _quantities(
        scene, path, "closed_form", _call(scene, path, "closed_form", module.closed_form, trajectory.t, q, v, params)
    )
    got = _quantities(
        scene, path, "simulated", _call(scene, path, "simulated", module.simulated, trajectory.t, q, v, params)
    )
    _refuse_overflow(scene, path, trajectory, {"simulated": got, "closed_form": expected}, summary)
    try:
        deviation = worst_deviation(expected, got)
    except ValueError as exc:
        raise _error(scene, path, f"closed_form() and simulated() do not compare: {exc}") from None
    worst = max(deviation.values(), default=0.0)
    passed = all(x <= rtol for x in deviation.values())  # a NaN fails
    duration = float(trajectory.t[-1] - trajectory.t[0])
    listed = ", ".join(f"{name} {x:.3e}" for name, x in deviation.items())
    print(
        f"closed form: {'passed' if passed else 'FAILED'}: worst deviation from {path.name} over {duration:g} s "
        f"({count(len(trajectory.t), 'sample', thousands=True)}): {listed} "
        f"(tolerance {rtol:g}, relative to the largest value)"
    )
    summary["closed_form"] = {
        "file": str(path),
        "passed": passed,
        "worst_deviation": deviation,
        "worst": worst,
        "tolerance": rtol,
    }
    return EXIT_OK if passed else EXIT_MISMATCH


def read_parameters(scene: Scene, path: Path, module: ModuleType) -> Any:
    """``parameters(scene_path)`` of the closed-form file: what it reads from the scene (SceneError if it fails)."""
    return _call(scene, path, "parameters", module.parameters, scene.path)


def _refuse_overflow(
    scene: Scene, path: Path, trajectory: Any, results: dict[str, dict[str, Any]], summary: dict[str, Any]
) -> None:
    """A quantity that is not finite (the run's numbers left float64) is an overflow, not a mismatch.

    Raises:
        DivergenceError: naming the function, the quantity and the first sample where it is inf or NaN.
    """
    for function, quantities in results.items():
        for name, values in quantities.items():
            x = np.asarray(values, dtype=np.float64)
            rows = x.reshape(len(x), -1) if x.ndim else x.reshape(1, 1)
            bad = np.flatnonzero(~np.isfinite(rows).all(axis=1))
            if not bad.size:
                continue
            k = int(bad[0])
            value = rows[k][~np.isfinite(rows[k])][0]
            t = float(trajectory.t[min(k, len(trajectory.t) - 1)])
            summary["closed_form"] = {"file": str(path), "passed": None, "overflowed": f"{function}() {name}"}
            raise DivergenceError(
                f"{scene.path}: [check] closed_form: the run overflowed: {function}() of {path.name} gives "
                f"{name} = {value} from t = {t:g} s (numbers beyond float64, nothing to compare; "
                "check the scene's torques and initial state)",
                step=k,
                time=t,
            )


def load(scene: Scene, path: Path) -> ModuleType:
    """Import ``path`` as a module of its own (like a user's formula file) and check its functions."""
    try:
        module = import_user_file(path, what="closed-form", expected=", ".join(FUNCTIONS))
    except InputError as exc:  # the file's own failure, never robodyn's
        raise scene.error("check", "closed_form", str(exc)) from None
    missing = [name for name in FUNCTIONS if not callable(getattr(module, name, None))]
    if missing:
        raise _error(
            scene, path, f"defines no {' or '.join(f'{m}()' for m in missing)}; expected {', '.join(FUNCTIONS)}"
        )
    return module


def joint_series(robot: Any, trajectory: Any, constraints: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    """Joint name -> q (n,) [rad | m] and v (n,) [rad/s | m/s] of every one-DoF joint of ``robot``.

    A continuous joint's q is its angle (unwrapped). With couplings the trajectory holds the
    leaders only; a follower is ratio * leader + offset.
    """
    followers = {c.joint: c for c in constraints.couplings}
    q, v, iq, iv = {}, {}, 0, 0
    for joint in robot.joints:  # the simulated robot's layout: a follower takes no coordinate
        if joint.name in followers:
            continue
        if joint.nv == 1 and joint.nq in (1, 2):  # a continuous joint's (cos, sin) pair: its angle, unwrapped
            x = trajectory.q[:, iq : iq + joint.nq]
            q[joint.name] = x[:, 0] if joint.nq == 1 else np.unwrap(np.arctan2(x[:, 1], x[:, 0]))
            v[joint.name] = trajectory.v[:, iv]
        iq, iv = iq + joint.nq, iv + joint.nv
    for _ in followers:  # once per link of the longest chain
        for name, c in followers.items():
            if c.leader in q and name not in q:
                q[name] = c.ratio * q[c.leader] + c.offset
                v[name] = c.ratio * v[c.leader]
    return q, v


def _call(scene: Scene, path: Path, name: str, function: Any, *args: Any) -> Any:
    try:
        return function(*args)
    except (Exception, SystemExit) as exc:
        raise _error(scene, path, f"{name}() failed: {_what(exc, path)}") from None


def _quantities(scene: Scene, path: Path, name: str, value: Any) -> dict[str, Any]:
    """``name()``'s answer as {quantity: float array}, or one line saying what came instead."""
    if not isinstance(value, Mapping) or not value:
        raise _error(scene, path, f"{name}() must return {{quantity: array}}, got {type(value).__name__}")
    out = {}
    for key, x in value.items():
        try:
            out[str(key)] = np.asarray(x, dtype=np.float64)
        except (TypeError, ValueError):
            raise _error(scene, path, f"{name}()[{str(key)!r}] must be numbers, got {type(x).__name__}") from None
    return out


def _what(exc: BaseException, path: Path) -> str:
    """``ZeroDivisionError: division by zero (line 12)``: the exception and the last line of ``path`` it passed."""
    where = at_line(exc, path)
    text = str(exc).splitlines()[0] if str(exc) else ""
    return f"{type(exc).__name__}: {text}{where}" if text else f"{type(exc).__name__}{where}"


def _error(scene: Scene, path: Path, message: str) -> SceneError:
    return scene.error("check", "closed_form", f"{path}: {message}")
