"""Simulate a robot: integrate its dynamics, keep the energy books, stop where it blows up.

:func:`simulate` assembles a :class:`robodyn.sim.system.RobotSystem` (robot + backend + losses
+ torque), steps it with an integrator from :mod:`robodyn.integrators`, records every
step, and returns a :class:`robodyn.Trajectory` whose ledger residual
E(t) - E(0) - W_input(t) - W_damping(t) measures the integrator's error.

Divergence is watched block by block (every ``CHECK_EVERY`` steps, then located to the
exact step): a non-finite state, a step the method cannot take, or an energy error above
``max_energy_growth`` times the energy scale stops the run; :class:`DivergenceError`
then carries the trajectory up to that step. A KeyboardInterrupt (Ctrl-C) during the run
stops it too: :class:`SimulationInterrupted` (a KeyboardInterrupt) carries the trajectory
up to the last step taken, with status ``"interrupted"``.

Before the run, q0 is checked (a ``continuous`` joint's cos/sin pair and a quaternion must
have norm 1 within ``UNIT_NORM_TOL``) and so is M(q0): a singular mass matrix is refused
rather than integrated into a blow-up that would look like the integrator's fault.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics, integrators
from robodyn.errors import DivergenceError, InputError, ModelError, SimulationInterrupted, StepError
from robodyn.integrators import Integrator
from robodyn.sim import energy
from robodyn.sim.system import SINGULAR_MASS_RTOL, RobotSystem, TorqueFn, coordinate_units, robot_system
from robodyn.sim.trajectory import Trajectory

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

# Steps between divergence checks; a failure is then located to its exact step.
CHECK_EVERY = 512

# Longest run robodyn will preallocate, in steps (memory: (nq + 2 nv + 4) floats a step).
MAX_STEPS = 50_000_000

DEFAULT_MAX_ENERGY_GROWTH = 1.0

# A cos/sin pair or a quaternion in q0 must have norm 1 to this absolute tolerance: what a
# configuration written with ~16 digits (or integrated by pin.integrate) satisfies, while a
# hand-typed pair off by a visible digit does not.
UNIT_NORM_TOL = 1e-9

# Joints whose configuration holds a unit vector: kind prefix -> (first, last) index of
# that vector within the joint's q, and what it is.
_UNIT_BLOCKS = (
    ("JointModelFreeFlyer", 3, 7, "quaternion (x, y, z, w)"),
    ("JointModelSpherical", 0, 4, "quaternion (x, y, z, w)"),
    ("JointModelPlanar", 2, 4, "(cos, sin) pair"),
    ("JointModelRUB", 0, 2, "(cos, sin) pair"),
    ("JointModelRevoluteUnbounded", 0, 2, "(cos, sin) pair"),
)


def simulate(
    robot: Robot,
    q0: ArrayLike,
    v0: ArrayLike,
    *,
    duration: float,
    dt: float,
    integrator: str | Integrator = "rk4",
    torque: ArrayLike | TorqueFn | None = None,
    backend: str | None = None,
    losses: bool = True,
    rtol: float = 1e-9,
    atol: float = 1e-12,
    max_energy_growth: float | None = DEFAULT_MAX_ENERGY_GROWTH,
) -> Trajectory:
    """Integrate ``robot`` from (q0, v0) for ``duration`` seconds and return the trajectory.

    Args:
        robot: the robot (see :func:`robodyn.load`).
        q0: initial configuration, nq entries [rad | m]; for models with ``continuous``
            joints (nq > nv) nv joint angles are accepted too. Cos/sin pairs and
            quaternions must have norm 1 within ``UNIT_NORM_TOL``.
        v0: initial velocity (nv,) [rad/s | m/s].
        duration: simulated time [s], > 0.
        dt: time step [s], > 0 and <= duration; the output interval of adaptive methods,
            whose own steps are error-controlled (and never straddle an output time).
        integrator: a name from :func:`robodyn.integrators.names` or an integrator object.
        torque: None, a constant vector (nv entries, or one per actuated joint) [N m | N],
            or a callable tau(t, q, v) -- the controller hook. Passive joints get none.
        backend: forward dynamics: ``"aba"``, ``"crba"`` or ``"formula"``; None picks
            ``"aba"``, or ``"crba"`` on a model with mimic joints (which ABA refuses).
        losses: apply the URDF joint damping and friction (their work is booked).
        rtol: relative tolerance of the adaptive methods.
        atol: absolute tolerance of the adaptive methods.
        max_energy_growth: stop when |ledger residual| exceeds this many times the
            energy scale max(T0 + |V0|, m |g| 0.1 m); None never stops on energy.

    Returns:
        The :class:`Trajectory`, sampled at every step (n_steps + 1 samples).

    Raises:
        InputError: bad vectors (a cos/sin pair or quaternion off the unit sphere
            included), dt, duration, torque or tolerances; backend ``"aba"`` on a model
            with mimic joints.
        ModelError: M(q0) is singular (a velocity direction that moves no mass or inertia).
        UnknownNameError: an unknown integrator or backend.
        DivergenceError: the run blew up; ``.trajectory`` holds it up to the failing step.
        SimulationInterrupted: Ctrl-C during the run; ``.trajectory`` holds it so far.
    """
    duration, dt = _check_times(duration, dt)
    method = integrators.get(integrator) if isinstance(integrator, str) else integrator
    q = configuration(robot, q0)
    v = robot.v_(v0, "v0")
    if max_energy_growth is not None and not max_energy_growth > 0:
        raise InputError(f"max_energy_growth must be > 0 or None, got {max_energy_growth!r}")
    system = robot_system(robot, backend=backend, torque=torque, losses=losses)
    _refuse_singular_mass(robot, system, q)
    check = energy.cross_check(robot, q, v)
    t_grid = _time_grid(duration, dt)
    run = _Run(robot, system, method, t_grid, q, v, rtol=rtol, atol=atol, max_energy_growth=max_energy_growth)
    start = time.perf_counter()
    run.integrate()
    trajectory = run.trajectory(time.perf_counter() - start, _meta(robot, system, method, run, dt, duration, check))
    if run.failure is not None:
        step, t_fail, message = run.failure
        raise DivergenceError(message, step=step, time=t_fail, trajectory=trajectory)
    if run.interrupted:
        raise SimulationInterrupted(trajectory.message, trajectory=trajectory)
    return trajectory


def configuration(robot: Robot, q0: ArrayLike) -> Array:
    """q0 as a configuration (nq,); on manifold models nv angles are integrated from neutral.

    Raises:
        InputError: the wrong number of entries, or a cos/sin pair or quaternion whose norm
            is not 1 within ``UNIT_NORM_TOL`` (naming the joint).
    """
    arr = np.asarray(q0, dtype=np.float64).reshape(-1) if not callable(q0) else None
    if arr is not None and robot.nq != robot.nv and arr.size == robot.nv:
        tangent = robot.v_(arr, "q0")
        return dynamics.integrate(robot.model, robot.neutral(), tangent)
    try:
        q = robot.q_(q0)
    except InputError:
        if robot.nq != robot.nv:
            raise InputError(
                f"q0 must have {robot.nq} entries (configuration) or {robot.nv} (joint angles) for {robot.name}, "
                f"got {np.size(q0)}"
            ) from None
        raise InputError(f"q0 must have {robot.nq} entries for {robot.name}, got {np.size(q0)}") from None
    check_unit_norms(robot, q, "q0")
    return q


def check_unit_norms(robot: Robot, q: Array, name: str = "q") -> None:
    """Raise :class:`InputError` if a cos/sin pair or quaternion of ``q`` (nq,) is off the unit sphere.

    The tolerance on | |x| - 1 | is ``UNIT_NORM_TOL``; the message names the joint.
    """
    for joint in robot.joints:
        for prefix, lo, hi, what in _UNIT_BLOCKS:
            if joint.kind.startswith(prefix):
                block = q[joint.idx_q + lo : joint.idx_q + hi]
                norm = float(np.linalg.norm(block))
                if not abs(norm - 1.0) <= UNIT_NORM_TOL:
                    values = ", ".join(f"{x:.10g}" for x in block)
                    hint = f" (or give q0 as {robot.nv} joint angles)" if "cos" in what else ""
                    raise InputError(
                        f"{name}: joint {joint.name!r} has the {what} ({values}) of norm {norm:.10g}; "
                        f"it must have norm 1 within {UNIT_NORM_TOL:g}{hint}"
                    )
                break


def _refuse_singular_mass(robot: Robot, system: RobotSystem, q: Array) -> None:
    """Raise :class:`ModelError` if M(q) is (numerically) singular: nothing could integrate that."""
    ratio, direction = system.mass_conditioning(q)
    if ratio > SINGULAR_MASS_RTOL:
        return
    raise ModelError(
        f"{robot.name}: the mass matrix M(q0) is singular (smallest eigenvalue {ratio:.2g} of the largest, "
        f"below {SINGULAR_MASS_RTOL:g}): the velocity direction {system.singular_direction(direction)} moves no "
        "mass, inertia or armature (e.g. a thin rod spinning about its own axis); give those links inertia "
        "or lock that motion"
    )


def _check_times(duration: float, dt: float) -> tuple[float, float]:
    for name, value in (("duration", duration), ("dt", dt)):
        if not isinstance(value, (int, float, np.floating)) or not np.isfinite(value) or value <= 0:
            raise InputError(f"{name} must be a positive number of seconds, got {value!r}")
    if dt > duration:
        raise InputError(f"dt must not exceed duration ({duration:g} s), got {dt:g} s")
    if duration / dt > MAX_STEPS:
        raise InputError(f"duration / dt = {duration / dt:.3g} steps; at most {MAX_STEPS:.0e} are allowed")
    return float(duration), float(dt)


def _time_grid(duration: float, dt: float) -> Array:
    """t_k = k dt up to ``duration``; a last, shorter step lands exactly on it."""
    n = int(np.ceil(duration / dt - 1e-9))
    t = dt * np.arange(n + 1, dtype=np.float64)
    t[-1] = duration
    return t


def _step_sizes(t: Array) -> list[float]:
    """Every step exactly dt = t[1] - t[0], but a last, shorter one that lands on t[-1]."""
    dt = float(t[1] - t[0])
    steps = [dt] * (t.size - 1)
    last = float(t[-1] - t[-2])
    if abs(last - dt) > 1e-9 * dt:
        steps[-1] = last
    return steps


def diagnose(method: Integrator, dt: float, system: RobotSystem, states: list[Array]) -> tuple[str, str]:
    """(likely cause, one suggestion) for a run of ``method`` at step ``dt`` [s] that failed.

    ``states`` are the finite configurations (nq,) around the failure: if M is singular at
    one of them, the integrator is not to blame.
    """
    for q in states:
        if not np.all(np.isfinite(q)):
            continue
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


class _Run:
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
    ) -> None:
        self.robot, self.system, self.method, self.t = robot, system, method, t
        n = t.size
        nv = system.nv
        self.Q = np.empty((n, system.nq))
        self.U = np.empty((n, nv + system.nw))
        self.A = np.full((n, nv), np.nan)
        self.kinetic = np.empty(n)
        self.potential = np.empty(n)
        self.Q[0] = q0
        self.U[0, :nv] = v0
        self.U[0, nv:] = 0.0
        self.stepper = method.start(system, float(t[0]), q0, self.U[0].copy(), t_end=float(t[-1]), rtol=rtol, atol=atol)
        self.meter = energy.EnergyMeter.for_robot(robot, q0)
        self.n = n  # samples kept (shrinks on failure)
        self.failure: tuple[int, float, str] | None = None
        self.interrupted: tuple[int, float, str] | None = None
        self.checked = 1  # samples [0, checked) are stored and checked
        # Evaluations (rates, jacobian) after each step of the current block, step lo + i at index i.
        self._block_lo = 0
        self._block_work: list[tuple[int, int]] = []
        self.work: tuple[int, int] | None = None  # evaluations spent on the kept samples, once known
        self._energies(0, 1)
        self.scale = energy.energy_scale(robot, float(self.kinetic[0]), float(self.potential[0]))
        self.bound = np.inf if max_energy_growth is None else max_energy_growth * self.scale
        self.rtol, self.atol = rtol, atol

    def _energies(self, lo: int, hi: int) -> None:
        nv = self.system.nv
        self.kinetic[lo:hi], self.potential[lo:hi] = self.meter(self.Q[lo:hi], self.U[lo:hi, :nv])

    def _residual(self, lo: int, hi: int) -> Array:
        nv = self.system.nv
        e = self.kinetic[lo:hi] + self.potential[lo:hi]
        w = self.U[lo:hi, nv:].sum(axis=1) if self.system.nw else 0.0
        return e - (self.kinetic[0] + self.potential[0]) - w

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
        """Every ``CHECK_EVERY`` steps store the block and check it."""
        times = self.t.tolist()
        steps = _step_sizes(self.t)
        advance = self.stepper.advance
        system = self.system
        q, u = self.Q[0].copy(), self.U[0].copy()
        n_steps = len(steps)
        with np.errstate(all="ignore"):
            for lo in range(0, n_steps, CHECK_EVERY):
                hi = min(lo + CHECK_EVERY, n_steps)
                qs: list[Array] = []
                us: list[Array] = []
                ks: list[Array | None] = []
                work: list[tuple[int, int]] = []
                self._block_lo, self._block_work = lo, work
                failed: BaseException | None = None
                interrupted = False
                try:
                    for k in range(lo, hi):
                        q, u, k_start = advance(times[k], q, u, steps[k])
                        qs.append(q)
                        us.append(u)
                        ks.append(k_start)
                        work.append((system.evaluations, system.jacobian_evaluations))
                except (StepError, np.linalg.LinAlgError) as exc:
                    failed = exc
                except KeyboardInterrupt:
                    interrupted = True
                done = lo + len(qs)
                if failed is not None or interrupted:
                    work.append(self._counters())  # the failed or interrupted step's work
                self._store(lo, qs, us, ks)
                self._check_block(lo + 1, done + 1)
                if self.failure is None and failed is not None:
                    what = failed.reason if isinstance(failed, StepError) else f"the forward dynamics failed ({failed})"
                    self._fail(done + 1, done + 1, what, during_step=True)
                if self.failure is not None:
                    return
                self.checked = done + 1
                if interrupted:
                    self._interrupt(done + 1)
                    return

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
        self._fail(
            first,
            first + 1,
            f"the energy error |E - E0 - W| = {residual[first - lo]:.3g} J exceeds the bound {self.bound:.3g} J "
            f"(max_energy_growth x the energy scale {self.scale:.3g} J)",
        )
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
        cause, suggestion = diagnose(self.method, float(self.t[1] - self.t[0]), self.system, [self.Q[keep - 1]])
        self.failure = (step, t_fail, f"diverged at {where}: {what}; likely cause: {cause}; {suggestion}")
        self.n = keep
        self.A[step:] = np.nan  # rates from steps after the failure are not counted: recompute them
        work = self._block_work
        index = step - 1 - self._block_lo  # the step that produced (or failed to produce) sample ``step``
        self.work = work[min(max(index, 0), len(work) - 1)] if work else self._counters()

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
                A[k] = system.rates(float(t[k]), Q[k], U[k])[:nv]
        evaluations, jacobians = self.work if self.work is not None else self._counters()
        evaluations += system.evaluations - before  # the accelerations filled in just now
        tau = self._torques(t, Q, U[:, :nv])
        works = U[:, nv:] if system.nw else np.zeros((n, 2))
        if self.failure is not None:
            status, message = "diverged", self.failure[2]
        elif self.interrupted is not None:
            status, message = "interrupted", self.interrupted[2]
        else:
            status, message = "ok", ""
        meta["evaluations_jacobian"] = jacobians
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
            wall_time_s=float(wall_time),
            evaluations=int(evaluations),
            status=status,
            message=message,
            meta=meta,
        )

    def _torques(self, t: Array, Q: Array, V: Array) -> Array:
        source = self.system.torque
        if source.kind != "callable":
            return np.tile(source.constant, (t.size, 1))
        tau = np.empty_like(V)
        for k in range(t.size):
            tau[k] = self.system.input_torque(float(t[k]), Q[k], V[k])
        return tau


def _meta(
    robot: Robot,
    system: RobotSystem,
    method: Integrator,
    run: _Run,
    dt: float,
    duration: float,
    check: energy.EnergyCheck,
) -> dict[str, Any]:
    q_units, v_units = coordinate_units(robot)
    meta: dict[str, Any] = {
        "model": robot.name,
        "urdf": str(robot.urdf_path) if robot.urdf_path is not None else None,
        "srdf": str(robot.srdf_path) if robot.srdf_path is not None else None,
        "integrator": method.name,
        "order": method.order,
        "symplectic": method.symplectic,
        "adaptive": method.adaptive,
        "implicit": method.implicit,
        "dt": dt,
        "duration": duration,
        "q0": run.Q[0].tolist(),
        "v0": run.U[0, : system.nv].tolist(),
        "energy_scale": run.scale,
        "energy_bound": None if not np.isfinite(run.bound) else run.bound,
        "energy_cross_check": check.relative_error,
        "joint_names": list(robot.joint_names),
        "q_units": q_units,
        "v_units": v_units,
    }
    meta.update(system.describe())
    if method.adaptive:
        meta["rtol"], meta["atol"] = run.rtol, run.atol
        meta["accepted_steps"] = getattr(run.stepper, "steps", None)
        meta["rejected_steps"] = getattr(run.stepper, "rejected", None)
    if run.failure is not None:
        meta["diverged_step"], meta["diverged_time"] = run.failure[0], run.failure[1]
    if run.interrupted is not None:
        meta["interrupted_step"], meta["interrupted_time"] = run.interrupted[0], run.interrupted[1]
    return meta
