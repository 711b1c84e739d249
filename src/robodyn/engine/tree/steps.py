"""numba kernels of whole runs on a kinematic tree: the step's stages, the methods, one state or a batch.

Imported only by :mod:`robodyn.sim.tree` (numba is heavy). :func:`rates` is one evaluation of
the pipeline of :class:`robodyn.sim.system.RobotSystem` (springs, losses, actuation, ABA of
:mod:`robodyn.engine.tree.algorithms`) with the powers of the ledger; :func:`step` is one step of a
fixed-step explicit method (classic RK4 with the integrators' own arithmetic, any explicit
Runge--Kutta tableau, semi-implicit Euler); :func:`sample` evaluates one sample of a run with the
joints held at a stop locked; :func:`batch_rollout` steps blocks of states in one ``prange``
(each thread owns a block through all of time). The whole runs, stop events and all, are in
:mod:`robodyn.engine.tree.events`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from robodyn.engine import jit
from robodyn.engine.tree.algorithms import aba, crba, integrate, kinematics, rnea
from robodyn.engine.tree.layout import W_LAMBDA, W_LOCK, WCOLS

__all__ = ["WCOLS", "aba", "crba", "integrate", "kinematics", "rnea"]

njit = jit.njit(nogil=True, error_model="numpy")

# method codes of step / batch_rollout (and of robodyn.engine.tree.events.run_events)
RK, RK4, SEMI_IMPLICIT_EULER = 0, 1, 2

# Torque callables of the runs under way, by key: key -> f(t, q, v) returning the applied torque (nv,);
# how many times each was called, and at which call a Ctrl-C (KeyboardInterrupt) came.
CALLBACKS: dict[int, object] = {}
CALLS: dict[int, int] = {}
INTERRUPTED: dict[int, int] = {}


def call_torque(key: int, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The applied torque of the callable registered under ``key`` at (t, q, v), as a fresh float64 (nv,).

    A KeyboardInterrupt inside the callable is recorded in :data:`INTERRUPTED` and answered with
    NaN torques from then on, so that the compiled loop stops at that step as on a blow-up.
    """
    if key in INTERRUPTED:
        return np.full(v.size, np.nan)
    CALLS[key] = CALLS.get(key, 0) + 1
    try:
        return np.ascontiguousarray(CALLBACKS[key](float(t), q.copy(), v.copy()), dtype=np.float64)  # type: ignore[operator]
    except KeyboardInterrupt:
        INTERRUPTED[key] = CALLS[key]
        return np.full(v.size, np.nan)


@jit.njit(error_model="numpy")  # no nogil: a torque callable runs in object mode
def _callable_torque(cb, t, q, v):  # type: ignore[no-untyped-def]
    with numba.objmode(tau_in="float64[::1]"):
        tau_in = call_torque(cb, t, q, v)
    return tau_in


@njit
def rates(itree, ftree, grav, flyer, t, q, u, forces, springs, cb, ws, tau, k):  # type: ignore[no-untyped-def]
    """Rates k = [a, P_input, P_damping] at (t, q, u); returns (T, V_gravity) [J] of (q, v).

    ``forces`` (4, nv): constant input torque, damping D, friction F, friction velocity (row 3,
    entry 0); ``cb`` >= 0 replaces the constant torque by the callable registered under that key
    (:data:`CALLBACKS`, called in object mode: a few microseconds a call); ``tau`` (nv,) is
    scratch; ``springs`` (4, m): coordinate index, velocity index, stiffness k, rest.
    The stages of :class:`robodyn.sim.system.RobotSystem`: springs, losses, actuation, ABA.
    """
    nv = forces.shape[1]
    p_in = 0.0
    p_loss = 0.0
    vf = forces[3, 0]
    tau_in = forces[0]
    if cb >= 0:  # the torque callable, through the Python object registered under cb
        tau_in = _callable_torque(cb, t, q, u[:nv])
    for j in range(nv):
        vj = u[j]
        loss = -forces[1, j] * vj
        if forces[2, j] != 0.0:
            loss -= forces[2, j] * math.tanh(vj / vf)
        tau[j] = tau_in[j] + loss
        p_in += tau_in[j] * vj
        p_loss += loss * vj
    for s in range(springs.shape[1]):
        tau[int(springs[1, s])] -= springs[2, s] * (q[int(springs[0, s])] - springs[3, s])
    kin, pot = aba(itree, ftree, grav, flyer, q, u, tau, ws, k)
    k[nv] = p_in
    k[nv + 1] = p_loss
    return kin, pot


@njit
def _finite(x):  # type: ignore[no-untyped-def]
    for j in range(x.shape[0]):
        if not np.isfinite(x[j]):
            return False
    return True


@njit
def step(itree, ftree, grav, flyer, method, tab, t, h, q, u, forces, springs, cb, ws, buf, qs, q1, u1, k0):  # type: ignore[no-untyped-def]
    """One step of size h [s] from (t, q, u) into (q1, u1); k0 gets the rates at the start; returns (T, V) there.

    ``tab`` (s + 2, s) holds an explicit tableau's rows a, then b, then c (method RK), or is None for
    RK4 and semi-implicit Euler (numba then compiles no general-tableau code); RK4 follows the
    classic RK4's own arithmetic, semi-implicit Euler kicks v then drifts q with the new v.
    ``buf`` (2 s + 3, nv + 2) holds the stages' u and k (its last row: scratch for the torque).
    """
    kin, pot = rates(itree, ftree, grav, flyer, t, q, u, forces, springs, cb, ws, buf[-1], k0)
    stages(itree, ftree, grav, flyer, method, tab, t, h, q, u, forces, springs, cb, ws, buf, qs, q1, u1, k0)
    return kin, pot


@njit
def stages(itree, ftree, grav, flyer, method, tab, t, h, q, u, forces, springs, cb, ws, buf, qs, q1, u1, k0):  # type: ignore[no-untyped-def]
    """The rest of :func:`step` once ``k0`` holds the rates at (t, q, u): the state at t + h into (q1, u1)."""
    nv = forces.shape[1]
    nu = nv + 2
    if method == SEMI_IMPLICIT_EULER:
        for j in range(nu):
            u1[j] = u[j] + h * k0[j]
        dq = buf[0]
        for j in range(nv):
            dq[j] = h * u1[j]
        integrate(itree, flyer, q, dq, q1)
        return
    if method == RK4:
        h2 = 0.5 * h
        u2, u3, u4, k2, k3, k4, dq = buf[0], buf[1], buf[2], buf[3], buf[4], buf[5], buf[6]
        for j in range(nu):
            u2[j] = u[j] + h2 * k0[j]
        for j in range(nv):
            dq[j] = h2 * u[j]
        integrate(itree, flyer, q, dq, qs)
        rates(itree, ftree, grav, flyer, t + h2, qs, u2, forces, springs, cb, ws, buf[-1], k2)
        for j in range(nu):
            u3[j] = u[j] + h2 * k2[j]
        for j in range(nv):
            dq[j] = h2 * u2[j]
        integrate(itree, flyer, q, dq, qs)
        rates(itree, ftree, grav, flyer, t + h2, qs, u3, forces, springs, cb, ws, buf[-1], k3)
        for j in range(nu):
            u4[j] = u[j] + h * k3[j]
        for j in range(nv):
            dq[j] = h * u3[j]
        integrate(itree, flyer, q, dq, qs)
        rates(itree, ftree, grav, flyer, t + h, qs, u4, forces, springs, cb, ws, buf[-1], k4)
        h6 = h / 6.0
        for j in range(nv):
            dq[j] = h6 * (u[j] + 2.0 * (u2[j] + u3[j]) + u4[j])
        integrate(itree, flyer, q, dq, q1)
        for j in range(nu):
            u1[j] = u[j] + h6 * (k0[j] + 2.0 * (k2[j] + k3[j]) + k4[j])
        return
    if tab is None:  # RK4 or semi-implicit Euler only: the general tableau's code below is not compiled
        return
    # a general explicit Runge-Kutta tableau: stage i from the non-zero a_ij (as the integrators' _combine)
    s = tab.shape[1]
    U = buf[0:s]
    K = buf[s : 2 * s]
    dq = buf[2 * s]
    du = buf[2 * s + 1]
    for j in range(nu):
        U[0, j] = u[j]
        K[0, j] = k0[j]
    for i in range(1, s + 1):
        first = True
        for j in range(i):
            x = tab[i, j]
            if x == 0.0:
                continue
            hx = h * x
            if first:
                for m in range(nv):
                    dq[m] = hx * U[j, m]
                for m in range(nu):
                    du[m] = hx * K[j, m]
                first = False
            else:
                for m in range(nv):
                    dq[m] = dq[m] + hx * U[j, m]
                for m in range(nu):
                    du[m] = du[m] + hx * K[j, m]
        if i == s:
            if first:  # all weights zero cannot happen for a checked tableau
                for m in range(nv):
                    dq[m] = 0.0
                for m in range(nu):
                    du[m] = 0.0
            integrate(itree, flyer, q, dq, q1)
            for m in range(nu):
                u1[m] = u[m] + du[m]
            break
        if first:  # a row of zeros: the stage is the start point
            for m in range(nu):
                U[i, m] = u[m]
            rates(itree, ftree, grav, flyer, t + tab[s + 1, i] * h, q, u, forces, springs, cb, ws, buf[-1], K[i])
            continue
        for m in range(nu):
            U[i, m] = u[m] + du[m]
        integrate(itree, flyer, q, dq, qs)
        rates(itree, ftree, grav, flyer, t + tab[s + 1, i] * h, qs, U[i], forces, springs, cb, ws, buf[-1], K[i])


@njit
def stage_rows(tab):  # type: ignore[no-untyped-def]
    """The stages s of :func:`step`'s buffer (2 s + 3, nv + 2): the tableau's, at least 7 (RK4's rows)."""
    if tab is None:
        return 7
    return max(tab.shape[1], 7)


@njit
def lock(ws, held):  # type: ignore[no-untyped-def]
    """Lock the tree rows of ``held`` (2, h): rows [tree row; side] of the joints held at a stop."""
    for r in range(ws.shape[0]):
        ws[r, W_LOCK] = 0.0
    for j in range(held.shape[1]):
        ws[int(held[0, j]), W_LOCK] = 1.0


@njit
def _pulling(ws, held, release_tol):  # type: ignore[no-untyped-def]
    """True when a held stop pulls (side x its force < -release_tol) in the last evaluation in ``ws``."""
    for j in range(held.shape[1]):
        if held[1, j] * ws[int(held[0, j]), W_LAMBDA] + release_tol < 0.0:
            return True
    return False


@njit
def sample(itree, ftree, grav, flyer, t, q, u, forces, springs, cb, held, release_tol, a):  # type: ignore[no-untyped-def]
    """(T, V) [J], the rates (into ``a``, nv + 2) of one sample, and whether a held stop pulls there.

    The joints of ``held`` (2, h) are locked; a stop pulls when side x its force < -``release_tol``.
    """
    ws = np.zeros((itree.shape[0], WCOLS))
    lock(ws, held)
    kin, pot = rates(itree, ftree, grav, flyer, t, q, u, forces, springs, cb, ws, np.empty(forces.shape[1]), a)
    return kin, pot, _pulling(ws, held, release_tol)


@jit.njit(nogil=True, error_model="numpy", parallel=True)
def batch_rollout(itree, ftree, grav, flyer, method, tab, h, steps, Q, V, forces, springs, blocks):  # type: ignore[no-untyped-def]
    """Step every state of Q (n, nq), V (n, nv) through ``steps`` steps of h [s], in place.

    One parallel region: ``blocks`` + 1 boundaries split the batch; each block is stepped
    state by state through all of time by one thread.
    """
    nv = forces.shape[1]
    n, nq = Q.shape
    s = max(tab.shape[1], 7)
    nb = blocks.shape[0] - 1
    for b in numba.prange(nb):
        ws = np.zeros((itree.shape[0], WCOLS))
        buf = np.zeros((2 * s + 3, nv + 2))
        qs = np.empty(nq)
        k0 = np.empty(nv + 2)
        q = np.empty(nq)
        u = np.zeros(nv + 2)
        q1 = np.empty(nq)
        u1 = np.zeros(nv + 2)
        for r in range(blocks[b], blocks[b + 1]):
            for j in range(nq):
                q[j] = Q[r, j]
            for j in range(nv):
                u[j] = V[r, j]
            u[nv] = 0.0
            u[nv + 1] = 0.0
            for _ in range(steps):
                step(itree, ftree, grav, flyer, method, tab, 0.0, h, q, u, forces, springs, -1, ws, buf, qs, q1, u1, k0)
                for j in range(nq):
                    q[j] = q1[j]
                for j in range(nv + 2):
                    u[j] = u1[j]
            for j in range(nq):
                Q[r, j] = q[j]
            for j in range(nv):
                V[r, j] = u[j]
    return n
