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
torque or a constant one, under one of those methods. What it does not handle it hands back,
and the run is then taken by the Python pipeline from its start (``Run.integrate``):

* a joint that comes within the stop tolerance of its stop (impacts and holds are events of
  :mod:`robodyn.sim.events`), including a q0 on a stop;
* a state that is not finite, or an energy error above the run's bound: the Python pipeline
  then writes the canonical divergence report.

Ctrl-C is honoured between blocks of ``BLOCK`` steps.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass
from types import ModuleType

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import RobodynError
from robodyn.integrators import Integrator
from robodyn.integrators.explicit import ClassicRK4, ExplicitEuler, ExplicitRungeKutta
from robodyn.integrators.symplectic import SemiImplicitEuler
from robodyn.sim import tree
from robodyn.sim.run import Run
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
    steps: int = 0  # steps the compiled loop took (all of them when ``ran``)
    wall_time_s: float = 0.0  # its wall time, even when the run was handed back


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


def _inputs(system: RobotSystem) -> tuple[Array, Array, Array]:
    """(forces (4, nv), springs (4, m), stops (3, k)) in the kernels' layout."""
    nv = system.nv
    forces = np.zeros((4, nv))
    forces[0] = system.torque.constant
    forces[1] = system.damping
    forces[2] = system.friction
    forces[3, 0] = V_FRICTION
    sp = system.springs
    springs = np.vstack([sp.iq.astype(np.float64), sp.iv.astype(np.float64), sp.stiffness, sp.rest])
    springs = np.ascontiguousarray(springs.reshape(4, -1))
    st = system.stops
    if st.empty:
        stops = np.zeros((3, 0))
    else:
        tol = st.tolerance()
        stops = np.ascontiguousarray(np.vstack([st.iq.astype(np.float64), st.lower + tol, st.upper - tol]))
    return forces, springs, stops


def step_sizes(t: Array) -> Array:
    """Every step t[1] - t[0], but a last, shorter one that lands on t[-1] (as the Python run takes them)."""
    dt = float(t[1] - t[0])
    hs = np.full(t.size - 1, dt)
    last = float(t[-1] - t[-2])
    if abs(last - dt) > 1e-9 * dt:
        hs[-1] = last
    return hs


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

    A Ctrl-C between blocks marks ``run`` interrupted (its records kept up to the last block)
    and returns ``ran=True``; the caller raises.
    """
    compiled, mcode, tab = plan.compiled, plan.method, plan.tableau
    kernels = tree.kernels()
    t = run.t
    n = t.size
    nv, nw = system.nv, system.nw
    hs = step_sizes(t)
    forces, springs, stops = _inputs(system)
    tr = compiled.tree
    Q = run.Q
    U = np.zeros((n, nv + 2))
    U[0, :nv] = run.U[0, :nv]
    A = np.empty((n, nv))
    kin = np.empty(n)
    pot = np.empty(n)
    stages = 1 if mcode == _SIE else (4 if mcode == _RK4 else tab.shape[1])
    cb = -1
    if system.torque.kind == "callable":  # called in object mode, stage by stage, as RobotSystem.input_torque
        cb = next(_KEYS)
        kernels.CALLBACKS[cb] = system.input_torque
    start = time.perf_counter()
    done, interrupted = 0, False
    try:
        while done < n - 1:
            hi = min(done + BLOCK, n - 1)
            status, last = kernels.run_block(
                tr.itree, tr.ftree, tr.grav, mcode, tab, t, hs, done, hi, Q, U, A, kin, pot, forces, springs, cb, stops
            )
            if status != kernels.DONE and cb in kernels.INTERRUPTED:  # Ctrl-C inside the torque callable
                done = last - 1  # the step from there was begun, not finished
                raise KeyboardInterrupt
            # samples done .. last - 1 have their energies: the first one over the bound ends the attempt
            over = _first_over_bound(run, kin, pot, U, done, last)
            if over is not None:
                return Outcome(False, over, last, time.perf_counter() - start)
            if status != kernels.DONE:
                wall = time.perf_counter() - start
                what = "a state that is not finite" if status == kernels.NOT_FINITE else _near_stop(system, Q[last])
                return Outcome(False, f"{what} at step {last} (t = {float(t[last]):.6g} s)", last, wall)
            done = hi
        a_last = np.empty(nv + 2)
        kin[done], pot[done] = kernels.sample(
            tr.itree, tr.ftree, tr.grav, float(t[done]), Q[done], U[done], forces, springs, cb, a_last
        )
        A[done] = a_last[:nv]
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
        kin[done], pot[done] = _energies_at(kernels, tr, Q[done], U[done], forces, springs)
    if not system.springs.empty:  # their energy 1/2 k (q - rest)^2 is potential energy, booked by Springs
        pot[:keep] += system.springs.energy(Q[:keep])
    wall = time.perf_counter() - start
    if not interrupted:
        residual = kin[:keep] + pot[:keep] - (kin[0] + pot[0]) - U[:keep, nv] - U[:keep, nv + 1]
        worst = float(np.max(np.abs(residual)))
        if not worst <= run.bound:
            return Outcome(False, f"an energy error of {worst:.3g} J above the bound {run.bound:.3g} J", done, wall)
    run.U[:keep, :nv] = U[:keep, :nv]
    if nw:
        run.U[:keep, nv:] = U[:keep, nv:]
    run.A[:keep] = A[:keep]
    run.kinetic[:keep] = kin[:keep]
    run.potential[:keep] = pot[:keep]
    run.n = keep
    run.checked = keep
    if stopped_at is not None:  # every stage begun called the torque: the interrupted one included
        run.work = (stopped_at, 0)
    elif interrupted:
        run.work = (stages * done, 0)
    else:
        run.work = (stages * done + 1, 0) if cb < 0 else (calls, 0)
    if interrupted:
        t_stop = float(t[keep - 1])
        run.interrupted = (keep - 1, t_stop, f"interrupted after step {keep - 1} (t = {t_stop:.6g} s)")
    return Outcome(True, "compiled loop", done, wall)


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
    residual = np.abs(e - e0 - U[lo:hi, nv] - U[lo:hi, nv + 1])
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
    return kernels.sample(tr.itree, tr.ftree, tr.grav, 0.0, q, u, forces, springs, -1, a)  # type: ignore[no-any-return]


def _near_stop(system: RobotSystem, q: Array) -> str:
    """'joint NAME at its lower|upper stop' for the first limited joint not clear of its stops at q."""
    st = system.stops
    tol = st.tolerance()
    for k in range(st.iq.size):
        x = float(q[st.iq[k]])
        if not x > st.lower[k] + tol[k]:
            return f"joint {st.names[k]!r} at its lower stop"
        if not x < st.upper[k] - tol[k]:
            return f"joint {st.names[k]!r} at its upper stop"
    return "a joint at its stop"
