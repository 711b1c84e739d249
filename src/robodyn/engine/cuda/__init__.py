"""The GPU paths: the engine's kernels compiled by numba's CUDA target, from arrays alone.

Each module imports ``numba.cuda`` on first use (:func:`robodyn.engine.cuda.batch.cuda_module`);
``NUMBA_ENABLE_CUDASIM=1`` runs the same kernels in numba's CUDA simulator on the CPU.
"""
