"""The built-in kinds: closed forms written once, parameter extractors, user formula files, the check.

``robodyn.formulas`` is this package: :func:`get` a built-in kind's :class:`Formula`,
:func:`load_user_formula` a user's derivation, :func:`resolve` either from a ``--formula`` value.
"""

from robodyn.kinds.formula import ClosedForm, Formula
from robodyn.kinds.formulas import KINDS, closed_form, get
from robodyn.kinds.user import load_user_formula, looks_like_file, resolve

__all__ = ["KINDS", "ClosedForm", "Formula", "closed_form", "get", "load_user_formula", "looks_like_file", "resolve"]
