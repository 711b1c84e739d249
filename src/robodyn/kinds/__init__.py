"""The built-in kinds: closed forms written once, their parameters and extractors, the registry by name.

``robodyn.formulas`` is this package: :func:`get` a built-in kind's :class:`Formula`. A user's own
derivation is :func:`robodyn.checker.user_formula.load_user_formula`'s (``robodyn check`` lives in
:mod:`robodyn.checker`).
"""

from robodyn.kinds.formula import ClosedForm, Formula
from robodyn.kinds.formulas import KINDS, closed_form, get

__all__ = ["KINDS", "ClosedForm", "Formula", "closed_form", "get"]
