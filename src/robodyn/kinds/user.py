"""A user's own derivation in a Python file, loaded into the same :class:`Formula` type as the built-ins.

The file defines ``KIND`` (one of the built-in kinds) and the functions ``mass_matrix(q, p)``,
``coriolis_matrix(q, v, p)``, ``gravity(q, p)``, optionally ``potential_energy(q, p)``, where ``p``
maps the kind's parameter names to floats. Every returned value is shape-checked and must be
finite; an error names the user's file and line.
"""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from types import ModuleType

import numpy as np

from robodyn.errors import FormulaError
from robodyn.kinds.formula import Array, Formula
from robodyn.kinds.formulas import KINDS, get
from robodyn.kinds.geared_arm import from_motor_coordinates


def looks_like_file(spec: str) -> bool:
    """True when a ``--formula`` value names a Python file rather than a built-in kind."""
    return spec.endswith(".py") or "/" in spec or "\\" in spec


def resolve(spec: str) -> Formula:
    """A built-in kind name, or a path to a user's formula file."""
    return load_user_formula(spec) if looks_like_file(spec) else get(spec)


REQUIRED_FUNCTIONS = ("mass_matrix", "coriolis_matrix", "gravity")


def _import_file(path: Path) -> ModuleType:
    if not path.is_file():
        raise FormulaError(
            f"{path}: no such formula file (expected a .py file defining KIND, mass_matrix, coriolis_matrix, gravity)"
        )
    name = f"robodyn_user_formula_{abs(hash(str(path.resolve())))}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise FormulaError(f"{path}: cannot be imported as a Python module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except SyntaxError as exc:
        raise FormulaError(f"{path}:{exc.lineno}: the formula file has a syntax error: {exc.msg}") from None
    except Exception as exc:  # a user's file can raise anything on import
        raise FormulaError(f"{path}: the formula file failed to import: {type(exc).__name__}: {exc}") from None
    finally:
        sys.modules.pop(name, None)
    return module


def load_user_formula(path: str | Path) -> Formula:
    """Load a user's derivation from a Python file.

    The file defines ``KIND`` (one of the built-in kinds) and the functions
    ``mass_matrix(q, p)``, ``coriolis_matrix(q, v, p)``, ``gravity(q, p)``, optionally
    ``potential_energy(q, p)``, where ``p`` maps the kind's parameter names to floats.
    For ``KIND = "geared_arm"`` the file may set ``COORDINATES = "motor"`` to write its
    formulas in the motor angle theta_m = n theta_l, as the seed does; robodyn maps them
    to the link coordinate (M_l = n^2 M_m, C_l = n^2 C_m, G_l = n G_m).
    """
    path = Path(path)
    module = _import_file(path)
    kind = getattr(module, "KIND", None)
    if not isinstance(kind, str):
        raise FormulaError(f"{path}: define KIND as one of {', '.join(KINDS.names())} (found {kind!r})")
    if kind not in KINDS:
        raise FormulaError(f"{path}: KIND = {kind!r} is not a known kind; expected one of {', '.join(KINDS.names())}")
    missing = [f for f in REQUIRED_FUNCTIONS if not callable(getattr(module, f, None))]
    if missing:
        raise FormulaError(
            f"{path}: missing function(s) {', '.join(missing)}; "
            "define mass_matrix(q, p), coriolis_matrix(q, v, p), gravity(q, p)"
        )
    builtin = get(kind)
    n = builtin.dof
    source = str(path)
    M = _shape_checked(module.mass_matrix, "mass_matrix", (n, n), source)
    C = _shape_checked(module.coriolis_matrix, "coriolis_matrix", (n, n), source)
    G = _shape_checked(module.gravity, "gravity", (n,), source)
    V_raw = getattr(module, "potential_energy", None)
    V = _shape_checked(V_raw, "potential_energy", (), source) if callable(V_raw) else None
    coordinates = getattr(module, "COORDINATES", "link")
    if coordinates not in ("link", "motor") or (coordinates == "motor" and kind != "geared_arm"):
        raise FormulaError(f"{path}: COORDINATES = {coordinates!r}; expected 'link' (or 'motor' for the geared_arm)")
    if coordinates == "motor":
        M, C, G, V = from_motor_coordinates(M, C, G, V)
    return Formula(kind, source, builtin.param_names, M, C, G, V, n)


def _shape_checked(fn: Callable[..., object], name: str, shape: tuple[int, ...], source: str) -> Callable[..., Array]:
    """Wrap a user's function: finite float64 of the right shape, or a FormulaError naming it."""

    def wrapped(*args: object) -> Array:
        try:
            out = np.asarray(fn(*args), dtype=np.float64)
        except FormulaError:
            raise
        except Exception as exc:  # a user's function can raise anything
            raise FormulaError(f"{source}: {name} raised {_describe(exc, source, args)}") from None
        if shape == () and out.shape in ((), (1,)):
            out = out.reshape(())
        elif out.shape != shape:
            raise FormulaError(f"{source}: {name} returned shape {out.shape}, expected {shape}")
        if not np.all(np.isfinite(out)):
            raise FormulaError(f"{source}: {name} returned non-finite values {out.tolist()} at q = {args[0]!r}")
        return out

    return wrapped


def _describe(exc: Exception, source: str, args: tuple[object, ...]) -> str:
    """``KeyError: 'mass1' (line 17); the parameters are m1, m2, ...``: the user's own line."""
    line = None
    user_file = Path(source).resolve()
    tb = exc.__traceback__
    while tb is not None:  # the deepest frame in the user's file, not in numpy or robodyn
        if Path(tb.tb_frame.f_code.co_filename).resolve() == user_file:
            line = tb.tb_lineno
        tb = tb.tb_next
    text = f"{type(exc).__name__}: {exc}" + (f" (line {line})" if line is not None else "")
    params = args[-1]
    if isinstance(exc, KeyError) and isinstance(params, Mapping):
        text += f"; the parameters are {', '.join(params)}"
    return text
