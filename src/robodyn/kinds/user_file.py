"""What a user's formula file must be, checked inside the process that runs it.

The file defines ``KIND`` (one of the built-in kinds) and the functions ``mass_matrix(q, p)``,
``coriolis_matrix(q, v, p)``, ``gravity(q, p)``, optionally ``potential_energy(q, p)``, where ``p``
maps the kind's parameter names to floats. Every returned value is shape-checked and must be
finite; an error, an exception or a ``sys.exit`` names the user's file and line.

This module imports and runs the user's code in the current process, so robodyn calls it only
in the formula's own process (:mod:`robodyn.kinds.sandbox`); :func:`robodyn.kinds.user.load_user_formula`
is the safe entry point.
"""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from types import ModuleType, TracebackType

import numpy as np

from robodyn.errors import FormulaError
from robodyn.kinds.formula import Array, Formula
from robodyn.kinds.formulas import KINDS, get
from robodyn.kinds.geared_arm import from_motor_coordinates

REQUIRED_FUNCTIONS = ("mass_matrix", "coriolis_matrix", "gravity")


def load_in_process(path: Path, source: str) -> Formula:
    """Import the formula file at ``path`` here and wrap its functions; errors name ``source`` (the path as given).

    For ``KIND = "geared_arm"`` the file may set ``COORDINATES = "motor"`` to write its
    formulas in the motor angle theta_m = n theta_l, as the seed does; they are mapped to the
    link coordinate (M_l = n^2 M_m, C_l = n^2 C_m, G_l = n G_m).
    """
    path = path.resolve()
    module = _import_file(path, source)
    kind = getattr(module, "KIND", None)
    if not isinstance(kind, str):
        raise FormulaError(f"{source}: define KIND as one of {', '.join(KINDS.names())} (found {kind!r})")
    if kind not in KINDS:
        raise FormulaError(f"{source}: KIND = {kind!r} is not a known kind; expected one of {', '.join(KINDS.names())}")
    missing = [f for f in REQUIRED_FUNCTIONS if not callable(getattr(module, f, None))]
    if missing:
        raise FormulaError(
            f"{source}: missing function(s) {', '.join(missing)}; "
            "define mass_matrix(q, p), coriolis_matrix(q, v, p), gravity(q, p)"
        )
    builtin = get(kind)
    n = builtin.dof
    M = _shape_checked(module.mass_matrix, "mass_matrix", (n, n), source, path)
    C = _shape_checked(module.coriolis_matrix, "coriolis_matrix", (n, n), source, path)
    G = _shape_checked(module.gravity, "gravity", (n,), source, path)
    V_raw = getattr(module, "potential_energy", None)
    V = _shape_checked(V_raw, "potential_energy", (), source, path) if callable(V_raw) else None
    coordinates = getattr(module, "COORDINATES", "link")
    if coordinates not in ("link", "motor") or (coordinates == "motor" and kind != "geared_arm"):
        raise FormulaError(f"{source}: COORDINATES = {coordinates!r}; expected 'link' (or 'motor' for the geared_arm)")
    if coordinates == "motor":
        M, C, G, V = from_motor_coordinates(M, C, G, V)
    return Formula(kind, source, builtin.param_names, M, C, G, V, n)


def _import_file(path: Path, source: str) -> ModuleType:
    if not path.is_file():
        raise FormulaError(
            f"{source}: no such formula file (expected a .py file defining KIND, mass_matrix, coriolis_matrix, gravity)"
        )
    name = f"robodyn_user_formula_{abs(hash(str(path.resolve())))}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise FormulaError(f"{source}: cannot be imported as a Python module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except SyntaxError as exc:
        raise FormulaError(f"{source}:{exc.lineno}: the formula file has a syntax error: {exc.msg}") from None
    except SystemExit as exc:  # a formula file must define, not decide the exit code
        raise FormulaError(
            f"{source}: the formula file called {exit_call(exc)} at import{at_line(exc, path)}"
        ) from None
    except Exception as exc:  # a user's file can raise anything on import
        raise FormulaError(
            f"{source}: the formula file failed to import: {type(exc).__name__}: {exc}{at_line(exc, path)}"
        ) from None
    finally:
        sys.modules.pop(name, None)
    return module


def _shape_checked(
    fn: Callable[..., object], name: str, shape: tuple[int, ...], source: str, user_file: Path
) -> Callable[..., Array]:
    """Wrap a user's function: finite float64 of the right shape, or a FormulaError naming it and its line."""

    def wrapped(*args: object) -> Array:
        try:
            out = np.asarray(fn(*args), dtype=np.float64)
        except FormulaError:
            raise
        except SystemExit as exc:  # sys.exit in a formula would end robodyn with the formula's code
            raise FormulaError(f"{source}: {name} called {exit_call(exc)}{at_line(exc, user_file)}") from None
        except Exception as exc:  # a user's function can raise anything
            raise FormulaError(f"{source}: {name} raised {_describe(exc, user_file, args)}") from None
        if shape == () and out.shape in ((), (1,)):
            out = out.reshape(())
        elif out.shape != shape:
            raise FormulaError(f"{source}: {name} returned shape {out.shape}, expected {shape}")
        if not np.all(np.isfinite(out)):
            raise FormulaError(f"{source}: {name} returned non-finite values {out.tolist()} at q = {args[0]!r}")
        return out

    return wrapped


def exit_call(exc: SystemExit) -> str:
    """``sys.exit(0)``, ``sys.exit()`` or ``sys.exit('bye')``: the call as the user would have written it."""
    return "sys.exit()" if exc.code is None else f"sys.exit({exc.code!r})"


def user_line(tb: TracebackType | None, user_file: Path) -> int | None:
    """The line of the deepest frame of ``tb`` in ``user_file`` (not in numpy or robodyn), or None."""
    target = user_file.resolve()
    line = None
    while tb is not None:
        if Path(tb.tb_frame.f_code.co_filename).resolve() == target:
            line = tb.tb_lineno
        tb = tb.tb_next
    return line


def at_line(exc: BaseException, user_file: Path) -> str:
    """`` (line 17)`` when the exception passed through the user's file, else ``""``."""
    line = user_line(exc.__traceback__, user_file)
    return f" (line {line})" if line is not None else ""


def _describe(exc: Exception, user_file: Path, args: tuple[object, ...]) -> str:
    """``KeyError: 'mass1' (line 17); the parameters are m1, m2, ...``: the user's own line."""
    text = f"{type(exc).__name__}: {exc}{at_line(exc, user_file)}"
    params = args[-1]
    if isinstance(exc, KeyError) and isinstance(params, Mapping):
        text += f"; the parameters are {', '.join(params)}"
    return text
