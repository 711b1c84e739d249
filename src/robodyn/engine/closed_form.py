"""The built-in kinds' closed forms compiled for the CPU: accelerations, energies, a run and a batch over arrays.

For a Pendubot, a cart-pole or a geared arm, the forward dynamics a = M^-1 (tau - C v - G - B v)
have a closed form (M is 2 x 2 or 1 x 1), so a whole fixed-step run compiles to one machine-code
loop with no allocation and no Python call per step. The closed forms are not written here: numba
compiles each kind's own scalar functions (``mass``, ``coriolis``, ``gravity``, ``potential`` of
:mod:`robodyn.kinds.pendubot`, :mod:`~robodyn.kinds.cart_pole`, :mod:`~robodyn.kinds.geared_arm`),
the same functions that serve ``robodyn check`` and the ``formula`` backend, and the RK4 step is
the one of :mod:`robodyn.engine.rk4` that the GPU paths compile too.

A kind enters the kernels as an integer code (:data:`CODES`), its parameters as a vector in its
``PARAMS`` order, its damping and the states as 2-vectors (a one-joint kind's second slot zero).
:class:`robodyn.sim.fast.FastDynamics` hands a robot's runs to :func:`kernels`.
numba is imported on first use, never at ``import robodyn``.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from robodyn.engine import jit
from robodyn.engine.rk4 import rk4_step
from robodyn.errors import MissingDependencyError
from robodyn.kinds import cart_pole, geared_arm, pendubot
from robodyn.kinds.catalog import closed_form, kinds
from robodyn.kinds.formula import solve_2x2

# Kind -> the integer code that selects it inside the compiled kernels: each Kind object's own ``code``.
CODES: dict[str, int] = {kind.name: kind.code for kind in kinds() if kind.code is not None}
KINDS: dict[str, tuple[int, tuple[str, ...]]] = {kind: (code, closed_form(kind).params) for kind, code in CODES.items()}
METHODS = ("rk4", "semi_implicit_euler")
# What a first compile of these kernels says it does (robodyn.engine.jit.announce)
COMPILING = ("the closed-form kernels of the built-in kinds", "about half a minute")


@lru_cache(maxsize=1)
def kernels() -> dict[str, Any]:
    """Compile (or load from numba's cache) the kernels; imported lazily."""
    try:
        import numba
    except ImportError:  # pragma: no cover - numba is a declared dependency
        raise MissingDependencyError("the fast path needs numba: pip install numba") from None
    njit = jit.njit(fastmath=False, nogil=True)

    pm, pc, pg, pp = (njit(f) for f in (pendubot.mass, pendubot.coriolis, pendubot.gravity, pendubot.potential))
    cm, cc, cg, cp = (njit(f) for f in (cart_pole.mass, cart_pole.coriolis, cart_pole.gravity, cart_pole.potential))
    gm, gc, gg, gp = (njit(f) for f in (geared_arm.mass, geared_arm.coriolis, geared_arm.gravity, geared_arm.potential))
    solve = njit(solve_2x2)

    @njit
    def acc(kind, p, b, q0, q1, v0, v1, t0, t1):  # type: ignore[no-untyped-def]
        if kind == 2:  # geared_arm, one degree of freedom
            m = gm(p, q0)[0]
            return (t0 - b[0] * v0 - gc(p, q0, v0)[0] * v0 - gg(p, q0)[0]) / m, 0.0
        if kind == 0:
            m11, m12, m22 = pm(p, q0, q1)
            c11, c12, c21, c22 = pc(p, q0, q1, v0, v1)
            g0, g1 = pg(p, q0, q1)
        else:
            m11, m12, m22 = cm(p, q0, q1)
            c11, c12, c21, c22 = cc(p, q0, q1, v0, v1)
            g0, g1 = cg(p, q0, q1)
        r0 = t0 - b[0] * v0 - (c11 * v0 + c12 * v1) - g0
        r1 = t1 - b[1] * v1 - (c21 * v0 + c22 * v1) - g1
        return solve(m11, m12, m22, r0, r1)

    @njit
    def rates(ctx, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        """The one RK4 step's rates: ctx = (kind, p, b, t0, t1); no power booked (the run books its work after)."""
        a0, a1 = acc(ctx[0], ctx[1], ctx[2], q0, q1, v0, v1, ctx[3], ctx[4])
        return a0, a1, 0.0

    rk4 = rk4_step(njit, rates)

    @njit
    def energies(kind, p, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        """(kinetic, potential) on each kind's own zero of the potential."""
        if kind == 2:
            return 0.5 * gm(p, q0)[0] * v0 * v0, gp(p, q0)
        if kind == 0:
            m11, m12, m22 = pm(p, q0, q1)
            pot = pp(p, q0, q1)
        else:
            m11, m12, m22 = cm(p, q0, q1)
            pot = cp(p, q0, q1)
        return 0.5 * (m11 * v0 * v0 + 2.0 * m12 * v0 * v1 + m22 * v1 * v1), pot

    @njit
    def run(kind, method, p, b, nv, q, v, tau, dt, n, Q, V, A):  # type: ignore[no-untyped-def]
        """Fill Q, V, A (n + 1, 2) from (q, v); method 0 = RK4, 1 = semi-implicit Euler."""
        q0, q1, v0, v1 = q[0], q[1], v[0], v[1]
        t0, t1 = tau[0], tau[1]
        h = dt
        for k in range(n + 1):
            Q[k, 0] = q0
            Q[k, 1] = q1
            V[k, 0] = v0
            V[k, 1] = v1
            a0, a1 = acc(kind, p, b, q0, q1, v0, v1, t0, t1)
            A[k, 0] = a0
            A[k, 1] = a1
            if k == n:  # the last sample: recorded, not stepped from
                break
            if method == 0:
                q0, q1, v0, v1, _work = rk4((kind, p, b, t0, t1), q0, q1, v0, v1, a0, a1, 0.0, h)
            else:
                # Semi-implicit Euler: kick the velocity first, then drift the position with the new velocity.
                v0 = v0 + h * a0
                v1 = v1 + h * a1
                q0 = q0 + h * v0
                q1 = q1 + h * v1
            if nv == 1:
                q1 = 0.0
                v1 = 0.0
            if not (np.isfinite(q0) and np.isfinite(q1) and np.isfinite(v0) and np.isfinite(v1)):
                return k + 1
        return n

    @njit
    def energy_series(kind, p, Q, V, K, P):  # type: ignore[no-untyped-def]
        for k in range(Q.shape[0]):
            K[k], P[k] = energies(kind, p, Q[k, 0], Q[k, 1], V[k, 0], V[k, 1])

    @njit
    def acc_batch(kind, p, b, Q, V, T, A):  # type: ignore[no-untyped-def]
        for k in range(Q.shape[0]):
            A[k, 0], A[k, 1] = acc(kind, p, b, Q[k, 0], Q[k, 1], V[k, 0], V[k, 1], T[k, 0], T[k, 1])

    @jit.njit(nogil=True, parallel=True)
    def batch_rk4(kind, p, b, nv, Q, V, dt, n, blocks):  # type: ignore[no-untyped-def]
        """Classic RK4 (the step of ``run``) on every state of Q, V (m, 2), in place, one prange over blocks."""
        h = dt
        for bi in numba.prange(blocks.shape[0] - 1):
            for r in range(blocks[bi], blocks[bi + 1]):
                q0, q1, v0, v1 = Q[r, 0], Q[r, 1], V[r, 0], V[r, 1]
                for _ in range(n):
                    a0, a1 = acc(kind, p, b, q0, q1, v0, v1, 0.0, 0.0)
                    q0, q1, v0, v1, _work = rk4((kind, p, b, 0.0, 0.0), q0, q1, v0, v1, a0, a1, 0.0, h)
                    if nv == 1:
                        q1 = 0.0
                        v1 = 0.0
                Q[r, 0], Q[r, 1], V[r, 0], V[r, 1] = q0, q1, v0, v1
        return 0

    # Compile now (or load numba's cache), so that no timed run pays for it.
    if not all(jit.is_cached(f) for f in (run, energy_series, acc_batch)):
        jit.announce(*COMPILING)
    z2, z = np.zeros(2), np.zeros((2, 2))
    for method in (0, 1):
        run(2, method, np.ones(6), z2, 1, z2, z2, z2, 1e-3, 1, z.copy(), z.copy(), z.copy())
    energy_series(2, np.ones(6), z, z, np.zeros(2), np.zeros(2))
    acc_batch(2, np.ones(6), z2, z, z, z, z.copy())
    return {"run": run, "energy_series": energy_series, "acc_batch": acc_batch, "batch_rk4": batch_rk4}
