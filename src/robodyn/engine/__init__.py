"""The compiled engine: numba kernels over plain arrays, below the simulator that hands runs to it.

* ``jit``: how a kernel is declared, compiled and cached (one key over every kernel source);
* ``tree``: the recursive rigid-body algorithms on a kinematic tree, its steps, stop events and impacts;
* ``torque_laws``: the built-in controllers' torque laws, one body for NumPy, numba and CUDA;
* ``cuda``: the GPU paths (the closed forms' batches and closed loops, sweep measures, the tree kernels).

Nothing here imports :mod:`robodyn.sim` or anything above it (an import-linter contract), nor
Pinocchio: a run arrives as arrays. numba is imported on first use, never at ``import robodyn``.
"""

from robodyn.engine import jit as jit  # first: it sets numba's environment before numba is imported
