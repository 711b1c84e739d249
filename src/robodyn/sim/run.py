"""One run's stepping loop: take the steps, record them, watch for divergence block by block.

:class:`Run` steps a :class:`~robodyn.sim.system.RobotSystem` with an integrator over a time
grid (through :class:`~robodyn.sim.events.EventStepper`, which takes the stop impacts and the
loop projections between steps), records q, v, a, the energies (springs included) and the
works of every sample (the stops' ``work_limits`` too), and checks each block of
``CHECK_EVERY`` steps: a non-finite state, a step the method cannot take, or an energy error
above the allowed growth stops the run at the exact step, with :func:`diagnose` naming the
likely cause. :func:`robodyn.simulate` validates the inputs, builds the run and turns its
outcome into a :class:`~robodyn.Trajectory` or an exception.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import StepError
from robodyn.integrators import Integrator
from robodyn.sim import energy
from robodyn.sim.events import EventStepper, Mark
from robodyn.sim.stiffness import divergence_cause, friction_stiffness
from robodyn.sim.system import SINGULAR_MASS_RTOL, RobotSystem
from robodyn.sim.trajectory import Trajectory

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

# Steps between divergence checks; a failure is then located to its exact step.
CHECK_EVERY = 512

Progress = Callable[[float], None]
"""A run's progress hook: called with the time reached [s], as often as after every step."""


def step_sizes(t: Array) -> list[float]:
    """Every step exactly dt = t[1] - t[0], but a last, shorter one that lands on t[-1]."""
    dt = float(t[1] - t[0])
    steps = [dt] * (t.size - 1)
    last = float(t[-1] - t[-2])
    if abs(last - dt) > 1e-9 * dt:
        steps[-1] = last
    return steps


def diagnose(
    method: Integrator, dt: float, system: RobotSystem, states: list[Array], *, reason: str = ""
) -> tuple[str, str]:
    """(likely cause, one suggestion) for a run of ``method`` at step ``dt`` [s] that failed.

    ``states`` are the finite configurations (nq,) around the failure: if M is singular at
    one of them, the integrator is not to blame. ``reason`` is what failed; a constraint
    solver or a stop that failed is blamed before the integrator.
    """
    if "loop" in reason and system.loops is not None:
        return (
            "the loop closures cannot be solved there (a fold of the linkage, or frames pulled apart)",
            "check the loops' frames and q0, or try a smaller dt",
        )
    finite = [q for q in states if np.all(np.isfinite(q))]
    for q in finite:
        with np.errstate(all="ignore"):
            try:
                ratio, direction = system.mass_conditioning(q)
            except (np.linalg.LinAlgError, ValueError, RuntimeError):
                continue
        if not ratio > SINGULAR_MASS_RTOL:
            where = system.singular_direction(direction) if np.all(np.isfinite(direction)) else "?"
            return (
                f"the mass matrix M(q) is singular there (smallest eigenvalue {ratio:.2g} of the largest, along "
                f"{where}), not the integrator",
                "give the links that move along that direction mass and inertia",
            )
    stiff = _stiff_losses(method, dt, system, finite)
    if stiff is not None:  # the cause a smaller step of the usual size would not cure
        return divergence_cause(stiff)
    if "stop events" in reason:
        e = system.stops.restitution
        cure = (
            f"lower the restitution (now {e:g}) or try a smaller dt"
            if e > 0
            else f"try a smaller dt, e.g. {dt / 10:g} s"
        )
        return "a joint chatters on its stop", cure
    if method.name == "euler":
        cause = f"explicit Euler is unstable at dt = {dt:g} s (it gains energy at every step)"
        suggestion = "try symplectic_euler, whose energy error stays bounded"
    elif method.adaptive:
        cause = f"{method.name} could not follow the solution: the motion itself may blow up"
        suggestion = "check the initial state, the torque and the model's inertias"
    elif method.implicit:
        cause = f"dt = {dt:g} s is too large for {method.name}'s iteration to converge"
        suggestion = f"try a smaller dt, e.g. {dt / 10:g} s"
    else:
        cause = f"{method.name} is unstable at dt = {dt:g} s"
        suggestion = f"try a smaller dt, e.g. {dt / 10:g} s"
    if system.torque.kind == "callable":
        cause += " (or the torque callable drives the robot without bound)"
    return cause, suggestion


def _stiff_losses(method: Integrator, dt: float, system: RobotSystem, states: list[Array]) -> dict[str, Any] | None:
    """The stiff-losses finding (:mod:`robodyn.sim.stiffness`) at the first of ``states`` where M is usable."""
    for q in states:
        with np.errstate(all="ignore"):
            try:
                found = friction_stiffness(system, method, q, dt)
            except (np.linalg.LinAlgError, ValueError, RuntimeError):
                continue
        return None if found is None else found.describe()
    return None


@dataclass
class _Block:
    """The records of one block of steps from step ``lo``: states, rates at the start, work, the events' marks."""

    lo: int
    marks: list[Mark]  # the events' marks (EventStepper.mark) at the block's start and after each step
    qs: list[Array] = field(default_factory=list)
    us: list[Array] = field(default_factory=list)
    ks: list[Array | None] = field(default_factory=list)
    work: list[tuple[int, int]] = field(default_factory=list)  # (rates, jacobian) evaluations after each step
    failed: BaseException | None = None
    interrupted: bool = False


class Run:
    """One simulation: the stepping loop, the records, the divergence checks.

    The work done is counted exactly: the dynamics evaluations up to the step that failed
    (or was interrupted), not those of the steps taken after it in the same check block.
    """

    def __init__(
        self,
        robot: Robot,
        system: RobotSystem,
        method: Integrator,
        t: Array,
        q0: Array,
        v0: Array,
        *,
        rtol: float,
        atol: float,
        max_energy_growth: float | None,
        progress: Progress | None = None,
    ) -> None:
        self.robot, self.system, self.method, self.t = robot, system, method, t
        self.progress = progress  # called with the time reached [s] before the first step and after every step
        n = t.size
        nv = system.nv
        self.Q = np.empty((n, system.nq))
        self.U = np.empty((n, nv + system.nw))
        self.A = np.full((n, nv), np.nan)
        self.kinetic = np.empty(n)
        self.potential = np.empty(n)
        self.work_limits = np.zeros(n)
        self.Q[0] = q0
        self.U[0, :nv] = v0
        self.U[0, nv:] = 0.0
        self.stepper = EventStepper(
            method, system, float(t[0]), q0, self.U[0].copy(), t_end=float(t[-1]), rtol=rtol, atol=atol
        )
        self.meter = energy.EnergyMeter.for_robot(robot, q0)
        self.n = n  # samples kept (shrinks on failure)
        self.failure: tuple[int, float, str] | None = None
        self.interrupted: tuple[int, float, str] | None = None
        self.checked = 1  # samples [0, checked) are stored and checked
        # Evaluations (rates, jacobian) after each step of the current block, step lo + i at index i.
        self._block_lo = 0
        self._block_work: list[tuple[int, int]] = []
        # The events' marks (EventStepper.mark) at the block's start and after each of its steps,
        # to forget the impacts of steps taken past a failure in the same block.
        self._block_marks: list[Mark] = []
        self.work: tuple[int, int] | None = None  # evaluations spent on the kept samples, once known
        self._energies(0, 1)
        self.scale = energy.energy_scale(robot, float(self.kinetic[0]), float(self.potential[0]))
        self.bound = np.inf if max_energy_growth is None else max_energy_growth * self.scale
        self.rtol, self.atol = rtol, atol

    def _energies(self, lo: int, hi: int) -> None:
        nv = self.system.nv
        self.kinetic[lo:hi], self.potential[lo:hi] = self.meter(self.Q[lo:hi], self.U[lo:hi, :nv])
        if not self.system.springs.empty:
            self.potential[lo:hi] += self.system.springs.energy(self.Q[lo:hi])

    def _residual(self, lo: int, hi: int) -> Array:
        nv = self.system.nv
        e = self.kinetic[lo:hi] + self.potential[lo:hi]
        w = self.U[lo:hi, nv:].sum(axis=1) if self.system.nw else 0.0
        return e - (self.kinetic[0] + self.potential[0]) - w - self.work_limits[lo:hi]

    def _counters(self) -> tuple[int, int]:
        return int(self.system.evaluations), int(getattr(self.system, "jacobian_evaluations", 0))

    def integrate(self) -> None:
        """Step through the time grid; a Ctrl-C keeps what was checked so far."""
        try:
            self._integrate()
        except KeyboardInterrupt:
            if self.failure is None and self.interrupted is None:
                self._interrupt(self.checked)
        if self.work is None:
            self.work = self._counters()

    def _integrate(self) -> None:
        """Every ``CHECK_EVERY`` steps: step the block, then store and check it (:meth:`_keep`)."""
        times = self.t.tolist()
        steps = step_sizes(self.t)
        q, u = self.Q[0].copy(), self.U[0].copy()
        n_steps = len(steps)
        eventful = not (self.system.stops.empty and self.system.loops is None)
        if self.progress is not None:  # the first step may be long (stops that chatter): the clock starts here
            self.progress(times[0])
        with np.errstate(all="ignore"):
            for lo in range(0, n_steps, CHECK_EVERY):
                block = _Block(lo, [self.stepper.mark()] if eventful else [])
                self._block_lo, self._block_work, self._block_marks = lo, block.work, block.marks
                try:
                    q, u = self._step(block, times, steps, min(lo + CHECK_EVERY, n_steps), q, u)
                except (StepError, np.linalg.LinAlgError) as exc:
                    block.failed = exc
                except KeyboardInterrupt:
                    block.interrupted = True
                if not self._keep(block):
                    return

    def _step(
        self, block: _Block, times: list[float], steps: list[float], hi: int, q: Array, u: Array
    ) -> tuple[Array, Array]:
        """Steps block.lo .. hi - 1 into ``block``'s records; returns the last state."""
        advance, system = self.stepper.advance, self.system
        qs, us, ks, work, marks = block.qs, block.us, block.ks, block.work, block.marks
        mark = self.stepper.mark if marks else None
        progress = self.progress
        for k in range(block.lo, hi):
            q, u, k_start = advance(times[k], q, u, steps[k])
            if progress is not None:
                progress(times[k + 1])
            qs.append(q)
            us.append(u)
            ks.append(k_start)
            work.append((system.evaluations, system.jacobian_evaluations))
            if mark is not None:  # the events so far (their work_limits included)
                marks.append(mark())
        return q, u

    def _keep(self, block: _Block) -> bool:
        """Store ``block`` and check it; False when the run stops there (a failure or a Ctrl-C)."""
        lo = block.lo
        done = lo + len(block.qs)
        if block.failed is not None or block.interrupted:
            block.work.append(self._counters())  # the failed or interrupted step's work
        if block.marks:
            self.work_limits[lo + 1 : lo + len(block.marks)] = [m[4] for m in block.marks[1:]]
        self._store(lo, block.qs, block.us, block.ks)
        self._check_block(lo + 1, done + 1)
        failed = block.failed
        if self.failure is None and failed is not None:
            what = failed.reason if isinstance(failed, StepError) else f"the forward dynamics failed ({failed})"
            self._fail(done + 1, done + 1, what, during_step=True)
        if self.failure is not None:
            return False
        self.checked = done + 1
        if block.interrupted:
            self._interrupt(done + 1)
            return False
        return True

    def _store(self, lo: int, qs: list[Array], us: list[Array], ks: list[Array | None]) -> None:
        """Samples lo+1 .. lo+len(qs) and the rates at samples lo .. lo+len(qs)-1."""
        if not qs:
            return
        hi = lo + len(qs)
        self.Q[lo + 1 : hi + 1] = qs
        self.U[lo + 1 : hi + 1] = us
        nv = self.system.nv
        if all(k is not None for k in ks):
            self.A[lo:hi] = np.asarray(ks)[:, :nv]
        else:
            for i, k in enumerate(ks):
                if k is not None:
                    self.A[lo + i] = k[:nv]

    def _check_block(self, lo: int, hi: int) -> None:
        """Samples lo .. hi-1 are new: find the first non-finite or over-energetic one."""
        if hi <= lo:
            return
        finite = np.isfinite(self.Q[lo:hi]).all(axis=1) & np.isfinite(self.U[lo:hi]).all(axis=1)
        end = hi if finite.all() else lo + int(np.argmin(finite))
        self._energies(lo, end)
        if self._over_bound(lo, end):
            return
        if end < hi:
            self._fail(end, end, "the state is not finite (q or v is inf or NaN)")

    def _over_bound(self, lo: int, hi: int) -> bool:
        if hi <= lo or not np.isfinite(self.bound):
            return False
        residual = np.abs(self._residual(lo, hi))
        over = ~(residual <= self.bound)
        if not over.any():
            return False
        first = lo + int(np.argmax(over))
        error = float(residual[first - lo])
        what = (
            f"the energy error |E - E0 - W| = {error:.3g} J exceeds the bound {self.bound:.3g} J "
            f"(max_energy_growth x the energy scale {self.scale:.3g} J)"
            if np.isfinite(error)
            else f"the energy error |E - E0 - W| is {error} (the step overflowed float64)"
        )
        self._fail(first, first + 1, what)
        return True

    def _fail(self, step: int, keep: int, what: str, *, during_step: bool = False) -> None:
        """Stop at ``step`` (the step that produced sample ``step``, or failed to); keep samples [0, keep).

        One sentence: where (step and time), what (the criterion), the likely cause and one suggestion.
        """
        last = self.t.size - 1
        t_fail = float(self.t[min(step, last)])
        if during_step:  # the step from t[step - 1] to t[step] could not be taken
            where = f"step {step} (t = {float(self.t[step - 1]):.6g} -> {t_fail:.6g} s)"
        else:
            where = f"step {step} (t = {t_fail:.6g} s)"
        cause, suggestion = diagnose(
            self.method, float(self.t[1] - self.t[0]), self.system, [self.Q[keep - 1]], reason=what
        )
        self.failure = (step, t_fail, f"diverged at {where}: {what}; likely cause: {cause}; {suggestion}")
        self.n = keep
        self.A[step:] = np.nan  # rates from steps after the failure are not counted: recompute them
        work = self._block_work
        index = step - 1 - self._block_lo  # the step that produced (or failed to produce) sample ``step``
        self.work = work[min(max(index, 0), len(work) - 1)] if work else self._counters()
        marks = self._block_marks
        if marks:  # the events of the kept steps only: sample keep - 1 is the last kept
            self.stepper.rewind(marks[min(max(keep - 1 - self._block_lo, 0), len(marks) - 1)], self.Q[keep - 1])

    def _interrupt(self, keep: int) -> None:
        """Ctrl-C: keep samples [0, keep); the work is what was done until then."""
        t_stop = float(self.t[keep - 1])
        self.interrupted = (keep - 1, t_stop, f"interrupted after step {keep - 1} (t = {t_stop:.6g} s)")
        self.n = keep
        self.work = self._counters()

    def trajectory(self, wall_time: float, meta: dict[str, Any]) -> Trajectory:
        """Package the kept samples, filling in accelerations and torques."""
        n, nv, system = self.n, self.system.nv, self.system
        t, Q, U, A = self.t[:n], self.Q[:n], self.U[:n], self.A[:n]
        missing = np.flatnonzero(np.isnan(A).any(axis=1))
        before = system.evaluations
        with np.errstate(all="ignore"):
            for k in missing:
                try:
                    A[k] = system.rates(float(t[k]), Q[k], U[k])[:nv]
                except (StepError, np.linalg.LinAlgError):  # where the run failed: left NaN
                    continue
        evaluations, jacobians = self.work if self.work is not None else self._counters()
        evaluations += system.evaluations - before  # the accelerations filled in just now
        tau, clamped = self._torques(t, Q, U[:, :nv])
        works = U[:, nv:] if system.nw else np.zeros((n, 2))
        if self.failure is not None:
            status, message = "diverged", self.failure[2]
        elif self.interrupted is not None:
            status, message = "interrupted", self.interrupted[2]
        else:
            status, message = "ok", ""
        meta["evaluations_jacobian"] = jacobians
        meta["effort_clamped_samples"] = clamped
        drift = system.loops.drift_series(Q) if system.loops is not None else None
        meta.update(self._constraint_meta(drift))
        return Trajectory(
            t=t.copy(),
            q=Q.copy(),
            v=U[:, :nv].copy(),
            a=A.copy(),
            tau=tau,
            kinetic=self.kinetic[:n].copy(),
            potential=self.potential[:n].copy(),
            work_input=works[:, 0].copy(),
            work_damping=works[:, 1].copy(),
            work_limits=self.work_limits[:n].copy(),
            wall_time_s=float(wall_time),
            evaluations=int(evaluations),
            status=status,
            message=message,
            meta=meta,
            constraint_drift=drift,
        )

    def _torques(self, t: Array, Q: Array, V: Array) -> tuple[Array, int]:
        """The applied (clamped) torque of every sample (n, nv), and how many samples were clamped."""
        system = self.system
        source = system.torque
        if source.kind != "callable":
            command = system.commanded_torque(0.0, Q[0], V[0])
            clamped = int(t.size) if np.any(command != source.constant) else 0
            return np.tile(source.constant, (t.size, 1)), clamped
        command = np.empty_like(V)
        for k in range(t.size):
            command[k] = system.commanded_torque(float(t[k]), Q[k], V[k])
        return system.effort.clamp_batch(command), int(np.count_nonzero(system.effort.clamped(command)))

    def _constraint_meta(self, drift: Array | None) -> dict[str, Any]:
        """What the constraints did: impacts, releases, the worst excursion past a stop, the loop drift (its max)."""
        stepper, system = self.stepper, self.system
        worst, joint = system.stops.violation(self.Q[: self.n])
        meta: dict[str, Any] = {
            "work_limits": float(self.work_limits[self.n - 1]),
            "impacts": stepper.n_impacts,
            "releases": stepper.n_releases,
            "impact_log": [vars(r) for r in stepper.impacts],
            "held_at_end": sorted(system.stops.names[k] for k in system.held),
            "limit_violation": worst,
            "limit_violation_joint": joint,
        }
        if drift is not None:
            meta["loop_drift"] = float(np.max(drift, initial=0.0))
            meta["loop_projections"] = stepper.projections
        return meta
