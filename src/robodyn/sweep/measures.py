"""What a sweep measures on each run, by name, and a user's own measure function (``file.py:function``).

Built in (columns in brackets):

* ``final_state``: the state at the end [q.<joint>, v.<joint>] in rad | m and rad/s | m/s;
* ``energy_drift``: E(end) - E(0) [J] (kinetic + potential; the work of a controller counts);
* ``time_to_balance``: the first time [s] from which every revolute coordinate stays within
  ``BALANCE_TOL`` of the upright until the end; NaN if the run ends outside (cart-pole, Pendubot).
  The test is :mod:`robodyn.control.outcome`'s, the one that ``robodyn simulate``'s outcome line and
  ``benchmarks/bench_swing_up.py`` read: a run balanced when time_to_balance <= duration - 1 s;
* ``lyapunov``: Benettin's largest Lyapunov exponent [1/s] (twins renormalised every
  ``LYAPUNOV_INTERVAL``; the twin's direction seeded by the sweep's seed plus the run number);
* ``wall_time``: the run's wall-clock time [s] (a vectorised chunk's time shared evenly).

A user's measure is ``path.py:function``: ``function(trajectory)`` gets the run's
:class:`robodyn.Trajectory` and returns a number or a mapping of names to numbers (columns
``function`` or ``function.name``). The file is imported like a user's formula file: errors
name the file and its line.
"""

from __future__ import annotations

import math
import reprlib
import threading
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.control.outcome import BALANCE_TOL as BALANCE_TOL
from robodyn.control.outcome import balanced_from, inside_upright
from robodyn.errors import InputError
from robodyn.sim.trajectory import Trajectory
from robodyn.user_import import at_line, exit_call, import_user_file

Array = NDArray[np.float64]

MEASURES = ("energy_drift", "final_state", "lyapunov", "time_to_balance", "wall_time")
# Benettin's renormalisation interval [s]: short against the built-in kinds' divergence time (~0.3 s).
LYAPUNOV_INTERVAL = 0.1
# Measures a vectorised chunk computes without a trajectory.
BATCH_MEASURES = frozenset({"final_state", "energy_drift", "wall_time"})
CLOSED_LOOP_MEASURES = BATCH_MEASURES | {"time_to_balance"}

UserMeasure = Callable[[Trajectory], Any]


def is_user(name: str) -> bool:
    """True for ``file.py:function``."""
    return ":" in name


def from_trajectory(
    trajectory: Trajectory,
    measures: tuple[str, ...],
    joint_names: tuple[str, ...],
    *,
    upright: tuple[Array, NDArray[np.bool_]] | None,
    user: Mapping[str, UserMeasure],
) -> dict[str, float]:
    """The measures of one run from its trajectory (``lyapunov`` and ``wall_time`` are added by the caller)."""
    ok = trajectory.status == "ok"
    out: dict[str, float] = {}
    for name in measures:
        if name == "final_state":
            for j, joint in enumerate(joint_names):
                out[f"q.{joint}"] = float(trajectory.q[-1, j]) if ok else math.nan
                out[f"v.{joint}"] = float(trajectory.v[-1, j]) if ok else math.nan
        elif name == "energy_drift":
            energy = trajectory.kinetic + trajectory.potential
            out["energy_drift"] = float(energy[-1] - energy[0]) if ok else math.nan
        elif name == "time_to_balance" and upright is not None:
            dt = float(trajectory.meta.get("dt", trajectory.t[1] - trajectory.t[0]))
            inside = inside_upright(trajectory.q, *upright)
            out["time_to_balance"] = balanced_from(inside, dt) if ok else math.nan
        elif is_user(name):
            out.update(_user_values(name, user[name], trajectory))
    return out


def _user_values(name: str, fn: UserMeasure, trajectory: Trajectory) -> dict[str, float]:
    label = name.rpartition(":")[2]
    path = Path(name.rpartition(":")[0])
    try:
        value = fn(trajectory)
    except SystemExit as exc:
        raise InputError(f"{name}: called {exit_call(exc)}{at_line(exc, path)}") from None
    except BaseException as exc:  # a user's function can raise anything, KeyboardInterrupt included
        if isinstance(exc, KeyboardInterrupt) and threading.current_thread() is threading.main_thread():
            raise  # maybe Ctrl-C; elsewhere (a Dask worker's thread) only the function can have raised it
        what = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        raise InputError(f"{name}: raised {what}{at_line(exc, path)}") from None
    items = value.items() if isinstance(value, Mapping) else [("", value)]
    out = {}
    for key, x in items:
        column = f"{label}.{key}" if key else label
        try:
            out[column] = float(x)
        except Exception:  # TypeError, ValueError, OverflowError (400 digits), or a __float__ of the user's
            raise InputError(f"{name}: returned {reprlib.repr(x)} for {column!r}; expected a number") from None
    return out


def load_user_measure(name: str) -> UserMeasure:
    """Import ``path.py:function`` (path absolute) and return the function.

    Raises:
        InputError: no such file, an import error (with its line), or no such function.
    """
    file_name, _, function = name.rpartition(":")
    path = Path(file_name)
    if not path.is_file() or path.suffix != ".py":
        raise InputError(f"measure {name!r}: no such Python file {file_name} (expected path.py:function)")
    module = import_user_file(path, what="measure", expected=f"the function {function}", source=file_name)
    fn = getattr(module, function, None)
    if not callable(fn):
        found = sorted(n for n, v in vars(module).items() if callable(v) and not n.startswith("_"))
        raise InputError(f"measure {name!r}: {file_name} defines no function {function!r}; it has: {', '.join(found)}")
    return fn  # type: ignore[no-any-return]


def user_files(measures: tuple[str, ...]) -> dict[str, bytes]:
    """Each user measure's file content by measure name (part of the sweep's digest)."""
    out = {}
    for name in measures:
        if is_user(name):
            path = Path(name.rpartition(":")[0])
            out[name] = path.read_bytes() if path.is_file() else b""
    return out
