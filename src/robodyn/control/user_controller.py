"""A user's own controller in a Python file, loaded into the same torque-callable form as the built-ins.

The file defines ``make(robot, **gains)`` returning a callable tau(t, q, v) -> torques, with nv
entries (zero on passive joints) or one per actuated joint [N m | N]; the gains are the keyword
arguments given to :func:`robodyn.control.make`. It follows the pattern of a user's formula file
(:mod:`robodyn.checker.user_formula`): an error on import, in ``make`` or in a call, and a torque of the
wrong shape or not finite, raise :class:`InputError` in one line naming the file and the line.

The callable gets read-only copies of q and v (a write into them raises, and the run is refused
in one line): it cannot change the state being integrated.

From the CLI (``simulate --controller FILE.py``, a scene's ``[control] kind = "file"``) the file is
imported and run inside a forked child that robodyn watches (:mod:`robodyn.control.supervised`):
an ``os._exit`` in it cannot end robodyn with exit 0, and each call has a time limit. Through the
Python API it runs inside the caller's process: load only files you trust.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.control import supervised
from robodyn.control.supervised import CALL_TIMEOUT, LOAD_TIMEOUT, OutOfTime, time_limit
from robodyn.errors import InputError
from robodyn.robot import Robot
from robodyn.user_import import exit_call, import_user_file, user_line

Array = NDArray[np.float64]


def looks_like_file(spec: str) -> bool:
    """True when a controller name is a Python file rather than a built-in name."""
    return spec.endswith(".py") or "/" in spec or "\\" in spec


class UserController:
    """A user's torque callable, checked at every call; errors name ``source`` and the user's line."""

    def __init__(self, fn: Callable[..., Any], source: str, path: Path, robot: Robot) -> None:
        self.fn = fn
        self.source = source
        self.path = path
        self.sizes = (robot.nv, int(robot.actuated.sum()))
        self.__qualname__ = f"controller file {source}"

    def __call__(self, t: float, q: Array, v: Array) -> Array:
        """The torques (nv,) or (n_act,) [N m | N] from the user's callable.

        It gets read-only copies of q and v: a controller that writes into them (``q[1] = 0.0``)
        would change the state being integrated; the write raises instead, and the run is refused.
        """
        q_in, v_in = _read_only(q), _read_only(v)
        watch = supervised.watch  # None outside the watched child: no limit
        try:
            if watch is not None:  # inline, not a context manager: ~0.2 us a call
                watch.seconds, watch.what = CALL_TIMEOUT, f"{self.source}: the controller"
                watch.deadline = time.monotonic() + CALL_TIMEOUT
            try:
                raw = self.fn(float(t), q_in, v_in)
            finally:
                if watch is not None:
                    watch.deadline = None
        except OutOfTime:
            raise InputError(
                f"{self.source}: the controller did not return within {CALL_TIMEOUT:g} s at t = {t:.6g} s "
                "(an endless loop?)"
            ) from None
        except BaseException as exc:  # a user's controller can raise anything, sys.exit included
            if isinstance(exc, KeyboardInterrupt):
                raise
            if isinstance(exc, ValueError) and "read-only" in str(exc):
                raise InputError(
                    f"{_where(self.source, exc, self.path)}: the controller wrote into its argument q or v at "
                    f"t = {t:.6g} s; they are read-only (work on a copy: q = q.copy())"
                ) from None
            raise InputError(
                f"{_where(self.source, exc, self.path)}: the controller raised {_what(exc)} at t = {t:.6g} s"
            ) from None
        out = self._torques(raw, t)
        return out

    def _torques(self, raw: Any, t: float) -> Array:
        """What the callable returned, as float64 torques: real numbers of a shape the robot takes, finite."""
        try:
            array = np.asarray(raw)
        except Exception as exc:  # a ragged list, an object whose __array__ raises
            raise InputError(
                f"{self.source}: the controller returned {type(raw).__name__} at t = {t:.6g} s, not an array of "
                f"numbers ({type(exc).__name__})"
            ) from None
        if array.dtype.kind not in "fiu":
            what = "complex numbers" if array.dtype.kind == "c" else f"{type(raw).__name__} of dtype {array.dtype}"
            raise InputError(
                f"{self.source}: the controller returned {what} at t = {t:.6g} s; expected real torques (float64)"
            )
        out = np.asarray(array, dtype=np.float64)
        if out.ndim != 1 or out.size not in self.sizes:
            nv, n_act = self.sizes
            expected = (
                f"({nv},) (one per velocity)"
                if nv == n_act
                else f"({nv},) (one per velocity) or ({n_act},) (one per actuated joint)"
            )
            raise InputError(
                f"{self.source}: the controller returned shape {out.shape} at t = {t:.6g} s; expected {expected}"
            )
        if not np.all(np.isfinite(out)):
            raise InputError(
                f"{self.source}: the controller returned non-finite torques {out.tolist()} at t = {t:.6g} s"
            )
        return out


def load_user_controller(path: str | Path, robot: Robot, **gains: Any) -> UserController:
    """Import the controller file ``path``, call its ``make(robot, **gains)`` and wrap the callable it returns."""
    source = str(path)
    file = Path(path)
    try:
        with time_limit(LOAD_TIMEOUT, f"{source}: the controller file's import"):
            module = import_user_file(file, what="controller", expected="make(robot, **gains)", source=source)
    except OutOfTime:
        raise InputError(f"{source}: the controller file did not finish its import within {LOAD_TIMEOUT:g} s") from None
    factory = getattr(module, "make", None)
    if not callable(factory):
        raise InputError(f"{source}: define make(robot, **gains) returning a callable tau(t, q, v)")
    try:
        with time_limit(LOAD_TIMEOUT, f"{source}: make(robot, **gains)"):
            fn = factory(robot, **gains)
    except OutOfTime:
        raise InputError(f"{source}: make(robot, **gains) did not return within {LOAD_TIMEOUT:g} s") from None
    except BaseException as exc:
        if isinstance(exc, KeyboardInterrupt):
            raise
        raise InputError(f"{_where(source, exc, file)}: make(robot, **gains) raised {_what(exc)}") from None
    if not callable(fn):
        raise InputError(f"{source}: make(robot, **gains) returned {type(fn).__name__}, not a callable tau(t, q, v)")
    return UserController(fn, source, file, robot)


def _read_only(x: Array) -> Array:
    """A copy of ``x`` that cannot be written (~1 us for a few entries)."""
    out = np.array(x, dtype=np.float64)
    out.flags.writeable = False
    return out


def _what(exc: BaseException) -> str:
    """``ZeroDivisionError: division by zero``, or ``sys.exit(3)`` for an exit."""
    if isinstance(exc, SystemExit):
        return exit_call(exc)
    return f"{type(exc).__name__}: {exc}"


def _where(source: str, exc: BaseException, path: Path) -> str:
    """``source:line`` with the line of the deepest frame of the traceback in the user's file, or ``source``."""
    line = user_line(exc.__traceback__, path)
    return source if line is None else f"{source}:{line}"
