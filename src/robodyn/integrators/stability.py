"""Stability theory of the fixed-step methods, and chaos, on linear and plain-array problems (no robots).

* **Prediction.** Near an equilibrium the dynamics are q'' = K dq + D v with K = da/dq and
  D = da/dv. A fixed-step method applied to this linear system is a linear map,
  x_{k+1} = Phi(h) x_k with x = (dq, v); it is stable while the spectral radius
  rho(Phi(h)) <= 1. :func:`step_matrix` builds Phi(h) by stepping the integrator itself from
  unit vectors (so it covers partitioned methods such as symplectic Euler, whose stability is
  not a scalar function R(h lambda)), and :func:`predicted_limit` finds the largest stable h.
  For a Runge--Kutta method Phi(h) = R(h A), so rho(Phi) = max |R(h lambda_i)| over the
  eigenvalues lambda_i of A: this is the method's stability region met along the rays of the
  eigenvalues (RK4's real-axis limit is h |lambda| = 2.785, its imaginary-axis limit 2 sqrt 2;
  explicit Euler's region misses the imaginary axis, so an undamped oscillator is unstable at
  every h). :func:`region_radius` and :func:`region_grid` map the region itself.
* **Measurement.** :func:`bisect_limit` bisects on a yes/no "did it fail" run, such as
  :func:`linear_blows_up`: the state went non-finite, or the energy grew beyond a multiple of
  its start value: 100 for a blow-up (which is what the linear prediction describes), 1 for an
  "energy error over 100 %" (reached earlier by methods that stay bounded but wobble, like
  symplectic Euler). :func:`criterion_factor` names those multiples.
* **Chaos.** :func:`lyapunov` estimates the largest Lyapunov exponent by Benettin's
  renormalised twin trajectories, from which the horizon beyond which a double-precision state
  means nothing is ln(1 / eps) / lambda_max; :func:`separation_time` measures when two runs one
  ulp apart part ways.

The robot studies built on this (linearising a robot, bisecting on simulate runs) live in
:mod:`robodyn.studies.stability`. Results are frozen dataclasses; nothing here prints or plots.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn.errors import InputError, RobodynError, StepError, UnknownNameError
from robodyn.integrators import twins
from robodyn.integrators.base import FixedStepIntegrator
from robodyn.integrators.problem import Array, ArrayProblem
from robodyn.integrators.registry import get

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
# * it is useless when the energy error exceeds ENERGY_ERROR_FRACTION (100 %).
BLOWUP_FACTOR = 1e2
ENERGY_ERROR_FRACTION = 1.0
CRITERIA = {"blowup": BLOWUP_FACTOR, "energy": ENERGY_ERROR_FRACTION}
# Bisection stops when the bracket is this narrow, relative.
BISECT_RTOL = 0.01
# Largest step tried when looking for a limit [in units of 1 / max |lambda|]: beyond it a method
# is reported stable "up to the cap" (A-stable methods never fail on a linear system).
CAP_TIMES_FASTEST = 1e2
# One ulp of a float64 relative to 1: a Lyapunov horizon is when this has grown to O(1).
EPS = float(np.finfo(np.float64).eps)


# ------------------------------------------------------------------------------ prediction
def _fixed(integrator: str | FixedStepIntegrator) -> FixedStepIntegrator:
    """The fixed-step integrator named or given; an adaptive one has no limit in dt (InputError)."""
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
    _check_rtol(rtol)
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
    if not (0 < dt_lo < dt_hi < np.inf):
        raise InputError(f"need 0 < dt_lo < dt_hi < inf, got dt_lo={dt_lo!r}, dt_hi={dt_hi!r}")
    _check_rtol(rtol)
    if not (1.0 < expand < np.inf):
        raise InputError(f"expand must be a finite number above 1, got {expand!r}")
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
    factor = criterion_factor(criterion)

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


def criterion_factor(criterion: str) -> float:
    """The energy-error multiple at which a run counts as failed under ``criterion`` (a key of CRITERIA).

    Raises:
        UnknownNameError: ``criterion`` is not one of CRITERIA (the message lists them).
    """
    if criterion not in CRITERIA:
        raise UnknownNameError("stability criterion", criterion, CRITERIA)
    return CRITERIA[criterion]


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
    direction of (q, v) (:func:`robodyn.integrators.twins.direction` of stream ``seed``, the
    generator the GPU kernels draw from in the thread); after each ``interval`` the separation d
    is measured, ln(d / d0) accumulated, and the twin pulled back to distance d0 along the separation.
    """
    q = np.asarray(q0, dtype=np.float64).copy()
    v = np.asarray(v0, dtype=np.float64).copy()
    n = q.size
    if not (duration > 0 and 0 < interval <= duration):
        raise InputError(f"need 0 < interval <= duration, got interval={interval!r}, duration={duration!r}")
    if not (isinstance(seed, (int, np.integer)) and 0 <= seed < 2**64):
        raise InputError(f"seed must be a whole number in [0, 2^64), got {seed!r}")
    direction = twins.direction(int(seed), 2 * n, d0)
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


def _check_rtol(rtol: float) -> None:
    """A bisection's relative tolerance must be reachable in float64: at least 4 ulps, and finite."""
    if not (4 * EPS <= rtol < 1.0):
        raise InputError(
            f"rtol must be in [{4 * EPS:.3g}, 1) (a bisection cannot resolve less than 4 ulps), got {rtol!r}"
        )
