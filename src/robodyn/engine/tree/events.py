"""numba kernels that find the stop events inside a step: :class:`robodyn.sim.events.EventStepper`, compiled.

Imported only by :mod:`robodyn.sim.tree` (numba is heavy). :func:`run_events` steps one state
through a block of steps of a run, taking every stop event inside its step as the event
stepper does, in the same order and with the same tests:

* a step from a state clear of every stop, that ends clear, is the method's own step;
* otherwise the step is taken with its events (``_events_in_step``): a joint sitting on its
  stop and moving into it is struck first (``_touch``); after each trial of the rest of the
  step, the rows past their stop (gap + tolerance < 0) or pulling while held (side x stop
  force + RELEASE_TOL < 0) are watched and their first zero located by regula falsi
  (Illinois) on the step length, every trial a fresh step of the method from the step's start
  (``_locate``); there the joints reaching their stop are snapped onto it and get the exact
  restitution impulse (``_impact``: the Delassus solve of :func:`robodyn.sim.limits.impact`,
  pulling rows dropped, by the same LAPACK calls), a rebound landing within one step is held
  instead (``_rests``), and the held set is made consistent (``_settle``: a pulling held stop
  lets go, a joint pushed onto its stop that would not leave it within a step is brought to
  rest by a plastic impulse, ``_rest``);
* more than ``MAX_EVENTS_PER_STEP`` events in one step is chattering: the block stops there.

The joints held at a stop are locked in the compiled ABA (``W_LOCK``), which leaves each held
stop's force in ``W_LAMBDA``. The event state lives in small arrays the caller keeps between
blocks: ``held`` (m + 1,) int64 [count, then the held stops in the order they were held],
``side`` (m,) int64 (0 free, +1 held at its lower stop, -1 at its upper), ``counts``
(NCOUNTS,) int64 (evaluations, impacts, releases, steps with an event, and the sample the
step under way started from: where a LAPACK error raised inside a step came from), ``wlim`` (1,) the stops' work
[J], ``records`` (R, 6) the first R impacts [time, stop, side, speed before, after, dT].
The event stepper's constants arrive in ``par`` (see :func:`robodyn.sim.whole_run`), so that
a cached kernel never runs with old ones.
"""

from __future__ import annotations

import numpy as np

from robodyn.engine.tree.algorithms import crba, kinematics
from robodyn.engine.tree.impacts import (
    AT,
    CHATTER,
    DONE,
    EVALS,
    EVENT_STEPS,
    EVENTS,
    IMPACTS,
    NCOUNTS,
    NOT_FINITE,
    P_ITERATIONS,
    P_LOCATE_FTOL,
    P_LOCATE_RTOL,
    P_MAX_EVENTS,
    P_NOISE_RTOL,
    P_PULL_RTOL,
    P_RCOND,
    P_RELEASE_TOL,
    P_RESTITUTION,
    P_STAGES,
    PCOLS,
    RELEASES,
    S_HI,
    S_IQ,
    S_IV,
    S_LO,
    S_ROW,
    S_TOL,
    _bound,
    _crossed,
    _eval,
    _lock,
    _take,
    _touch,
    njit,
)
from robodyn.engine.tree.layout import W_LAMBDA, WCOLS
from robodyn.engine.tree.steps import _finite, stage_rows, stages, step

# re-exported: robodyn.sim.tree and whole_run read the event state's layout from this module
__all__ = [
    "AT",
    "CHATTER",
    "DONE",
    "EVALS",
    "EVENTS",
    "EVENT_STEPS",
    "IMPACTS",
    "NCOUNTS",
    "NOT_FINITE",
    "PCOLS",
    "P_ITERATIONS",
    "P_LOCATE_FTOL",
    "P_LOCATE_RTOL",
    "P_MAX_EVENTS",
    "P_NOISE_RTOL",
    "P_PULL_RTOL",
    "P_RCOND",
    "P_RELEASE_TOL",
    "P_RESTITUTION",
    "P_STAGES",
    "RELEASES",
    "S_HI",
    "S_IQ",
    "S_IV",
    "S_LO",
    "S_ROW",
    "S_TOL",
    "run_events",
    "run_steps",
]


@njit
def _step(md, par, ws, counts, t, q, u, h, q1, u1, k0):  # type: ignore[no-untyped-def]
    """One step of the method from (t, q, u) into (q1, u1); k0 the rates at its start; returns (T, V) there."""
    itree, ftree, grav, forces, springs, method, tab, cb, flyer = md
    nv = forces.shape[1]
    s = stage_rows(tab)
    buf = np.zeros((2 * s + 3, nv + 2))
    counts[EVALS] += int(par[P_STAGES])
    return step(
        itree, ftree, grav, flyer, method, tab, t, h, q, u, forces, springs, cb, ws, buf, np.empty(q.size), q1, u1, k0
    )


@njit
def _step_from(md, par, ws, counts, t, q, u, h, q1, u1, k0):  # type: ignore[no-untyped-def]
    """:func:`_step` when k0 already holds the rates at (t, q, u)."""
    itree, ftree, grav, forces, springs, method, tab, cb, flyer = md
    nv = forces.shape[1]
    s = stage_rows(tab)
    buf = np.zeros((2 * s + 3, nv + 2))
    counts[EVALS] += int(par[P_STAGES]) - 1
    stages(
        itree, ftree, grav, flyer, method, tab, t, h, q, u, forces, springs, cb, ws, buf, np.empty(q.size), q1, u1, k0
    )


@njit
def _clear(q, st):  # type: ignore[no-untyped-def]
    """True when every limited joint is clear of its stops (``EventStepper._clear``)."""
    for k in range(st.shape[1]):
        x = q[int(st[S_IQ, k])]
        if not (x > st[S_LO, k] + st[S_TOL, k] and x < st[S_HI, k] - st[S_TOL, k]):
            return False
    return True


@njit
def _values(md, par, st, side, ws, counts, t, q, u, rows, n, out, kout):  # type: ignore[no-untyped-def]
    """The event functions of rows[:n] at (t, q, u) into ``out`` (``EventStepper._values``).

    A held row's function is its stop force, from the rates at (t, q, u) (into ``kout``).
    Returns (whether the rates were evaluated, T, V [J]).
    """
    evaluated, kin, pot = False, 0.0, 0.0
    for i in range(n):
        if side[rows[i, 0]] != 0:
            kin, pot = _eval(md, ws, counts, t, q, u, kout)
            evaluated = True
            break
    for i in range(n):
        k, s = rows[i, 0], rows[i, 1]
        if side[k] != 0:
            out[i] = s * ws[int(st[S_ROW, k]), W_LAMBDA] + par[P_RELEASE_TOL]
        else:
            out[i] = s * (q[int(st[S_IQ, k])] - _bound(st, k, s)) + st[S_TOL, k]
    return evaluated, kin, pot


@njit
def _events(md, par, st, held, side, ws, counts, t, q, u, watch, wval, kout):  # type: ignore[no-untyped-def]
    """The rows whose event function is negative at (t, q, u) into watch, wval.

    Returns (their number, whether the rates at (t, q, u) were evaluated (into ``kout``), T, V [J]).
    """
    m = st.shape[1]
    rows = np.empty((2 * m + 1, 2), dtype=np.int64)
    n = _crossed(q, st, side, rows, 0)
    for i in range(held[0]):
        rows[n, 0], rows[n, 1] = held[1 + i], side[held[1 + i]]
        n += 1
    if n == 0:
        return 0, False, 0.0, 0.0
    vals = np.empty(n)
    evaluated, kin, pot = _values(md, par, st, side, ws, counts, t, q, u, rows, n, vals, kout)
    w = 0
    for i in range(n):
        if vals[i] < 0:
            watch[w, 0], watch[w, 1] = rows[i, 0], rows[i, 1]
            wval[w] = vals[i]
            w += 1
    return w, evaluated, kin, pot


@njit
def _scaled_min(vals, scale, n):  # type: ignore[no-untyped-def]
    """(min over i of vals[i] / scale[i], its first index)."""
    best = vals[0] / scale[0]
    at = 0
    for i in range(1, n):
        f = vals[i] / scale[i]
        if f < best:
            best, at = f, i
    return best, at


@njit
def _locate(md, par, st, side, ws, counts, t, q, u, h, q1, u1, watch, wval, n, qo, uo):  # type: ignore[no-untyped-def]
    """The first s in [0, h] where a watched function reaches 0, the state there into (qo, uo) (``_locate``)."""
    itree, ftree, grav, flyer = md[0], md[1], md[2], md[8]
    nv = md[3].shape[1]
    scale = np.empty(n)
    for i in range(n):
        scale[i] = abs(wval[i])
        if scale[i] == 0:
            scale[i] = 1.0
    vals = np.empty(n)
    kx = np.empty(u.size)
    _values(md, par, st, side, ws, counts, t, q, u, watch, n, vals, kx)
    f_start, _ = _scaled_min(vals, scale, n)
    if f_start <= 0:
        qo[:] = q
        uo[:] = u
        return 0.0
    # every trial is a step from (t, q, u): the rates there, evaluated once, start each of them
    k_start = np.empty(nv + 2)
    _eval(md, ws, counts, t, q, u, k_start)
    close = np.full(n, par[P_LOCATE_FTOL])
    any_held = False
    for i in range(n):
        any_held = any_held or side[watch[i, 0]] != 0
    if any_held:  # a held row's function is its stop force, known to FORCE_NOISE_RTOL sum_i |M_ji a_i|
        M = np.zeros((nv, nv))
        crba(itree, ftree, grav, flyer, q, ws, M)
        a = k_start
        for i in range(n):
            k = watch[i, 0]
            if side[k] != 0:
                iv = int(st[S_IV, k])
                size = 0.0
                for j in range(nv):
                    size += abs(M[iv, j]) * abs(a[j])
                close[i] = max(par[P_LOCATE_FTOL], par[P_NOISE_RTOL] * size / scale[i])
    lo, f_lo = 0.0, f_start
    hi, f_hi = h, -1.0
    qo[:] = q1
    uo[:] = u1
    qs, us, k0 = np.empty(q.size), np.empty(u.size), np.empty(u.size)
    turn = 0
    floor = par[P_LOCATE_RTOL] * h
    for _ in range(int(par[P_ITERATIONS])):
        if hi - lo <= floor:
            break
        s = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        if not lo < s < hi:
            s = 0.5 * (lo + hi)
        k0[:] = k_start
        _step_from(md, par, ws, counts, t, q, u, s, qs, us, k0)
        _values(md, par, st, side, ws, counts, t + s, qs, us, watch, n, vals, kx)
        f_s, i = _scaled_min(vals, scale, n)
        if -close[i] <= f_s < 0:  # just past the event, by less than its function is known
            qo[:] = qs
            uo[:] = us
            return s
        if f_s < 0:
            hi, f_hi = s, f_s
            qo[:] = qs
            uo[:] = us
            f_lo = f_lo * 0.5 if turn == -1 else f_lo
            turn = -1
        else:
            lo, f_lo = s, f_s
            f_hi = f_hi * 0.5 if turn == 1 else f_hi
            turn = 1
    return hi


@njit
def _events_in_step(md, par, st, held, side, ws, counts, wlim, records, t, q0, u0, h, first, q1, u1, k0, kc, cache):  # type: ignore[no-untyped-def]
    """The step from t to t + h with its events into (q1, u1) (``_events_in_step``).

    ``first``: (q1, u1, k0) already hold the method's step from (t, q0, u0). k0 gets the rates
    at the start of the first step taken. ``kc`` and ``cache`` [valid, t, T, V]: the rates at
    (t, q0, u0) with the same held set when the previous step ended by evaluating them (its
    held stops' forces), and are set for the next step the same way. Returns (CHATTER or DONE,
    T, V [J] of (q0, u0) when the first step started there, else NaN).
    """
    cached = cache[0] != 0.0 and cache[1] == t and not first
    cache[0] = 0.0
    q, u = q0.copy(), u0.copy()
    before = (counts[IMPACTS], counts[RELEASES], held[0], wlim[0])
    if not first:
        _touch(md, par, st, held, side, ws, counts, wlim, records, t, q, u, h)
    touched = before != (counts[IMPACTS], counts[RELEASES], held[0], wlim[0])
    kin, pot = np.nan, np.nan
    m = st.shape[1]
    watch = np.empty((2 * m + 1, 2), dtype=np.int64)
    wval = np.empty(2 * m + 1)
    qa, ua = np.empty(q.size), np.empty(u.size)
    kk = np.empty(u.size)
    t_stop = t + h
    remaining = h
    kset = first
    for _ in range(int(par[P_MAX_EVENTS])):
        if first:
            first = False
        elif cached and not kset and not touched:  # the rates at the start are the last step's end's
            k0[:] = kc
            _step_from(md, par, ws, counts, t, q, u, remaining, q1, u1, k0)
            kset = True
            kin, pot = cache[2], cache[3]
        else:
            kin_s, pot_s = _step(md, par, ws, counts, t, q, u, remaining, q1, u1, kk)
            if not kset:
                k0[:] = kk
                kset = True
                if not touched:
                    kin, pot = kin_s, pot_s
        t1 = t + remaining
        n, evaluated, kin_e, pot_e = _events(md, par, st, held, side, ws, counts, t1, q1, u1, watch, wval, kc)
        if n == 0:
            counts[EVENT_STEPS] += touched
            if evaluated:
                cache[0], cache[1], cache[2], cache[3] = 1.0, t1, kin_e, pot_e
            return DONE, kin, pot
        touched = True
        s = _locate(md, par, st, side, ws, counts, t, q, u, remaining, q1, u1, watch, wval, n, qa, ua)
        q[:] = qa
        u[:] = ua
        t = t_stop if remaining - s <= par[P_LOCATE_RTOL] * h else t + s
        _take(md, par, st, held, side, ws, counts, wlim, records, t, q, u, h)
        if t >= t_stop:
            q1[:] = q
            u1[:] = u
            counts[EVENT_STEPS] += 1
            return DONE, kin, pot
        remaining = t_stop - t
    counts[EVENT_STEPS] += 1
    return CHATTER, kin, pot


@njit
def run_events(md, par, st, held, side, counts, wlim, records, ts, hs, lo, hi, Q, U, A, KIN, POT, WL):  # type: ignore[no-untyped-def]
    """Take steps lo .. hi-1 (times ``ts``, sizes ``hs``) from sample lo of Q (n, nq), U (n, nv + 2), events and all.

    ``md``: (itree, ftree, grav, forces, springs, method, tab, cb, flyer), as :func:`robodyn.engine.tree.steps.step`
    takes them; ``st`` (6, m): every limited joint [index in q; index in v; lower; upper;
    tolerance; tree row]. Fills samples lo+1 .. hi of Q, U and WL (the stops' work [J]), and
    A, KIN, POT (gravity's potential only) of samples lo .. hi-1. Returns (outcome, sample):
    ``DONE`` (hi), ``NOT_FINITE`` (the state of that sample is not finite) or ``CHATTER``
    (more than the events allowed in the step from that sample).
    """
    itree, ftree, grav, flyer = md[0], md[1], md[2], md[8]
    nv = md[3].shape[1]
    ws = np.zeros((itree.shape[0], WCOLS))
    _lock(ws, st, held)
    k0 = np.empty(nv + 2)
    kc = np.empty(nv + 2)
    cache = np.zeros(4)
    for k in range(lo, hi):
        t, h = ts[k], hs[k]
        counts[AT] = k
        # a bool known only at run time: _events_in_step compiles once, not once per literal
        clear = held[0] == 0 and _clear(Q[k], st)
        if clear:  # the common case: the method's own step, clear at both ends
            kin, pot = _step(md, par, ws, counts, t, Q[k], U[k], h, Q[k + 1], U[k + 1], k0)
            status = DONE
            cache[0] = 0.0
            if _finite(Q[k + 1]) and _finite(U[k + 1]) and not _clear(Q[k + 1], st):
                status, _, _ = _events_in_step(
                    md, par, st, held, side, ws, counts, wlim, records, t, Q[k], U[k], h, clear, Q[k + 1], U[k + 1],
                    k0, kc, cache,
                )  # fmt: skip
        else:
            status, kin, pot = _events_in_step(
                md, par, st, held, side, ws, counts, wlim, records, t, Q[k], U[k], h, clear, Q[k + 1], U[k + 1], k0,
                kc, cache,
            )  # fmt: skip
            if np.isnan(kin):
                kin, pot = kinematics(itree, ftree, grav, flyer, Q[k], U[k], ws)
        if status == CHATTER:
            return CHATTER, k
        for j in range(nv):
            A[k, j] = k0[j]
        KIN[k] = kin
        POT[k] = pot
        WL[k + 1] = wlim[0]
        if not (_finite(Q[k + 1]) and _finite(U[k + 1])):
            return NOT_FINITE, k + 1
    return DONE, hi


@njit
def run_steps(md, par, st, counts, wlim, ts, hs, lo, hi, Q, U, A, KIN, POT, WL):  # type: ignore[no-untyped-def]
    """:func:`run_events` while no stop is held and every step stays clear of the stops: its common case alone.

    A small kernel that compiles in a fraction of :func:`run_events`' time: a run that meets no
    stop never compiles the events. Each step is :func:`run_events`' own for a step clear at
    both ends, with the same arithmetic and counts. Returns (outcome, sample) as :func:`run_events`,
    or ``EVENTS``: the step from that sample starts or ends at a stop, nothing of it kept (its
    evaluations uncounted), for :func:`run_events` to take from there. The caller hands a run
    with a torque callable (called in object mode, which must not be called twice for a step) or
    a held stop to :func:`run_events` directly.
    """
    nv = md[3].shape[1]
    ws = np.zeros((md[0].shape[0], WCOLS))
    k0 = np.empty(nv + 2)
    for k in range(lo, hi):
        if not _clear(Q[k], st):
            return EVENTS, k
        counts[AT] = k
        evaluations = counts[EVALS]
        kin, pot = _step(md, par, ws, counts, ts[k], Q[k], U[k], hs[k], Q[k + 1], U[k + 1], k0)
        if _finite(Q[k + 1]) and _finite(U[k + 1]) and not _clear(Q[k + 1], st):
            counts[EVALS] = evaluations
            return EVENTS, k
        for j in range(nv):
            A[k, j] = k0[j]
        KIN[k] = kin
        POT[k] = pot
        WL[k + 1] = wlim[0]
        if not (_finite(Q[k + 1]) and _finite(U[k + 1])):
            return NOT_FINITE, k + 1
    return DONE, hi
