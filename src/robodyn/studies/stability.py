"""Where integrators fail on robots: stability limits predicted from the linearisation and measured by bisection.

The robot-free theory -- step matrices, stability regions, predicted limits, bisection,
Lyapunov exponents -- is :mod:`robodyn.integrators.stability` (its names are re-exported
here). This module applies it to robots:

* **Prediction.** :func:`linearise` gives q'' = K dq + D v about an equilibrium, with
  K = da/dq and D = da/dv from Pinocchio's analytical ABA derivatives (damping included);
  :func:`hanging_equilibrium` finds a stable one. ``predicted_limit(method, K, D)`` is then
  the largest stable step.
* **Measurement.** :func:`robot_blows_up` is the yes/no predicate that
  :func:`bisect_limit` bisects on: a torque-free ``simulate`` run failed when the state went
  non-finite, or the energy ledger E - E0 - W_damping (zero for the exact solution) grew
  beyond a multiple of the energy above equilibrium (:data:`CRITERIA`). :func:`limits` puts
  prediction and measurement side by side for every fixed-step method.
* **Stiffness, chaos and conditioning.** :func:`stiff_runs` runs every method on a stiff
  model above the explicit limits; :func:`chaos` estimates the Pendubot's Lyapunov exponent
  and one-ulp separation time; :func:`backend_accuracy` and :func:`near_singular` measure how
  each forward-dynamics backend copes with an ill-conditioned mass matrix.

Which methods the study runs is derived from the integrator registry (:func:`study_methods`),
never written out. Results are frozen dataclasses; nothing here prints or plots.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics, integrators
from robodyn.errors import InputError, RobodynError

# The robot-free theory, re-exported: ``stability.predicted_limit`` and friends keep working here.
from robodyn.integrators.stability import (
    BISECT_RTOL,
    BLOWUP_FACTOR,
    CAP_TIMES_FASTEST,
    CRITERIA,
    ENERGY_ERROR_FRACTION,
    EPS,
    RHO_SLACK,
    SCAN_START,
    Bisection,
    Lyapunov,
    Prediction,
    bisect_limit,
    criterion_factor,
    linear_blows_up,
    linear_problem,
    lyapunov,
    predicted_limit,
    region_grid,
    region_radius,
    separation_time,
    spectral_radius,
    step_matrix,
)
from robodyn.kinds import catalog, params
from robodyn.kinds.catalog import closed_form
from robodyn.kinds.formula import accelerations
from robodyn.studies.chaos import Chaos, chaos

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

__all__ = [
    "BISECT_RTOL",
    "BLOWUP_FACTOR",
    "CAP_TIMES_FASTEST",
    "CRITERIA",
    "ENERGY_ERROR_FRACTION",
    "EPS",
    "FIXED_METHODS",
    "LIGHT_VARIANT",
    "QUICK_FIXED_METHODS",
    "RHO_SLACK",
    "SCAN_START",
    "SMALL_OFFSET",
    "STIFF_VARIANT",
    "BackendAccuracy",
    "Bisection",
    "Chaos",
    "Limit",
    "Linearisation",
    "Lyapunov",
    "NearSingular",
    "Prediction",
    "StiffRun",
    "as_dict",
    "backend_accuracy",
    "bisect_limit",
    "chaos",
    "criterion_factor",
    "hanging_equilibrium",
    "limits",
    "linear_blows_up",
    "linear_problem",
    "linearise",
    "lyapunov",
    "near_singular",
    "pendubot_accel_longdouble",
    "predicted_limit",
    "region_grid",
    "region_radius",
    "robot_blows_up",
    "separation_time",
    "spectral_radius",
    "step_matrix",
    "stiff_runs",
    "study_methods",
    "variant_path",
]


# ------------------------------------------------------------------------------ linearisation
@dataclass(frozen=True, eq=False)
class Linearisation:
    """q'' = K dq + D v about (q_eq, v = 0): K = da/dq, D = da/dv (damping included), each (nv, nv)."""

    q_eq: Array
    K: Array
    D: Array

    @property
    def A(self) -> Array:
        """First-order system matrix [[0, I], [K, D]], (2 nv, 2 nv)."""
        nv = self.K.shape[0]
        return np.block([[np.zeros((nv, nv)), np.eye(nv)], [self.K, self.D]])

    @property
    def eigenvalues(self) -> NDArray[np.complex128]:
        """Eigenvalues of A [1/s], sorted by decreasing modulus."""
        lam = np.linalg.eigvals(self.A).astype(np.complex128)
        return lam[np.argsort(-np.abs(lam))]


def linearise(robot: Robot, q_eq: ArrayLike | None = None) -> Linearisation:
    """Linearise the torque-free, damped dynamics of ``robot`` about ``q_eq`` at rest.

    ``q_eq`` defaults to the neutral configuration; it should be an equilibrium (G(q_eq) = 0)
    for the prediction to describe small motions about it. Requires nq == nv.
    """
    if not robot.nq_equals_nv:
        raise InputError(
            f"{robot.name}: linearisation needs plain coordinates (nq == nv), got nq={robot.nq}, nv={robot.nv}"
        )
    q = robot.neutral() if q_eq is None else robot.q_(q_eq)
    zero = np.zeros(robot.nv)
    da_dq, da_dv, Minv = dynamics.aba_derivatives(robot.model, robot.data, q, zero, zero)
    D = da_dv - Minv @ np.diag(robot.damping)
    return Linearisation(q, da_dq, D)


def hanging_equilibrium(robot: Robot, *, seed: int = 0, iterations: int = 50) -> Array:
    """A stable equilibrium (G = 0, potential minimum) found by damped Newton on G from rest.

    Starts from the best of a few seeded configurations; raises :class:`RobodynError` when
    none converges (a model without gravity or with a free joint has no isolated one).
    """
    rng = np.random.default_rng(seed)
    best = None
    for _ in range(16):
        q, _v = robot.random_state(rng)
        for _ in range(iterations):
            G = robot.G(q)
            H = dynamics.aba_derivatives(robot.model, robot.data, q, np.zeros(robot.nv), np.zeros(robot.nv))[0]
            M = robot.M(q)
            dG = -M @ H  # dG/dq = -M da/dq at rest with zero torque
            step = np.linalg.lstsq(dG, -G, rcond=None)[0]
            q = robot.integrate(q, step)
            if np.max(np.abs(step)) < 1e-13:
                break
        if np.max(np.abs(robot.G(q))) > 1e-9:
            continue
        if best is None or robot.potential_energy(q) < robot.potential_energy(best) - 1e-12:
            best = q
    if best is None:
        raise RobodynError(f"{robot.name}: no equilibrium found (G(q) = 0) from 16 seeded starts")
    for j in robot.joints:  # revolute angles into (-pi, pi]
        if j.nq == 1 and ("Revolute" in j.kind or j.kind.startswith("JointModelR")):
            best[j.idx_q] = float(np.angle(np.exp(1j * best[j.idx_q])))
    return best


# ------------------------------------------------------------------------------ measurement
def robot_blows_up(
    robot: Robot,
    integrator: str,
    q0: ArrayLike,
    v0: ArrayLike,
    *,
    steps: int,
    q_eq: ArrayLike,
    backend: str = "aba",
    criterion: str = "blowup",
) -> Callable[[float], bool]:
    """Predicate for :func:`bisect_limit`: do ``steps`` torque-free simulate steps of dt fail?

    Failing: the run diverged (non-finite state or a failed step), or the energy-ledger residual
    |E - E0 - W_damping| exceeds CRITERIA[criterion] times the energy above the equilibrium
    ``q_eq`` (E0 - V(q_eq)).
    """
    from robodyn.sim.simulation import simulate

    q0_ = robot.q_(q0)
    v0_ = robot.v_(v0)
    factor = criterion_factor(criterion)
    scale = robot.kinetic_energy(q0_, v0_) + robot.potential_energy(q0_) - robot.potential_energy(q_eq)
    if scale <= 0:
        raise InputError(f"the start state has no energy above equilibrium ({scale:g} J); give it a velocity")

    def blows_up(dt: float) -> bool:
        try:
            traj = simulate(
                robot,
                q0_,
                v0_,
                duration=steps * dt,
                dt=dt,
                integrator=integrator,
                backend=backend,
                max_energy_growth=None,
            )
        except RobodynError:
            return True
        residual = traj.ledger_residual
        return bool(traj.diverged or not np.all(np.isfinite(residual)) or np.max(np.abs(residual)) > factor * scale)

    return blows_up


# ------------------------------------------------------------------------------ conditioning
@dataclass(frozen=True)
class BackendAccuracy:
    """Relative error of each backend's accelerations against an extended-precision closed form.

    ``errors`` maps backend name -> max relative error over ``states`` seeded states;
    ``condition`` is the largest cond(M) met.
    """

    model: str
    condition: float
    states: int
    errors: dict[str, float] = field(default_factory=dict)


def pendubot_accel_longdouble(p: dict[str, float], q: Array, v: Array, tau: Array) -> Array:
    """Pendubot forward dynamics in ``np.longdouble``: the reference of the conditioning study.

    It is the kind's one closed form, evaluated in extended precision by
    :func:`robodyn.kinds.formula.accelerations`.
    """
    form = closed_form("pendubot")
    L = np.longdouble
    a = accelerations(form, form.vector(p, L), [L(x) for x in q], [L(x) for x in v], [L(x) for x in tau])
    return np.array(a, dtype=np.float64)


def backend_accuracy(robot: Robot, *, states: int = 50, seed: int = 0) -> BackendAccuracy:
    """Errors of ABA, CRBA + Cholesky and the NumPy formula on a Pendubot-kind robot.

    The reference is the same closed form evaluated in extended precision (64-bit mantissa),
    so float64 round-off shows as ~1e-16 and loss to conditioning as more.
    """
    p = params.extract(robot, "pendubot").as_dict()
    formula = catalog.get("pendubot")
    rng = np.random.default_rng(seed)
    errors = {"aba": 0.0, "crba": 0.0, "formula": 0.0}
    cond = 0.0
    for _ in range(states):
        q, v = robot.random_state(rng)
        tau = rng.uniform(-1.0, 1.0, 2)
        ref = pendubot_accel_longdouble(p, q, v, tau)
        scale = float(np.max(np.abs(ref)))
        got = {
            "aba": robot.forward_dynamics(q, v, tau, backend="aba"),
            "crba": robot.forward_dynamics(q, v, tau, backend="crba"),
            "formula": formula.forward_dynamics(q, v, tau, p),
        }
        for name, a in got.items():
            errors[name] = max(errors[name], float(np.max(np.abs(a - ref))) / scale)
        cond = max(cond, float(np.linalg.cond(robot.M(q))))
    return BackendAccuracy(robot.name, cond, states, errors)


def as_dict(obj: Any) -> Any:
    """JSON-ready copy of a result of this module (arrays to lists, inf/nan to strings)."""
    from dataclasses import asdict, is_dataclass

    if is_dataclass(obj) and not isinstance(obj, type):
        return {k: as_dict(v) for k, v in asdict(obj).items()}
    if isinstance(obj, dict):
        return {k: as_dict(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [as_dict(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [as_dict(v) for v in obj.tolist()]
    if isinstance(obj, complex):
        return [as_dict(obj.real), as_dict(obj.imag)]
    if isinstance(obj, float | np.floating):
        x = float(obj)
        return x if np.isfinite(x) else str(x)
    return obj


# ------------------------------------------------------------------------------ the study
def study_methods(*, quick: bool = False) -> tuple[str, ...]:
    """The fixed-step methods the study runs, read from the registry: explicit before implicit, then by order.

    Every registered :class:`~robodyn.integrators.FixedStepIntegrator` takes part, sorted by
    (implicit, declared order, name). ``quick`` keeps a bracket of each kind instead: the
    explicit methods of the lowest and of the highest declared order (the first-order ones fail
    most differently -- explicit Euler on an oscillator at every step, kick-drift Euler only past
    h w = 2 -- and the highest-order one has the widest explicit region), and the implicit methods
    of the highest order (the A-stable end). With today's registry that is euler,
    semi_implicit_euler, rk4 and implicit_midpoint.
    """
    found = sorted(
        (integrators.get(name) for name in integrators.names(fixed_step=True)),
        key=lambda m: (m.implicit, m.order, m.name),
    )
    if quick:
        keep = []
        for implicit in (False, True):
            orders = {m.order for m in found if m.implicit == implicit}
            wanted = {min(orders, default=0), max(orders, default=0)} if not implicit else {max(orders, default=0)}
            keep += [m for m in found if m.implicit == implicit and m.order in wanted]
        found = keep
    return tuple(m.name for m in found)


# The full and the quick study's methods (``robodyn bench`` and ``bench --quick``).
FIXED_METHODS = study_methods()
QUICK_FIXED_METHODS = study_methods(quick=True)
STIFF_VARIANT = "geared_arm_stiff"
LIGHT_VARIANT = "pendubot_light_tip"
# Start of the limit runs: this far [rad | m] from the equilibrium on every joint, at rest,
# small enough for the linearisation to describe the motion.
SMALL_OFFSET = 0.05


def variant_path(name: str) -> Any:
    """Path of a URDF in the built-in ``models/variants`` folder."""
    from robodyn.model.files import models_dir

    return models_dir() / "variants" / f"{name}.urdf"


@dataclass(frozen=True)
class Limit:
    """Predicted and measured largest stable dt [s] of one integrator on one model.

    ``measured_dt_max`` bisects on blow-up (energy error x 100, what the linear theory
    predicts); ``energy_dt_max`` on an energy error over 100 %. ``ratio`` is
    measured / predicted (1 when theory and measurement agree).
    """

    case: str
    integrator: str
    fastest: float
    predicted_dt_max: float
    measured_dt_max: float
    energy_dt_max: float
    steps: int
    runs: int

    @property
    def ratio(self) -> float:
        """Measured / predicted, nan when either is 0 or inf."""
        p, m = self.predicted_dt_max, self.measured_dt_max
        if 0 < p < np.inf and 0 < m < np.inf:
            return m / p
        return float("nan")


def limits(
    robot: Robot,
    *,
    methods: tuple[str, ...] = FIXED_METHODS,
    steps: int = 2000,
    rtol: float = BISECT_RTOL,
    expand: float = 64.0,
) -> list[Limit]:
    """Predicted and measured limits for every method, from a small offset about the hanging equilibrium.

    The bisection brackets start at half and twice the prediction (or at 1 / |lambda| and
    10 / |lambda| when it is 0 or inf) and may widen ``expand``-fold.
    """
    q_eq = hanging_equilibrium(robot)
    lin = linearise(robot, q_eq)
    q0 = robot.integrate(q_eq, np.full(robot.nv, SMALL_OFFSET))
    v0 = np.zeros(robot.nv)
    out = []
    for name in methods:
        pred = predicted_limit(name, lin.K, lin.D)
        if 0 < pred.dt_max < np.inf:
            lo, hi = pred.dt_max / 2, pred.dt_max * 2
        elif pred.dt_max == 0:
            lo, hi = 1e-2 / pred.fastest, 1.0 / pred.fastest
        else:
            lo, hi = 1.0 / pred.fastest, 10.0 / pred.fastest
        found = []
        runs = 0
        for criterion in ("blowup", "energy"):
            test = robot_blows_up(robot, name, q0, v0, steps=steps, q_eq=q_eq, criterion=criterion)
            b = bisect_limit(test, dt_lo=lo, dt_hi=hi, rtol=rtol, expand=expand)
            found.append(b.dt_unstable if b.dt_unstable == np.inf else b.dt_max)
            runs += b.runs
        out.append(Limit(robot.name, name, pred.fastest, pred.dt_max, found[0], found[1], steps, runs))
    return out


@dataclass(frozen=True)
class StiffRun:
    """One run of the stiff case at a step well above the explicit limits."""

    integrator: str
    dt: float
    rtol: float | None
    diverged: bool
    error: float
    evaluations: int
    wall_time_s: float


def stiff_runs(robot: Robot, *, dt: float, duration: float, quick: bool = False) -> list[StiffRun]:
    """Every method on ``robot`` at step (or output interval) ``dt`` [s], against a Radau reference."""
    from robodyn.errors import DivergenceError
    from robodyn.sim.simulation import simulate

    q_eq = hanging_equilibrium(robot)
    q0 = robot.integrate(q_eq, np.full(robot.nv, 0.5))
    v0 = np.zeros(robot.nv)
    ref = simulate(robot, q0, v0, duration=duration, dt=dt, integrator="scipy_radau", rtol=1e-11, atol=1e-13)
    x_ref = np.hstack([ref.q, ref.v])
    scale = float(np.max(np.abs(x_ref)))
    methods: list[tuple[str, float | None]] = [(m, None) for m in (QUICK_FIXED_METHODS if quick else FIXED_METHODS)]
    methods += [("dopri5", 1e-6), ("scipy_radau", 1e-6), ("scipy_bdf", 1e-6)]
    out = []
    for name, tol in methods:
        options: dict[str, Any] = {"rtol": tol, "atol": tol * 1e-3} if tol is not None else {}
        try:
            traj = simulate(robot, q0, v0, duration=duration, dt=dt, integrator=name, **options)
            diverged = False
        except DivergenceError as exc:
            if exc.trajectory is None:  # simulate always attaches the partial run
                raise
            traj, diverged = exc.trajectory, True
        n = traj.t.size
        x = np.hstack([traj.q, traj.v])
        err = float(np.max(np.abs(x - x_ref[:n])) / scale) if not diverged else float("inf")
        out.append(StiffRun(name, dt, tol, diverged, err, int(traj.evaluations), float(traj.wall_time_s)))
    return out


@dataclass(frozen=True)
class NearSingular:
    """What each backend does with an ill-conditioned mass matrix (a very light distal link).

    ``accuracy``: acceleration errors against the extended-precision closed form, for the light
    variant and the normal model; ``spread``: max relative state difference of a 2 s RK4 run on
    each backend from the ABA run of the light variant.
    """

    light: BackendAccuracy
    normal: BackendAccuracy
    spread: dict[str, float]


def near_singular(light: Robot, normal: Robot, *, duration: float = 2.0, dt: float = 1e-3) -> NearSingular:
    """Backend accuracy on the light-tip and the normal Pendubot, and the run-to-run spread."""
    from robodyn.sim.simulation import simulate
    from robodyn.studies.bench import start_state

    q0, v0 = start_state(light)
    runs = {b: simulate(light, q0, v0, duration=duration, dt=dt, backend=b) for b in ("aba", "crba", "formula")}
    x_aba = np.hstack([runs["aba"].q, runs["aba"].v])
    scale = float(np.max(np.abs(x_aba)))
    spread = {b: float(np.max(np.abs(np.hstack([r.q, r.v]) - x_aba)) / scale) for b, r in runs.items()}
    return NearSingular(backend_accuracy(light), backend_accuracy(normal), spread)
