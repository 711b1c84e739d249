"""numba kernels of what happens at a joint stop: the impact's velocity jump, holding and letting go.

This module holds the event itself; :mod:`robodyn.engine.tree.events` finds where in a step it
happens and runs the blocks of steps. The impulse when joints reach their stops (``_impact``: the
Delassus solve of :func:`robodyn.sim.limits.impact`, pulling rows dropped, by the same LAPACK
calls; ``_rests``: a rebound that would land again within one step is held instead), the held set
made consistent (``_settle``: a pulling held stop lets go, a joint pushed onto its stop that would
not leave it within a step is brought to rest by a plastic impulse, ``_rest``), and the two
entries the event search calls: ``_take`` (at the located instant) and ``_touch`` (before a step).
Also the layout of the event state (its constants) and the small kernels that read it. The
arithmetic and order are those of :class:`robodyn.sim.events.EventStepper`.
"""

from __future__ import annotations

import numpy as np

from robodyn.engine import jit
from robodyn.engine.tree.algorithms import crba
from robodyn.engine.tree.layout import W_LAMBDA, W_LOCK
from robodyn.engine.tree.steps import rates

# run_events outcomes (and run_steps': EVENTS, the step from that sample needs run_events)
DONE, NOT_FINITE, CHATTER, EVENTS = 0, 1, 2, 3
# counts: evaluations, impacts, releases, steps with an event, the sample the step under way started from
EVALS, IMPACTS, RELEASES, EVENT_STEPS, AT = 0, 1, 2, 3, 4
NCOUNTS = 5
# par entries: the event stepper's constants, the restitution and the method's stages per step
P_LOCATE_RTOL, P_LOCATE_FTOL, P_NOISE_RTOL, P_RELEASE_TOL, P_PULL_RTOL = 0, 1, 2, 3, 4
P_ITERATIONS, P_MAX_EVENTS, P_RESTITUTION, P_STAGES, P_RCOND = 5, 6, 7, 8, 9
PCOLS = 10
# stops rows: index in q, index in v, lower, upper, tolerance, tree row
S_IQ, S_IV, S_LO, S_HI, S_TOL, S_ROW = 0, 1, 2, 3, 4, 5

njit = jit.njit(error_model="numpy")  # holds the GIL: a torque callable runs in object mode


@njit
def _lock(ws, st, held):  # type: ignore[no-untyped-def]
    for r in range(ws.shape[0]):
        ws[r, W_LOCK] = 0.0
    for i in range(held[0]):
        ws[int(st[S_ROW, held[1 + i]]), W_LOCK] = 1.0


@njit
def _set_held(ws, st, held, side, rows, n):  # type: ignore[no-untyped-def]
    """Hold exactly the stop rows rows[:n] (k, side), in that order (``system.hold``)."""
    for k in range(side.shape[0]):
        side[k] = 0
    held[0] = n
    for i in range(n):
        held[1 + i] = rows[i, 0]
        side[rows[i, 0]] = rows[i, 1]
    _lock(ws, st, held)


@njit
def _eval(md, ws, counts, t, q, u, out):  # type: ignore[no-untyped-def]
    """The rates (into ``out``) at (t, q, u) with the held joints locked; one evaluation counted."""
    itree, ftree, grav, forces, springs, cb, flyer = md[0], md[1], md[2], md[3], md[4], md[7], md[8]
    counts[EVALS] += 1
    return rates(itree, ftree, grav, flyer, t, q, u, forces, springs, cb, ws, np.empty(forces.shape[1]), out)


@njit
def _crossed(q, st, side, rows, n):  # type: ignore[no-untyped-def]
    """Append to rows[n:] the rows past their stop of the joints not held (``Stops.crossed``); the new n."""
    m = st.shape[1]
    for k in range(m):
        if side[k] == 0 and q[int(st[S_IQ, k])] - st[S_LO, k] < -st[S_TOL, k]:
            rows[n, 0], rows[n, 1] = k, 1
            n += 1
    for k in range(m):
        if side[k] == 0 and st[S_HI, k] - q[int(st[S_IQ, k])] < -st[S_TOL, k]:
            rows[n, 0], rows[n, 1] = k, -1
            n += 1
    return n


@njit
def _bound(st, k, s):  # type: ignore[no-untyped-def]
    return st[S_LO, k] if s > 0 else st[S_HI, k]


@njit
def _solve(M, v, st, rows, n, hit, e, plastic, par):  # type: ignore[no-untyped-def]
    """:func:`robodyn.sim.limits.impact` on stop rows rows[:n] (``hit[i]``: a hitting row, else held).

    Returns (v+, the number of rows kept, dT [J]); the kept rows (those that pushed, unless
    ``plastic``) are moved to the front of ``rows`` and ``hit``.
    """
    nv = v.size
    if n == 0:
        return v.copy(), 0, 0.0
    while True:
        JT = np.zeros((nv, n))
        J = np.zeros((n, nv))
        target = np.zeros(n)
        for i in range(n):
            iv = int(st[S_IV, rows[i, 0]])
            J[i, iv] = rows[i, 1]
            JT[iv, i] = rows[i, 1]
            if hit[i]:
                target[i] = -e * (J[i] @ v)
        MiJt = np.linalg.solve(M, JT)
        D = J @ MiJt
        L = np.linalg.lstsq(D, target - J @ v, rcond=par[P_RCOND])[0]
        big = 1.0
        for i in range(n):
            big = max(big, abs(L[i]))
        kept = 0
        for i in range(n):
            if plastic or not L[i] < -par[P_PULL_RTOL] * big:
                rows[kept, 0], rows[kept, 1], hit[kept] = rows[i, 0], rows[i, 1], hit[i]
                kept += 1
        if kept == n:
            break
        n = kept
        if n == 0:
            return v.copy(), 0, 0.0
    vp = v + MiJt @ L
    dT = 0.5 * ((vp @ M) @ vp) - 0.5 * ((v @ M) @ v)
    return vp, n, dT


@njit
def _rests(md, par, st, ws, counts, t, q, vp, k, s, h, e):  # type: ignore[no-untyped-def]
    """True when stop row (k, s) stays at its stop after the impulse: e = 0, or its rebound lands within h."""
    if e == 0.0:
        return True
    iv = int(st[S_IV, k])
    speed = s * vp[iv]
    if speed <= 0.0:
        return True
    nv = vp.size
    u = np.zeros(nv + 2)
    u[:nv] = vp
    a = np.empty(nv + 2)
    _eval(md, ws, counts, t, q, u, a)
    pull = -s * a[iv]
    return pull > 0 and 2.0 * speed / pull < h


@njit
def _impact(md, par, st, held, side, ws, counts, wlim, records, t, q, u, h, hitting, nh):  # type: ignore[no-untyped-def]
    """The impulse of hitting[:nh] with the held rows holding, into u; the held set updated (``_impact``)."""
    itree, ftree, grav, flyer = md[0], md[1], md[2], md[8]
    nv = md[3].shape[1]
    e = par[P_RESTITUTION]
    M = np.zeros((nv, nv))
    crba(itree, ftree, grav, flyer, q, ws, M)
    v = u[:nv].copy()
    nheld = held[0]
    m = st.shape[1]
    rows = np.empty((nh + nheld, 2), dtype=np.int64)
    hit = np.zeros(nh + nheld, dtype=np.bool_)
    for i in range(nh):
        rows[i, 0], rows[i, 1], hit[i] = hitting[i, 0], hitting[i, 1], True
    for i in range(nheld):
        rows[nh + i, 0], rows[nh + i, 1] = held[1 + i], side[held[1 + i]]
    # np.int64 / np.bool_ around a literal (or a count that starts as one): numba's type inference would
    # compile the callee once more for the literal's own type (measured: 7 s of the first compile)
    vp, nc, dT = _solve(M, v, st, rows, nh + nheld, hit, e, np.bool_(False), par)
    # rows in contact after it: the first nc of rows; resting: hitting rows in contact whose rebound lands soon
    resting = np.zeros(m, dtype=np.int64)  # side of a resting row, by stop
    nrest = 0
    for i in range(nh):
        k, s = hitting[i, 0], hitting[i, 1]
        inside = False
        for j in range(nc):
            inside = inside or (rows[j, 0] == k and rows[j, 1] == s)
        if inside and _rests(md, par, st, ws, counts, t, q, vp, k, s, h, e):
            resting[k] = s
            nrest += 1
    if nrest and e > 0:  # rebounds that land within a step: held now
        n2 = 0
        for i in range(nh):
            if resting[hitting[i, 0]] != hitting[i, 1]:
                rows[n2, 0], rows[n2, 1], hit[n2] = hitting[i, 0], hitting[i, 1], True
                n2 += 1
        for i in range(nheld):
            rows[n2, 0], rows[n2, 1], hit[n2] = held[1 + i], side[held[1 + i]], False
            n2 += 1
        for i in range(nh):
            if resting[hitting[i, 0]] == hitting[i, 1]:
                rows[n2, 0], rows[n2, 1], hit[n2] = hitting[i, 0], hitting[i, 1], False
                n2 += 1
        vp, nc, dT = _solve(M, v, st, rows, np.int64(n2), hit, e, np.bool_(False), par)
    # the record (EventStepper._record)
    wlim[0] += dT
    for i in range(nh):
        r = counts[IMPACTS]
        counts[IMPACTS] += 1
        if r < records.shape[0]:
            k, s = hitting[i, 0], hitting[i, 1]
            iv = int(st[S_IV, k])
            records[r, 0], records[r, 1], records[r, 2] = t, k, s
            records[r, 3], records[r, 4], records[r, 5] = v[iv], vp[iv], dT
    # held from now on: the contact rows that were held or rest; a held row not in contact let go
    new = np.empty((nc, 2), dtype=np.int64)
    nn = 0
    for j in range(nc):
        k, s = rows[j, 0], rows[j, 1]
        if (side[k] == s) or resting[k] == s:
            new[nn, 0], new[nn, 1] = k, s
            nn += 1
    for i in range(nheld):
        k = held[1 + i]
        inside = False
        for j in range(nc):
            inside = inside or (rows[j, 0] == k and rows[j, 1] == side[k])
        if not inside:
            counts[RELEASES] += 1
    u[:nv] = vp
    for j in range(nn):
        u[int(st[S_IV, new[j, 0]])] = 0.0
    _set_held(ws, st, held, side, new, np.int64(nn))


@njit
def _rest(md, par, st, held, side, ws, counts, wlim, q, u, k, s):  # type: ignore[no-untyped-def]
    """Bring stop row (k, s) to rest with the held rows: a plastic impulse (booked), into u (``_rest``)."""
    itree, ftree, grav, flyer = md[0], md[1], md[2], md[8]
    nv = md[3].shape[1]
    M = np.zeros((nv, nv))
    crba(itree, ftree, grav, flyer, q, ws, M)
    nheld = held[0]
    rows = np.empty((nheld + 1, 2), dtype=np.int64)
    for i in range(nheld):
        rows[i, 0], rows[i, 1] = held[1 + i], side[held[1 + i]]
    rows[nheld, 0], rows[nheld, 1] = k, s
    keep = rows.copy()
    none_hit = np.zeros(nheld + 1, dtype=np.bool_)  # every row is held or comes to rest: none rebounds
    vp, _, dT = _solve(M, u[:nv].copy(), st, rows, nheld + 1, none_hit, 0.0, np.bool_(True), par)
    wlim[0] += dT
    u[:nv] = vp
    for i in range(nheld + 1):
        u[int(st[S_IV, keep[i, 0]])] = 0.0
    _set_held(ws, st, held, side, keep, nheld + 1)


@njit
def _settle(md, par, st, held, side, ws, counts, wlim, t, q, u, h):  # type: ignore[no-untyped-def]
    """Make the held set consistent at t, one row at a time, u updated in place (``_settle``)."""
    nv = md[3].shape[1]
    m = st.shape[1]
    rel = par[P_RELEASE_TOL]
    a = np.empty(nv + 2)
    for _ in range(2 * m + 2):
        if held[0]:
            _eval(md, ws, counts, t, q, u, a)
            at, least = -1, 0.0
            for i in range(held[0]):
                k = held[1 + i]
                pull = side[k] * ws[int(st[S_ROW, k]), W_LAMBDA]
                if at < 0 or pull < least:
                    at, least = i, pull
            if least < -rel:  # that stop pulls: let it go
                side[held[1 + at]] = 0
                for i in range(at, held[0] - 1):
                    held[1 + i] = held[2 + i]
                held[0] -= 1
                _lock(ws, st, held)
                counts[RELEASES] += 1
                continue
        found = False
        for k in range(m):
            if side[k] == 0:
                for s in (1, -1):
                    if abs(s * (q[int(st[S_IQ, k])] - _bound(st, k, s))) <= st[S_TOL, k]:
                        found = True
        if not found:
            return
        _eval(md, ws, counts, t, q, u, a)
        best_k, best_s, best = -1, 0, 0.0
        for k in range(m):
            if side[k] != 0:
                continue
            for s in (1, -1):
                if abs(s * (q[int(st[S_IQ, k])] - _bound(st, k, s))) <= st[S_TOL, k]:
                    iv = int(st[S_IV, k])
                    push = s * a[iv]  # < 0: pushed into the stop
                    speed = s * u[iv]  # > 0: leaving it
                    if push < -rel and (speed <= 0 or 2.0 * speed < -push * h):
                        if best_k < 0 or push < best:
                            best_k, best_s, best = k, s, push
        if best_k < 0:
            return
        _rest(md, par, st, held, side, ws, counts, wlim, q, u, np.int64(best_k), np.int64(best_s))


@njit
def _take(md, par, st, held, side, ws, counts, wlim, records, t, q, u, h):  # type: ignore[no-untyped-def]
    """At t: the impact of the stops reached (snapped onto them), then the held set settled (``_take``)."""
    m = st.shape[1]
    hitting = np.empty((2 * m + 1, 2), dtype=np.int64)
    nh = _crossed(q, st, side, hitting, 0)
    for k in range(m):  # Stops.touching: at a stop, moving into it
        if side[k] != 0:
            continue
        x = q[int(st[S_IQ, k])]
        for s in (1, -1):
            if abs(x - _bound(st, k, s)) <= st[S_TOL, k] and s * u[int(st[S_IV, k])] < 0:
                new = True
                for i in range(nh):
                    new = new and not (hitting[i, 0] == k and hitting[i, 1] == s)
                if new:
                    hitting[nh, 0], hitting[nh, 1] = k, s
                    nh += 1
    if nh:
        for i in range(nh):
            q[int(st[S_IQ, hitting[i, 0]])] = _bound(st, hitting[i, 0], hitting[i, 1])
        _impact(md, par, st, held, side, ws, counts, wlim, records, t, q, u, h, hitting, nh)
    _settle(md, par, st, held, side, ws, counts, wlim, t, q, u, h)


@njit
def _touch(md, par, st, held, side, ws, counts, wlim, records, t, q, u, h):  # type: ignore[no-untyped-def]
    """Before a step: a free joint on a stop gets taken there (``_touch``); True when it was looked at."""
    for k in range(st.shape[1]):
        if side[k] != 0:
            continue
        x = q[int(st[S_IQ, k])]
        if abs(x - st[S_LO, k]) <= st[S_TOL, k] or abs(x - st[S_HI, k]) <= st[S_TOL, k]:
            _take(md, par, st, held, side, ws, counts, wlim, records, t, q, u, h)
            return True
    return False
