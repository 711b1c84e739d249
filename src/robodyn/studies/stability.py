"""Where integrators fail: stability limits predicted from the linearisation and measured by bisection.

Three questions, three parts.

* **Prediction.** Near an equilibrium the dynamics are q'' = K dq + D v with K = da/dq and
  D = da/dv (Pinocchio's analytical ABA derivatives, damping included). A fixed-step method
  applied to this linear system is a linear map, x_{k+1} = Phi(h) x_k with x = (dq, v); it is
  stable while the spectral radius rho(Phi(h)) <= 1. :func:`step_matrix` builds Phi(h) by
  stepping the integrator itself from unit vectors (so it covers partitioned methods such as
  symplectic Euler, whose stability is not a scalar function R(h lambda)), and
  :func:`predicted_limit` finds the largest stable h. For a Runge--Kutta method Phi(h) = R(h A),
  so rho(Phi) = max |R(h lambda_i)| over the eigenvalues lambda_i of A: this is the method's
  stability region met along the rays of the eigenvalues (RK4's real-axis limit is
  h |lambda| = 2.785, its imaginary-axis limit 2 sqrt 2; explicit Euler's region misses the
  imaginary axis, so an undamped oscillator is unstable at every h).
* **Measurement.** :func:`bisect_limit` bisects on a yes/no "did it fail" run: the state
  went non-finite, or the energy ledger E - E0 - W_damping (zero for the exact solution of a
  torque-free run) grew beyond a multiple of the energy above equilibrium: 100 for a blow-up
  (which is what the linear prediction describes), 1 for the issue's "energy error over 100 %"
  (reached earlier by methods that stay bounded but wobble, like symplectic Euler).
* **Chaos and conditioning.** :func:`lyapunov` estimates the largest Lyapunov exponent by
  Benettin's renormalised twin trajectories, from which the horizon beyond which a
  double-precision state means nothing is ln(1 / eps) / lambda_max; :func:`backend_accuracy`
  measures how each forward-dynamics backend copes with an ill-conditioned mass matrix.

Results are frozen dataclasses; nothing here prints or plots.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics
from robodyn.errors import InputError, RobodynError, StepError
from robodyn.integrators import ArrayProblem, FixedStepIntegrator, get

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

# rho(Phi(h)) above 1 + this is unstable: rho comes from an eigenvalue solver whose error is
# a few ulps of |Phi| for the non-defective matrices used here.
RHO_SLACK = 1e-12
# The scan for a limit starts at h = this / max |lambda|: a method unstable there is reported
# unstable at every step (Heun on the imaginary axis has rho - 1 = (h w)^4 / 8 = 1.2e-9 there).
SCAN_START = 1e-2
# Two ways a run fails, as multiples of the energy above equilibrium:
# * it blows up when its energy error exceeds BLOWUP_FACTOR (amplitude x10): a stable but
#   inaccurate method (semi-implicit Euler's bounded energy wobble, 1 / (1 - (h w / 2)^2)) gets
#   there only within 0.5 % of its limit, while an unstable mode growing by rho > 1 a step does
#   within the run's steps, and still within the physical range of a pendulum's energy;
# * it is useless when the energy error exceeds ENERGY_ERROR_FRACTION (the "100 %").
BLOWUP_FACTOR = 1e2
ENERGY_ERROR_FRACTION = 1.0
CRITERIA = {"blowup": BLOWUP_FACTOR, "energy": ENERGY_ERROR_FRACTION}
# Bisection stops when the bracket is this narrow, relative.
BISECT_RTOL = 0.01
# Largest step tried when looking for a limit [in units of 1 / max |lambda|]: beyond it a method
# is reported stable "up to the cap" (A-stable methods never fail on a linear system).
CAP_TIMES_FASTEST = 1e2
EPS = float(np.finfo(np.float64).eps)


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


# ------------------------------------------------------------------------------ prediction
def _fixed(integrator: str | FixedStepIntegrator) -> FixedStepIntegrator:
    method = get(integrator) if isinstance(integrator, str) else integrator
    if not isinstance(method, FixedStepIntegrator):
        raise InputError(
            f"integrator {method.name!r} adapts its step; a stability limit in dt exists for fixed-step methods only"
        )
    return method


def linear_problem(K: Array, D: Array) -> ArrayProblem:
    """The :class:`ArrayProblem` q'' = K q + D v with its exact Jacobian."""
    K = np.asarray(K, dtype=np.float64)
    D = np.asarray(D, dtype=np.float64)
    n = K.shape[0]
    return ArrayProblem(lambda t, q, v: K @ q + D @ v[:n], n, n, jacobian_fn=lambda t, q, v: (K, D))


def step_matrix(integrator: str | FixedStepIntegrator, K: Array, D: Array, h: float) -> Array:
    """Phi(h), (2 nv, 2 nv): one step of ``integrator`` on q'' = K q + D v maps x = (q, v) to Phi x.

    A step the method cannot take (its Newton or fixed-point iteration fails) gives a matrix
    of inf: for the user that step size fails just as an unstable one does.
    """
    method = _fixed(integrator)
    problem = linear_problem(K, D)
    n = problem.nv
    Phi = np.empty((2 * n, 2 * n))
    for j in range(2 * n):
        x = np.zeros(2 * n)
        x[j] = 1.0
        try:
            q1, u1, _ = method.step(problem, 0.0, x[:n], x[n:], h)
        except StepError:  # an implicit method whose iteration cannot take this step
            return np.full((2 * n, 2 * n), np.inf)
        Phi[:n, j] = q1
        Phi[n:, j] = u1[:n]
    return Phi


def spectral_radius(Phi: Array) -> float:
    """Max |eigenvalue| of Phi (inf if it holds non-finite numbers)."""
    if not np.all(np.isfinite(Phi)):
        return float("inf")
    return float(np.max(np.abs(np.linalg.eigvals(Phi))))


@dataclass(frozen=True)
class Prediction:
    """Largest stable step predicted from the linearisation.

    ``dt_max`` [s] is 0 when the method is unstable at every step (explicit Euler on an
    undamped oscillator) and ``inf`` when it is stable up to ``dt_cap`` (an A-stable method).
    ``fastest`` is max |lambda| [1/s]; ``h_lambda`` = dt_max * fastest, the step in the
    units of the stability region.
    """

    integrator: str
    dt_max: float
    dt_cap: float
    fastest: float
    eigenvalues: tuple[complex, ...]

    @property
    def h_lambda(self) -> float:
        """dt_max |lambda|_max (dimensionless)."""
        return self.dt_max * self.fastest


def predicted_limit(integrator: str | FixedStepIntegrator, K: Array, D: Array, *, rtol: float = 1e-6) -> Prediction:
    """Largest h with rho(Phi(h)) <= 1 + RHO_SLACK, by a geometric scan then bisection to ``rtol``.

    The scan starts at h = SCAN_START / |lambda|_max; unstable there means unstable at every h
    (``dt_max = 0``: the region misses an eigenvalue's ray near the origin). It stops at
    ``CAP_TIMES_FASTEST / |lambda|_max`` (``dt_max = inf``).
    """
    method = _fixed(integrator)
    lam = np.linalg.eigvals(np.block([[np.zeros_like(K), np.eye(K.shape[0])], [K, D]]))
    fastest = float(np.max(np.abs(lam)))
    if fastest == 0.0:
        raise InputError("the linearisation has only zero eigenvalues: no time scale to compare a step with")
    h0 = SCAN_START / fastest
    cap = CAP_TIMES_FASTEST / fastest
    eig = tuple(complex(x) for x in lam[np.argsort(-np.abs(lam))])

    def unstable(h: float) -> bool:
        return spectral_radius(step_matrix(method, K, D, h)) > 1.0 + RHO_SLACK

    if unstable(h0):
        return Prediction(method.name, 0.0, cap, fastest, eig)
    lo, hi = h0, None
    h = h0
    while h < cap:
        h = min(h * 1.25, cap)
        if unstable(h):
            hi = h
            break
        lo = h
    if hi is None:
        return Prediction(method.name, float("inf"), cap, fastest, eig)
    while hi - lo > rtol * lo:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if unstable(mid) else (mid, hi)
    return Prediction(method.name, lo, cap, fastest, eig)


def region_radius(integrator: str | FixedStepIntegrator, angle: float) -> float:
    """Boundary of the stability region along the ray arg(h lambda) = ``angle`` [rad], in |h lambda|.

    Computed on the oscillator q'' = -q + 2 cos(angle) v, whose eigenvalues are
    exp(+-i angle): for a Runge--Kutta method this is exactly the region {|R(z)| <= 1};
    for a partitioned method it is the region in the mechanical (q, v) form. On the real
    axis (a defective double root) the eigenvalues -1 and -1/2 are used instead.
    Returns 0 if the ray leaves the region at once, inf if it never does (up to CAP_TIMES_FASTEST).
    """
    if abs(np.sin(angle)) < 1e-12 and np.cos(angle) < 0:
        K, D = np.array([[-0.5]]), np.array([[-1.5]])
    else:
        K, D = np.array([[-1.0]]), np.array([[2.0 * np.cos(angle)]])
    return predicted_limit(integrator, K, D).dt_max


def region_grid(integrator: str | FixedStepIntegrator, re: Array, im: Array) -> NDArray[np.float64]:
    """Max |eigenvalue of Phi| on the grid z = re + i im of h lambda, shape (len(im), len(re)).

    The stability region is where the value is <= 1 (same oscillator as :func:`region_radius`).
    """
    method = _fixed(integrator)
    out = np.empty((len(im), len(re)))
    for i, y in enumerate(im):
        for j, x in enumerate(re):
            r = float(np.hypot(x, y))
            if r == 0.0:
                out[i, j] = 1.0
                continue
            K = np.array([[-1.0]])
            D = np.array([[2.0 * x / r]])
            out[i, j] = spectral_radius(step_matrix(method, K, D, r))
    return out


# ------------------------------------------------------------------------------ measurement
@dataclass(frozen=True)
class Bisection:
    """Measured largest stable step [s]: stable at ``dt_stable``, blown up at ``dt_unstable``.

    ``dt_unstable`` is inf when no tried step blew up (stable up to ``dt_stable``); ``dt_stable``
    is 0 when even the smallest tried step blew up. ``runs`` counts the trial runs.
    """

    dt_stable: float
    dt_unstable: float
    runs: int

    @property
    def dt_max(self) -> float:
        """Best estimate of the limit: the stable end of the bracket."""
        return self.dt_stable


def bisect_limit(
    blows_up: Callable[[float], bool],
    *,
    dt_lo: float,
    dt_hi: float,
    rtol: float = BISECT_RTOL,
    expand: float = 1e3,
) -> Bisection:
    """Bracket and bisect (geometrically) the step at which ``blows_up(dt)`` turns True.

    ``dt_lo`` is shrunk (down to dt_lo / expand) until stable and ``dt_hi`` grown (up to
    dt_hi * expand) until unstable before bisecting.
    """
    if not (0 < dt_lo < dt_hi):
        raise InputError(f"need 0 < dt_lo < dt_hi, got dt_lo={dt_lo!r}, dt_hi={dt_hi!r}")
    runs = 0
    lo, hi = dt_lo, dt_hi
    floor, ceiling = dt_lo / expand, dt_hi * expand
    while True:
        runs += 1
        if not blows_up(lo):
            break
        hi, lo = lo, lo / 8.0
        if lo < floor:
            return Bisection(0.0, hi, runs)
    while True:
        runs += 1
        if blows_up(hi):
            break
        lo, hi = hi, hi * 8.0
        if hi > ceiling:
            return Bisection(lo, float("inf"), runs)
    while hi / lo - 1.0 > rtol:
        mid = float(np.sqrt(lo * hi))
        runs += 1
        if blows_up(mid):
            hi = mid
        else:
            lo = mid
    return Bisection(lo, hi, runs)


def linear_blows_up(
    integrator: str | FixedStepIntegrator,
    K: Array,
    D: Array,
    x0: ArrayLike,
    *,
    steps: int,
    criterion: str = "blowup",
) -> Callable[[float], bool]:
    """Predicate for :func:`bisect_limit` on q'' = K q + D v: do ``steps`` steps of dt fail?

    The energy E = 1/2 v.v - 1/2 q.K q (K symmetric negative definite) of the exact solution
    never grows. Failing means a non-finite state or E - E0 > CRITERIA[criterion] * E0.
    """
    method = _fixed(integrator)
    K = np.asarray(K, dtype=np.float64)
    D = np.asarray(D, dtype=np.float64)
    x = np.asarray(x0, dtype=np.float64)
    n = K.shape[0]
    factor = _criterion(criterion)

    def energy(q: Array, v: Array) -> float:
        return 0.5 * float(v @ v) - 0.5 * float(q @ K @ q)

    e0 = energy(x[:n], x[n:])
    if e0 <= 0:
        raise InputError(f"the start state {x} has no energy (K must be negative definite and x0 non-zero)")

    def blows_up(dt: float) -> bool:
        problem = linear_problem(K, D)
        q, u = x[:n].copy(), x[n:].copy()
        for _ in range(steps):
            q, u, _k = method.step(problem, 0.0, q, u, dt)
            if not (np.all(np.isfinite(q)) and np.all(np.isfinite(u))):
                return True
            if energy(q, u[:n]) - e0 > factor * e0:
                return True
        return False

    return blows_up


def _criterion(name: str) -> float:
    if name not in CRITERIA:
        from robodyn.errors import UnknownNameError

        raise UnknownNameError("stability criterion", name, CRITERIA)
    return CRITERIA[name]


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
    factor = _criterion(criterion)
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


# ------------------------------------------------------------------------------ chaos
@dataclass(frozen=True)
class Lyapunov:
    """Largest Lyapunov exponent ``exponent`` [1/s] from ``renormalisations`` intervals of ``interval`` [s].

    ``running`` holds the running estimate after each interval (its settling shows convergence);
    ``horizon_s`` = ln(1 / eps) / exponent [s] is when a round-off error of one ulp has grown
    to O(1): beyond it no double-precision integrator's state means anything.
    """

    exponent: float
    interval: float
    renormalisations: int
    running: Array
    horizon_s: float


def lyapunov(
    step_run: Callable[[Array, Array, float], tuple[Array, Array]],
    q0: ArrayLike,
    v0: ArrayLike,
    *,
    duration: float,
    interval: float,
    d0: float = 1e-8,
    seed: int = 0,
) -> Lyapunov:
    """Benettin's estimate of the largest Lyapunov exponent.

    ``step_run(q, v, T) -> (q_T, v_T)`` advances a state by T [s] (accurately: the twin
    separation d0 must stay far above its error). A twin starts d0 away in a seeded random
    direction of (q, v); after each ``interval`` the separation d is measured, ln(d / d0)
    accumulated, and the twin pulled back to distance d0 along the separation.
    """
    q = np.asarray(q0, dtype=np.float64).copy()
    v = np.asarray(v0, dtype=np.float64).copy()
    n = q.size
    if not (duration > 0 and 0 < interval <= duration):
        raise InputError(f"need 0 < interval <= duration, got interval={interval!r}, duration={duration!r}")
    rng = np.random.default_rng(seed)
    direction = rng.normal(size=2 * n)
    direction *= d0 / np.linalg.norm(direction)
    qt, vt = q + direction[:n], v + direction[n:]
    count = round(duration / interval)
    total = 0.0
    running = np.empty(count)
    for k in range(count):
        q, v = step_run(q, v, interval)
        qt, vt = step_run(qt, vt, interval)
        sep = np.concatenate([qt - q, vt - v])
        d = float(np.linalg.norm(sep))
        if not np.isfinite(d) or d == 0.0:
            raise RobodynError(f"Lyapunov estimate: twin separation became {d} after {k + 1} intervals")
        total += np.log(d / d0)
        running[k] = total / ((k + 1) * interval)
        sep *= d0 / d
        qt, vt = q + sep[:n], v + sep[n:]
    exponent = float(running[-1])
    horizon = float(np.log(1.0 / EPS) / exponent) if exponent > 0 else float("inf")
    return Lyapunov(exponent, interval, count, running, horizon)


def separation_time(
    run: Callable[[Array, Array], tuple[Array, Array]], q0: ArrayLike, *, v0: ArrayLike, threshold: float = 0.1
) -> tuple[float, Array, Array]:
    """Time [s] at which two runs whose starts differ by one ulp in q are ``threshold`` [rad] apart.

    ``run(q0, v0) -> (t, q)`` returns sample times (n,) and configurations (n, nq). Returns
    (time, t, |dq|_max per sample); time is inf if they never separate that far.
    """
    q = np.asarray(q0, dtype=np.float64)
    t, qa = run(q, np.asarray(v0, dtype=np.float64))
    _, qb = run(np.nextafter(q, np.inf), np.asarray(v0, dtype=np.float64))
    gap = np.max(np.abs(qa - qb), axis=1)
    over = np.flatnonzero(gap > threshold)
    return (float(t[over[0]]) if over.size else float("inf")), t, gap


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
    """Pendubot forward dynamics by Cramer's rule in ``np.longdouble`` (the reference)."""
    L = np.longdouble
    m1, m2, l1, lc1, lc2, I1, I2, g = (L(p[k]) for k in ("m1", "m2", "l1", "lc1", "lc2", "I1", "I2", "g"))
    q1, q2, v1, v2 = (L(x) for x in (q[0], q[1], v[0], v[1]))
    c = m2 * l1 * lc2
    bb = m2 * lc2 * lc2 + I2
    m11 = m1 * lc1 * lc1 + m2 * l1 * l1 + I1 + bb + 2 * c * np.cos(q2)
    m12 = bb + c * np.cos(q2)
    g12 = m2 * lc2 * g * np.cos(q1 + q2)
    r0 = L(tau[0]) + c * np.sin(q2) * (2 * v1 * v2 + v2 * v2) - (m1 * lc1 + m2 * l1) * g * np.cos(q1) - g12
    r1 = L(tau[1]) - c * np.sin(q2) * v1 * v1 - g12
    det = m11 * bb - m12 * m12
    return np.array([(bb * r0 - m12 * r1) / det, (m11 * r1 - m12 * r0) / det], dtype=np.float64)


def backend_accuracy(robot: Robot, *, states: int = 50, seed: int = 0) -> BackendAccuracy:
    """Errors of ABA, CRBA + Cholesky and the NumPy formula on a Pendubot-kind robot.

    The reference is the same closed form evaluated in extended precision (64-bit mantissa),
    so float64 round-off shows as ~1e-16 and loss to conditioning as more.
    """
    from robodyn.kinds import formulas, params

    p = params.extract(robot, "pendubot").as_dict()
    formula = formulas.get("pendubot")
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
FIXED_METHODS = ("euler", "semi_implicit_euler", "symplectic_euler", "heun", "rk4", "implicit_midpoint")
QUICK_FIXED_METHODS = ("euler", "semi_implicit_euler", "rk4", "implicit_midpoint")
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
    predicts); ``energy_dt_max`` on the issue's "energy error over 100 %". ``ratio`` is
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


@dataclass(frozen=True, eq=False)
class Chaos:
    """The chaotic case: Lyapunov estimate and the measured separation of runs one ulp apart."""

    model: str
    q0: Array
    v0: Array
    lyapunov: Lyapunov
    separation_time_s: float
    gap_t: Array
    gap: Array


def chaos(robot: Robot, q0: Array, v0: Array, *, duration: float, dt: float = 1e-3) -> Chaos:
    """Lyapunov exponent (compiled RK4, renormalised every 0.1 s) and the one-ulp separation time."""
    from robodyn.sim.fast import FastDynamics

    fast = FastDynamics.from_robot(robot)
    interval = 0.1

    def step_run(q: Array, v: Array, T: float) -> tuple[Array, Array]:
        traj = fast.simulate(q, v, duration=T, dt=dt)
        return traj.q[-1].copy(), traj.v[-1].copy()

    def run(q: Array, v: Array) -> tuple[Array, Array]:
        traj = fast.simulate(q, v, duration=duration, dt=dt)
        return traj.t, traj.q

    lyap = lyapunov(step_run, q0, v0, duration=duration, interval=interval)
    when, t, gap = separation_time(run, q0, v0=v0, threshold=0.1)
    stride = max(1, t.size // 2000)
    return Chaos(robot.name, np.asarray(q0), np.asarray(v0), lyap, when, t[::stride], gap[::stride])


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
