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

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import InputError
from robodyn.robot import Robot
from robodyn.userfile import exit_call, import_user_file, user_line

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
    module = import_user_file(file, what="controller", expected="make(robot, **gains)", source=source)
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


def _what(exc: BaseException) -> str:
    """``ZeroDivisionError: division by zero``, or ``sys.exit(3)`` for an exit."""
    if isinstance(exc, SystemExit):
        return exit_call(exc)
    return f"{type(exc).__name__}: {exc}"


def _where(source: str, exc: BaseException, path: Path) -> str:
    """``source:line`` with the line of the deepest frame of the traceback in the user's file, or ``source``."""
    line = user_line(exc.__traceback__, path)
    return source if line is None else f"{source}:{line}"
