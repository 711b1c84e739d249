"""Work against precision: every integrator, step and dynamics backend, measured against a reference.

For one robot and one start state, :func:`sweep` runs

* every fixed-step integrator over a ladder of steps dt, and every adaptive one over a ladder
  of tolerances rtol, through :func:`robodyn.simulate`;
* the integrators of ``SweepPlan.all_backends_for`` on every dynamics backend (Pinocchio ABA,
  CRBA + Cholesky, the NumPy hand formula) and, for the built-in kinds, on the compiled fast path
  (:mod:`robodyn.sim.fast`);

and measures for each run:

* ``error``: the relative state error max_k |x_k - x_ref,k|_inf / max_k |x_ref,k|_inf over the
  samples t_k = k * sample_interval <= error_horizon, with x = (q, v) and x_ref from scipy's
  DOP853 at rtol = 1e-12 (its own accuracy confirmed by a rerun at rtol / 10, kept in
  :class:`Reference`);
* ``wall_time_s``: wall time per simulated second [s/s] (the integration loop only);
* ``evaluations``: forward-dynamics evaluations for the whole run;
* ``energy_drift``: max |E - E0 - W| / energy scale over the long ``energy_horizon``
  (the ledger residual, zero for the exact solution; the scale is simulate's max(T0 + |V0|, ...));
* ``diverged``: the run blew up or its energy error passed 100 % (simulate's default bound).

Results are frozen :class:`BenchResult` records; :func:`measured_order` fits the convergence
order, :func:`best_by_accuracy` answers "which method is cheapest at each accuracy".
Nothing here prints, plots or writes files.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn import integrators
from robodyn.errors import AssumptionError, BenchInterrupted, DivergenceError, InputError, RobodynError

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.sim.trajectory import Trajectory

Array = NDArray[np.float64]
Progress = Callable[[int, int, str], None]

# The reference and its tighter rerun must agree to this (relative state error): far below
# the smallest error the sweep is meant to resolve (~1e-10).
REFERENCE_AGREEMENT = 1e-10
# Orders are fitted on points whose error lies in this band: above the reference's own
# error (and round-off) and below the pre-asymptotic range.
ORDER_FIT_BAND = (1e-11, 1e-1)
# Accuracy levels of the report's "best method at each accuracy" table.
ACCURACY_LEVELS = (1e-2, 1e-4, 1e-6, 1e-8, 1e-10)


@dataclass(frozen=True)
class SweepPlan:
    """What a sweep runs: horizons [s], the dt and rtol ladders, integrators and backends.

    Every dt must divide ``sample_interval`` (errors are compared on that grid), which is also
    the output interval of the adaptive methods. ``all_backends_for`` names the integrators
    run on every backend; the others run on ABA only.
    """

    error_horizon: float
    energy_horizon: float
    sample_interval: float
    dts: tuple[float, ...]
    rtols: tuple[float, ...]
    fixed: tuple[str, ...]
    adaptive: tuple[str, ...]
    backends: tuple[str, ...]
    all_backends_for: tuple[str, ...]
    reference_rtol: float = 1e-12

    def __post_init__(self) -> None:
        if not (0 < self.sample_interval <= self.error_horizon <= self.energy_horizon):
            raise InputError(
                "need 0 < sample_interval <= error_horizon <= energy_horizon, got "
                f"{self.sample_interval}, {self.error_horizon}, {self.energy_horizon}"
            )
        for dt in self.dts:
            ratio = self.sample_interval / dt
            if dt <= 0 or abs(ratio - round(ratio)) > 1e-9 * ratio:
                raise InputError(f"dt = {dt} s does not divide the sample interval {self.sample_interval} s")
        for name in (*self.fixed, *self.adaptive):
            method = integrators.get(name)
            if method.adaptive != (name in self.adaptive):
                kind, other = ("adapts its step", "adaptive") if method.adaptive else ("takes fixed steps", "fixed")
                raise InputError(f"integrator {name!r} {kind}; list it under {other}")


# Registered integrators the default sweep leaves out, and why. Every other one is swept, so a
# new integrator joins the bench without an edit here.
NOT_SWEPT = {
    "scipy_bdf": "an implicit stiff solver like scipy_radau, which stands for them; BDF runs in the stiff study",
    "scipy_lsoda": "switches between Adams and BDF by itself; the non-stiff built-in kinds would show only Adams",
}
# Backends compared method for method (every other method runs on ABA only).
BACKENDS = ("aba", "crba", "formula", "fast")


def _sort_key(method: integrators.Integrator) -> tuple[bool, int, str]:
    return (method.implicit, method.order, method.name)


def swept_methods() -> tuple[list[integrators.Integrator], list[integrators.Integrator]]:
    """(fixed-step, adaptive) registered integrators of the sweep: explicit first, then by order and name."""
    methods = sorted((integrators.get(n) for n in integrators.names() if n not in NOT_SWEPT), key=_sort_key)
    return [m for m in methods if not m.adaptive], [m for m in methods if m.adaptive]


def default_plan(*, quick: bool = False) -> SweepPlan:
    """The sweep of ``robodyn bench`` (``quick``: a CI-sized subset that runs in seconds).

    Methods come from the integrator registry by their declared properties. The full sweep runs
    every fixed-step and every adaptive integrator (less ``NOT_SWEPT``), and the fixed-step methods
    the compiled fast path implements on every backend. The quick sweep runs the explicit
    fixed-step methods of the lowest and the highest order, the explicit adaptive method of the
    lowest order (ties by name), and the highest-order fast-path method on every backend.
    """
    from robodyn.sim.fast import METHODS as FAST_METHODS

    fixed, adaptive = swept_methods()
    on_every_backend = [m for m in fixed if m.name in FAST_METHODS]
    if quick:
        explicit = [m for m in fixed if not m.implicit]
        ends = {min(m.order for m in explicit), max(m.order for m in explicit)} if explicit else set()
        fixed = [m for m in explicit if m.order in ends]
        adaptive = sorted((m for m in adaptive if not m.implicit), key=lambda m: (m.order, m.name))[:1]
        on_every_backend = sorted(on_every_backend, key=lambda m: m.order)[-1:]
    names = (tuple(m.name for m in fixed), tuple(m.name for m in adaptive), tuple(m.name for m in on_every_backend))
    if quick:
        return SweepPlan(
            error_horizon=1.0,
            energy_horizon=2.0,
            sample_interval=0.02,
            dts=(0.02, 0.01, 0.005, 0.0025),
            rtols=(1e-4, 1e-6, 1e-8),
            fixed=names[0],
            adaptive=names[1],
            backends=BACKENDS,
            all_backends_for=names[2],
        )
    return SweepPlan(
        error_horizon=2.0,
        energy_horizon=10.0,
        sample_interval=0.02,
        dts=(0.02, 0.01, 0.005, 0.0025, 0.00125, 0.000625),
        rtols=(1e-3, 1e-5, 1e-7, 1e-9, 1e-11),
        fixed=names[0],
        adaptive=names[1],
        backends=BACKENDS,
        all_backends_for=names[2],
    )


@dataclass(frozen=True)
class BenchResult:
    """One run of the sweep (see the module docstring for the measures and their units)."""

    model: str
    integrator: str
    backend: str
    dt: float | None
    rtol: float | None
    error: float
    wall_time_s: float
    evaluations: int
    energy_drift: float
    diverged: bool
    order: int
    adaptive: bool
    symplectic: bool
    duration: float

    def as_record(self) -> dict[str, Any]:
        """A JSON-ready dict (non-finite numbers as None)."""
        out: dict[str, Any] = {}
        for key, value in self.__dict__.items():
            out[key] = None if isinstance(value, float) and not math.isfinite(value) else value
        return out

    @property
    def label(self) -> str:
        """``integrator/backend``."""
        return f"{self.integrator}/{self.backend}"


@dataclass(frozen=True, eq=False)
class Reference:
    """DOP853 reference: states (n, nq), (n, nv) at ``t`` (n,); ``self_error`` against rtol / 10."""

    t: Array
    q: Array
    v: Array
    rtol: float
    self_error: float
    wall_time_s: float


@dataclass(frozen=True, eq=False)
class EnergySeries:
    """The relative energy error (E - E0 - W) / scale against time, for the energy chart."""

    integrator: str
    backend: str
    dt: float
    t: Array
    error: Array


@dataclass(frozen=True, eq=False)
class Sweep:
    """Everything one model's sweep produced."""

    model: str
    kind: str | None
    q0: Array
    v0: Array
    plan: SweepPlan
    reference: Reference
    results: tuple[BenchResult, ...]
    energy: tuple[EnergySeries, ...] = field(default=())
    skipped: tuple[str, ...] = field(default=())


# Where a start offset would pass a joint's limit, the joint starts this fraction of its range
# inside that limit instead (a start outside would be moved onto the stop by simulate).
INSIDE_RANGE = 0.1


def start_state(robot: Robot) -> tuple[Array, Array]:
    """The bench's start: 0.5 rad (or m) from neutral on the first joint, -0.3 on the others, at rest.

    Away from any equilibrium, so that every joint moves, and torque-free, so that the energy
    ledger reduces to E - E0 - W_damping. A joint of one coordinate whose offset would pass its
    URDF limit starts ``INSIDE_RANGE`` of its range inside that limit (a prismatic joint of range
    [0, 0.2] m starts at 0.02 m, not at -0.3 m).
    """
    offsets = np.full(robot.nv, -0.3)
    offsets[0] = 0.5
    q = robot.integrate(robot.neutral(), offsets)
    lower, upper = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    for i in (j.idx_q for j in robot.joints if j.nq == j.nv == 1):
        lo, hi = float(lower[i]), float(upper[i])  # Pinocchio's unbounded default is +-max float: no range
        if np.isfinite(hi - lo) and 0 < hi - lo < 1e300 and not lo <= q[i] <= hi:
            q[i] = min(max(q[i], lo + INSIDE_RANGE * (hi - lo)), hi - INSIDE_RANGE * (hi - lo))
    return q, np.zeros(robot.nv)


def reference(
    robot: Robot, q0: Array, v0: Array, *, duration: float, sample_interval: float, rtol: float = 1e-12
) -> Reference:
    """DOP853 at ``rtol`` (atol = rtol * 1e-2), sampled every ``sample_interval``, and checked.

    Raises:
        RobodynError: the rerun at rtol / 10 disagrees by more than REFERENCE_AGREEMENT.
    """
    from robodyn.sim.simulation import simulate

    def run(tol: float) -> Trajectory:
        return simulate(
            robot, q0, v0, duration=duration, dt=sample_interval, integrator="scipy_dop853", rtol=tol, atol=tol * 1e-2
        )

    start = time.perf_counter()
    main = run(rtol)
    wall = time.perf_counter() - start
    tight = run(rtol / 10.0)
    self_error = _relative_error(main.q, main.v, tight.q, tight.v)
    if not self_error <= REFERENCE_AGREEMENT:
        raise RobodynError(
            f"{robot.name}: the DOP853 reference at rtol {rtol:g} and its rerun at {rtol / 10:g} differ by "
            f"{self_error:.3g} (relative), expected <= {REFERENCE_AGREEMENT:g}; shorten the error horizon"
        )
    return Reference(main.t, main.q, main.v, rtol, self_error, wall)


def _relative_error(q: Array, v: Array, q_ref: Array, v_ref: Array) -> float:
    x = np.hstack([q, v])
    x_ref = np.hstack([q_ref, v_ref])
    if not np.all(np.isfinite(x)):
        return float("inf")
    return float(np.max(np.abs(x - x_ref)) / max(float(np.max(np.abs(x_ref))), 1e-300))


def error_against(traj: Trajectory, ref: Reference, step: float) -> float:
    """Error of ``traj`` (sampled every ``step``) on the reference grid, inf if it ended early."""
    stride = round((ref.t[1] - ref.t[0]) / step)
    idx = stride * np.arange(ref.t.size)
    if idx[-1] >= traj.t.size:
        return float("inf")
    return _relative_error(traj.q[idx], traj.v[idx], ref.q, ref.v)


def _energy_error(traj: Trajectory, scale: float) -> Array:
    return traj.ledger_residual / scale


def run_one(
    robot: Robot,
    fast: Any,
    name: str,
    backend: str,
    q0: Array,
    v0: Array,
    *,
    dt: float,
    rtol: float | None,
    duration: float,
    scale: float,
) -> tuple[Trajectory, bool]:
    """One run; returns the (possibly truncated) trajectory and whether it diverged.

    The fast path does not stop on energy; it is held to simulate's bound (100 % of ``scale``) here.
    """
    from robodyn.sim.simulation import DEFAULT_MAX_ENERGY_GROWTH, simulate

    if backend == "fast" and fast is None:  # not a built-in kind: the compiled loop simulate runs by default
        backend = "numba"
    elif backend == "fast":
        traj = fast.simulate(q0, v0, duration=duration, dt=dt, method=name)
        over = not np.all(np.abs(traj.ledger_residual) <= DEFAULT_MAX_ENERGY_GROWTH * scale)
        return traj, bool(traj.diverged or over)
    options: dict[str, Any] = {"rtol": rtol, "atol": rtol * 1e-2} if rtol is not None else {}
    try:
        traj = simulate(robot, q0, v0, duration=duration, dt=dt, integrator=name, backend=backend, **options)
    except DivergenceError as exc:
        if exc.trajectory is None:  # simulate always attaches the partial run
            raise
        return exc.trajectory, True
    return traj, traj.diverged


def _jobs(plan: SweepPlan, backends: Sequence[str]) -> list[tuple[str, str, float | None, float | None]]:
    """(integrator, backend, dt, rtol) for every run of the plan."""
    from robodyn.sim.fast import METHODS as FAST_METHODS

    jobs: list[tuple[str, str, float | None, float | None]] = []
    for name in plan.fixed:
        for backend in backends if name in plan.all_backends_for else ("aba",):
            if backend == "fast" and name not in FAST_METHODS:
                continue
            jobs.extend((name, backend, dt, None) for dt in plan.dts)
    for name in plan.adaptive:
        for backend in backends if name in plan.all_backends_for else ("aba",):
            if backend == "fast":
                continue
            jobs.extend((name, backend, None, rtol) for rtol in plan.rtols)
    return jobs


def sweep(
    robot: Robot,
    *,
    plan: SweepPlan | None = None,
    q0: Array | None = None,
    v0: Array | None = None,
    progress: Progress | None = None,
) -> Sweep:
    """Run the work--precision sweep of ``plan`` on ``robot`` (see the module docstring).

    Backends that do not apply are skipped and named in ``Sweep.skipped``: ``formula`` needs a
    built-in kind (Pendubot, cart-pole, geared arm). ``fast`` is the compiled closed form of a
    built-in kind (no Coulomb friction), and on any other robot the compiled whole-run loop that
    ``simulate`` runs by default (backend ``numba``), skipped only where that loop does not apply.
    ``progress(done, total, label)`` is called after every run. A Ctrl-C raises
    :class:`~robodyn.errors.BenchInterrupted` holding the runs finished so far.
    """
    from robodyn.kinds import catalog
    from robodyn.kinds.params import detect_kind
    from robodyn.sim import energy

    plan = plan or default_plan()
    if q0 is None or v0 is None:
        q0, v0 = start_state(robot)
    q0, v0 = robot.q_(q0), robot.v_(v0)
    kind = detect_kind(robot)
    backends: list[str] = []
    skipped: list[str] = []
    fast = None
    for backend in plan.backends:
        if backend == "formula" and kind is None:
            skipped.append(f"{backend}: {robot.name} is not a built-in kind ({catalog.listed()})")
            continue
        if backend == "fast" and kind is None:
            why = _compiled_loop_refusal(robot, q0, v0, plan)
            if why is not None:
                skipped.append(f"fast: {why}")
                continue
        elif backend == "fast":
            from robodyn.sim.fast import FastDynamics

            try:
                fast = FastDynamics.from_robot(robot, kind)
            except AssumptionError as exc:
                skipped.append(f"fast: {exc}")
                continue
        backends.append(backend)
    ref = reference(
        robot, q0, v0, duration=plan.error_horizon, sample_interval=plan.sample_interval, rtol=plan.reference_rtol
    )
    scale = energy.energy_scale(robot, robot.kinetic_energy(q0, v0), robot.potential_energy(q0))
    jobs = _jobs(plan, backends)
    results: list[BenchResult] = []
    series: list[EnergySeries] = []
    try:
        _run_jobs(robot, fast, plan, jobs, q0, v0, ref, scale, results, series, progress)
    except KeyboardInterrupt:
        partial = Sweep(robot.name, kind, q0, v0, plan, ref, tuple(results), tuple(series), tuple(skipped))
        raise BenchInterrupted(
            f"interrupted after {len(results)} of {len(jobs)} runs of {robot.name}", sweep=partial
        ) from None
    return Sweep(robot.name, kind, q0, v0, plan, ref, tuple(results), tuple(series), tuple(skipped))


def _compiled_loop_refusal(robot: Robot, q0: Array, v0: Array, plan: SweepPlan) -> str | None:
    """Why simulate's compiled whole-run loop does not run ``robot`` (a two-step trial run), or None."""
    from robodyn.sim.fast import METHODS as FAST_METHODS
    from robodyn.sim.simulation import simulate

    names = [m for m in (*plan.fixed, *plan.adaptive) if m in FAST_METHODS]
    if not names:
        return None
    dt = plan.dts[0] if plan.dts else plan.sample_interval
    try:
        trial = simulate(robot, q0, v0, duration=2 * dt, dt=dt, integrator=names[0], backend="numba")
    except RobodynError as exc:
        return f"the compiled loop refused {robot.name}: {exc}"
    if trial.meta.get("loop") != "compiled":
        return f"{robot.name}: compiled loop {trial.meta.get('compiled_loop')}"
    return None


def _run_jobs(
    robot: Robot,
    fast: Any,
    plan: SweepPlan,
    jobs: list[tuple[str, str, float | None, float | None]],
    q0: Array,
    v0: Array,
    ref: Reference,
    scale: float,
    results: list[BenchResult],
    series: list[EnergySeries],
    progress: Progress | None,
) -> None:
    """Run ``jobs`` in order, appending each result to ``results`` (and energy series to ``series``)."""
    energy_dt = plan.dts[len(plan.dts) // 2] if plan.dts else None
    for done, (name, backend, dt, rtol) in enumerate(jobs, start=1):
        method = integrators.get(name)
        step = dt if dt is not None else plan.sample_interval
        traj, diverged = run_one(
            robot, fast, name, backend, q0, v0, dt=step, rtol=rtol, duration=plan.energy_horizon, scale=scale
        )
        simulated = float(traj.t[-1]) if traj.t.size > 1 else step
        residual = _energy_error(traj, scale)
        results.append(
            BenchResult(
                model=robot.name,
                integrator=name,
                backend=backend,
                dt=dt,
                rtol=rtol,
                error=float("inf") if diverged and traj.t[-1] < plan.error_horizon else error_against(traj, ref, step),
                wall_time_s=float(traj.wall_time_s) / simulated,
                evaluations=int(traj.evaluations),
                energy_drift=float("inf") if diverged else float(np.max(np.abs(residual))),
                diverged=bool(diverged),
                order=method.order,
                adaptive=method.adaptive,
                symplectic=method.symplectic,
                duration=simulated,
            )
        )
        if backend == "aba" and dt is not None and dt == energy_dt:
            series.append(EnergySeries(name, backend, dt, traj.t.copy(), residual.copy()))
        if progress is not None:
            progress(done, len(jobs), f"{robot.name} {name}/{backend} " + (f"dt={dt:g}" if dt else f"rtol={rtol:g}"))


def measured_order(results: Sequence[BenchResult], integrator: str, backend: str = "aba") -> float | None:
    """Least-squares slope of log(error) against log(dt) for one integrator and backend.

    Only points with an error inside ORDER_FIT_BAND count; None if fewer than two remain.
    """
    pts = [
        (r.dt, r.error)
        for r in results
        if r.integrator == integrator
        and r.backend == backend
        and r.dt is not None
        and not r.diverged
        and ORDER_FIT_BAND[0] <= r.error <= ORDER_FIT_BAND[1]
    ]
    if len(pts) < 2:
        return None
    x = np.log([p[0] for p in pts])
    y = np.log([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def best_by_accuracy(
    results: Sequence[BenchResult], levels: Sequence[float] = ACCURACY_LEVELS
) -> list[tuple[float, BenchResult | None]]:
    """For each accuracy level, the cheapest (wall time per simulated second) run that reaches it."""
    table = []
    for level in levels:
        fit = [r for r in results if not r.diverged and r.error <= level]
        table.append((level, min(fit, key=lambda r: r.wall_time_s) if fit else None))
    return table


def records(sweeps: Sequence[Sweep]) -> list[dict[str, Any]]:
    """Every result of every sweep as JSON-ready records (the content of ``bench.json``)."""
    return [r.as_record() for s in sweeps for r in s.results]
