"""A compiled fast path for the seed kinds: closed-form forward dynamics and the step loop in numba.

For a Pendubot, a cart-pole or a geared arm, the forward dynamics a = M^-1 (tau - C v - G - B v)
have a closed form (M is 2 x 2 or 1 x 1), so a whole fixed-step run compiles to one machine-code
loop with no allocation and no Python call per step. It is a second path, not a second truth:
:meth:`FastDynamics.from_robot` checks its accelerations against Pinocchio's ABA on seeded random
states before handing it out, and ``tests/test_fast.py`` holds whole trajectories to round-off
against :func:`robodyn.simulate` with the ABA backend.

Closed forms (link coordinates, the conventions of :mod:`robodyn.kinds.formulas`):

* Pendubot: with a = m1 lc1^2 + m2 l1^2 + I1, b = m2 lc2^2 + I2, c = m2 l1 lc2,
  M = [[a + b + 2 c cos q2, b + c cos q2], [b + c cos q2, b]],
  C v = [-c sin q2 (2 q1' q2' + q2'^2), c sin q2 q1'^2],
  G = [(m1 lc1 + m2 l1) g cos q1 + m2 lc2 g cos(q1 + q2), m2 lc2 g cos(q1 + q2)].
* Cart-pole: M = [[M + m, m l cos th], [m l cos th, m l^2 + I]],
  C v = [-m l sin th th'^2, 0], G = [0, -m g l sin th].
* Geared arm: (J_l + n^2 J_m) q'' + M g l sin q = tau.

The 2 x 2 system is solved by Cramer's rule: det M = M11 M22 - M12^2 > 0 for any physical
parameters. Viscous damping B = diag(robot.damping) is applied as -B v, as :func:`robodyn.simulate`
does; Coulomb friction is refused (its sign switch has no place in a smooth closed form).

numba is imported on first use, never at ``import robodyn``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn.errors import AssumptionError, InputError, MissingDependencyError, UnknownNameError
from robodyn.integrators import step_count

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.sim.trajectory import Trajectory

Array = NDArray[np.float64]

# Kind -> (integer code used inside the compiled kernels, parameter names in kernel order).
KINDS: dict[str, tuple[int, tuple[str, ...]]] = {
    "pendubot": (0, ("m1", "m2", "l1", "lc1", "lc2", "I1", "I2", "g")),
    "cart_pole": (1, ("M", "m", "l", "I", "g")),
    "geared_arm": (2, ("J_m", "J_l", "n", "M", "l", "g")),
}
METHODS = ("rk4", "semi_implicit_euler")

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
    njit = numba.njit(cache=True, fastmath=False, nogil=True)

    @njit
    def acc(kind, p, b, q0, q1, v0, v1, t0, t1):  # type: ignore[no-untyped-def]
        if kind == 0:  # pendubot
            m1, m2, l1, lc1, lc2, I1, I2, g = p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]
            c = m2 * l1 * lc2
            cq2 = np.cos(q1)
            sq2 = np.sin(q1)
            bb = m2 * lc2 * lc2 + I2
            m11 = m1 * lc1 * lc1 + m2 * l1 * l1 + I1 + bb + 2.0 * c * cq2
            m12 = bb + c * cq2
            m22 = bb
            g12 = m2 * lc2 * g * np.cos(q0 + q1)
            r0 = t0 - b[0] * v0 + c * sq2 * (2.0 * v0 * v1 + v1 * v1) - (m1 * lc1 + m2 * l1) * g * np.cos(q0) - g12
            r1 = t1 - b[1] * v1 - c * sq2 * v0 * v0 - g12
        elif kind == 1:  # cart_pole
            mc, mp, lp, ip, g = p[0], p[1], p[2], p[3], p[4]
            ct = np.cos(q1)
            st = np.sin(q1)
            m11 = mc + mp
            m12 = mp * lp * ct
            m22 = mp * lp * lp + ip
            r0 = t0 - b[0] * v0 + mp * lp * st * v1 * v1
            r1 = t1 - b[1] * v1 + mp * g * lp * st
        else:  # geared_arm, one degree of freedom
            J_m, J_l, n, ma, la, g = p[0], p[1], p[2], p[3], p[4], p[5]
            return (t0 - b[0] * v0 - ma * g * la * np.sin(q0)) / (J_l + n * n * J_m), 0.0
        det = m11 * m22 - m12 * m12
        return (m22 * r0 - m12 * r1) / det, (m11 * r1 - m12 * r0) / det

    @njit
    def energies(kind, p, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        """(kinetic, potential) with V zero at world height 0 (Pinocchio's convention)."""
        if kind == 0:
            m1, m2, l1, lc1, lc2, I1, I2, g = p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]
            c = m2 * l1 * lc2
            bb = m2 * lc2 * lc2 + I2
            m11 = m1 * lc1 * lc1 + m2 * l1 * l1 + I1 + bb + 2.0 * c * np.cos(q1)
            m12 = bb + c * np.cos(q1)
            kin = 0.5 * (m11 * v0 * v0 + 2.0 * m12 * v0 * v1 + bb * v1 * v1)
            pot = (m1 * lc1 + m2 * l1) * g * np.sin(q0) + m2 * lc2 * g * np.sin(q0 + q1)
            return kin, pot
        if kind == 1:
            mc, mp, lp, ip, g = p[0], p[1], p[2], p[3], p[4]
            kin = 0.5 * ((mc + mp) * v0 * v0 + 2.0 * mp * lp * np.cos(q1) * v0 * v1 + (mp * lp * lp + ip) * v1 * v1)
            return kin, mp * g * lp * np.cos(q1)
        J_m, J_l, n, ma, la, g = p[0], p[1], p[2], p[3], p[4], p[5]
        return 0.5 * (J_l + n * n * J_m) * v0 * v0, -ma * g * la * np.cos(q0)

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

    # Compile now (or load numba's cache), so that no timed run pays for it.
    z2, z = np.zeros(2), np.zeros((2, 2))
    for method in (0, 1):
        run(2, method, np.ones(6), z2, 1, z2, z2, z2, 1e-3, 1, z.copy(), z.copy(), z.copy())
    energy_series(2, np.ones(6), z, z, np.zeros(2), np.zeros(2))
    acc_batch(2, np.ones(6), z2, z, z, z, z.copy())
    return {"run": run, "energy_series": energy_series, "acc_batch": acc_batch}


def _pad(x: Array) -> Array:
    """A 1- or 2-vector as a 2-vector (the kernels always carry two slots)."""
    out = np.zeros(2)
    out[: x.size] = x
    return out


@dataclass(frozen=True, eq=False)
class FastDynamics:
    """Compiled closed-form dynamics of one seed-kind robot.

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
            AssumptionError: the robot is not of a seed kind, has Coulomb friction, or its
                closed-form accelerations disagree with ABA by more than ``VERIFY_RTOL``.
        """
        from robodyn.kinds import params as params_module

        if kind is None:
            kind = params_module.detect_kind(robot)
            if kind is None:
                raise AssumptionError(
                    f"{robot.name}: the fast path serves only the seed kinds ({', '.join(KINDS)}); "
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
        from robodyn.sim.trajectory import Trajectory

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


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel now; later runs time the loop only."""
    _kernels()
