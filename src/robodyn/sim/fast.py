"""A compiled fast path for the built-in kinds: closed-form forward dynamics and the step loop in numba.

For a Pendubot, a cart-pole or a geared arm, the forward dynamics a = M^-1 (tau - C v - G - B v)
have a closed form (M is 2 x 2 or 1 x 1), so a whole fixed-step run compiles to one machine-code
loop with no allocation and no Python call per step. The closed forms are not written here: numba
compiles each kind's own scalar functions (``mass``, ``coriolis``, ``gravity``, ``potential`` of
:mod:`robodyn.kinds.pendubot`, :mod:`~robodyn.kinds.cart_pole`, :mod:`~robodyn.kinds.geared_arm`),
the same functions that serve ``robodyn check`` and the ``formula`` backend.

It is a second path, not a second truth: :meth:`FastDynamics.from_robot` checks its accelerations
against Pinocchio's ABA on seeded random states before handing it out, and ``tests/test_fast.py``
holds whole trajectories to round-off against :func:`robodyn.simulate` with the ABA backend.

Viscous damping B = diag(robot.damping) is applied as -B v, as :func:`robodyn.simulate` does;
Coulomb friction is refused (its sign switch has no place in a smooth closed form).

numba is imported on first use, never at ``import robodyn``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn.engine import jit
from robodyn.errors import AssumptionError, InputError, MissingDependencyError, UnknownNameError
from robodyn.integrators import step_count
from robodyn.kinds import cart_pole, geared_arm, pendubot
from robodyn.kinds import params as params_module
from robodyn.kinds.formula import solve_2x2
from robodyn.kinds.formulas import closed_form
from robodyn.sim.trajectory import Trajectory

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

# Kind -> the integer code that selects it inside the compiled kernels.
CODES: dict[str, int] = {"pendubot": 0, "cart_pole": 1, "geared_arm": 2}
KINDS: dict[str, tuple[int, tuple[str, ...]]] = {kind: (code, closed_form(kind).params) for kind, code in CODES.items()}
METHODS = ("rk4", "semi_implicit_euler")
# What a first compile of these kernels says it does (robodyn.engine.jit.announce)
COMPILING = ("the closed-form kernels of the built-in kinds", "about half a minute")

# Closed form against Pinocchio's ABA, relative to the largest acceleration: both are exact
# formulas evaluated in float64, so they differ by a few hundred ulps at most.
VERIFY_RTOL = 1e-9
VERIFY_STATES = 16


@lru_cache(maxsize=1)
def _kernels() -> dict[str, Any]:
    """Compile (or load from numba's cache) the kernels; imported lazily."""
    try:
        import numba
    except ImportError:  # pragma: no cover - numba is a declared dependency
        raise MissingDependencyError("the fast path needs numba: pip install numba") from None
    njit = jit.njit(fastmath=False, nogil=True)

    pm, pc, pg, pp = (njit(f) for f in (pendubot.mass, pendubot.coriolis, pendubot.gravity, pendubot.potential))
    cm, cc, cg, cp = (njit(f) for f in (cart_pole.mass, cart_pole.coriolis, cart_pole.gravity, cart_pole.potential))
    gm, gc, gg, gp = (njit(f) for f in (geared_arm.mass, geared_arm.coriolis, geared_arm.gravity, geared_arm.potential))
    solve = njit(solve_2x2)

    @njit
    def acc(kind, p, b, q0, q1, v0, v1, t0, t1):  # type: ignore[no-untyped-def]
        if kind == 2:  # geared_arm, one degree of freedom
            m = gm(p, q0)[0]
            return (t0 - b[0] * v0 - gc(p, q0, v0)[0] * v0 - gg(p, q0)[0]) / m, 0.0
        if kind == 0:
            m11, m12, m22 = pm(p, q0, q1)
            c11, c12, c21, c22 = pc(p, q0, q1, v0, v1)
            g0, g1 = pg(p, q0, q1)
        else:
            m11, m12, m22 = cm(p, q0, q1)
            c11, c12, c21, c22 = cc(p, q0, q1, v0, v1)
            g0, g1 = cg(p, q0, q1)
        r0 = t0 - b[0] * v0 - (c11 * v0 + c12 * v1) - g0
        r1 = t1 - b[1] * v1 - (c21 * v0 + c22 * v1) - g1
        return solve(m11, m12, m22, r0, r1)

    @njit
    def energies(kind, p, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        """(kinetic, potential) on each kind's own zero of the potential."""
        if kind == 2:
            return 0.5 * gm(p, q0)[0] * v0 * v0, gp(p, q0)
        if kind == 0:
            m11, m12, m22 = pm(p, q0, q1)
            pot = pp(p, q0, q1)
        else:
            m11, m12, m22 = cm(p, q0, q1)
            pot = cp(p, q0, q1)
        return 0.5 * (m11 * v0 * v0 + 2.0 * m12 * v0 * v1 + m22 * v1 * v1), pot

    @njit
    def run(kind, method, p, b, nv, q, v, tau, dt, n, Q, V, A):  # type: ignore[no-untyped-def]
        """Fill Q, V, A (n + 1, 2) from (q, v); method 0 = RK4, 1 = semi-implicit Euler."""
        q0, q1, v0, v1 = q[0], q[1], v[0], v[1]
        t0, t1 = tau[0], tau[1]
        h = dt
        for k in range(n + 1):
            Q[k, 0] = q0
            Q[k, 1] = q1
            V[k, 0] = v0
            V[k, 1] = v1
            a0, a1 = acc(kind, p, b, q0, q1, v0, v1, t0, t1)
            A[k, 0] = a0
            A[k, 1] = a1
            if k == n:  # the last sample: recorded, not stepped from
                break
            if method == 0:
                b0, b1 = acc(
                    kind, p, b, q0 + 0.5 * h * v0, q1 + 0.5 * h * v1, v0 + 0.5 * h * a0, v1 + 0.5 * h * a1, t0, t1
                )
                w0 = v0 + 0.5 * h * a0
                w1 = v1 + 0.5 * h * a1
                c0, c1 = acc(
                    kind, p, b, q0 + 0.5 * h * w0, q1 + 0.5 * h * w1, v0 + 0.5 * h * b0, v1 + 0.5 * h * b1, t0, t1
                )
                x0 = v0 + 0.5 * h * b0
                x1 = v1 + 0.5 * h * b1
                d0, d1 = acc(kind, p, b, q0 + h * x0, q1 + h * x1, v0 + h * c0, v1 + h * c1, t0, t1)
                y0 = v0 + h * c0
                y1 = v1 + h * c1
                q0 = q0 + h / 6.0 * (v0 + 2.0 * w0 + 2.0 * x0 + y0)
                q1 = q1 + h / 6.0 * (v1 + 2.0 * w1 + 2.0 * x1 + y1)
                v0 = v0 + h / 6.0 * (a0 + 2.0 * b0 + 2.0 * c0 + d0)
                v1 = v1 + h / 6.0 * (a1 + 2.0 * b1 + 2.0 * c1 + d1)
            else:
                # Semi-implicit Euler: kick the velocity first, then drift the position with the new velocity.
                v0 = v0 + h * a0
                v1 = v1 + h * a1
                q0 = q0 + h * v0
                q1 = q1 + h * v1
            if nv == 1:
                q1 = 0.0
                v1 = 0.0
            if not (np.isfinite(q0) and np.isfinite(q1) and np.isfinite(v0) and np.isfinite(v1)):
                return k + 1
        return n

    @njit
    def energy_series(kind, p, Q, V, K, P):  # type: ignore[no-untyped-def]
        for k in range(Q.shape[0]):
            K[k], P[k] = energies(kind, p, Q[k, 0], Q[k, 1], V[k, 0], V[k, 1])

    @njit
    def acc_batch(kind, p, b, Q, V, T, A):  # type: ignore[no-untyped-def]
        for k in range(Q.shape[0]):
            A[k, 0], A[k, 1] = acc(kind, p, b, Q[k, 0], Q[k, 1], V[k, 0], V[k, 1], T[k, 0], T[k, 1])

    @jit.njit(nogil=True, parallel=True)
    def batch_rk4(kind, p, b, nv, Q, V, dt, n, blocks):  # type: ignore[no-untyped-def]
        """Classic RK4 (the arithmetic of ``run``) on every state of Q, V (m, 2), in place, one prange over blocks."""
        h = dt
        for bi in numba.prange(blocks.shape[0] - 1):
            for r in range(blocks[bi], blocks[bi + 1]):
                q0, q1, v0, v1 = Q[r, 0], Q[r, 1], V[r, 0], V[r, 1]
                for _ in range(n):
                    a0, a1 = acc(kind, p, b, q0, q1, v0, v1, 0.0, 0.0)
                    b0, b1 = acc(
                        kind, p, b, q0 + 0.5 * h * v0, q1 + 0.5 * h * v1, v0 + 0.5 * h * a0, v1 + 0.5 * h * a1, 0.0, 0.0
                    )
                    w0 = v0 + 0.5 * h * a0
                    w1 = v1 + 0.5 * h * a1
                    c0, c1 = acc(
                        kind, p, b, q0 + 0.5 * h * w0, q1 + 0.5 * h * w1, v0 + 0.5 * h * b0, v1 + 0.5 * h * b1, 0.0, 0.0
                    )
                    x0 = v0 + 0.5 * h * b0
                    x1 = v1 + 0.5 * h * b1
                    d0, d1 = acc(kind, p, b, q0 + h * x0, q1 + h * x1, v0 + h * c0, v1 + h * c1, 0.0, 0.0)
                    y0 = v0 + h * c0
                    y1 = v1 + h * c1
                    q0 = q0 + h / 6.0 * (v0 + 2.0 * w0 + 2.0 * x0 + y0)
                    q1 = q1 + h / 6.0 * (v1 + 2.0 * w1 + 2.0 * x1 + y1)
                    v0 = v0 + h / 6.0 * (a0 + 2.0 * b0 + 2.0 * c0 + d0)
                    v1 = v1 + h / 6.0 * (a1 + 2.0 * b1 + 2.0 * c1 + d1)
                    if nv == 1:
                        q1 = 0.0
                        v1 = 0.0
                Q[r, 0], Q[r, 1], V[r, 0], V[r, 1] = q0, q1, v0, v1
        return 0

    # Compile now (or load numba's cache), so that no timed run pays for it.
    if not all(jit.is_cached(f) for f in (run, energy_series, acc_batch)):
        jit.announce(*COMPILING)
    z2, z = np.zeros(2), np.zeros((2, 2))
    for method in (0, 1):
        run(2, method, np.ones(6), z2, 1, z2, z2, z2, 1e-3, 1, z.copy(), z.copy(), z.copy())
    energy_series(2, np.ones(6), z, z, np.zeros(2), np.zeros(2))
    acc_batch(2, np.ones(6), z2, z, z, z, z.copy())
    return {"run": run, "energy_series": energy_series, "acc_batch": acc_batch, "batch_rk4": batch_rk4}


def batch_rk4(fast: FastDynamics, Q: Array, V: Array, *, dt: float, steps: int, blocks: NDArray[np.int64]) -> None:
    """Classic RK4 without torque on a batch Q, V (m, 2) in place (padded to 2 columns), one prange over ``blocks``."""
    code = KINDS[fast.kind][0]
    _kernels()["batch_rk4"](code, fast.param_vector, _pad(fast.damping), fast.nv, Q, V, dt, steps, blocks)


def _pad(x: Array) -> Array:
    """A 1- or 2-vector as a 2-vector (the kernels always carry two slots)."""
    out = np.zeros(2)
    out[: x.size] = x
    return out


@dataclass(frozen=True, eq=False)
class FastDynamics:
    """Compiled closed-form dynamics of one robot of a built-in kind.

    ``params`` is the kind's parameter mapping (:func:`robodyn.kinds.params.extract`), ``damping``
    the viscous joint damping [N m s/rad | N s/m] (nv,), ``potential_offset`` [J] the constant
    that puts the closed-form potential on Pinocchio's zero (world height 0).
    """

    kind: str
    params: dict[str, float]
    damping: Array
    nv: int
    potential_offset: float = 0.0
    robot_name: str = ""

    @classmethod
    def from_params(cls, kind: str, params: dict[str, float], *, damping: ArrayLike | None = None) -> FastDynamics:
        """Build from a parameter mapping (no Pinocchio check: see :meth:`from_robot`)."""
        if kind not in KINDS:
            raise UnknownNameError("fast-path kind", kind, KINDS)
        names = KINDS[kind][1]
        missing = [n for n in names if n not in params]
        if missing:
            raise InputError(f"{kind} parameters miss {', '.join(missing)}; expected {', '.join(names)}")
        nv = 1 if kind == "geared_arm" else 2
        b = np.zeros(nv) if damping is None else np.asarray(damping, dtype=np.float64).reshape(-1)
        if b.shape != (nv,) or not np.all(np.isfinite(b)) or np.any(b < 0):
            raise InputError(f"damping must be {nv} finite numbers >= 0, got {b}")
        return cls(kind, {n: float(params[n]) for n in names}, b, nv)

    @classmethod
    def from_robot(cls, robot: Robot, kind: str | None = None, *, verify: bool = True) -> FastDynamics:
        """Read the kind's parameters from ``robot`` and check the closed form against Pinocchio.

        Raises:
            AssumptionError: the robot is not of a built-in kind, has Coulomb friction, or its
                closed-form accelerations disagree with ABA by more than ``VERIFY_RTOL``.
        """
        if kind is None:
            kind = params_module.detect_kind(robot)
            if kind is None:
                raise AssumptionError(
                    f"{robot.name}: the fast path serves only the built-in kinds ({', '.join(KINDS)}); "
                    "this model matches none of them"
                )
        if kind not in KINDS:
            raise UnknownNameError("fast-path kind", kind, KINDS)
        if np.any(robot.friction != 0.0):
            raise AssumptionError(f"{robot.name}: the fast path has no Coulomb friction; friction is {robot.friction}")
        p = params_module.extract(robot, kind).as_dict()
        fast = cls.from_params(kind, p, damping=robot.damping)
        q = robot.neutral()
        offset = robot.potential_energy(q) - fast.energies(q, np.zeros(robot.nv))[1]
        fast = cls(kind, fast.params, fast.damping, fast.nv, float(offset), robot.name)
        if verify:
            fast.verify(robot)
        return fast

    @property
    def param_vector(self) -> Array:
        """Parameters in kernel order."""
        return np.array([self.params[n] for n in KINDS[self.kind][1]], dtype=np.float64)

    def verify(self, robot: Robot, *, seed: int = 0) -> float:
        """Largest relative difference of the closed-form accelerations from ABA on seeded states.

        Raises:
            AssumptionError: if it exceeds ``VERIFY_RTOL``.
        """
        rng = np.random.default_rng(seed)
        worst = 0.0
        for _ in range(VERIFY_STATES):
            q, v = robot.random_state(rng)
            tau = rng.uniform(-1.0, 1.0, robot.nv)
            ref = robot.forward_dynamics(q, v, tau - robot.damping * v)
            got = self.acceleration(q, v, tau)
            worst = max(worst, float(np.max(np.abs(got - ref)) / max(np.max(np.abs(ref)), 1.0)))
        if worst > VERIFY_RTOL:
            raise AssumptionError(
                f"{robot.name}: the compiled {self.kind} closed form differs from ABA by {worst:.3g} "
                f"(relative), expected <= {VERIFY_RTOL:g}"
            )
        return worst

    def acceleration(self, q: ArrayLike, v: ArrayLike, tau: ArrayLike | None = None) -> Array:
        """Accelerations M^-1 (tau - C v - G - B v) [rad/s^2 | m/s^2] of one state (nv,) or a batch (n, nv)."""
        q_, v_ = np.atleast_2d(np.asarray(q, dtype=np.float64)), np.atleast_2d(np.asarray(v, dtype=np.float64))
        t_ = np.zeros_like(q_) if tau is None else np.atleast_2d(np.asarray(tau, dtype=np.float64))
        for name, x in (("q", q_), ("v", v_), ("tau", t_)):
            if x.shape[1] != self.nv or x.shape[0] != q_.shape[0]:
                raise InputError(f"{name} must have shape ({self.nv},) or (n, {self.nv}), got {x.shape}")
        pad = np.zeros((q_.shape[0], 2))
        Q, V, T = pad.copy(), pad.copy(), pad.copy()
        Q[:, : self.nv], V[:, : self.nv], T[:, : self.nv] = q_, v_, t_
        A = np.zeros_like(Q)
        _kernels()["acc_batch"](KINDS[self.kind][0], self.param_vector, _pad(self.damping), Q, V, T, A)
        out = A[:, : self.nv]
        return out[0].copy() if np.ndim(q) == 1 else out

    def energies(self, q: ArrayLike, v: ArrayLike) -> tuple[float, float]:
        """(kinetic, potential) [J] of one state; the potential on Pinocchio's zero."""
        Q = _pad(np.asarray(q, dtype=np.float64))[None, :]
        V = _pad(np.asarray(v, dtype=np.float64))[None, :]
        K, P = np.zeros(1), np.zeros(1)
        _kernels()["energy_series"](KINDS[self.kind][0], self.param_vector, Q, V, K, P)
        return float(K[0]), float(P[0]) + self.potential_offset

    def energies_batch(self, Q: ArrayLike, V: ArrayLike) -> tuple[Array, Array]:
        """(kinetic (n,), potential (n,)) [J] of a batch of states Q, V (n, nv); the potential on Pinocchio's zero."""
        Q_, V_ = _pad2(np.asarray(Q, dtype=np.float64)), _pad2(np.asarray(V, dtype=np.float64))
        K, P = np.zeros(Q_.shape[0]), np.zeros(Q_.shape[0])
        _kernels()["energy_series"](KINDS[self.kind][0], self.param_vector, Q_, V_, K, P)
        return K, P + self.potential_offset

    def simulate(
        self,
        q0: ArrayLike,
        v0: ArrayLike,
        *,
        duration: float,
        dt: float,
        method: str = "rk4",
        tau: ArrayLike | None = None,
    ) -> Trajectory:
        """Fixed-step run from (q0, v0) for ``duration`` [s] at step ``dt`` [s] under a constant ``tau``.

        ``method`` is ``"rk4"`` (classical Runge-Kutta, order 4, 4 evaluations a step) or
        ``"semi_implicit_euler"`` (kick then drift in (q, v), order 1, 1 evaluation a step), the
        same methods as the integrators of those names. The
        :class:`Trajectory` carries ``wall_time_s`` (the compiled loop only) and ``evaluations``;
        a blow-up stops the run with ``status == "diverged"``.
        """
        if method not in METHODS:
            raise UnknownNameError("fast-path method", method, METHODS)
        q = np.asarray(q0, dtype=np.float64).reshape(-1)
        v = np.asarray(v0, dtype=np.float64).reshape(-1)
        t_ = np.zeros(self.nv) if tau is None else np.asarray(tau, dtype=np.float64).reshape(-1)
        for name, x in (("q0", q), ("v0", v), ("tau", t_)):
            if x.shape != (self.nv,) or not np.all(np.isfinite(x)):
                raise InputError(f"{name} must be {self.nv} finite numbers, got {x}")
        n = step_count(duration, dt)
        kern = _kernels()
        code, method_code = KINDS[self.kind][0], METHODS.index(method)
        Q, V, A = np.zeros((n + 1, 2)), np.zeros((n + 1, 2)), np.zeros((n + 1, 2))
        p, b = self.param_vector, _pad(self.damping)
        start = time.perf_counter()
        done = kern["run"](code, method_code, p, b, self.nv, _pad(q), _pad(v), _pad(t_), dt, n, Q, V, A)
        wall = time.perf_counter() - start
        evals = (4 if method == "rk4" else 1) * done + (1 if done == n else 0)
        keep = done + 1 if done == n else done
        Q, V, A = Q[:keep, : self.nv], V[:keep, : self.nv], A[:keep, : self.nv]
        K, P = np.zeros(keep), np.zeros(keep)
        kern["energy_series"](code, p, _pad2(Q), _pad2(V), K, P)
        t = dt * np.arange(keep)
        with np.errstate(over="ignore", invalid="ignore"):  # a blown-up run's last samples are huge
            power_in = V @ t_
            power_damp = -np.sum(self.damping * V * V, axis=1)
        status = "ok" if done == n else "diverged"
        message = "" if done == n else f"state not finite at step {done} (t = {done * dt:.6g} s)"
        return Trajectory(
            t=t,
            q=Q.copy(),
            v=V.copy(),
            a=A.copy(),
            tau=np.tile(t_, (keep, 1)),
            kinetic=K,
            potential=P + self.potential_offset,
            work_input=_cumtrapz(power_in, dt),
            work_damping=_cumtrapz(power_damp, dt),
            wall_time_s=wall,
            evaluations=int(evals),
            status=status,
            message=message,
            meta={"model": self.robot_name, "integrator": method, "dt": dt, "backend": "fast", "kind": self.kind},
        )


def _pad2(X: Array) -> Array:
    out = np.zeros((X.shape[0], 2))
    out[:, : X.shape[1]] = X
    return out


def _cumtrapz(y: Array, dt: float) -> Array:
    out = np.zeros_like(y)
    if y.size > 1:
        out[1:] = np.cumsum(0.5 * dt * (y[1:] + y[:-1]))
    return out


def warm_up() -> dict[str, Any]:
    """Compile (or load from numba's cache) every kernel now; later runs time the loop only. Returns them by name."""
    return _kernels()
