"""Simulate a robot: integrate its dynamics, keep the energy books, stop where it blows up.

:func:`simulate` assembles a :class:`robodyn.system.RobotSystem` (robot + backend + losses
+ torque), steps it with an integrator from :mod:`robodyn.integrators`, records every
step, and returns a :class:`robodyn.Trajectory` whose ledger residual
E(t) - E(0) - W_input(t) - W_damping(t) measures the integrator's error.

Divergence is watched block by block (every ``CHECK_EVERY`` steps, then located to the
exact step): a non-finite state, a step the method cannot take, or an energy error above
``max_energy_growth`` times the energy scale stops the run; :class:`DivergenceError`
then carries the trajectory up to that step.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics, energy, integrators
from robodyn.errors import DivergenceError, InputError
from robodyn.integrators import Integrator, StepError
from robodyn.system import RobotSystem, TorqueFn, robot_system
from robodyn.trajectory import Trajectory

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

# Steps between divergence checks; a failure is then located to its exact step.
CHECK_EVERY = 512

# Longest run robodyn will preallocate, in steps (memory: (nq + 2 nv + 4) floats a step).
MAX_STEPS = 50_000_000

DEFAULT_MAX_ENERGY_GROWTH = 1.0


def simulate(
    robot: Robot,
    q0: ArrayLike,
    v0: ArrayLike,
    *,
    duration: float,
    dt: float,
    integrator: str | Integrator = "rk4",
    torque: ArrayLike | TorqueFn | None = None,
    backend: str = "aba",
    losses: bool = True,
    rtol: float = 1e-9,
    atol: float = 1e-12,
    max_energy_growth: float | None = DEFAULT_MAX_ENERGY_GROWTH,
) -> Trajectory:
    """Integrate ``robot`` from (q0, v0) for ``duration`` seconds and return the trajectory.

    Args:
        robot: the robot (see :func:`robodyn.load`).
        q0: initial configuration, nq entries [rad | m]; for models with ``continuous``
            joints (nq > nv) nv joint angles are accepted too.
        v0: initial velocity (nv,) [rad/s | m/s].
        duration: simulated time [s], > 0.
        dt: time step [s], > 0 and <= duration; the output interval of adaptive methods,
            whose own steps are error-controlled (and never straddle an output time).
        integrator: a name from :func:`robodyn.integrators.names` or an integrator object.
        torque: None, a constant vector (nv entries, or one per actuated joint) [N m | N],
            or a callable tau(t, q, v) -- the controller hook. Passive joints get none.
        backend: forward dynamics: ``"aba"``, ``"crba"`` or ``"formula"``.
        losses: apply the URDF joint damping and friction (their work is booked).
        rtol: relative tolerance of the adaptive methods.
        atol: absolute tolerance of the adaptive methods.
        max_energy_growth: stop when |ledger residual| exceeds this many times the
            energy scale max(T0 + |V0|, m |g| 0.1 m); None never stops on energy.

    Returns:
        The :class:`Trajectory`, sampled at every step (n_steps + 1 samples).

    Raises:
        InputError: bad vectors, dt, duration, torque or tolerances.
        UnknownNameError: an unknown integrator or backend.
        DivergenceError: the run blew up; ``.trajectory`` holds it up to the failing step.
    """
    duration, dt = _check_times(duration, dt)
    method = integrators.get(integrator) if isinstance(integrator, str) else integrator
    q = configuration(robot, q0)
    v = robot.v_(v0, "v0")
    if max_energy_growth is not None and not max_energy_growth > 0:
        raise InputError(f"max_energy_growth must be > 0 or None, got {max_energy_growth!r}")
    system = robot_system(robot, backend=backend, torque=torque, losses=losses)
    check = energy.cross_check(robot, q, v)
    t_grid = _time_grid(duration, dt)
    run = _Run(robot, system, method, t_grid, q, v, rtol=rtol, atol=atol, max_energy_growth=max_energy_growth)
    start = time.perf_counter()
    run.integrate()
    trajectory = run.trajectory(time.perf_counter() - start, _meta(robot, system, method, run, dt, duration, check))
    if run.failure is not None:
        step, t_fail, message = run.failure
        raise DivergenceError(message, step=step, time=t_fail, trajectory=trajectory)
    return trajectory


def configuration(robot: Robot, q0: ArrayLike) -> Array:
    """q0 as a configuration (nq,); on manifold models nv angles are integrated from neutral."""
    arr = np.asarray(q0, dtype=np.float64).reshape(-1) if not callable(q0) else None
    if arr is not None and robot.nq != robot.nv and arr.size == robot.nv:
        tangent = robot.v_(arr, "q0")
        return dynamics.integrate(robot.model, robot.neutral(), tangent)
    try:
        return robot.q_(q0)
    except InputError:
        if robot.nq != robot.nv:
            raise InputError(
                f"q0 must have {robot.nq} entries (configuration) or {robot.nv} (joint angles) for {robot.name}, "
                f"got {np.size(q0)}"
            ) from None
        raise InputError(f"q0 must have {robot.nq} entries for {robot.name}, got {np.size(q0)}") from None


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


def likely_cause(method: Integrator, dt: float, system: RobotSystem) -> str:
    """A one-line guess at why ``method`` diverged at step ``dt`` [s]."""
    if method.name == "euler":
        cause = "explicit Euler is unstable at this dt; try a smaller dt or a symplectic method (symplectic_euler)"
    elif method.adaptive:
        cause = f"{method.name} could not follow the solution; the motion itself may blow up"
    elif method.implicit:
        cause = f"{method.name} cannot converge at dt = {dt:g} s; try a smaller dt"
    else:
        cause = f"{method.name} is unstable at dt = {dt:g} s; try a smaller dt or the adaptive dopri5"
    if system.torque.kind == "callable":
        cause += ", or the torque callable drives the robot without bound"
    return cause


class _Run:
    """One simulation: the stepping loop, the records, the divergence checks."""

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

    def integrate(self) -> None:
        """Step through the time grid; every ``CHECK_EVERY`` steps store the block and check it."""
        times = self.t.tolist()
        steps = _step_sizes(self.t)
        advance = self.stepper.advance
        q, u = self.Q[0].copy(), self.U[0].copy()
        n_steps = len(steps)
        with np.errstate(all="ignore"):
            for lo in range(0, n_steps, CHECK_EVERY):
                hi = min(lo + CHECK_EVERY, n_steps)
                qs: list[Array] = []
                us: list[Array] = []
                ks: list[Array | None] = []
                failed: BaseException | None = None
                try:
                    for k in range(lo, hi):
                        q, u, k_start = advance(times[k], q, u, steps[k])
                        qs.append(q)
                        us.append(u)
                        ks.append(k_start)
                except (StepError, np.linalg.LinAlgError) as exc:
                    failed = exc
                done = lo + len(qs)
                self._store(lo, qs, us, ks)
                self._check_block(lo + 1, done + 1)
                if self.failure is None and failed is not None:
                    self._fail(done + 1, done + 1, f"{failed}")
                if self.failure is not None:
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

    def _fail(self, step: int, keep: int, what: str) -> None:
        """Stop at ``step``; keep samples [0, keep)."""
        t_fail = float(self.t[min(step, self.t.size - 1)])
        cause = likely_cause(self.method, float(self.t[1] - self.t[0]), self.system)
        self.failure = (step, t_fail, f"diverged at step {step} (t = {t_fail:.6g} s): {what}; likely cause: {cause}")
        self.n = keep

    def trajectory(self, wall_time: float, meta: dict[str, Any]) -> Trajectory:
        """Package the kept samples, filling in accelerations and torques."""
        n, nv, system = self.n, self.system.nv, self.system
        t, Q, U, A = self.t[:n], self.Q[:n], self.U[:n], self.A[:n]
        missing = np.flatnonzero(np.isnan(A).any(axis=1))
        with np.errstate(all="ignore"):
            for k in missing:
                A[k] = system.rates(float(t[k]), Q[k], U[k])[:nv]
        tau = self._torques(t, Q, U[:, :nv])
        works = U[:, nv:] if system.nw else np.zeros((n, 2))
        status, message = ("ok", "") if self.failure is None else ("diverged", self.failure[2])
        meta["evaluations_jacobian"] = system.jacobian_evaluations
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
            evaluations=int(system.evaluations),
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
    }
    meta.update(system.describe())
    if method.adaptive:
        meta["rtol"], meta["atol"] = run.rtol, run.atol
        meta["accepted_steps"] = getattr(run.stepper, "steps", None)
        meta["rejected_steps"] = getattr(run.stepper, "rejected", None)
    if run.failure is not None:
        meta["diverged_step"], meta["diverged_time"] = run.failure[0], run.failure[1]
    return meta
