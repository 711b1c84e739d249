"""The Lagrangian of a tree robot derived symbolically from its per-link table (``robodyn derive``).

:mod:`~robodyn.lagrange.trig` is the exact trigonometric algebra, :mod:`~robodyn.lagrange.naming`
names the parameters per link, :mod:`~robodyn.lagrange.derivation` derives M, the Christoffel
symbols, G and V, :mod:`~robodyn.lagrange.symbolic` turns them into sympy expressions,
:mod:`~robodyn.lagrange.render` prints them, :mod:`~robodyn.lagrange.selfcheck` checks them
against Pinocchio (through the Robot's methods: this package never imports Pinocchio).
Only ``symbolic`` and what uses it import sympy, on first use.
"""
