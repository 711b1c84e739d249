"""The registry of built-in kinds: each one's closed form, by name.

Every kind resolves through :data:`KINDS`; a miss names the kinds that exist. The kinds are
``cart_pole``, ``geared_arm`` and ``pendubot`` (one module each, closed form written once).
Coordinates and units are Pinocchio's (link angles [rad], cart position [m]). A user's own
derivation loads through :mod:`robodyn.checker.user_formula` into the same :class:`Formula` type.
"""

from __future__ import annotations

from robodyn.kinds import cart_pole, geared_arm, pendubot
from robodyn.kinds.formula import ClosedForm, Formula
from robodyn.registry import Registry

KINDS: Registry[ClosedForm] = Registry("formula kind")
KINDS.register("cart_pole", cart_pole.CLOSED_FORM)
KINDS.register("geared_arm", geared_arm.CLOSED_FORM)
KINDS.register("pendubot", pendubot.CLOSED_FORM)

_FORMULAS = {"cart_pole": cart_pole.FORMULA, "geared_arm": geared_arm.FORMULA, "pendubot": pendubot.FORMULA}


def closed_form(kind: str) -> ClosedForm:
    """The scalar closed form of ``kind``; an unknown kind raises UnknownNameError listing the kinds."""
    return KINDS.get(kind)


def get(kind: str) -> Formula:
    """The built-in formula set (NumPy matrices) for ``kind``."""
    KINDS.get(kind)
    return _FORMULAS[kind]
