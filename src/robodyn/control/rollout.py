"""Closed-loop rollouts of a batch of initial states: a vectorised controller inside a vectorised RK4.

:func:`robodyn.simulate` runs one state with a Python callable per stage; a basin map needs
thousands. Here the controller takes a batch, policy(q (m, nq), v (m, nv)) -> u (m, n_act), and
the accelerations of the whole batch come from one call per RK4 stage:

* ``"fast"``: the built-in kinds' compiled closed form (:class:`robodyn.sim.fast.FastDynamics`,
  checked against Pinocchio's ABA when built), joint damping included;
* ``"aba"``: Pinocchio's ABA state by state (any robot with nq == nv), the slow, obviously
  correct oracle;
* ``"cuda"``: an NVIDIA GPU, one thread a state (:func:`robodyn.engine.cuda.closed_loop.closed_loop`), for
  the controllers of ``robodyn.control.make("lqr" | "swing_up", robot)`` on the cart-pole and the
  Pendubot: their laws are written once (:mod:`robodyn.engine.torque_laws`) and compiled by numba for
  the GPU, the same arithmetic as ``"fast"`` with the sweep's batch form of the controller
  (:func:`robodyn.sweep.policy.batch_policy`). Needs the ``cuda`` extra and a GPU (numba's CUDA
  simulator, ``NUMBA_ENABLE_CUDASIM=1``, runs it on the CPU, slowly).

The step is classical RK4 with the torque re-evaluated at every stage, as
:func:`robodyn.simulate` does with ``integrator="rk4"``, so the two agree to round-off on the
same states. Besides the final states, the range each coordinate swept is kept (the cart's rail).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics
from robodyn.errors import InputError, UnknownNameError
from robodyn.integrators import step_count
from robodyn.kinds import params
from robodyn.robot import Robot
from robodyn.sim.fast import FastDynamics

Array = NDArray[np.float64]
Policy = Callable[[Array, Array], Array]

BACKENDS = ("fast", "aba", "cuda")


@dataclass(frozen=True, eq=False)
class Rollout:
    """Final states q (m, nq), v (m, nv); the extremes q_min, q_max (m, nq) over the run; its cost."""

    q: Array
    v: Array
    q_min: Array
    q_max: Array
    dt: float
    steps: int
    backend: str
    wall_time_s: float


def closed_loop(
    robot: Robot,
    policy: Policy,
    q0: ArrayLike,
    v0: ArrayLike,
    *,
    duration: float,
    dt: float,
    backend: str = "fast",
) -> Rollout:
    """Advance every state of the batch (q0 (m, nq), v0 (m, nv)) for ``duration`` [s] by RK4 steps of ``dt`` [s].

    ``policy`` maps a batch of states to the actuated torques (m, n_act) [N m | N]; ``backend`` is
    ``"fast"`` (built-in kinds) or ``"aba"``. A state that blows up stays non-finite (NaN) from then on.
    With ``backend="cuda"``, ``policy`` is the controller itself (an LQR or a swing-up to LQR that
    :func:`robodyn.control.make` built for a cart-pole or a Pendubot), or its ``batch`` method.

    Raises:
        InputError: bad shapes, nq != nv, or a ``policy`` the GPU has no law for.
        MissingDependencyError, UnavailableError: ``backend="cuda"`` without the ``cuda`` extra or a GPU.
    """
    if backend not in BACKENDS:
        raise UnknownNameError("rollout backend", backend, BACKENDS)
    if not robot.nq_equals_nv:
        raise InputError(f"{robot.name}: closed-loop rollouts need nq == nv, got nq={robot.nq}, nv={robot.nv}")
    Q = np.atleast_2d(np.asarray(q0, dtype=np.float64)).copy()
    V = np.atleast_2d(np.asarray(v0, dtype=np.float64)).copy()
    if Q.shape[1] != robot.nq or V.shape != Q.shape:
        raise InputError(f"q0 and v0 must both have shape (m, {robot.nq}), got {Q.shape} and {V.shape}")
    steps = step_count(duration, dt)
    if backend == "cuda":
        return _cuda(robot, policy, Q, V, dt, steps)
    accel = _accelerations(robot, backend)
    S = robot.input_matrix()

    def rates(q: Array, v: Array) -> Array:
        return accel(q, v, policy(q, v) @ S.T)

    q_min, q_max = Q.copy(), Q.copy()
    start = time.perf_counter()
    with np.errstate(all="ignore"):  # a state that blows up is kept as NaN, not raised on
        for _ in range(steps):
            k1q, k1v = V, rates(Q, V)
            k2q, k2v = V + 0.5 * dt * k1v, rates(Q + 0.5 * dt * k1q, V + 0.5 * dt * k1v)
            k3q, k3v = V + 0.5 * dt * k2v, rates(Q + 0.5 * dt * k2q, V + 0.5 * dt * k2v)
            k4q, k4v = V + dt * k3v, rates(Q + dt * k3q, V + dt * k3v)
            Q = Q + dt / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q)
            V = V + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
            np.fmin(q_min, Q, out=q_min)
            np.fmax(q_max, Q, out=q_max)
            bad = ~np.isfinite(Q).all(axis=1) | ~np.isfinite(V).all(axis=1)
            if np.any(bad):
                Q[bad], V[bad] = np.nan, np.nan
    wall = time.perf_counter() - start
    return Rollout(Q, V, q_min, q_max, dt, steps, backend, wall)


def _accelerations(robot: Robot, backend: str) -> Callable[[Array, Array, Array], Array]:
    """a(q (m, nq), v (m, nv), tau (m, nv)) of the batch, joint damping included."""
    if backend == "fast":
        fast = FastDynamics.from_robot(robot)
        return lambda q, v, tau: np.asarray(fast.acceleration(q, v, tau), dtype=np.float64).reshape(q.shape)
    model, data, damping = robot.model, robot.data, robot.damping

    def aba(q: Array, v: Array, tau: Array) -> Array:
        out = np.full(q.shape, np.nan)
        for k in range(q.shape[0]):
            if np.isfinite(q[k]).all() and np.isfinite(v[k]).all() and np.isfinite(tau[k]).all():
                out[k] = dynamics.aba(model, data, q[k], v[k], tau[k] - damping * v[k])
        return out

    return aba


def _cuda(robot: Robot, policy: object, Q: Array, V: Array, dt: float, steps: int) -> Rollout:
    """:func:`closed_loop` on the GPU: the controller's law (its parameter vector) in one thread a state."""
    from robodyn.control.compiled import law_of
    from robodyn.engine.cuda import closed_loop as cuda_closed

    controller = getattr(policy, "__self__", policy)  # lqr.batch -> the LQR
    kind = params.detect_kind(robot)
    fast = FastDynamics.from_robot(robot, kind) if kind in ("pendubot", "cart_pole") else None
    found = law_of(controller, fast)
    if fast is None or found is None:
        raise InputError(
            "backend 'cuda' runs the controllers robodyn.control.make('lqr' | 'swing_up', robot) builds for a "
            f"cart-pole or a Pendubot; got {type(controller).__name__} for {robot.name}"
        )
    name, c = found
    b = np.zeros(2)
    b[: fast.nv] = fast.damping
    n = Q.shape[0]
    q, v, q_min, q_max, _, blown, wall = cuda_closed.closed_loop(
        fast.kind,
        name,
        fast.param_vector,
        b,
        c,
        Q,
        V,
        upright=np.zeros(2),
        angular=np.zeros(2),
        tol=0.0,
        bound=np.full(n, np.inf),  # no energy bound: only a state that stops being finite ends a run
        offset=fast.potential_offset,
        dt=dt,
        steps=steps,
    )
    q[blown], v[blown] = np.nan, np.nan
    return Rollout(q, v, q_min, q_max, dt, steps, "cuda", wall)


@dataclass(frozen=True, eq=False)
class FamilyRollout:
    """Per run of a family (m,): when it entered the upright for good, its error and torque, the switch's use.

    ``time_to_balance`` [s] (NaN: outside at the end), ``final_error`` [rad] the largest wrapped
    angle error over the last ``hold`` seconds, ``peak_torque`` [N m | N] the largest |u| applied,
    ``entered_region`` whether the LQR ever took over, ``q_min``/``q_max`` (m, 2) the range swept.
    """

    time_to_balance: Array
    final_error: Array
    peak_torque: Array
    entered_region: NDArray[np.bool_]
    q_min: Array
    q_max: Array
    q: Array
    v: Array
    wall_time_s: float


def closed_loop_family(
    kind: str,
    law: str,
    c: Array,
    p: Array,
    b: Array,
    q0: Array,
    v0: Array,
    *,
    duration: float,
    dt: float,
    upright: Array,
    angular: NDArray[np.bool_],
    hold: float,
) -> FamilyRollout:
    """RK4 closed loops of m different systems of one built-in kind at once, each with its own controller.

    ``c`` (SIZE, m) stacks the controllers' parameter vectors (:func:`robodyn.control.compiled.law_of`),
    ``p`` (n_params, m) the kinds' closed-form parameters, ``b`` (2, m) the damping; the law
    (:func:`robodyn.engine.torque_laws.law`, the body the GPU compiles) and the closed form act
    element-wise, so one NumPy pass steps the whole family. The balance measure is
    :func:`robodyn.control.outcome.inside_upright` sample by sample, as the sweep's ``time_to_balance``.
    """
    from robodyn.control import outcome
    from robodyn.engine import torque_laws as tl
    from robodyn.kinds.catalog import closed_form

    form = closed_form(kind)
    torque = tl.law(kind, law)
    act = c[tl.ACT] > 0.5
    steps = step_count(duration, dt)
    hold_steps = round(hold / dt)

    def rates(q: Array, v: Array) -> tuple[Array, Array, Array]:
        u = torque(c, p, b, q[0], q[1], v[0], v[1])
        m11, m12, m22 = form.mass(p, q[0], q[1])
        c11, c12, c21, c22 = form.coriolis(p, q[0], q[1], v[0], v[1])
        g0, g1 = form.gravity(p, q[0], q[1])
        r0 = np.where(act, 0.0, u) - (c11 * v[0] + c12 * v[1]) - g0 - b[0] * v[0]
        r1 = np.where(act, u, 0.0) - (c21 * v[0] + c22 * v[1]) - g1 - b[1] * v[1]
        det = m11 * m22 - m12 * m12
        return np.stack([(m22 * r0 - m12 * r1) / det, (m11 * r1 - m12 * r0) / det]), u, m11

    Q, V = np.array(q0, dtype=np.float64).T.copy(), np.array(v0, dtype=np.float64).T.copy()
    m = Q.shape[1]
    q_min, q_max = Q.copy(), Q.copy()
    last_out = np.full(m, -1)
    error = np.zeros(m)
    peak = np.zeros(m)
    entered = np.zeros(m, dtype=bool)
    start = time.perf_counter()
    with np.errstate(all="ignore"):
        for step in range(steps + 1):
            inside = outcome.inside_upright(Q.T, upright, angular)
            last_out[~inside] = step
            if step >= steps - hold_steps:
                error = np.fmax(error, outcome.angle_error(Q.T, upright, angular))
            if step == steps:
                break
            k1v, u, _ = rates(Q, V)
            peak = np.fmax(peak, np.abs(u))
            entered |= _inside_region(c, Q, V)
            k1q = V
            k2v = rates(Q + 0.5 * dt * k1q, V + 0.5 * dt * k1v)[0]
            k2q = V + 0.5 * dt * k1v
            k3v = rates(Q + 0.5 * dt * k2q, V + 0.5 * dt * k2v)[0]
            k3q = V + 0.5 * dt * k2v
            k4v = rates(Q + dt * k3q, V + dt * k3v)[0]
            k4q = V + dt * k3v
            Q = Q + dt / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q)
            V = V + dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v)
            np.fmin(q_min, Q, out=q_min)
            np.fmax(q_max, Q, out=q_max)
    wall = time.perf_counter() - start
    finite = np.isfinite(Q).all(axis=0) & np.isfinite(V).all(axis=0)
    ttb = np.where((last_out < steps) & finite, (last_out + 1) * dt, np.nan)
    error[~finite] = np.nan
    return FamilyRollout(ttb, error, peak, entered, q_min.T, q_max.T, Q.T, V.T, wall)


def _inside_region(c: Array, Q: Array, V: Array) -> NDArray[np.bool_]:
    """Whether each state lies in its controller's region e^T P e < rho (the switch's own test)."""
    from robodyn.engine import torque_laws as tl

    e = np.stack([Q[0] - c[tl.Q_EQ], Q[1] - c[tl.Q_EQ + 1], V[0], V[1]])
    for i in range(2):
        e[i] = np.where(c[tl.ANGULAR + i] > 0.5, (e[i] + np.pi) % (2.0 * np.pi) - np.pi, e[i])
    value = sum(e[i] * c[tl.P + 4 * i + j] * e[j] for i in range(4) for j in range(4))
    return np.asarray(value < c[tl.RHO])
