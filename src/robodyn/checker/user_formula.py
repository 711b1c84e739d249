"""A user's own derivation in a Python file, as a :class:`Formula` whose code runs in a process of its own.

The file defines ``KIND`` (one of the built-in kinds) and the functions ``mass_matrix(q, p)``,
``coriolis_matrix(q, v, p)`` (or ``coriolis_vector(q, v, p)``, C v alone), ``gravity(q, p)``, optionally
``potential_energy(q, p)``, where ``p`` maps the kind's parameter names (current or earlier) to floats
(the contract: :mod:`robodyn.checker.file_contract`); or
``KIND = "constrained"``, a closed chain's reduced Lagrangian (:mod:`robodyn.checker.constrained_kind`).

:func:`load_user_formula` imports the file in its own process (:mod:`robodyn.checker.sandbox`),
under a time limit, and returns a :class:`UserFormula`: each of its functions is a round trip
to that process, and :meth:`UserFormula.evaluate` evaluates a whole batch of points in one.
``sys.exit``, ``os._exit``, a hang or a ``print`` in the file become one :class:`FormulaError`
naming the file (and the line, where there is one); robodyn's own process and output are untouched.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from robodyn.checker.constrained_kind import LoopStates, checked_parameters
from robodyn.checker.evaluation import Points, Values
from robodyn.checker.sandbox import DEFAULT_TIMEOUT, FormulaProcess
from robodyn.errors import FormulaError
from robodyn.kinds.catalog import get
from robodyn.kinds.formula import Array, Formula


def looks_like_file(spec: str) -> bool:
    """True when a ``--formula`` value names a Python file rather than a built-in kind."""
    return spec.endswith(".py") or "/" in spec or "\\" in spec


def resolve(spec: str, *, timeout: float = DEFAULT_TIMEOUT) -> Formula:
    """A built-in kind name, or a path to a user's formula file (its code limited to ``timeout`` s a request)."""
    return load_user_formula(spec, timeout=timeout) if looks_like_file(spec) else get(spec)


@dataclass(frozen=True)
class UserFormula(Formula):
    """A :class:`Formula` read from a user's file, evaluated in the file's own process.

    Close it (or use it as a context manager) to end the process early; otherwise it ends
    when the object is garbage-collected or robodyn exits.
    """

    path: Path = field(default=Path(), kw_only=True)
    process: FormulaProcess | None = field(default=None, kw_only=True, compare=False, repr=False)
    independent: tuple[str, ...] = field(default=(), kw_only=True)  # KIND = "constrained": its coordinates' joints
    # KIND = "any" (robodyn.checker.any_kind): independent is JOINTS; q_formula = A q_urdf + b (offsets); LOCKED
    matrix: tuple[tuple[float, ...], ...] = field(default=(), kw_only=True)  # A of q_formula = A q_urdf + b
    offsets: tuple[float, ...] = field(default=(), kw_only=True)
    locked: tuple[tuple[str, float], ...] = field(default=(), kw_only=True)
    names: tuple[str, ...] = field(default=(), kw_only=True)  # NAMES: the coordinates' own names, or ()
    constant_parameters: bool = field(default=False, kw_only=True)  # PARAMETERS, not parameters(robot)

    def evaluate(self, p: Mapping[str, float], points: Points) -> Values:
        """The file's functions at every point of ``points``, in one round trip to its process."""
        return self._process().evaluate(p, points, self.dof)

    def parameters(self, scene: str | None) -> dict[str, float]:
        """A constrained file's ``parameters(scene)`` (``scene``: the scene file's path), run in its process."""
        header, _ = self._process().call({"function": "parameters", "scene": scene})
        return checked_parameters(header.get("params"), self.source)

    def link_parameters(self, table: Any) -> dict[str, float]:
        """A ``KIND = "any"`` file's PARAMETERS or ``parameters(robot)`` of the per-link ``table``, in its process."""
        header, _ = self._process().call({"function": "parameters", "robot": table.as_dict()})
        return checked_parameters(header.get("params"), self.source)

    def loop_states(self, q: Array, v: Array, p: Mapping[str, float]) -> LoopStates:
        """A constrained file's ``on_the_loop`` at each row of q, v (k, n), in one round trip to its process."""
        params = {str(k): float(x) for k, x in p.items()}
        header, arrays = self._process().call(
            {"function": "on_the_loop", "params": params}, {"q": np.asarray(q, float), "v": np.asarray(v, float)}
        )
        joints = header.get("joints")
        got_q, got_v = arrays.get("q"), arrays.get("v")
        if (
            not isinstance(joints, list)
            or not all(isinstance(j, str) for j in joints)
            or got_q is None
            or got_v is None
            or got_q.shape != (len(q), len(joints))
            or got_v.shape != got_q.shape
        ):
            self.close()
            raise FormulaError(f"{self.source}: the formula's process sent on_the_loop states robodyn did not ask for")
        return LoopStates(tuple(joints), got_q, got_v)

    @property
    def renamed(self) -> tuple[str, ...]:
        """One note per earlier parameter name the file read so far (``p["M"]`` for the cart's mass)."""
        return tuple(self._process().renamed)

    def close(self) -> None:
        """End the formula's process (a later call starts a fresh one)."""
        self._process().close()

    def _process(self) -> FormulaProcess:
        if self.process is None:
            raise ValueError("this UserFormula has no process: build it with load_user_formula")
        return self.process

    def __enter__(self) -> UserFormula:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()


def load_user_formula(
    path: str | Path, *, timeout: float = DEFAULT_TIMEOUT, process: FormulaProcess | None = None
) -> UserFormula:
    """Load a user's derivation from a Python file, in a process of its own.

    The file defines ``KIND`` (one of the built-in kinds) and the functions
    ``mass_matrix(q, p)``, ``coriolis_matrix(q, v, p)``, ``gravity(q, p)``, optionally
    ``potential_energy(q, p)``, where ``p`` maps the kind's parameter names to floats.
    For ``KIND = "geared_arm"`` the file may set ``COORDINATES = "motor"`` to write its
    formulas in the motor angle theta_m = n theta_l, as the textbook's Example 6.1.1 does; robodyn maps them
    to the link coordinate (M_l = n^2 M_m, C_l = n^2 C_m, G_l = n G_m).

    Args:
        path: the formula file; error messages name it as given.
        timeout: seconds the file's code may run per request: its import, then each call
            (or each batch, :meth:`UserFormula.evaluate`).
        process: a process already started for ``path`` (``FormulaProcess(path, ...)``, whose
            own timeout then holds): the command line starts it before loading the models, so
            that the formula's Python starts while they load.

    Raises:
        FormulaError: the file is missing, fails to import, exits, hangs, or lacks KIND or a function.
        InputError: ``timeout`` is not in (0, MAX_TIMEOUT].
    """
    if process is None:
        process = FormulaProcess(Path(path), str(path), timeout=timeout)
    info = process.load()
    dof = int(info["dof"])
    return UserFormula(
        str(info["kind"]),
        str(path),
        tuple(str(name) for name in info["param_names"]),
        _one_call(process, "mass_matrix", dof),
        _one_call(process, "coriolis_matrix", dof),
        _one_call(process, "gravity", dof),
        _one_call(process, "potential_energy", dof) if info["potential"] else None,
        dof,
        str(info.get("coriolis", "matrix")),
        path=Path(path),
        process=process,
        independent=tuple(str(name) for name in info.get("independent", ())),
        matrix=tuple(tuple(float(x) for x in row) for row in info.get("matrix", ())),
        offsets=tuple(float(x) for x in info.get("offsets", ())),
        locked=tuple((str(name), float(x)) for name, x in info.get("locked", ())),
        names=tuple(str(name) for name in info.get("names", ())),
        constant_parameters=bool(info.get("constant_parameters", False)),
    )


def _one_call(process: FormulaProcess, function: str, dof: int) -> Callable[..., Any]:
    """``function(q, p)`` or ``function(q, v, p)`` as one round trip to the formula's process."""

    def call(*args: Any) -> Array:
        *state, p = args
        return process.evaluate(p, Points.only(function, *state), dof).of(function)[0]

    call.__name__ = function
    return call
