"""Runs under a torque law on an NVIDIA GPU: the LQR and the swing-up to LQR of the built-in two-joint kinds.

One GPU thread steps one run by classic RK4 (the one step of :mod:`robodyn.engine.rk4`) with the torque of the law
(:func:`robodyn.engine.torque_laws.forces`, the controller packed into a parameter vector) at every
stage, integrates the work of the torques and the joint damping with the RK4 weights, stops a
run once |E - E0 - W| passes its bound or its state stops being finite, and counts the last step
outside the upright band (the time to balance). Only the final states, each coordinate's range,
the time to balance and a divergence flag come back. The kind's closed form is compiled from its
own functions (:func:`robodyn.kinds.catalog.closed_form`), as in :mod:`robodyn.engine.cuda.batch`,
whose :func:`~robodyn.engine.cuda.batch.cuda_module` finds the GPU (or numba's CUDA simulator).
"""

from __future__ import annotations

import math
import time
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.engine.cuda import batch as cuda_batch
from robodyn.engine.rk4 import rk4_step
from robodyn.engine.torque_laws import forces
from robodyn.errors import InputError
from robodyn.kinds.catalog import closed_form
from robodyn.kinds.formula import solve_2x2

Array = NDArray[np.float64]

# numba.cuda, set by closed_kernel(): the kernel reaches it as a module global (numba's simulator patches those).
cuda: Any = None


def _closed(jit: Any, kind: str, law: str) -> Any:
    """``closed(p, b, c, up, ang, tol, q0, q1, v0, v1, bound, offset, dt, n)``: n RK4 steps under a torque law.

    The arithmetic of the sweep's CPU closed loop (``_closed_loop`` in :mod:`robodyn.sweep.chunk`),
    one state: the law :func:`robodyn.engine.torque_laws.forces` (parameter vector ``c``) gives the
    torque at every RK4 stage; the work W of the torques and the damping is integrated with the
    RK4 weights; a run is diverged once |E - E0 - W| passes ``bound`` [J] or its state stops being
    finite (the step stops there: the caller recomputes such runs); ``last`` is the last step
    (0 ... n) whose state had a revolute coordinate (``ang`` flags) ``tol`` [rad] or more from ``up``.
    Returns (q0, q1, v0, v1, lo0, lo1, hi0, hi1, last, diverged).
    """
    form = closed_form(kind)
    if form.dof != 2:
        raise InputError(f"device cuda: torque laws run on the two-joint kinds; {kind!r} has {form.dof}")
    mass, coriolis, gravity, potential, solve = (
        jit(f) for f in (form.mass, form.coriolis, form.gravity, form.potential, solve_2x2)
    )
    torque = forces(kind, law, jit)

    @jit
    def rates(ctx, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        """(a0, a1, power of the torques and damping [W]); ctx = (p, b, c)."""
        p, b, c = ctx
        t0, t1 = torque(c, p, b, q0, q1, v0, v1)
        m11, m12, m22 = mass(p, q0, q1)
        c11, c12, c21, c22 = coriolis(p, q0, q1, v0, v1)
        g0, g1 = gravity(p, q0, q1)
        r0 = t0 - b[0] * v0 - (c11 * v0 + c12 * v1) - g0
        r1 = t1 - b[1] * v1 - (c21 * v0 + c22 * v1) - g1
        a0, a1 = solve(m11, m12, m22, r0, r1)
        return a0, a1, (t0 - b[0] * v0) * v0 + (t1 - b[1] * v1) * v1

    rk4 = rk4_step(jit, rates)

    @jit
    def energy(p, q0, q1, v0, v1, offset):  # type: ignore[no-untyped-def]
        m11, m12, m22 = mass(p, q0, q1)
        return 0.5 * (m11 * v0 * v0 + 2.0 * m12 * v0 * v1 + m22 * v1 * v1) + (potential(p, q0, q1) + offset)

    @jit
    def outside(up, ang, tol, q0, q1):  # type: ignore[no-untyped-def]
        """True unless every flagged coordinate is within ``tol`` of ``up`` (wrapped): robodyn.sweep.measures."""
        e0 = (q0 - up[0] + math.pi) % (2.0 * math.pi) - math.pi
        e1 = (q1 - up[1] + math.pi) % (2.0 * math.pi) - math.pi
        return (ang[0] > 0.5 and not abs(e0) < tol) or (ang[1] > 0.5 and not abs(e1) < tol)

    @jit
    def closed(p, b, c, up, ang, tol, q0, q1, v0, v1, bound, offset, dt, n):  # type: ignore[no-untyped-def]
        h = dt
        lo0, lo1, hi0, hi1 = q0, q1, q0, q1
        e0 = energy(p, q0, q1, v0, v1, offset)
        work = 0.0
        last = -1
        diverged = False
        for step in range(n + 1):
            if outside(up, ang, tol, q0, q1):
                last = step
            if step == n:
                break
            a0, a1, p1 = rates((p, b, c), q0, q1, v0, v1)
            q0, q1, v0, v1, dw = rk4((p, b, c), q0, q1, v0, v1, a0, a1, p1, h)
            work = work + dw
            if not abs(energy(p, q0, q1, v0, v1, offset) - e0 - work) <= bound:  # NaN (a blown-up state) counts
                diverged = True
                break
            lo0 = min(lo0, q0)
            lo1 = min(lo1, q1)
            hi0 = max(hi0, q0)
            hi1 = max(hi1, q1)
        return q0, q1, v0, v1, lo0, lo1, hi0, hi1, last, diverged

    return closed


def _closed_row(jit: Any, kind: str, law: str) -> Any:
    """``row(r, p, b, c, up, ang, tol, Q, V, bound, offset, dt, n, qmin, qmax, out)``: run r under the law, in place."""
    closed = _closed(jit, kind, law)

    @jit
    def row(r, p, b, c, up, ang, tol, Q, V, bound, offset, dt, n, qmin, qmax, out):  # type: ignore[no-untyped-def]
        q0, q1, v0, v1, lo0, lo1, hi0, hi1, last, bad = closed(
            p, b, c, up, ang, tol, Q[r, 0], Q[r, 1], V[r, 0], V[r, 1], bound[r], offset, dt, n
        )
        Q[r, 0], Q[r, 1], V[r, 0], V[r, 1] = q0, q1, v0, v1
        qmin[r, 0], qmin[r, 1], qmax[r, 0], qmax[r, 1] = lo0, lo1, hi0, hi1
        out[r, 0] = math.nan if last == n else (last + 1) * dt
        out[r, 1] = 1.0 if bad else 0.0

    return row


@cache
def closed_kernel(kind: str, law: str) -> Any:
    """The CUDA kernel ``(p, b, c, up, ang, tol, Q, V, bound, offset, dt, n, qmin, qmax, out)`` of a torque law.

    ``out`` (n, 2) receives each run's time to balance [s] (NaN: never balanced by the end) and 1.0
    where it diverged.
    """
    global cuda
    module = cuda = cuda_batch.cuda_module()
    row = _closed_row(module.jit(device=True), kind, law)

    @module.jit
    def kernel(p, b, c, up, ang, tol, Q, V, bound, offset, dt, n, qmin, qmax, out):  # type: ignore[no-untyped-def]
        r = cuda.grid(1)
        if r < Q.shape[0]:
            row(r, p, b, c, up, ang, tol, Q, V, bound, offset, dt, n, qmin, qmax, out)

    return kernel


@cache
def cpu_closed_kernel(kind: str, law: str) -> Any:
    """:func:`closed_kernel`'s device function on the CPU's cores (numba ``prange``): the benchmark's CPU column."""
    import numba

    row = _closed_row(numba.njit, kind, law)

    @numba.njit(parallel=True)
    def kernel(p, b, c, up, ang, tol, Q, V, bound, offset, dt, n, qmin, qmax, out):  # type: ignore[no-untyped-def]
        for r in numba.prange(Q.shape[0]):
            row(r, p, b, c, up, ang, tol, Q, V, bound, offset, dt, n, qmin, qmax, out)

    return kernel


def closed_loop(
    kind: str,
    law: str,
    p: Array,
    b: Array,
    c: Array,
    Q: Array,
    V: Array,
    *,
    upright: Array,
    angular: Array,
    tol: float,
    bound: Array,
    offset: float,
    dt: float,
    steps: int,
    cpu: bool = False,
) -> tuple[Array, Array, Array, Array, Array, NDArray[np.bool_], float]:
    """RK4 under the torque law ``law`` (:mod:`robodyn.engine.torque_laws`, parameters ``c``) on the GPU.

    ``Q``, ``V`` (n, 2) the starts; ``p`` the kind's parameters, ``b`` (2,) its damping; ``upright``
    (2,) and ``angular`` (2,) flags the balance test (every flagged coordinate within ``tol`` [rad]);
    ``bound`` (n,) each run's allowed |E - E0 - W| [J], ``offset`` [J] the potential's zero. Returns
    (q, v, q_min, q_max) (n, 2) each, time to balance (n,) [s] (NaN: outside at the end), diverged
    (n,) (the state is then where the run stopped) and the kernel's wall time [s] (compiled
    beforehand). ``cpu=True`` runs the same device function on the CPU's cores.
    """
    n = Q.shape[0]
    Qp, Vp = np.array(Q, dtype=np.float64, order="C"), np.array(V, dtype=np.float64, order="C")
    lo, hi, out = np.zeros((n, 2)), np.zeros((n, 2)), np.zeros((n, 2))
    consts = [np.ascontiguousarray(x, dtype=np.float64) for x in (p, b, c, upright, angular)]
    bound_ = np.ascontiguousarray(bound, dtype=np.float64)
    if cpu:
        kernel = cpu_closed_kernel(kind, law)
        args1 = [Qp[:1].copy(), Vp[:1].copy(), bound_[:1].copy(), offset, dt, 0, lo[:1].copy(), hi[:1].copy()]
        kernel(*consts, tol, *args1, out[:1].copy())  # compile outside the timing
        start = time.perf_counter()
        kernel(*consts, tol, Qp, Vp, bound_, offset, dt, steps, lo, hi, out)
        wall = time.perf_counter() - start
        return Qp, Vp, lo, hi, out[:, 0].copy(), out[:, 1] > 0.5, wall
    module = cuda_batch.cuda_module()
    kernel = closed_kernel(kind, law)
    dev = [module.to_device(x) for x in consts]
    Q_d, V_d, bound_d = module.to_device(Qp), module.to_device(Vp), module.to_device(bound_)
    lo_d, hi_d, out_d = (module.device_array((n, 2), dtype=np.float64) for _ in range(3))
    blocks = cuda_batch.blocks_for(n)
    with cuda_batch.quiet():
        one = [module.to_device(x[:1].copy()) for x in (Qp, Vp, bound_)]
        spare = [module.device_array((1, 2), dtype=np.float64) for _ in range(3)]
        kernel[1, 1](*dev, tol, one[0], one[1], one[2], offset, dt, 0, *spare)  # compile outside the timing
        module.synchronize()
        start = time.perf_counter()
        kernel[blocks, cuda_batch.THREADS_PER_BLOCK](*dev, tol, Q_d, V_d, bound_d, offset, dt, steps, lo_d, hi_d, out_d)
        module.synchronize()
        wall = time.perf_counter() - start
    q, v, q_min, q_max, flags = (a.copy_to_host() for a in (Q_d, V_d, lo_d, hi_d, out_d))
    return q, v, q_min, q_max, flags[:, 0].copy(), flags[:, 1] > 0.5, wall
