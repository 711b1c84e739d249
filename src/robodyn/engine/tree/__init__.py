"""numba kernels on a kinematic tree's arrays: the layout, the algorithms, the steps, stop events and impacts.

:mod:`robodyn.sim.tree` reads a Pinocchio model into these arrays and hands runs to the kernels.
"""
