"""What a user's formula file must be, checked inside the process that runs it.

The file defines ``KIND`` (one of the built-in kinds) and the functions ``mass_matrix(q, p)``,
``coriolis_matrix(q, v, p)`` (or ``coriolis_vector(q, v, p)``: C v alone, :mod:`robodyn.checker.velocity_terms`),
``gravity(q, p)``, optionally ``potential_energy(q, p)``, where ``p`` maps the kind's parameter names
to floats; it also answers the names the kind's parameters had before (the textbook's ``M`` for the
cart's mass, :data:`robodyn.kinds.units.RENAMED`), and :func:`renamed_notes` says which a file used.
``KIND = "constrained"`` is a closed chain's reduced Lagrangian, which also defines ``INDEPENDENT``,
``parameters(scene)`` and ``on_the_loop(q, v, p)`` (:mod:`robodyn.checker.constrained_kind`). Every returned value is
shape-checked and must be finite; an error, an exception or a ``sys.exit`` names the user's file and line.

This module imports and runs the user's code in the current process, so robodyn calls it only
in the formula's own process (:mod:`robodyn.checker.sandbox`); :func:`robodyn.checker.user_formula.load_user_formula`
is the safe entry point.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from robodyn.checker.any_kind import KIND as ANY
from robodyn.checker.any_kind import load_any
from robodyn.checker.constrained_kind import KIND as CONSTRAINED
from robodyn.checker.constrained_kind import ConstrainedFormula, independent_names
from robodyn.checker.velocity_terms import BOTH_OPTIONS, coriolis_function, defines_coriolis
from robodyn.errors import FormulaError
from robodyn.kinds.catalog import KINDS, get
from robodyn.kinds.formula import Array, Formula
from robodyn.kinds.geared_arm import from_motor_coordinates
from robodyn.kinds.units import RENAMED, RENAMED_MEANING
from robodyn.user_import import at_line, exit_call, import_user_file, real_path

REQUIRED_FUNCTIONS = ("mass_matrix", "coriolis_matrix", "gravity")
CONSTRAINED_FUNCTIONS = ("parameters", "on_the_loop")
SYMBOLS = {"mass_matrix": "M", "coriolis_matrix": "C", "coriolis_vector": "(C v)", "gravity": "G"}


EXPECTED_DEFINITIONS = "KIND, mass_matrix, coriolis_matrix, gravity"


class OldNames(Mapping[str, float]):
    """A built-in kind's parameters that also answer their earlier names (``p["M"]`` is the cart-pole's m_cart).

    Iterating gives robodyn's current names only; ``read`` collects the earlier names a formula asked for.
    """

    def __init__(self, kind: str, table: Mapping[str, float], read: set[str]) -> None:
        self.kind, self.table, self.read = kind, table, read

    def __getitem__(self, key: str) -> float:
        if key in self.table:
            return self.table[key]
        new = RENAMED.get((self.kind, key))
        if new is None or new not in self.table:
            raise KeyError(key)
        self.read.add(key)
        return self.table[new]

    def __iter__(self) -> Iterator[str]:
        return iter(self.table)

    def __len__(self) -> int:
        return len(self.table)


@dataclass(frozen=True)
class KindFileFormula(Formula):
    """A built-in kind's formula file loaded here: its functions read ``p`` through :class:`OldNames`."""

    old_names_read: set[str] = field(default_factory=set, kw_only=True, compare=False)


def renamed_notes(formula: Formula) -> list[str]:
    """``cart_pole.py uses the textbook's M for the cart's mass (robodyn calls it m_cart)``, per earlier name read."""
    if not isinstance(formula, KindFileFormula):
        return []
    name = Path(formula.source).name
    return [
        f"{name} uses the textbook's {old} for {RENAMED_MEANING[formula.kind, old]} "
        f"(robodyn calls it {RENAMED[formula.kind, old]})"
        for old in sorted(formula.old_names_read)
    ]


def _with_old_names(fn: Callable[..., Array], kind: str, read: set[str]) -> Callable[..., Array]:
    """``fn(*state, p)`` called with ``p`` answering the kind's earlier parameter names."""

    def call(*args: object) -> Array:
        *state, p = args
        return fn(*state, OldNames(kind, p, read) if isinstance(p, Mapping) else p)

    return call


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
    present = {
        "mass_matrix": callable(getattr(module, "mass_matrix", None)),
        "coriolis_matrix or coriolis_vector": defines_coriolis(module),
        "gravity": callable(getattr(module, "gravity", None)),
    }
    missing = [f for f, there in present.items() if not there]
    if missing:
        raise FormulaError(
            f"{source}: missing function(s) {', '.join(missing)}; define mass_matrix(q, p), gravity(q, p), and "
            f"{BOTH_OPTIONS}"
        )
    if kind == CONSTRAINED:
        return _constrained(module, source, path)
    if kind == ANY:
        return load_any(module, source, path, _shape_checked)
    builtin = get(kind)
    n = builtin.dof
    read: set[str] = set()

    def checked(fn: Callable[..., object], name: str, shape: tuple[int, ...], src: str, at: Path) -> Callable:
        return _with_old_names(_shape_checked(fn, name, shape, src, at), kind, read)

    M = checked(module.mass_matrix, "mass_matrix", (n, n), source, path)
    C, form = coriolis_function(module, n, source, path, checked)
    G = checked(module.gravity, "gravity", (n,), source, path)
    V_raw = getattr(module, "potential_energy", None)
    V = checked(V_raw, "potential_energy", (), source, path) if callable(V_raw) else None
    coordinates = getattr(module, "COORDINATES", "link")
    if coordinates not in ("link", "motor") or (coordinates == "motor" and kind != "geared_arm"):
        raise FormulaError(f"{source}: COORDINATES = {coordinates!r}; expected 'link' (or 'motor' for the geared_arm)")
    if coordinates == "motor":
        M, C, G, V = from_motor_coordinates(M, C, G, V)
    return KindFileFormula(kind, source, builtin.param_names, M, C, G, V, n, form, old_names_read=read)


def _constrained(module: ModuleType, source: str, path: Path) -> ConstrainedFormula:
    """A ``KIND = "constrained"`` file (contract: :mod:`~robodyn.checker.constrained_kind`), its functions wrapped."""
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
            raise FormulaError(_non_finite(fn, name, out, args, source, user_file))
        return out

    return wrapped


def _non_finite(
    fn: Callable[..., object], name: str, out: Array, args: tuple[object, ...], source: str, user_file: Path
) -> str:
    """``x.py: mass_matrix returned NaN in M[0,1] at q = [0.5, 1], v = [..] (line 12)``: one line."""
    bad = np.argwhere(~np.isfinite(out))
    first = tuple(int(i) for i in bad[0])
    value = float(out[first])
    what = "NaN" if np.isnan(value) else ("inf" if value > 0 else "-inf")
    entry = f" in {SYMBOLS.get(name, name)}[{','.join(map(str, first))}]" if first else ""
    more = f" (and {len(bad) - 1} more entr{'y' if len(bad) == 2 else 'ies'})" if len(bad) > 1 else ""
    state = ", ".join(f"{label} = {_numbers(x)}" for label, x in zip(("q", "v"), args[:-1], strict=False))
    line = _return_line(fn, args, user_file)
    return f"{source}: {name} returned {what}{entry}{more} at {state}{f' (line {line})' if line else ''}"


def _numbers(x: object) -> str:
    return "[" + ", ".join(f"{v:.6g}" for v in np.atleast_1d(np.asarray(x, dtype=np.float64))) + "]"


def _return_line(fn: Callable[..., object], args: tuple[object, ...], user_file: Path) -> int | None:
    """The line of ``fn``'s return statement in ``user_file`` when it is called with ``args`` again, or None."""
    code = getattr(fn, "__code__", None)
    if code is None or Path(code.co_filename).resolve() != user_file.resolve():
        return None
    returned: list[int] = []

    def profile(frame: Any, event: str, arg: object) -> None:
        if event == "return" and frame.f_code is code:
            returned.append(frame.f_lineno)

    copies = [np.array(a, copy=True) if isinstance(a, np.ndarray) else a for a in args]
    previous = sys.getprofile()
    sys.setprofile(profile)
    try:
        fn(*copies)
    except Exception:  # it raised this time: no return line to give
        return None
    finally:
        sys.setprofile(previous)
    return returned[-1] if returned else None


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
