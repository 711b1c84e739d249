"""What a user's formula file must be, checked inside the process that runs it.

The file defines ``KIND`` (one of the built-in kinds) and the functions ``mass_matrix(q, p)``,
``coriolis_matrix(q, v, p)``, ``gravity(q, p)``, optionally ``potential_energy(q, p)``, where ``p``
maps the kind's parameter names to floats. ``KIND = "constrained"`` is a closed chain's reduced
Lagrangian, which also defines ``INDEPENDENT``, ``parameters(scene)`` and ``on_the_loop(q, v, p)``
(:mod:`robodyn.kinds.reduced`). Every returned value is shape-checked and must be
finite; an error, an exception or a ``sys.exit`` names the user's file and line.

This module imports and runs the user's code in the current process, so robodyn calls it only
in the formula's own process (:mod:`robodyn.kinds.sandbox`); :func:`robodyn.kinds.user.load_user_formula`
is the safe entry point.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from types import ModuleType

import numpy as np

from robodyn.errors import FormulaError
from robodyn.kinds.any_file import KIND as ANY
from robodyn.kinds.any_file import load_any
from robodyn.kinds.formula import Array, Formula
from robodyn.kinds.formulas import KINDS, get
from robodyn.kinds.geared_arm import from_motor_coordinates
from robodyn.kinds.reduced import KIND as CONSTRAINED
from robodyn.kinds.reduced import ConstrainedFormula, independent_names
from robodyn.userfile import at_line, exit_call, import_user_file, real_path

REQUIRED_FUNCTIONS = ("mass_matrix", "coriolis_matrix", "gravity")
CONSTRAINED_FUNCTIONS = ("parameters", "on_the_loop")


EXPECTED_DEFINITIONS = "KIND, mass_matrix, coriolis_matrix, gravity"


def load_in_process(path: Path, source: str) -> Formula:
    """Import the formula file at ``path`` here and wrap its functions; errors name ``source`` (the path as given).

    For ``KIND = "geared_arm"`` the file may set ``COORDINATES = "motor"`` to write its
    formulas in the motor angle theta_m = n theta_l, as the textbook's Example 6.1.1 does; they are mapped to the
    link coordinate (M_l = n^2 M_m, C_l = n^2 C_m, G_l = n G_m).
    """
    path = real_path(path)
    module = import_user_file(
        path, what="formula", expected="KIND, mass_matrix, coriolis_matrix, gravity", source=source, error=FormulaError
    )
    kind = getattr(module, "KIND", None)
    kinds = ", ".join(KINDS.names())
    closed = (
        f"; or {ANY!r}: any tree robot in your own coordinates; or {CONSTRAINED!r}: a closed chain's reduced Lagrangian"
    )
    if not isinstance(kind, str):
        raise FormulaError(f"{source}: define KIND as one of {kinds} (found {kind!r}){closed}")
    if kind not in KINDS and kind not in (CONSTRAINED, ANY):
        raise FormulaError(f"{source}: KIND = {kind!r} is not a known kind; expected one of {kinds}{closed}")
    missing = [f for f in REQUIRED_FUNCTIONS if not callable(getattr(module, f, None))]
    if missing:
        raise FormulaError(
            f"{source}: missing function(s) {', '.join(missing)}; "
            "define mass_matrix(q, p), coriolis_matrix(q, v, p), gravity(q, p)"
        )
    if kind == CONSTRAINED:
        return _constrained(module, source, path)
    if kind == ANY:
        return load_any(module, source, path, _shape_checked)
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


def _constrained(module: ModuleType, source: str, path: Path) -> ConstrainedFormula:
    """A ``KIND = "constrained"`` file (the contract: :mod:`robodyn.kinds.reduced`), its functions wrapped."""
    independent = independent_names(getattr(module, "INDEPENDENT", None), source)
    missing = [f for f in (*REQUIRED_FUNCTIONS, *CONSTRAINED_FUNCTIONS) if not callable(getattr(module, f, None))]
    if missing:
        raise FormulaError(
            f"{source}: missing function(s) {', '.join(missing)}; a constrained formula defines parameters(scene), "
            "mass_matrix(q, p), coriolis_matrix(q, v, p), gravity(q, p) and on_the_loop(q, v, p)"
        )
    n = len(independent)
    V_raw = getattr(module, "potential_energy", None)
    return ConstrainedFormula(
        CONSTRAINED,
        source,
        (),
        _shape_checked(module.mass_matrix, "mass_matrix", (n, n), source, path),
        _shape_checked(module.coriolis_matrix, "coriolis_matrix", (n, n), source, path),
        _shape_checked(module.gravity, "gravity", (n,), source, path),
        _shape_checked(V_raw, "potential_energy", (), source, path) if callable(V_raw) else None,
        n,
        independent=independent,
        path=path,
        read_parameters=module.parameters,
        to_the_loop=module.on_the_loop,
    )


def _shape_checked(
    fn: Callable[..., object], name: str, shape: tuple[int, ...], source: str, user_file: Path
) -> Callable[..., Array]:
    """Wrap a user's function: finite float64 of the right shape, or a FormulaError naming it and its line."""

    def wrapped(*args: object) -> Array:
        try:
            raw = fn(*args)
        except FormulaError:
            raise
        except SystemExit as exc:  # sys.exit in a formula would end robodyn with the formula's code
            raise FormulaError(f"{source}: {name} called {exit_call(exc)}{at_line(exc, user_file)}") from None
        except Exception as exc:  # a user's function can raise anything
            raise FormulaError(f"{source}: {name} raised {_describe(exc, user_file, args)}") from None
        out = real_values(raw, f"{source}: {name}")
        if shape == () and out.shape in ((), (1,)):
            out = out.reshape(())
        elif out.shape != shape:
            raise FormulaError(f"{source}: {name} returned shape {out.shape}, expected {shape}")
        if not np.all(np.isfinite(out)):
            raise FormulaError(f"{source}: {name} returned non-finite values {out.tolist()} at q = {args[0]!r}")
        return out

    return wrapped


def real_values(raw: object, where: str) -> Array:
    """``raw`` as float64, or a FormulaError: only real numbers (floats, integers) convert.

    ``np.asarray(x, dtype=float64)`` would drop a complex value's imaginary part (with a warning on
    stderr), parse strings, and take an object array of huge integers (``2**70``) to the nearest
    float; each is refused here in one line instead, saying what came back.
    """
    try:
        array = np.asarray(raw)
    except Exception as exc:  # a ragged list, an object whose __array__ raises
        raise FormulaError(
            f"{where} returned something that is not an array of numbers ({type(exc).__name__})"
        ) from None
    kind = array.dtype.kind
    if kind == "c":
        raise FormulaError(f"{where} returned complex numbers; expected real ones (float64)")
    if kind == "O":
        what = "integers too large for 64 bits" if _big_integers(array) else "Python objects"
        raise FormulaError(f"{where} returned {what} (an array of dtype object); expected real numbers (float64)")
    if kind not in "fiu":
        raise FormulaError(f"{where} returned {array.dtype} values; expected real numbers (float64)")
    return np.asarray(array, dtype=np.float64)


def _big_integers(array: np.ndarray) -> bool:
    return any(isinstance(x, int) and not isinstance(x, bool) for x in array.reshape(-1)[:1000])


def _describe(exc: Exception, user_file: Path, args: tuple[object, ...]) -> str:
    """``KeyError: 'mass1' (line 17); the parameters are m1, m2, ...``: the user's own line."""
    text = f"{type(exc).__name__}: {exc}{at_line(exc, user_file)}"
    params = args[-1]
    if isinstance(exc, KeyError) and isinstance(params, Mapping):
        text += f"; the parameters are {', '.join(params)}"
    return text
