"""A built-in kind as one object: closed form, parameters and units, URDF, controller defaults, code.

Every place that knows a kind reads it from its :class:`Kind` (registered once, in
:mod:`robodyn.kinds.catalog`): the parameter reader (:func:`robodyn.kinds.params.extract`), the
checker, the units printed beside each parameter, the help strings of the command line, the
controller's upright and hanging states, and the integer code that the compiled closed-form loop
branches on. Adding a kind is a module holding its ``KIND``, its URDF in ``models/`` and one line in
the catalog (``docs/contributing.md`` shows the diff).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from robodyn.kinds.bodies import Body
from robodyn.kinds.formula import ClosedForm, Formula

Array = NDArray[np.float64]
Reader = Callable[[Sequence[Body], Array], dict[str, float]]
"""``read(bodies, gravity) -> {name: value}``: a model's parameters (SI), or AssumptionError."""


@dataclass(frozen=True)
class Balance:
    """What the swing-up controller needs of a kind: its upright and hanging q, the joint it drives."""

    upright: tuple[float, ...]  # q of the unstable equilibrium [rad | m]
    hanging: tuple[float, ...]  # q of the stable rest [rad | m]
    driven: int  # the place, in the model's joints, of the one joint the swing-up law drives


@dataclass(frozen=True, eq=False)
class Kind:
    """One built-in kind.

    Attributes:
        name: the kind's name: its URDF's stem in ``models/`` (whose opening comment line describes it),
            its module's name, and what help strings and messages list.
        closed_form: the Lagrangian closed form, written once (:mod:`robodyn.kinds.formula`).
        read: reads the parameters from a model's bodies (:mod:`robodyn.kinds.bodies`).
        units: the SI unit of every parameter ("1": a pure number).
        code: the integer the compiled closed-form loop branches on (``if kind == 2:``), or None
            for a kind that has no compiled path (it runs on the Pinocchio or numba tree backends).
        balance: the controller's defaults, or None for a kind no swing-up law serves.
        renamed: parameters once named otherwise: old name -> (new name, what the old one meant).
        formula: the closed form's NumPy matrices (:class:`Formula`), made once.
    """

    name: str
    closed_form: ClosedForm
    read: Reader
    units: Mapping[str, str]
    code: int | None = None
    balance: Balance | None = None
    renamed: Mapping[str, tuple[str, str]] = field(default_factory=dict)
    formula: Formula = field(init=False)

    def __post_init__(self) -> None:
        missing = [p for p in self.closed_form.params if p not in self.units]
        if missing:
            raise ValueError(f"kind {self.name!r} gives no unit for {', '.join(missing)}")
        if self.balance is not None and len(self.balance.upright) != self.closed_form.dof:
            raise ValueError(f"kind {self.name!r}: the upright q has {len(self.balance.upright)} entries")
        object.__setattr__(self, "formula", self.closed_form.formula(self.name, f"robodyn.kinds.{self.name}"))

    @property
    def params(self) -> tuple[str, ...]:
        """The parameter names, in the closed form's order."""
        return self.closed_form.params
