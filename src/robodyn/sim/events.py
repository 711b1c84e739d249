"""Stepping across events: a joint reaching its stop, a held joint letting go, a loop drifting open.

:class:`EventStepper` wraps an integrator's stepper. Each ``advance`` takes the step; if a
joint ended past its stop, or a held stop ended pulling, it finds the first such instant
inside the step by regula falsi (Illinois) on the step length -- every trial a fresh step
of the same integrator from the step's start, so the event is located to round-off, not to
the step -- and there:

* **impact**: the joints that reach their stop get the exact restitution impulse
  (:func:`robodyn.sim.limits.impact`); the kinetic energy it removes is booked as
  ``work_limits``. A joint whose rebound would land again within one step (or any joint at
  e = 0) is held at its stop from then on;
* **release**: a held joint whose stop force crosses zero is let go. The force is a
  difference of terms of size sum_i |M_ji a_i|, so its zero is located only to that size's
  round-off (``FORCE_NOISE_RTOL``): a release is taken where the stop pulls by less than it.

Then the rest of the step is taken with the new set of held joints (the integrator restarts
there, so an adaptive method never reuses rates from before a velocity jump). After the step
a loop whose residual exceeds ``PROJECT_ABOVE`` is projected back (:mod:`robodyn.sim.loops`).
On a robot without stops in range and without loops, ``advance`` is the integrator's own: the
arithmetic of an unconstrained run is untouched.

The stages of ``advance``, in order: **step** (the integrator's own), **classify** how the step
ended (clear of every stop, or which event functions went negative: :meth:`EventStepper._events`),
**locate** the first event (:meth:`EventStepper._locate`), **take** it (the impact, then the held
set made consistent: :meth:`EventStepper._take`), and step on from there. The set of held stops
(limited joint k -> side) flows through these stages as an argument and a returned value; each
stage that changes it tells the system (``system.hold``), whose constraint solve reads it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import StepError
from robodyn.integrators import Integrator, Stepper
from robodyn.sim import limits
from robodyn.sim.loops import PROJECT_ABOVE, PROJECTION_TOL
from robodyn.sim.system import RobotSystem

Array = NDArray[np.float64]

# The event is located when the bracket on the step length is this narrow relative to the
# step (~5 ulps of a step): the joint then sits within |v| x 1e-15 h of its stop.
LOCATE_RTOL = 1e-15
# An adaptive method refuses steps below ~1e-12 x max(|t|, interval) (no progress): for
# those the bracket stops, and a step's rest is dropped, below this x max(|t|, h).
ADAPTIVE_FLOOR = 1e-11
LOCATE_ITERATIONS = 100
# ...or when the event function is past zero by less than this fraction of its value at the
# step's end (a gap of ~1e-13 of the step's travel).
LOCATE_FTOL = 1e-13

# More events than this within one step is chattering (a bouncing joint whose rebounds
# shrink faster than the step): the run stops with a StepError rather than spin.
MAX_EVENTS_PER_STEP = 64

# A held stop lets go when its force pulls by more than this [N m | N].
RELEASE_TOL = 1e-12
# A stop force lambda_j = (M a - (tau - C v - G))_j is a difference of terms of size
# sum_i |M_ji a_i|; it is known to no better than this fraction of that size (~5e3 ulps, for
# the sums of a 40-dof ABA/RNEA). A release is located once lambda is past zero by less than
# that: the joint then lets go where its stop pulls by less than round-off (no work: a held
# joint does not move), and the locator does not chase zero below the noise of lambda.
FORCE_NOISE_RTOL = 1e-12

# Impacts kept in the metadata (the count is always exact).
IMPACTS_KEPT = 200

# What the events have done at a point of the run (EventStepper.mark): impacts, releases, impacts kept,
# projections, work_limits [J] and the held stops.
Mark = tuple[int, int, int, int, float, dict[int, int]]


@dataclass(frozen=True)
class ImpactRecord:
    """One impact: time [s], joint, side ('lower' | 'upper'), joint speed before and after, dT [J]."""

    time: float
    joint: str
    side: str
    speed_before: float
    speed_after: float
    energy_change: float


class EventStepper(Stepper):
    """An integrator's stepper that also takes the stop events and the loop projection of a run."""

    def __init__(
        self,
        method: Integrator,
        system: RobotSystem,
        t0: float,
        q0: Array,
        u0: Array,
        *,
        t_end: float,
        rtol: float,
        atol: float,
    ) -> None:
        self.method, self.problem, self.t_end, self.rtol, self.atol = method, system, t_end, rtol, atol
        self.system = system
        self.inner = method.start(system, t0, q0, u0, t_end=t_end, rtol=rtol, atol=atol)
        self.stops = system.stops
        tol = self.stops.tolerance()
        self._lower_in, self._upper_in = self.stops.lower + tol, self.stops.upper - tol
        self.work_limits = 0.0
        self.impacts: list[ImpactRecord] = []
        self.n_impacts = 0
        self.n_releases = 0
        self.projections = 0
        self._steps = 0
        self._rejected = 0
        # Fixed at construction: with no stop in range and no loop there is no event to watch.
        self._watching = not (self.stops.empty and system.loops is None)
        self._loops = system.loops
        # The bounds as Python floats: comparing a handful of scalars beats two NumPy reductions.
        self._lower_list, self._upper_list = self._lower_in.tolist(), self._upper_in.tolist()
        iq = self.stops.iq
        self._iq: NDArray[np.intp] | None = None if np.array_equal(iq, np.arange(system.nq)) else iq
        # The last configuration found clear of every stop (q arrays are never written in place).
        self._clear_q: Array | None = None
        self._mark: Mark | None = None  # the last mark, until an event changes it (see :meth:`mark`)

    def mark(self) -> Mark:
        """What the events have done so far: counts, impacts kept, the held stops (for :meth:`rewind`).

        Asked after every step: the last mark is kept until an event step or a projection (which
        drop it) or a new held set (``system.hold`` replaces the dict, never edits it).
        """
        mark = self._mark
        if mark is None or mark[5] is not self.system.held:
            held = self.system.held
            mark = self.n_impacts, self.n_releases, len(self.impacts), self.projections, self.work_limits, held
            self._mark = mark
        return mark

    def rewind(self, mark: Mark, q: Array) -> None:
        """Forget the events after ``mark`` (steps taken past a failure); q is the configuration kept last."""
        self.n_impacts, self.n_releases, kept, self.projections, self.work_limits, held = mark
        self._mark = None
        del self.impacts[kept:]
        if held != self.system.held:
            self.system.hold(held, q)

    @property
    def steps(self) -> int | None:
        """Accepted steps of an adaptive method, over every restart."""
        inner = getattr(self.inner, "steps", None)
        return None if inner is None else self._steps + inner

    @property
    def rejected(self) -> int | None:
        """Rejected steps of an adaptive method, over every restart."""
        inner = getattr(self.inner, "rejected", None)
        return None if inner is None else self._rejected + inner

    def restart(self, t: float, q: Array, u: Array) -> None:
        """Start the method afresh at (t, q, u): after steps taken elsewhere (the compiled loop), no rates kept."""
        self._restart(t, q, u)

    def _restart(self, t: float, q: Array, u: Array) -> None:
        self._steps += getattr(self.inner, "steps", 0) or 0
        self._rejected += getattr(self.inner, "rejected", 0) or 0
        self.inner = self.method.start(self.system, t, q, u, t_end=self.t_end, rtol=self.rtol, atol=self.atol)

    def _trial(self, t: float, q: Array, u: Array, s: float) -> tuple[Array, Array]:
        """A fresh step of length s from (t, q, u): the state the run would have at t + s."""
        stepper = self.method.start(self.system, t, q, u, t_end=t + s, rtol=self.rtol, atol=self.atol)
        q1, u1, _ = stepper.advance(t, q, u, s)
        return q1, u1

    def _floor(self, t: float, h: float) -> float:
        """The shortest time the event location resolves [s]: round-off, or what an adaptive method accepts."""
        if self.method.adaptive:
            return max(LOCATE_RTOL * h, ADAPTIVE_FLOOR * max(abs(t), h))
        return LOCATE_RTOL * h

    # ------------------------------------------------------------------ the step
    def _clear(self, q: Array) -> bool:
        """True when every limited joint is clear of its stops at q (farther than the tolerance; NaN is not)."""
        x = (q if self._iq is None else q[self._iq]).tolist()
        return all(map(float.__lt__, self._lower_list, x)) and all(map(float.__lt__, x, self._upper_list))

    def advance(self, t: float, q: Array, u: Array, h: float) -> tuple[Array, Array, Array | None]:
        """Move (q, u) from t to t + h [s], taking every event inside the step."""
        if not self._watching:  # nothing to watch: the integrator's own step
            return self.inner.advance(t, q, u, h)
        if self.system.held or not (q is self._clear_q or self._clear(q)):
            return self._events_in_step(t, q, u, h, None)
        q1, u1, k = self.inner.advance(t, q, u, h)  # the common case: free at the step's start...
        x = (q1 if self._iq is None else q1[self._iq]).tolist()  # :meth:`_clear`, inline on the hot path
        if not (all(map(float.__lt__, self._lower_list, x)) and all(map(float.__lt__, x, self._upper_list))):
            return self._events_in_step(t, q, u, h, (q1, u1, k))
        self._clear_q = q1  # ...and at its end
        if self._loops is None:
            return q1, u1, k
        return (*self._close_loops(t + h, q1, u1, {}), k)

    def _events_in_step(
        self, t: float, q: Array, u: Array, h: float, first: tuple[Array, Array, Array | None] | None
    ) -> tuple[Array, Array, Array | None]:
        """The step from t to t + h with its events; ``first`` is the step already taken from (t, q, u)."""
        t_stop = t + h
        k_start: Array | None = None
        self._mark = None  # the events below change what the run has done
        held = self.system.held
        if first is None:
            q, u, held = self._touch(t, q, u, h, held)
        remaining = h  # the step as asked (t + h - t is not always h in floating point)
        for _ in range(MAX_EVENTS_PER_STEP):
            if first is not None:
                (q1, u1, k), first = first, None
            else:
                q1, u1, k = self.inner.advance(t, q, u, remaining)
            if k_start is None:
                k_start = k
            watch = self._events(t + remaining, q1, u1, held)  # classify how the step ended
            if not watch:
                return (*self._close_loops(t_stop, q1, u1, held), k_start)
            s, q, u = self._locate(t, q, u, remaining, q1, u1, watch, held)
            t = t_stop if remaining - s <= self._floor(t_stop, h) else t + s
            q, u, held = self._take(t, q, u, h, held)  # take the event
            self._restart(t, q, u)
            if t >= t_stop:
                return (*self._close_loops(t_stop, q, u, held), k_start)
            remaining = t_stop - t
        joints = ", ".join(sorted({self.stops.names[k] for k in held} | {r.joint for r in self.impacts[-3:]}))
        raise StepError(
            f"more than {MAX_EVENTS_PER_STEP} stop events within one step at t = {t:.6g} s ({joints})",
            time=t,
            reason=f"more than {MAX_EVENTS_PER_STEP} stop events within one step at joint(s) {joints} (chattering)",
        )

    def _events(self, t: float, q: Array, u: Array, held: dict[int, int]) -> dict[tuple[int, int], float]:
        """The event functions that are negative at (t, q, u): stops crossed, held stops pulling."""
        rows = self.stops.crossed(q, held) + [(k, side) for k, side in held.items()]
        values = self._values(t, q, u, rows, held)
        return {row: value for row, value in zip(rows, values, strict=True) if value < 0}

    def _values(self, t: float, q: Array, u: Array, rows: list[tuple[int, int]], held: dict[int, int]) -> list[float]:
        """The event functions of ``rows`` at (t, q, u); each crosses 0 exactly where its event happens.

        A free row: gap + tolerance (negative once the joint is past its stop); a held row:
        its stop force + RELEASE_TOL (negative once the stop pulls).
        """
        f = self.system.stop_forces(t, q, u) if any(k in held for k, _ in rows) else None
        tol = self.stops.tolerance()
        out = []
        for k, side in rows:
            if k in held and f is not None:
                out.append(side * float(f[self.stops.iv[k]]) + RELEASE_TOL)
            else:
                out.append(self.stops.gap(q, (k, side)) + float(tol[k]))
        return out

    def _locate(
        self,
        t: float,
        q: Array,
        u: Array,
        h: float,
        q1: Array,
        u1: Array,
        watch: dict[tuple[int, int], float],
        held: dict[int, int],
    ) -> tuple[float, Array, Array]:
        """The first instant s in [0, h] where a watched function reaches 0; the state there (just past it).

        Regula falsi (Illinois) on F(s) = min over the watched rows of f(s) / |f(h)|.
        """
        rows = list(watch)
        scale = np.array([abs(watch[r]) for r in rows])
        scale[scale == 0] = 1.0
        f_start = float(np.min(np.array(self._values(t, q, u, rows, held)) / scale))
        if f_start <= 0:  # already there at the start: take it now
            return 0.0, q, u
        # Past zero by less than this (per row, in units of its scale) is past it: a relative
        # 1e-13 of the value at the step's end, or, for a held row, the round-off of its force.
        close = np.maximum(LOCATE_FTOL, self._force_noise(t, q, u, rows, held) / scale)

        def F(s: float) -> tuple[float, bool, Array, Array]:
            qs, us = self._trial(t, q, u, s)
            f = np.array(self._values(t + s, qs, us, rows, held)) / scale
            i = int(np.argmin(f))
            return float(f[i]), bool(-close[i] <= f[i] < 0), qs, us

        lo, f_lo = 0.0, f_start
        hi, f_hi, q_hi, u_hi = h, -1.0, q1, u1
        side = 0
        for _ in range(LOCATE_ITERATIONS):
            if hi - lo <= self._floor(t + hi, h):
                break
            s = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
            if not lo < s < hi:
                s = 0.5 * (lo + hi)
            f_s, past, qs, us = F(s)
            if past:  # just past the event, by less than its function is known: close enough
                return s, qs, us
            if f_s < 0:
                hi, f_hi, q_hi, u_hi = s, f_s, qs, us
                f_lo = f_lo * 0.5 if side == -1 else f_lo
                side = -1
            else:
                lo, f_lo = s, f_s
                f_hi = f_hi * 0.5 if side == 1 else f_hi
                side = 1
        return hi, q_hi, u_hi

    def _force_noise(self, t: float, q: Array, u: Array, rows: list[tuple[int, int]], held: dict[int, int]) -> Array:
        """Per row, how well its event function is known [N m | N for a held row, 0 for a gap row].

        A held row's stop force is sum_i M_ji a_i - force_j with a the held acceleration:
        FORCE_NOISE_RTOL x sum_i |M_ji a_i| at the step's start.
        """
        if not any(k in held for k, _ in rows):
            return np.zeros(len(rows))
        nv = self.system.nv
        M = self.system.mass_matrix_free(q)
        a = self.system.rates(t, q, u)[:nv]
        size = np.abs(M) @ np.abs(a)
        return np.array([FORCE_NOISE_RTOL * float(size[self.stops.iv[k]]) if k in held else 0.0 for k, _ in rows])

    def _take(
        self, t: float, q: Array, u: Array, h: float, held: dict[int, int]
    ) -> tuple[Array, Array, dict[int, int]]:
        """At time t: the impact of the stops reached, then the held set made consistent (:meth:`_settle`)."""
        stops = self.stops
        hitting = stops.crossed(q, held)
        hitting += [r for r in stops.touching(q, u[: self.system.nv], held) if r not in hitting]
        if hitting:
            q = stops.snap(q, hitting)
            u, held = self._impact(t, q, u, h, hitting, stops.restitution, held)
        u, held = self._settle(t, q, u, h, held)
        return q, u, held

    def _touch(
        self, t: float, q: Array, u: Array, h: float, held: dict[int, int]
    ) -> tuple[Array, Array, dict[int, int]]:
        """Before a step: a joint that sits on a stop moving into it (the initial state, say) hits it now."""
        if self.stops.empty:
            return q, u, held
        x = q[self.stops.iq]
        tol = self.stops.tolerance()
        at_stop = (np.abs(x - self.stops.lower) <= tol) | (np.abs(x - self.stops.upper) <= tol)
        if not any(at_stop[k] for k in range(x.size) if k not in held):
            return q, u, held
        q1, u1, held = self._take(t, q, u, h, held)
        if q1 is not q or u1 is not u:
            self._restart(t, q1, u1)
        return q1, u1, held

    def _settle(self, t: float, q: Array, u: Array, h: float, held: dict[int, int]) -> tuple[Array, dict[int, int]]:
        """Make the held set consistent at t, one row at a time; return (u, the held set).

        Let go a held stop that pulls; hold a joint that sits on its stop, is pushed into it
        and would not leave it for a whole step (the small speed it has is taken by a
        plastic impulse, booked).
        """
        system, stops = self.system, self.stops
        nv = system.nv
        tol = stops.tolerance()
        for _ in range(2 * stops.iq.size + 2):
            if held:
                f = system.stop_forces(t, q, u)
                pull = {k: side * float(f[stops.iv[k]]) for k, side in held.items()}
                k = min(pull, key=lambda j: pull[j])
                if pull[k] < -RELEASE_TOL:
                    held = {j: s for j, s in held.items() if j != k}
                    system.hold(held, q)
                    self.n_releases += 1
                    continue
            rows = [
                (k, side)
                for k in range(stops.iq.size)
                if k not in held
                for side in (1, -1)
                if abs(stops.gap(q, (k, side))) <= tol[k]
            ]
            if not rows:
                return u, held
            a = system.rates(t, q, u)[:nv]
            resting = {}
            for k, side in rows:
                push = side * float(a[stops.iv[k]])  # < 0: pushed into the stop
                speed = side * float(u[stops.iv[k]])  # > 0: leaving it
                if push < -RELEASE_TOL and (speed <= 0 or 2.0 * speed < -push * h):  # back within a step
                    resting[(k, side)] = push
            if not resting:
                return u, held
            row = min(resting, key=lambda r: resting[r])
            u, held = self._rest(t, q, u, row, held)
        return u, held

    def _rest(
        self, t: float, q: Array, u: Array, row: tuple[int, int], held: dict[int, int]
    ) -> tuple[Array, dict[int, int]]:
        """Bring ``row`` to rest at its stop with the held rows: a plastic impulse (booked); returns (u, held)."""
        system, stops = self.system, self.stops
        nv = system.nv
        M = system.mass_matrix_free(q)
        J_loops = system.loops.jacobian(q) if system.loops is not None else None
        held_rows = list(held.items())
        result = limits.impact(M, u[:nv], stops, [], [*held_rows, row], J_loops, plastic=True)
        self.work_limits += result.energy_change
        held = dict([*held_rows, row])
        u = u.copy()
        u[:nv] = result.v
        u[stops.iv[list(held)]] = 0.0
        system.hold(held, q)
        return u, held

    def _impact(
        self,
        t: float,
        q: Array,
        u: Array,
        h: float,
        hitting: list[tuple[int, int]],
        restitution: float,
        held: dict[int, int],
    ) -> tuple[Array, dict[int, int]]:
        """The impulse of ``hitting`` (restitution e) with the held rows (and loops) holding; returns (u, held).

        A row whose rebound would land again within the step h is held instead (e = 0 for it).
        """
        system, stops = self.system, self.stops
        nv = system.nv
        M = system.mass_matrix_free(q)
        J_loops = system.loops.jacobian(q) if system.loops is not None else None
        held_rows = list(held.items())
        v = u[:nv]
        result = limits.impact(M, v, stops, hitting, held_rows, J_loops, restitution=restitution)
        resting = [r for r in hitting if r in result.contact and self._rests(t, q, result.v, r, h, restitution)]
        if resting and restitution > 0:  # rebounds that land within a step: held now
            bouncing = [r for r in hitting if r not in resting]
            result = limits.impact(M, v, stops, bouncing, held_rows + resting, J_loops, restitution=restitution)
        self._record(t, v, result, hitting)
        held = {k: side for k, side in result.contact if (k, side) in held_rows or (k, side) in resting}
        self.n_releases += sum(1 for row in held_rows if row not in result.contact)
        u = u.copy()
        u[:nv] = result.v
        u[stops.iv[list(held)]] = 0.0
        system.hold(held, q)
        return u, held

    def _rests(self, t: float, q: Array, v: Array, row: tuple[int, int], h: float, restitution: float) -> bool:
        """True when ``row`` stays at its stop: e = 0, or its rebound would land again within one step h."""
        if restitution == 0.0:
            return True
        k, side = row
        speed = side * float(v[self.stops.iv[k]])
        if speed <= 0.0:
            return True
        u = np.concatenate([v, np.zeros(self.system.nw)])
        a = self.system.rates(t, q, u)[: self.system.nv]
        pull = -side * float(a[self.stops.iv[k]])
        return pull > 0 and 2.0 * speed / pull < h

    def _record(self, t: float, v: Array, result: limits.Impact, hitting: list[tuple[int, int]]) -> None:
        self.work_limits += result.energy_change
        for k, side in hitting:
            self.n_impacts += 1
            if len(self.impacts) < IMPACTS_KEPT:
                i = self.stops.iv[k]
                self.impacts.append(
                    ImpactRecord(
                        float(t),
                        self.stops.names[k],
                        "lower" if side > 0 else "upper",
                        float(v[i]),
                        float(result.v[i]),
                        result.energy_change,
                    )
                )

    def _close_loops(self, t: float, q: Array, u: Array, held: dict[int, int]) -> tuple[Array, Array]:
        """Project (q, v) back onto the loops when the step left a residual above ``PROJECT_ABOVE``.

        The joints of ``held`` stay still.
        """
        loops = self.system.loops
        if loops is None:
            return q, u
        if float(np.max(np.abs(loops.residual(q)), initial=0.0)) <= PROJECT_ABOVE:
            return q, u
        nv = self.system.nv
        free = np.setdiff1d(np.arange(nv), self.stops.iv[list(held)]).astype(np.intp)
        q, v, left = loops.project(q, u[:nv], free)
        if not left <= 1e3 * PROJECTION_TOL:
            raise StepError(
                f"the loops cannot be closed after the step to t = {t:.6g} s (residual {left:.3g} m)",
                time=t,
                reason=f"the loop projection did not converge (residual {left:.3g} m)",
            )
        self.projections += 1
        self._mark = None
        u = u.copy()
        u[:nv] = v
        return q, u
