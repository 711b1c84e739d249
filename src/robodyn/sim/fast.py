"""The built-in kinds' fast path: a robot of a built-in kind handed to the compiled closed-form kernels.

For a Pendubot, a cart-pole or a geared arm, :class:`FastDynamics` reads the kind's parameters
from the robot and runs :mod:`robodyn.engine.closed_form` (the kind's own closed form and the one
RK4 step, compiled by numba) on its arrays, returning a :class:`~robodyn.sim.trajectory.Trajectory`.

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
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn.engine.closed_form import KINDS, METHODS, kernels
from robodyn.errors import AssumptionError, InputError, UnknownNameError
from robodyn.integrators import step_count
from robodyn.kinds import params as params_module
from robodyn.sim.trajectory import Trajectory

if TYPE_CHECKING:
    from robodyn.robot import Robot

__all__ = ["KINDS", "METHODS", "FastDynamics", "batch_rk4", "warm_up"]

Array = NDArray[np.float64]

# Closed form against Pinocchio's ABA, relative to the largest acceleration: both are exact
# formulas evaluated in float64, so they differ by a few hundred ulps at most.
VERIFY_RTOL = 1e-9
VERIFY_STATES = 16


def batch_rk4(fast: FastDynamics, Q: Array, V: Array, *, dt: float, steps: int, blocks: NDArray[np.int64]) -> None:
    """Classic RK4 without torque on a batch Q, V (m, 2) in place (padded to 2 columns), one prange over ``blocks``."""
    code = KINDS[fast.kind][0]
    kernels()["batch_rk4"](code, fast.param_vector, _pad(fast.damping), fast.nv, Q, V, dt, steps, blocks)


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
        kernels()["acc_batch"](KINDS[self.kind][0], self.param_vector, _pad(self.damping), Q, V, T, A)
        out = A[:, : self.nv]
        return out[0].copy() if np.ndim(q) == 1 else out

    def energies(self, q: ArrayLike, v: ArrayLike) -> tuple[float, float]:
        """(kinetic, potential) [J] of one state; the potential on Pinocchio's zero."""
        Q = _pad(np.asarray(q, dtype=np.float64))[None, :]
        V = _pad(np.asarray(v, dtype=np.float64))[None, :]
        K, P = np.zeros(1), np.zeros(1)
        kernels()["energy_series"](KINDS[self.kind][0], self.param_vector, Q, V, K, P)
        return float(K[0]), float(P[0]) + self.potential_offset

    def energies_batch(self, Q: ArrayLike, V: ArrayLike) -> tuple[Array, Array]:
        """(kinetic (n,), potential (n,)) [J] of a batch of states Q, V (n, nv); the potential on Pinocchio's zero."""
        Q_, V_ = _pad2(np.asarray(Q, dtype=np.float64)), _pad2(np.asarray(V, dtype=np.float64))
        K, P = np.zeros(Q_.shape[0]), np.zeros(Q_.shape[0])
        kernels()["energy_series"](KINDS[self.kind][0], self.param_vector, Q_, V_, K, P)
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
        kern = kernels()
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
    return kernels()
