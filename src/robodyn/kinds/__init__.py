"""The built-in kinds: each one a :class:`Kind` (closed form, parameters and units, URDF, controller defaults).

``robodyn.formulas`` is this package: :func:`get` a built-in kind's :class:`Formula`, :func:`kind`
its whole :class:`Kind`. The kinds are registered in one place, :mod:`robodyn.kinds.catalog`. A
user's own derivation is :func:`robodyn.checker.user_formula.load_user_formula`'s (``robodyn check``
lives in :mod:`robodyn.checker`).
"""

from robodyn.kinds.catalog import KINDS, closed_form, get, kind
from robodyn.kinds.formula import ClosedForm, Formula
from robodyn.kinds.kind import Kind

__all__ = ["KINDS", "ClosedForm", "Formula", "Kind", "closed_form", "get", "kind"]
