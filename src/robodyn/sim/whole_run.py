"""A whole run in one compiled loop: the stages of a step, the ledger and the energies, no Python per step.

:func:`prepare` checks that the compiled loop can take a run, and :func:`attempt` takes a
:class:`~robodyn.sim.run.Run` that :func:`robodyn.simulate` has set up
and, when the compiled loop can take it, fills its records (q, v, the works, a, T, V) with
:func:`robodyn.engine.tree.events.run_events`: the same pipeline as
:class:`~robodyn.sim.system.RobotSystem` (springs, losses -D v - F tanh(v / v_friction), the
constant torque clamped at the efforts, ABA), the works W_input and W_damping integrated in the
same stages as v, stepped by the same method (classic RK4, any explicit Runge--Kutta tableau,
explicit Euler, semi-implicit Euler) with the same step sizes.

It takes a run when the robot is a tree the compiled algorithms serve (checked against
Pinocchio first, :func:`robodyn.sim.tree.compiled_of`), without loops or couplings, with no
torque, a constant one or a torque callable, under one of those methods.

The steps clear of every stop are taken by :func:`robodyn.engine.tree.events.run_steps`, a small
kernel; a run that meets no stop never compiles the events (about four fifths of the compile).
Joint stops are taken inside the compiled loop (:func:`robodyn.engine.tree.events.run_events`)
with the arithmetic of the event stepper of :mod:`robodyn.sim.events` (the Python pipeline's,
which stays the reference): crossings located to round-off by the same regula falsi on trial
steps, the same restitution impulse and holds, releases where a held stop pulls, the work of
the stops booked; the held joints are locked in the compiled ABA (qdd = 0, their stop force
computed in the same pass). The impacts, releases and held set are handed to the run's event
stepper at the end, where the run's metadata reads them.

What it does not handle (a state that is not finite, an energy error above the run's bound, a
step with more stop events than the event stepper allows) it hands back to the Python pipeline,
which takes the run from its start and writes the canonical report. Ctrl-C is honoured between blocks.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass
from types import ModuleType

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import AssumptionError, RobodynError
from robodyn.integrators import Integrator
from robodyn.integrators.explicit import ClassicRK4, ExplicitEuler, ExplicitRungeKutta
from robodyn.integrators.symplectic import SemiImplicitEuler
from robodyn.sim import tree
from robodyn.sim.events import (
    FORCE_NOISE_RTOL,
    IMPACTS_KEPT,
    LOCATE_FTOL,
    LOCATE_ITERATIONS,
    LOCATE_RTOL,
    MAX_EVENTS_PER_STEP,
    RELEASE_TOL,
    ImpactRecord,
)
from robodyn.sim.limits import IMPACT_RCOND, PULL_RTOL
from robodyn.sim.run import Run, step_sizes
from robodyn.sim.system import V_FRICTION, RobotSystem

Array = NDArray[np.float64]

_KEYS = itertools.count()
_EK_PCOLS = 10  # entries of the event kernels' constants (events.PCOLS, without loading numba here)
BLOCK = 4096  # steps per call of the compiled loop: between calls Ctrl-C is seen (Talos: ~0.15 s a block)

_RK, _RK4, _SIE = 0, 1, 2  # method codes of the kernels (RK, RK4, SEMI_IMPLICIT_EULER)
# The methods whose step the kernels mirror, with the class that defines that step.
_OWN = {
    ClassicRK4: "ClassicRK4",
    SemiImplicitEuler: "SemiImplicitEuler",
    ExplicitEuler: "ExplicitEuler",
    ExplicitRungeKutta: "ExplicitRungeKutta",
}


@dataclass(frozen=True)
class Outcome:
    """What :func:`attempt` did: ``ran`` the whole run compiled, or handed it back, and why (``note``)."""

    ran: bool
    note: str
    steps: int = 0  # steps the compiled loop took
    wall_time_s: float = 0.0  # its wall time, even when the run was handed back
    event_steps: int = 0  # steps with a stop event (an impact, a hold, a release) when ``ran``
    passes: str = ""  # the axes of the compiled ABA's passes 2 and 3 when ``ran`` (CompiledDynamics.passes)


def method_code(method: Integrator) -> tuple[int, Array] | None:
    """(kernel method code, tableau (s + 2, s): rows a, then b, then c) of the methods the loop takes, else None."""
    kind = type(method)
    step = getattr(kind, "step", None)
    # a step replaced on the class (an instrumented or patched method) is not the arithmetic mirrored here
    if kind not in _OWN or getattr(step, "__qualname__", "") != f"{_OWN[kind]}.step":
        return None
    if kind is ClassicRK4:
        return _RK4, np.zeros((6, 4))
    if kind is SemiImplicitEuler:
        return _SIE, np.zeros((3, 1))
    if kind is ExplicitEuler:
        return _RK, np.array([[0.0], [1.0], [0.0]])
    tab = method.tableau  # type: ignore[attr-defined]
    rows = [
        np.asarray(tab.a, dtype=np.float64),
        np.asarray(tab.b, dtype=np.float64),
        np.asarray(tab.c, dtype=np.float64),
    ]
    return _RK, np.ascontiguousarray(np.vstack(rows))


def stages(method: Integrator) -> tuple[int, bool]:
    """(evaluations a step of a compiled ``method`` takes, whether the kernels take it by its tableau)."""
    code, tab = method_code(method) or (-1, np.zeros((1, 0)))
    return tab.shape[1], code == _RK


def refusal(system: RobotSystem, method: Integrator) -> str | None:
    """Why the compiled loop cannot take this run (one phrase), or None when it can."""
    if system.loops is not None:
        return "loop closures are solved by Pinocchio"
    if system.couplings is not None:
        return "couplings are mimic joints"
    if method_code(method) is None:
        return f"{method.name} is not a fixed-step explicit method"
    return tree.unsupported(system.robot)


def _inputs(system: RobotSystem) -> tuple[Array, Array]:
    """(forces (4, nv), springs (4, m)) in the kernels' layout."""
    nv = system.nv
    forces = np.zeros((4, nv))
    forces[0] = system.torque.constant
    forces[1] = system.damping
    forces[2] = system.friction
    forces[3, 0] = V_FRICTION
    sp = system.springs
    springs = np.vstack([sp.iq.astype(np.float64), sp.iv.astype(np.float64), sp.stiffness, sp.rest])
    return forces, np.ascontiguousarray(springs.reshape(4, -1))


@dataclass(frozen=True, eq=False)
class Plan:
    """A run the compiled loop can take: the checked compiled tree and the method's code and tableau."""

    compiled: tree.CompiledDynamics
    method: int
    tableau: Array


def prepare(system: RobotSystem, method: Integrator) -> Plan | str:
    """The :class:`Plan` of this run, or why the compiled loop cannot take it (one phrase).

    Loads (or compiles, the first time on a machine) the kernels, those of the stop events
    too, and checks the compiled algorithms against Pinocchio, so that a timed run pays for
    neither.
    """
    reason = refusal(system, method)
    if reason is not None:
        return reason
    code = method_code(method)
    if code is None:  # pragma: no cover - refusal() checked it
        return f"{method.name} is not a fixed-step explicit method"
    try:
        compiled = tree.compiled_of(system.robot)
        tree.step_kernels(compiled.tree.flyer is not None, code[0] == _RK)
    except RobodynError as exc:
        return str(exc)
    return Plan(compiled, code[0], code[1])


def _tab(plan: Plan) -> Array | None:
    """The kernels' ``tab``: the plan's tableau for a general method, None for RK4 and semi-implicit Euler.

    With None numba compiles no general-tableau code (:func:`robodyn.engine.tree.steps.stages`).
    """
    return plan.tableau if plan.method == _RK else None


def _event_arrays(system: RobotSystem, tr: tree.TreeModel) -> tuple[Array, Array]:
    """(stops (6, m), par) in :mod:`robodyn.engine.tree.events`' layout: the limited joints, the stepper's constants."""
    st = system.stops
    rows = np.empty(system.nv, dtype=np.intp)  # the tree row of each index in v
    rows[tr.itree[:, 3]] = np.arange(tr.itree.shape[0])
    stops = np.vstack(
        [st.iq.astype(np.float64), st.iv.astype(np.float64), st.lower, st.upper, st.tolerance(), rows[st.iv]]
    ).reshape(6, -1)
    par = np.zeros(_EK_PCOLS)
    par[:_EK_PCOLS] = [
        LOCATE_RTOL,
        LOCATE_FTOL,
        FORCE_NOISE_RTOL,
        RELEASE_TOL,
        PULL_RTOL,
        LOCATE_ITERATIONS,
        MAX_EVENTS_PER_STEP,
        st.restitution,
        0.0,  # the method's stages per step: set by _setup
        IMPACT_RCOND,
    ]
    return np.ascontiguousarray(stops), par


@dataclass(eq=False)
class Work:
    """A compiled run under way: the kernels' inputs, its records, the event state, how far it got."""

    run: Run
    system: RobotSystem
    compiled: tree.CompiledDynamics
    kernels: ModuleType
    events: ModuleType
    tree: tree.TreeModel
    md: tuple[object, ...]  # (itree, ftree, grav, forces, springs, method, tab, cb, flyer) of the kernels
    forces: Array  # (4, nv) and (4, m) in the kernels' layout (_inputs)
    springs: Array
    par: Array
    stops: Array
    U: Array  # (n, nv + 2): v and the works W_input, W_damping
    A: Array
    kin: Array
    pot: Array
    held: NDArray[np.int64]  # [count, the held stops in the order they were held]
    side: NDArray[np.int64]  # per stop: 0 free, +1 held at its lower stop, -1 at its upper
    counts: NDArray[np.int64]  # evaluations, impacts, releases, steps with an event
    wlim: Array  # the stops' work so far [J]
    records: Array  # (IMPACTS_KEPT, 6): the first impacts [time, stop, side, speed before, after, dT]
    hs: Array  # the step sizes [s]
    cb: int
    start: float
    done: int = 0  # the last sample taken


@dataclass(frozen=True)
class Ending:
    """How a block ended: the last sample kept, and why the run must be handed back (None: go on)."""

    kept: int
    why: str | None = None


def _setup(plan: Plan, system: RobotSystem, run: Run) -> Work:
    """Stage 1: the kernels' inputs and records of ``run``; the torque callable registered."""
    tr, n, nv, nw = plan.compiled.tree, run.t.size, system.nv, system.nw
    kernels, events = tree.kernels(tr.flyer is not None), tree.step_kernels(tr.flyer is not None, plan.method == _RK)
    forces, springs = _inputs(system)
    stops, par = _event_arrays(system, tr)
    par[events.P_STAGES] = plan.tableau.shape[1]  # RK4's (6, 4), semi-implicit Euler's (3, 1): no tableau
    cb = -1
    if system.torque.kind == "callable":  # called in object mode, stage by stage, as RobotSystem.input_torque
        cb = next(_KEYS)
        kernels.CALLBACKS[cb] = system.input_torque
    m = system.stops.iq.size
    held = np.zeros(m + 1, dtype=np.int64)
    side = np.zeros(m, dtype=np.int64)
    held[0] = len(system.held)
    for i, (k, s) in enumerate(system.held.items()):
        held[1 + i], side[k] = k, s
    U = np.zeros((n, nv + 2))
    U[0, : nv + nw] = run.U[0]
    return Work(
        run=run,
        system=system,
        compiled=plan.compiled,
        kernels=kernels,
        events=events,
        tree=tr,
        md=(tr.itree, tr.ftree, tr.grav, forces, springs, plan.method, _tab(plan), cb, tr.flyer),
        forces=forces,
        springs=springs,
        par=par,
        stops=stops,
        U=U,
        A=np.full((n, nv), np.nan),
        kin=np.full(n, np.nan),
        pot=np.full(n, np.nan),
        held=held,
        side=side,
        counts=np.zeros(events.NCOUNTS, dtype=np.int64),
        wlim=np.array([run.stepper.work_limits]),
        records=np.zeros((IMPACTS_KEPT, 6)),
        hs=np.array(step_sizes(run.t)),
        cb=cb,
        start=time.perf_counter(),
    )


def _block(w: Work) -> tuple[int, int]:
    """Stage 2: one block of steps from sample ``w.done``, events and all, in the compiled loop: (outcome, sample).

    The steps clear of the stops are taken by ``run_steps`` up to the first that meets one (when
    no stop is held and no torque callable runs); from there ``run_events``, compiled then (its
    compile kept out of the run's wall time), takes the rest of the block.
    """
    run, ev = w.run, w.events
    hi = min(w.done + BLOCK, run.t.size - 1)
    hs, ts = w.hs[w.done : hi], run.t[w.done : hi + 1]
    records = (
        run.Q[w.done : hi + 1], w.U[w.done : hi + 1], w.A[w.done : hi + 1], w.kin[w.done : hi + 1],
        w.pot[w.done : hi + 1], run.work_limits[w.done : hi + 1],
    )  # fmt: skip
    lo = 0
    if w.cb < 0 and w.held[0] == 0:
        status, lo = ev.run_steps(w.md, w.par, w.stops, w.counts, w.wlim, ts, hs, 0, hi - w.done, *records)
        if status != ev.EVENTS:
            return status, lo  # type: ignore[no-any-return]
    compile_start = time.perf_counter()
    w.compiled.ensure_checked("crba")  # the stop events' compiled CRBA, checked against Pinocchio at first use
    # loaded, or compiled with its notice, the first time a run meets a stop
    tree.event_kernels(w.tree.flyer is not None, w.md[5] == _RK)
    w.start += time.perf_counter() - compile_start
    return ev.run_events(  # type: ignore[no-any-return]
        w.md, w.par, w.stops, w.held, w.side, w.counts, w.wlim, w.records, ts, hs, lo, hi - w.done, *records
    )


def _classify(w: Work, status: int, last: int) -> Ending:
    """Stage 3: how the block from ``w.done`` ended (``last`` relative to it); a Ctrl-C in the torque raises.

    A state that is not finite, chattering or an energy above the run's bound hands the run back.
    """
    ev, run, lo = w.events, w.run, w.done
    last += lo
    if status != ev.DONE and w.cb in w.kernels.INTERRUPTED:  # Ctrl-C inside the torque callable
        w.done = max(last - 1, lo)  # the step from there was begun, not finished
        raise KeyboardInterrupt
    kept = last
    over = _first_over_bound(run, w.kin, w.pot, w.U, lo, kept)
    if over is not None:
        return Ending(kept, over)
    t = run.t
    if status == ev.NOT_FINITE:
        return Ending(kept, f"a state that is not finite at step {kept} (t = {float(t[kept]):.6g} s)")
    if status == ev.CHATTER:
        return Ending(kept, f"{_chattering(w)} at step {kept + 1} (t = {float(t[kept + 1]):.6g} s)")
    return Ending(kept)


def _failed_solve(w: Work, exc: Exception) -> str:
    """Why a block that raised from LAPACK hands back: an energy over the bound before it, or the failed solve."""
    at = int(w.counts[w.events.AT])  # the step from this sample raised; the samples before it have energies
    over = _first_over_bound(w.run, w.kin, w.pot, w.U, w.done, at)
    if over is not None:
        return over
    return f"the impact solve failed ({exc}) at step {at + 1} (t = {float(w.run.t[at + 1]):.6g} s)"


def _chattering(w: Work) -> str:
    """The event stepper's reason for a step with too many events: the joints held and last struck."""
    names = w.system.stops.names
    struck = min(int(w.counts[w.events.IMPACTS]), IMPACTS_KEPT)
    joints = {names[int(k)] for k in w.held[1 : 1 + int(w.held[0])]}
    joints |= {names[int(r[1])] for r in w.records[max(struck - 3, 0) : struck]}
    where = ", ".join(sorted(joints))
    return f"more than {MAX_EVENTS_PER_STEP} stop events within one step at joint(s) {where} (chattering)"


def _hand_back(w: Work, held0: dict[int, int], evaluations0: tuple[int, int], why: str) -> Outcome:
    """The run goes to the Python pipeline from its start: the held set and counters as they were."""
    system = w.system
    if system.held != held0:
        system.hold(held0, w.run.Q[0])
    system.evaluations, system.jacobian_evaluations = evaluations0
    return Outcome(False, why, w.done, time.perf_counter() - w.start)


def attempt(plan: Plan, system: RobotSystem, run: Run) -> Outcome:
    """Run ``run`` in the compiled loop and fill its records; or leave it untouched and say why not.

    The stages: set up the kernels' inputs (:func:`_setup`), then blocks of steps with their stop
    events (:func:`_block`), each classified (:func:`_classify`: go on, or hand back), the last
    sample's rates (:func:`_last_sample`), then the books checked and the records filled
    (:func:`_close`). A Ctrl-C between blocks marks ``run`` interrupted (its records kept up to
    the last sample taken) and returns ``ran=True``; the caller raises.
    """
    held0, evaluations0 = dict(system.held), (system.evaluations, system.jacobian_evaluations)
    w = _setup(plan, system, run)
    interrupted = False
    try:
        while w.done < run.t.size - 1:
            status, last = _block(w)
            ending = _classify(w, status, last)
            w.done = ending.kept
            if run.progress is not None:
                run.progress(float(run.t[w.done]))
            if ending.why is not None:
                return _hand_back(w, held0, evaluations0, ending.why)
        _last_sample(w)
    except KeyboardInterrupt:
        interrupted = True
    except AssumptionError as exc:  # the compiled CRBA, checked at the first stop met, differs from Pinocchio's
        return _hand_back(w, held0, evaluations0, str(exc))
    except np.linalg.LinAlgError as exc:  # an impact's solve on a state blown up inside the block
        failed = _failed_solve(w, exc)
        w.done = int(w.counts[w.events.AT])  # the steps before the one that raised were taken
        return _hand_back(w, held0, evaluations0, failed)
    finally:
        w.kernels.CALLBACKS.pop(w.cb, None)
        calls = w.kernels.CALLS.pop(w.cb, 0)
        stopped_at = w.kernels.INTERRUPTED.pop(w.cb, None)
    interrupted = interrupted or stopped_at is not None  # (a Ctrl-C in the last sample's torque call too)
    why = _energies(w, interrupted)
    if why is not None:
        return _hand_back(w, held0, evaluations0, why)
    evaluations = calls if w.cb >= 0 else int(w.counts[w.events.EVALS])
    if stopped_at is not None:  # every stage begun called the torque: the interrupted one included
        evaluations = stopped_at
    return _close(w, interrupted, evaluations)


def _last_sample(w: Work) -> None:
    """Stage 4: the rates and energies of the last sample, with the joints held there locked."""
    run, tr, nv = w.run, w.tree, w.system.nv
    a_last = np.empty(nv + 2)
    w.kin[w.done], w.pot[w.done], _ = w.kernels.sample(
        tr.itree, tr.ftree, tr.grav, tr.flyer, float(run.t[w.done]), run.Q[w.done], w.U[w.done], w.forces, w.springs,
        w.cb, _held_rows(w), RELEASE_TOL, a_last,
    )  # fmt: skip
    w.counts[w.events.EVALS] += 1
    w.A[w.done] = a_last[:nv]


def _energies(w: Work, interrupted: bool) -> str | None:
    """Stage 5: the energies of every sample kept (the springs' added); why the books do not close, if so."""
    run, system, nv = w.run, w.system, w.system.nv
    keep = w.done + 1
    if interrupted:  # the last kept sample's rates: filled in by Run.trajectory, as the Python run does
        w.A[w.done] = np.nan
    for i in np.flatnonzero(np.isnan(w.kin[:keep])):  # an interrupted end
        w.kin[i], w.pot[i] = _energies_at(w.kernels, w.tree, run.Q[i], w.U[i], w.forces, w.springs)
    if not system.springs.empty:  # their energy 1/2 k (q - rest)^2 is potential energy, booked by Springs
        w.pot[:keep] += system.springs.energy(run.Q[:keep])
    if interrupted:
        return None
    U, kin, pot, wl = w.U, w.kin, w.pot, run.work_limits
    residual = kin[:keep] + pot[:keep] - (kin[0] + pot[0]) - U[:keep, nv] - U[:keep, nv + 1] - wl[:keep]
    worst = float(np.max(np.abs(residual)))
    if not worst <= run.bound:
        return f"an energy error of {worst:.3g} J above the bound {run.bound:.3g} J"
    return None


def _close(w: Work, interrupted: bool, evaluations: int) -> Outcome:
    """Stage 6: the run's records, its event counts and impacts, and how the compiled loop went."""
    run, nv, nw, keep = w.run, w.system.nv, w.system.nw, w.done + 1
    wall = time.perf_counter() - w.start
    run.U[:keep, :nv] = w.U[:keep, :nv]
    if nw:
        run.U[:keep, nv:] = w.U[:keep, nv:]
    run.A[:keep] = w.A[:keep]
    run.kinetic[:keep] = w.kin[:keep]
    run.potential[:keep] = w.pot[:keep]
    run.n = keep
    run.checked = keep
    run.work = (evaluations, 0)
    _book_events(w)
    if interrupted:
        t_stop = float(run.t[keep - 1])
        run.interrupted = (keep - 1, t_stop, f"interrupted after step {keep - 1} (t = {t_stop:.6g} s)")
    return Outcome(True, "compiled loop", w.done, wall, int(w.counts[w.events.EVENT_STEPS]), w.compiled.passes)


def _held_rows(w: Work) -> Array:
    """The held stops in :func:`robodyn.engine.tree.steps.sample`'s layout (2, h): [tree row; side]."""
    ks = w.held[1 : 1 + int(w.held[0])]
    return np.ascontiguousarray(np.vstack([w.stops[5, ks], w.side[ks].astype(np.float64)]).reshape(2, -1))


def _book_events(w: Work) -> None:
    """The event counts, the impacts kept, the stops' work and the held set, where the run reads them."""
    stepper, system, ev = w.run.stepper, w.system, w.events
    stops = system.stops
    stepper.n_impacts = int(w.counts[ev.IMPACTS])
    stepper.n_releases = int(w.counts[ev.RELEASES])
    stepper.work_limits = float(w.wlim[0])
    stepper.impacts = [
        ImpactRecord(
            float(r[0]), stops.names[int(r[1])], "lower" if r[2] > 0 else "upper", float(r[3]), float(r[4]), float(r[5])
        )
        for r in w.records[: min(stepper.n_impacts, IMPACTS_KEPT)]
    ]
    held = {int(k): int(w.side[k]) for k in w.held[1 : 1 + int(w.held[0])]}
    if held != system.held:
        system.hold(held, w.run.Q[w.done])


def _first_over_bound(run: Run, kin: Array, pot: Array, U: Array, lo: int, hi: int) -> str | None:
    """'an energy error of X J above the bound B J at step k (t = ...)': the first of samples lo .. hi-1 over it.

    ``pot`` is gravity's potential (the kernels'); the springs' is added here, as Run books it.
    """
    bound, system = run.bound, run.system
    if hi <= lo or not np.isfinite(bound):
        return None
    nv = system.nv
    e = kin[lo:hi] + pot[lo:hi]
    e0 = kin[0] + pot[0]
    if not system.springs.empty:
        e = e + system.springs.energy(run.Q[lo:hi])
        e0 = e0 + float(system.springs.energy(run.Q[:1])[0])
    residual = np.abs(e - e0 - U[lo:hi, nv] - U[lo:hi, nv + 1] - run.work_limits[lo:hi])
    over = ~(residual <= bound)
    if not over.any():
        return None
    k = lo + int(np.argmax(over))
    return (
        f"an energy error of {float(residual[k - lo]):.3g} J above the bound {bound:.3g} J "
        f"at step {k} (t = {float(run.t[k]):.6g} s)"
    )


def _energies_at(
    kernels: ModuleType, tr: tree.TreeModel, q: Array, u: Array, forces: Array, springs: Array
) -> tuple[float, float]:
    """(T, V_gravity) [J] of one sample, without calling the torque."""
    a = np.empty(u.size)
    none = np.zeros((2, 0))  # no joint locked: the energies do not depend on the held set
    kin, pot, _ = kernels.sample(
        tr.itree, tr.ftree, tr.grav, tr.flyer, 0.0, q, u, forces, springs, -1, none, RELEASE_TOL, a
    )
    return float(kin), float(pot)
