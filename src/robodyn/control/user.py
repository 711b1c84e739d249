"""A user's own controller in a Python file, loaded into the same torque-callable form as the built-ins.

The file defines ``make(robot, **gains)`` returning a callable tau(t, q, v) -> torques, with nv
entries (zero on passive joints) or one per actuated joint [N m | N]; the gains are the keyword
arguments given to :func:`robodyn.control.make`. It follows the pattern of a user's formula file
(:mod:`robodyn.kinds.user`): an error on import, in ``make`` or in a call, and a torque of the
wrong shape or not finite, raise :class:`InputError` in one line naming the file and the line.

The file runs inside robodyn's process (a controller is called at every integrator stage, so a
process of its own would cost more than the dynamics): load only files you trust.
"""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Callable
from pathlib import Path
from types import ModuleType, TracebackType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import InputError
from robodyn.robot import Robot

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
        """The torques (nv,) or (n_act,) [N m | N] from the user's callable."""
        try:
            out = np.asarray(self.fn(t, q, v), dtype=np.float64)
        except BaseException as exc:  # a user's controller can raise anything, sys.exit included
            if isinstance(exc, KeyboardInterrupt):
                raise
            raise InputError(
                f"{_where(self.source, exc, self.path)}: the controller raised {_what(exc)} at t = {t:.6g} s"
            ) from None
        if out.ndim != 1 or out.size not in self.sizes:
            raise InputError(
                f"{self.source}: the controller returned shape {out.shape} at t = {t:.6g} s; expected "
                f"({self.sizes[0]},) (one per velocity) or ({self.sizes[1]},) (one per actuated joint)"
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
    module = _import_file(file, source)
    factory = getattr(module, "make", None)
    if not callable(factory):
        raise InputError(f"{source}: define make(robot, **gains) returning a callable tau(t, q, v)")
    try:
        fn = factory(robot, **gains)
    except BaseException as exc:
        if isinstance(exc, KeyboardInterrupt):
            raise
        raise InputError(f"{_where(source, exc, file)}: make(robot, **gains) raised {_what(exc)}") from None
    if not callable(fn):
        raise InputError(f"{source}: make(robot, **gains) returned {type(fn).__name__}, not a callable tau(t, q, v)")
    return UserController(fn, source, file, robot)


def _import_file(path: Path, source: str) -> ModuleType:
    if not path.is_file():
        raise InputError(f"{source}: no such controller file (expected a .py file defining make(robot, **gains))")
    name = f"robodyn_user_controller_{abs(hash(str(path.resolve())))}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise InputError(f"{source}: cannot be imported as a Python module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except SyntaxError as exc:
        raise InputError(f"{source}:{exc.lineno}: the controller file has a syntax error: {exc.msg}") from None
    except BaseException as exc:  # a user's file can raise anything on import, sys.exit included
        if isinstance(exc, KeyboardInterrupt):
            raise
        raise InputError(f"{_where(source, exc, path)}: the controller file failed to import: {_what(exc)}") from None
    finally:
        sys.modules.pop(name, None)
    return module


def _what(exc: BaseException) -> str:
    """``ZeroDivisionError: division by zero``, or ``sys.exit(3)`` for an exit."""
    if isinstance(exc, SystemExit):
        return "sys.exit()" if exc.code is None else f"sys.exit({exc.code!r})"
    return f"{type(exc).__name__}: {exc}"


def _where(source: str, exc: BaseException, path: Path) -> str:
    """``source:line`` with the line of the deepest frame of the traceback in the user's file, or ``source``."""
    line = _user_line(exc.__traceback__, path)
    return source if line is None else f"{source}:{line}"


def _user_line(tb: TracebackType | None, path: Path) -> int | None:
    target = path.resolve()
    line = None
    while tb is not None:
        if Path(tb.tb_frame.f_code.co_filename).resolve() == target:
            line = tb.tb_lineno
        tb = tb.tb_next
    return line
