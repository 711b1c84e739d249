"""A whole run in one compiled loop: the stages of a step, the ledger and the energies, no Python per step.

:func:`prepare` checks that the compiled loop can take a run, and :func:`attempt` takes a
:class:`~robodyn.sim.run.Run` that :func:`robodyn.simulate` has set up
and, when the compiled loop can take it, fills its records (q, v, the works, a, T, V) with
:func:`robodyn.sim.tree_steps.run_block`: the same pipeline as
:class:`~robodyn.sim.system.RobotSystem` (springs, losses -D v - F tanh(v / v_friction), the
constant torque clamped at the efforts, ABA), the works W_input and W_damping integrated in the
same stages as v, stepped by the same method (classic RK4, any explicit Runge--Kutta tableau,
explicit Euler, semi-implicit Euler) with the same step sizes.

It takes a run when the robot is a tree the compiled algorithms serve (checked against
Pinocchio first, :func:`robodyn.sim.tree.compiled_of`), without loops or couplings, with no
torque, a constant one or a torque callable, under one of those methods.

Joint stops are shared with the event stepper of :mod:`robodyn.sim.events`: the compiled
loop steps while every free limited joint is clear of its stops, with the joints held at a
stop locked (qdd = 0, their stop force computed in the same ABA pass), and stops at the first
sample where a free joint comes within the stop tolerance or a held stop pulls. The event
stepper (``run.stepper``, the Python pipeline) then takes that one step (locating the impact
or the release to round-off, applying the impulse, changing the held set, booking the work of
the stops), and the compiled loop goes on from the next sample with the new held set.

What it does not handle it hands back, and the run is then taken by the Python pipeline
from its start (``Run.integrate``): a state that is not finite, an energy error above the
run's bound, or a step the event stepper cannot take (the Python pipeline then writes the
canonical divergence report).

Ctrl-C is honoured between blocks of ``BLOCK`` steps.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass
from types import ModuleType

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import RobodynError, StepError
from robodyn.integrators import Integrator
from robodyn.integrators.explicit import ClassicRK4, ExplicitEuler, ExplicitRungeKutta
from robodyn.integrators.symplectic import SemiImplicitEuler
from robodyn.sim import tree
from robodyn.sim.events import RELEASE_TOL
from robodyn.sim.run import Run, step_sizes
from robodyn.sim.system import V_FRICTION, RobotSystem

Array = NDArray[np.float64]

_KEYS = itertools.count()

# Steps per call of the compiled loop: between calls Ctrl-C is seen (Talos: ~0.15 s a block).
BLOCK = 4096

# Method codes of tree_steps (RK, RK4, SEMI_IMPLICIT_EULER).
_RK, _RK4, _SIE = 0, 1, 2
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
    event_steps: int = 0  # steps the event stepper took (stop events) when ``ran``


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


def _stop_rows(system: RobotSystem, rows: NDArray[np.intp]) -> tuple[Array, Array]:
    """(stops (5, k), held (2, h)) in the kernels' layout, for the stops held now (``system.held``).

    ``stops``: the free limited joints [index in q; index in v; lower; upper; tolerance];
    ``held``: the held joints [tree row; side]. ``rows`` maps an index in v to its tree row.
    """
    st = system.stops
    if st.empty:
        return np.zeros((5, 0)), np.zeros((2, 0))
    tol = st.tolerance()
    free = np.array([k for k in range(st.iq.size) if k not in system.held], dtype=np.intp)
    stops = np.vstack(
        [st.iq[free].astype(np.float64), st.iv[free].astype(np.float64), st.lower[free], st.upper[free], tol[free]]
    )
    held = np.array(
        [[float(rows[st.iv[k]]) for k in system.held], [float(side) for side in system.held.values()]]
    ).reshape(2, -1)
    return np.ascontiguousarray(stops), np.ascontiguousarray(held)


@dataclass(frozen=True, eq=False)
class Plan:
    """A run the compiled loop can take: the checked compiled tree and the method's code and tableau."""

    compiled: tree.CompiledDynamics
    method: int
    tableau: Array


def prepare(system: RobotSystem, method: Integrator) -> Plan | str:
    """The :class:`Plan` of this run, or why the compiled loop cannot take it (one phrase).

    Loads (or compiles, the first time on a machine) the kernels and checks the compiled
    algorithms against Pinocchio, so that a timed run pays for neither.
    """
    reason = refusal(system, method)
    if reason is not None:
        return reason
    try:
        compiled = tree.compiled_of(system.robot)
    except RobodynError as exc:
        return str(exc)
    code = method_code(method)
    if code is None:  # pragma: no cover - refusal() checked it
        return f"{method.name} is not a fixed-step explicit method"
    return Plan(compiled, code[0], code[1])


def attempt(plan: Plan, system: RobotSystem, run: Run) -> Outcome:
    """Run ``run`` in the compiled loop and fill its records; or leave it untouched and say why not.

    Steps with a stop event (an impact, a hold, a release) are taken by the run's event stepper
    (``run.stepper``, the Python pipeline), one step at a time; the compiled loop takes every
    other step, with the held joints locked. A Ctrl-C between blocks (or during an event step)
    marks ``run`` interrupted (its records kept up to the last sample taken) and returns
    ``ran=True``; the caller raises.
    """
    compiled, mcode, tab = plan.compiled, plan.method, plan.tableau
    kernels = tree.kernels()
    t = run.t
    n = t.size
    nv, nw = system.nv, system.nw
    hs = np.array(step_sizes(t))
    forces, springs = _inputs(system)
    tr = compiled.tree
    rows = np.empty(nv, dtype=np.intp)  # the tree row of each index in v
    rows[tr.itree[:, 3]] = np.arange(tr.itree.shape[0])
    held0 = dict(system.held)
    Q = run.Q
    U = np.zeros((n, nv + 2))
    U[0, : nv + nw] = run.U[0]
    A = np.full((n, nv), np.nan)
    kin = np.full(n, np.nan)
    pot = np.full(n, np.nan)
    wl = run.work_limits
    stepper = run.stepper
    stages = 1 if mcode == _SIE else (4 if mcode == _RK4 else tab.shape[1])
    cb = -1
    if system.torque.kind == "callable":  # called in object mode, stage by stage, as RobotSystem.input_torque
        cb = next(_KEYS)
        kernels.CALLBACKS[cb] = system.input_torque
    start = time.perf_counter()
    done, interrupted = 0, False
    compiled_steps = compiled_evals = event_steps = 0
    events_work = np.zeros(2, dtype=np.int64)  # (evaluations, jacobian evaluations) of the event steps

    evaluations0 = (system.evaluations, system.jacobian_evaluations)
    prev_compiled = False  # the step into sample ``done`` was taken by the compiled loop

    def hand_back(why: str) -> Outcome:
        if system.held != held0:  # the Python run starts again from q0 with the stops held there
            system.hold(held0, run.Q[0])
        # the Python run counts its own work only (Run reads the system's counters)
        system.evaluations, system.jacobian_evaluations = evaluations0
        return Outcome(False, why, compiled_steps, time.perf_counter() - start)

    try:
        while True:
            if done < n - 1:
                stops, held = _stop_rows(system, rows)
                hi = min(done + BLOCK, n - 1)
                status, last = kernels.run_block(
                    tr.itree,
                    tr.ftree,
                    tr.grav,
                    mcode,
                    tab,
                    t,
                    hs,
                    done,
                    hi,
                    Q,
                    U,
                    A,
                    kin,
                    pot,
                    forces,
                    springs,
                    cb,
                    stops,
                    held,
                    RELEASE_TOL,
                )
                compiled_evals += stages * (last - done) + (status in (kernels.RELEASE, kernels.AT_STOP))
                if status != kernels.DONE and cb in kernels.INTERRUPTED:  # Ctrl-C inside the torque callable
                    keep_to = max(last - 1, done)  # the step from there was begun, not finished
                    wl[done + 1 : keep_to + 1] = stepper.work_limits
                    done = keep_to
                    raise KeyboardInterrupt
                # DONE, NOT_FINITE, AT_STOP (the event stepper takes the step from ``last``) keep every sample
                # taken; NEAR_STOP, RELEASE: the step into ``last`` is the event's, when the compiled loop took it
                redo = status in (kernels.NEAR_STOP, kernels.RELEASE) and (
                    last > done or (status == kernels.RELEASE and prev_compiled)
                )
                kept = last - 1 if redo else last
            else:  # the last sample: a held stop pulling there is the event of the compiled last step
                _, held = _stop_rows(system, rows)
                a_last = np.empty(nv + 2)
                kin[done], pot[done], pulls = kernels.sample(
                    tr.itree, tr.ftree, tr.grav, float(t[done]), Q[done], U[done], forces, springs, cb, held,
                    RELEASE_TOL, a_last,
                )  # fmt: skip
                compiled_evals += 1
                if not (pulls and prev_compiled):
                    A[done] = a_last[:nv]
                    break
                status, kept = kernels.RELEASE, done - 1
            if kept < done:  # a compiled step to take again: its sample is the event step's now
                kin[done] = pot[done] = np.nan
                A[done] = np.nan
            wl[done + 1 : kept + 1] = stepper.work_limits
            compiled_steps += kept - done
            # samples done .. kept - 1 have their energies: the first one over the bound ends the attempt
            over = _first_over_bound(run, kin, pot, U, done, kept)
            if over is not None:
                return hand_back(over)
            if status == kernels.NOT_FINITE:
                return hand_back(f"a state that is not finite at step {kept} (t = {float(t[kept]):.6g} s)")
            prev_compiled = kept > done
            done = kept
            if status == kernels.DONE:
                continue
            reason = _event_step(run, kernels, tr, forces, springs, U, A, kin, pot, done, hs, events_work)
            if reason is not None:
                return hand_back(reason)
            event_steps += 1
            prev_compiled = False
            over = _first_over_bound(run, kin, pot, U, done, done + 1)
            if over is not None:
                return hand_back(over)
            done += 1
    except KeyboardInterrupt:
        interrupted = True
    finally:
        kernels.CALLBACKS.pop(cb, None)
        calls = kernels.CALLS.pop(cb, 0)
        stopped_at = kernels.INTERRUPTED.pop(cb, None)
    interrupted = interrupted or stopped_at is not None  # (a Ctrl-C in the last sample's torque call too)
    keep = done + 1
    if interrupted:  # the last kept sample's rates: filled in by Run.trajectory, as the Python run does
        A[done] = np.nan
    for k in np.flatnonzero(np.isnan(kin[:keep])):  # samples an event step began from, and an interrupted end
        kin[k], pot[k] = _energies_at(kernels, tr, Q[k], U[k], forces, springs)
    if not system.springs.empty:  # their energy 1/2 k (q - rest)^2 is potential energy, booked by Springs
        pot[:keep] += system.springs.energy(Q[:keep])
    wall = time.perf_counter() - start
    if not interrupted:
        residual = kin[:keep] + pot[:keep] - (kin[0] + pot[0]) - U[:keep, nv] - U[:keep, nv + 1] - wl[:keep]
        worst = float(np.max(np.abs(residual)))
        if not worst <= run.bound:
            return hand_back(f"an energy error of {worst:.3g} J above the bound {run.bound:.3g} J")
    run.U[:keep, :nv] = U[:keep, :nv]
    if nw:
        run.U[:keep, nv:] = U[:keep, nv:]
    run.A[:keep] = A[:keep]
    run.kinetic[:keep] = kin[:keep]
    run.potential[:keep] = pot[:keep]
    run.n = keep
    run.checked = keep
    evaluations = (calls if cb >= 0 else compiled_evals) + int(events_work[0])
    if stopped_at is not None:  # every stage begun called the torque: the interrupted one included
        evaluations = stopped_at + int(events_work[0])
    run.work = (evaluations, int(events_work[1]))
    if interrupted:
        t_stop = float(t[keep - 1])
        run.interrupted = (keep - 1, t_stop, f"interrupted after step {keep - 1} (t = {t_stop:.6g} s)")
    return Outcome(True, "compiled loop", compiled_steps, wall, event_steps)


def _event_step(
    run: Run,
    kernels: ModuleType,
    tr: tree.TreeModel,
    forces: Array,
    springs: Array,
    U: Array,
    A: Array,
    kin: Array,
    pot: Array,
    k: int,
    hs: Array,
    work: NDArray[np.int64],
) -> str | None:
    """Step k (sample k to k + 1) by the run's event stepper, into Q, U, A[k] and the limits' work.

    Returns why the compiled loop must hand the run back (a step the event stepper cannot
    take), or None. ``work`` gets the evaluations the step spent.
    """
    system, stepper, t = run.system, run.stepper, run.t
    nv, nw = system.nv, system.nw
    before = (system.evaluations, system.jacobian_evaluations)
    q, u = run.Q[k].copy(), U[k, : nv + nw].copy()
    if np.isnan(kin[k]):
        kin[k], pot[k] = _energies_at(kernels, tr, q, U[k], forces, springs)
    try:
        stepper.restart(float(t[k]), q, u)  # a fresh start of the method: no rates kept from a compiled step
        with np.errstate(all="ignore"):
            q1, u1, k_start = stepper.advance(float(t[k]), q, u, float(hs[k]))
    except (StepError, np.linalg.LinAlgError) as exc:
        what = exc.reason if isinstance(exc, StepError) else f"the forward dynamics failed ({exc})"
        return f"{what} at step {k + 1} (t = {float(t[k + 1]):.6g} s)"
    finally:
        work += (system.evaluations - before[0], system.jacobian_evaluations - before[1])
    run.Q[k + 1] = q1
    U[k + 1, : nv + nw] = u1
    if k_start is not None:
        A[k] = k_start[:nv]
    run.work_limits[k + 1] = stepper.work_limits
    return None


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
    kin, pot, _ = kernels.sample(tr.itree, tr.ftree, tr.grav, 0.0, q, u, forces, springs, -1, none, RELEASE_TOL, a)
    return float(kin), float(pot)
