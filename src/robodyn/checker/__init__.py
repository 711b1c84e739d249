"""``robodyn check``: hand-derived formulas against Pinocchio, their files, ``--explain`` and the report.

The comparison is :func:`robodyn.checker.compare.check`, its result a
:class:`robodyn.checker.rows.CheckReport`; a user's formula file is loaded by
:func:`robodyn.checker.user_formula.load_user_formula` and runs in a process of its own
(:mod:`robodyn.checker.sandbox`). This package imports nothing on its own, so that a light
caller (a scene file's ``formula_timeout`` bound) does not load Pinocchio.
"""
