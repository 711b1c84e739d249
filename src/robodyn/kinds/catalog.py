"""The built-in kinds, registered in this one place: each one's :class:`~robodyn.kinds.kind.Kind` by name.

Every kind resolves through :data:`KINDS`; a miss names the kinds that exist. A kind's module
(``cart_pole``, ``geared_arm``, ``pendubot``) holds its closed form, written once, its parameter
reader, units and controller defaults in one ``KIND``; everything else (the parameter reader's
dispatch, ``robodyn check``, the units printed, the command line's help strings, the controllers'
states, the compiled loop's code) reads it from here. Coordinates and units are Pinocchio's (link
angles [rad], cart position [m]). A user's own derivation loads through
:mod:`robodyn.checker.user_formula` into the same :class:`Formula` type.
"""

from __future__ import annotations

from robodyn.kinds import cart_pole, geared_arm, pendubot
from robodyn.kinds.formula import ClosedForm, Formula
from robodyn.kinds.kind import Kind
from robodyn.registry import Registry

KINDS: Registry[Kind] = Registry("formula kind")
for _kind in (cart_pole.KIND, geared_arm.KIND, pendubot.KIND):
    KINDS.register(_kind.name, _kind)


def kind(name: str) -> Kind:
    """The kind called ``name``; an unknown name raises UnknownNameError listing the kinds."""
    return KINDS.get(name)


def kinds() -> tuple[Kind, ...]:
    """Every registered kind, by name."""
    return tuple(KINDS.get(name) for name in KINDS.names())


def names() -> tuple[str, ...]:
    """The kinds' names, sorted: the order help strings and messages list them in."""
    return KINDS.names()


def listed(conjunction: str = "") -> str:
    """The kinds' names for a sentence: ``cart_pole, geared_arm, pendubot`` (or ``..., or pendubot``)."""
    all_names = names()
    if not conjunction or len(all_names) < 2:
        return ", ".join(all_names)
    return f"{', '.join(all_names[:-1])} {conjunction} {all_names[-1]}"


def closed_form(name: str) -> ClosedForm:
    """The scalar closed form of ``name``; an unknown kind raises UnknownNameError listing the kinds."""
    return KINDS.get(name).closed_form


def get(name: str) -> Formula:
    """The built-in formula set (NumPy matrices) for ``name``."""
    return KINDS.get(name).formula


def units() -> dict[str, str]:
    """Every built-in parameter's SI unit, by name ("1": a pure number); a name means one quantity in every kind."""
    return {param: unit for k in kinds() for param, unit in k.units.items()}


def renamed() -> dict[tuple[str, str], str]:
    """(kind, earlier name) -> the parameter's name now (M is only ever the mass matrix)."""
    return {(k.name, old): new for k in kinds() for old, (new, _meaning) in k.renamed.items()}


def renamed_meaning() -> dict[tuple[str, str], str]:
    """(kind, earlier name) -> what it stood for, as a note about a file that still uses it says it."""
    return {(k.name, old): meaning for k in kinds() for old, (_new, meaning) in k.renamed.items()}
