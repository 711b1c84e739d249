"""Minimal models: lock the joints a scene does not move, and prove it costs nothing.

:func:`reduce` locks joints through ``pinocchio.buildReducedModel``: each locked joint
becomes a fixed joint at its locked value, and the bodies it carried are welded to their
parent. The joint parameters robodyn relies on (armature, rotor inertia and gear ratio,
damping, friction, position, velocity and effort limits) are copied by joint name from
the full model afterwards, so they survive whichever Pinocchio release did the reduction
(some were reported to drop armature).

:class:`Reduction` maps states between the two models, and :func:`locked_acceleration`
gives the full model's accelerations with the locked joints held by constraint (the KKT
system of constrained dynamics with a selection-matrix constraint Jacobian): the exactness
proof compares it, and trajectories built on it, with the reduced model.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics
from robodyn.errors import InputError, ModelError, UnknownNameError
from robodyn.robot import Robot, as_vector

Array = NDArray[np.float64]
IndexArray = NDArray[np.intp]

# Per-coordinate joint parameters carried over by name: attribute -> "q" or "v" indexed.
CARRIED = {
    "armature": "v",
    "rotorInertia": "v",
    "rotorGearRatio": "v",
    "damping": "v",
    "friction": "v",
    "effortLimit": "v",
    "velocityLimit": "v",
    "lowerPositionLimit": "q",
    "upperPositionLimit": "q",
}


@dataclass(frozen=True, eq=False)
class Reduction:
    """A full robot, its reduced model, and the maps between their states.

    ``q_reference`` (nq_full,) is the full configuration whose locked coordinates are held;
    ``kept_q`` / ``kept_v`` index the reduced coordinates inside the full q / v.
    """

    full: Robot
    reduced: Robot
    locked: tuple[str, ...]
    q_reference: Array
    kept_q: IndexArray
    kept_v: IndexArray

    @property
    def locked_v(self) -> IndexArray:
        """Indices of the locked velocity coordinates in the full v."""
        return np.setdiff1d(np.arange(self.full.nv), self.kept_v)

    @property
    def selection(self) -> Array:
        """Constraint Jacobian S (n_locked_v, nv_full): S v = 0 holds the locked joints."""
        S = np.zeros((self.locked_v.size, self.full.nv))
        S[np.arange(self.locked_v.size), self.locked_v] = 1.0
        return S

    def full_q(self, q: ArrayLike) -> Array:
        """Full configuration (nq_full,) of a reduced configuration (nq_red,)."""
        out = self.q_reference.copy()
        out[self.kept_q] = self.reduced.q_(q)
        return out

    def full_v(self, v: ArrayLike) -> Array:
        """Full velocity (nv_full,) of a reduced one: zero on the locked joints."""
        out = np.zeros(self.full.nv)
        out[self.kept_v] = self.reduced.v_(v)
        return out

    def reduced_q(self, q: ArrayLike) -> Array:
        """Reduced configuration of a full one (its locked coordinates are ignored)."""
        return self.full.q_(q)[self.kept_q].copy()

    def reduced_v(self, v: ArrayLike) -> Array:
        """Reduced velocity of a full one (its locked coordinates are ignored)."""
        return self.full.v_(v)[self.kept_v].copy()

    def lock_values(self) -> dict[str, Array]:
        """Locked joint name -> its held coordinates [rad | m]."""
        return {
            name: self.q_reference[j.idx_q : j.idx_q + j.nq].copy()
            for name in self.locked
            for j in (self.full.joint(name),)
        }


def parse_lock(text: str) -> dict[str, float]:
    """``"joint_a=0.1,joint_b=-0.5"`` -> {name: value}; an InputError names a bad item."""
    values: dict[str, float] = {}
    for item in (x.strip() for x in text.split(",")):
        if not item:
            continue
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise InputError(f"--lock expects name=value items separated by commas, got {item!r}")
        try:
            number = float(value)
        except ValueError:
            raise InputError(f"--lock {name.strip()}: expected a number after '=', got {value!r}") from None
        if not np.isfinite(number):
            raise InputError(f"--lock {name.strip()}: expected a finite number, got {value!r}")
        values[name.strip()] = number
    if not values:
        raise InputError("--lock expects at least one name=value item")
    return values


def parse_keep(text: str) -> tuple[str, ...]:
    """``"joint_a,joint_b"`` -> the names (at least one)."""
    names = tuple(x.strip() for x in text.split(",") if x.strip())
    if not names:
        raise InputError("--keep expects at least one joint name")
    return names


def reference_configuration(robot: Robot, reference: ArrayLike | str | None) -> Array:
    """The full configuration at which locked joints are held: neutral, a vector, or an SRDF state."""
    if reference is None:
        return robot.neutral()
    if isinstance(reference, str):
        from robodyn.model.files import reference_configurations

        states = reference_configurations(robot)
        if reference not in states:
            raise UnknownNameError(f"reference configuration of {robot.name}", reference, states)
        return states[reference]
    return as_vector(reference, robot.nq, "reference configuration")


def locked_joints(
    robot: Robot,
    *,
    lock: Mapping[str, float | Sequence[float]] | None = None,
    keep: Iterable[str] | None = None,
    reference: ArrayLike | str | None = None,
) -> tuple[tuple[str, ...], Array]:
    """Which joints to lock, and the full configuration (nq,) that holds them.

    ``keep`` names the joints that stay (all others are locked); ``lock`` names joints to
    lock with their values. Both may be given: then ``lock`` sets values of joints that
    ``keep`` leaves out. Values outside a joint's position limits are refused.
    """
    from robodyn.robot import joint_coordinates

    lock = dict(lock or {})
    names = robot.joint_names
    for name in lock:
        if name not in names:
            raise UnknownNameError(f"joint of {robot.name} to lock", name, names)
    if keep is not None:
        kept = tuple(keep)
        for name in kept:
            if name not in names:
                raise UnknownNameError(f"joint of {robot.name} to keep", name, names)
        both = sorted(set(kept) & set(lock))
        if both:
            raise InputError(f"joint {both[0]!r} is both kept and locked; keep it or lock it")
        locked = tuple(n for n in names if n not in kept)
    else:
        locked = tuple(n for n in names if n in lock)
    if len(locked) == len(names):
        raise InputError(f"locking every joint of {robot.name} leaves nothing to move; keep at least one")
    q = reference_configuration(robot, reference).copy()
    lower, upper = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    for name, value in lock.items():
        joint = robot.joint(name)
        coords = joint_coordinates(joint.kind, joint.nq, np.atleast_1d(np.asarray(value, dtype=np.float64)))
        if joint.nq == joint.nv:
            lo, hi = lower[joint.idx_q : joint.idx_q + joint.nq], upper[joint.idx_q : joint.idx_q + joint.nq]
            if np.any(coords < lo) or np.any(coords > hi):
                raise InputError(
                    f"lock value {np.array2string(coords, precision=6)} of joint {name!r} is outside its limits "
                    f"[{np.array2string(lo, precision=6)}, {np.array2string(hi, precision=6)}]"
                )
        q[joint.idx_q : joint.idx_q + joint.nq] = coords
    return locked, q


def reduce(
    robot: Robot,
    *,
    lock: Mapping[str, float | Sequence[float]] | None = None,
    keep: Iterable[str] | None = None,
    reference: ArrayLike | str | None = None,
) -> Reduction:
    """Lock joints of ``robot`` and return the :class:`Reduction` to its minimal model.

    See :func:`locked_joints` for ``lock``, ``keep`` and ``reference``. The reduced robot
    keeps the full robot's name, URDF (geometry loads onto it) and passive joints.
    """
    locked, q_ref = locked_joints(robot, lock=lock, keep=keep, reference=reference)
    full = robot.model
    ids = [int(full.getJointId(name)) for name in locked]
    try:
        model = pin.buildReducedModel(full, ids, q_ref)
    except (RuntimeError, ValueError) as exc:
        raise ModelError(f"Pinocchio cannot reduce {robot.name}: {str(exc).strip().splitlines()[0]}") from None
    carry_joint_parameters(full, model)
    kept_names = [str(n) for n in list(model.names)[1:]]
    kept_q = np.concatenate([_q_slice(robot, n) for n in kept_names]).astype(np.intp)
    kept_v = np.concatenate([_v_slice(robot, n) for n in kept_names]).astype(np.intp)
    reduced = Robot.from_model(
        model,
        name=robot.name,
        urdf_path=robot.urdf_path,
        srdf_path=robot.srdf_path,
        passive_joints=tuple(n for n in robot.passive_joints if n in kept_names),
    )
    return Reduction(robot, reduced, locked, q_ref, kept_q, kept_v)


def _q_slice(robot: Robot, name: str) -> IndexArray:
    j = robot.joint(name)
    return np.arange(j.idx_q, j.idx_q + j.nq)


def _v_slice(robot: Robot, name: str) -> IndexArray:
    j = robot.joint(name)
    return np.arange(j.idx_v, j.idx_v + j.nv)


def carry_joint_parameters(full: pin.Model, reduced: pin.Model) -> None:
    """Copy armature, rotor, damping, friction and limits from ``full`` to ``reduced`` by joint name."""
    for attr, space in CARRIED.items():
        source = np.asarray(getattr(full, attr), dtype=np.float64)
        target = np.array(getattr(reduced, attr), dtype=np.float64)
        for j in range(1, reduced.njoints):
            jr, jf = reduced.joints[j], full.joints[full.getJointId(reduced.names[j])]
            if space == "v":
                target[jr.idx_v : jr.idx_v + jr.nv] = source[jf.idx_v : jf.idx_v + jf.nv]
            else:
                target[jr.idx_q : jr.idx_q + jr.nq] = source[jf.idx_q : jf.idx_q + jf.nq]
        setattr(reduced, attr, target)


def locked_acceleration(reduction: Reduction, q: ArrayLike, v: ArrayLike, tau: ArrayLike) -> tuple[Array, Array]:
    """Full-model accelerations with the locked joints held by constraint, and the holding torques.

    Solves the KKT system of constrained dynamics

        [ M  S^T ] [  a  ]   [ tau - C v - G ]
        [ S   0  ] [ -lam] = [       0       ]

    with S the selection of the locked velocity coordinates (:attr:`Reduction.selection`);
    ``lam`` (n_locked_v,) [N m | N] is what the locks apply. Returns (a (nv,), lam).
    """
    full = reduction.full
    q_, v_, tau_ = full.q_(q), full.v_(v), full.v_(tau, "tau")
    M = dynamics.mass_matrix(full.model, full.data, q_)
    b = dynamics.nonlinear_effects(full.model, full.data, q_, v_)
    S = reduction.selection
    k = S.shape[0]
    K = np.block([[M, S.T], [S, np.zeros((k, k))]])
    rhs = np.concatenate([tau_ - b, np.zeros(k)])
    solution = np.linalg.solve(K, rhs)
    return solution[: full.nv], -solution[full.nv :]


@dataclass(frozen=True)
class ExactnessReport:
    """A reduced trajectory against the full model's with the locked joints held by constraint.

    Arrays: ``t`` (n,) [s]; ``q_reduced`` (n, nq_red) and ``q_full`` (n, nq_full) with
    velocities ``v_reduced``, ``v_full``. Errors are max-abs over the run: ``q_error``
    [rad | m] and ``v_error`` [rad/s | m/s] between the kept coordinates; ``lock_drift``
    how far the locked coordinates moved from their held values; ``max_lock_torque``
    [N m | N] the largest torque the locks applied.
    """

    t: Array
    q_reduced: Array
    v_reduced: Array
    q_full: Array
    v_full: Array
    q_error: float
    v_error: float
    lock_drift: float
    max_lock_torque: float
    method: str
    dt: float
    wall_time_reduced_s: float
    wall_time_full_s: float


def prove_exact(
    reduction: Reduction,
    q0: ArrayLike,
    v0: ArrayLike,
    *,
    duration: float,
    dt: float,
    tau: ArrayLike | Callable[[float, Array, Array], ArrayLike] | None = None,
    method: str = "rk4",
) -> ExactnessReport:
    """Integrate the reduced model and the constrained full model side by side.

    Both use the integrator ``method`` with step ``dt`` [s] for ``duration`` [s], joint
    torques ``tau`` on the reduced joints [N m | N]: zero by default, a constant (nv_red,),
    or a controller tau(t, q_red, v_red) (the full model feeds it its kept coordinates),
    and each model's viscous damping (-damping * v). The reduced model runs on ABA; the full model on the KKT solve
    of :func:`locked_acceleration`. Exactness means the errors are round-off.
    """
    import time

    from robodyn import integrators

    red, full = reduction.reduced, reduction.full
    q0_, v0_ = red.q_(q0), red.v_(v0)
    if callable(tau):
        controller = tau

        def torque_reduced(t: float, q: Array, v: Array) -> Array:
            return red.v_(controller(t, q, v), "tau")

    else:
        constant = np.zeros(red.nv) if tau is None else red.v_(tau, "tau")

        def torque_reduced(t: float, q: Array, v: Array) -> Array:
            return constant

    if not (np.isfinite(duration) and duration > 0):
        raise InputError(f"duration must be a positive number of seconds, got {duration!r}")
    if not (np.isfinite(dt) and dt > 0):
        raise InputError(f"dt must be a positive number of seconds, got {dt!r}")
    n_steps = max(1, round(duration / dt))
    damping_red, damping_full = red.damping, full.damping

    def accel_reduced(t: float, q: Array, v: Array) -> Array:
        return dynamics.aba(red.model, red.data, q, v, torque_reduced(t, q, v) - damping_red * v)

    lock_torque = [0.0]

    def accel_full(t: float, q: Array, v: Array) -> Array:
        tau_full = np.zeros(full.nv)
        tau_full[reduction.kept_v] = torque_reduced(t, q[reduction.kept_q], v[reduction.kept_v])
        a, lam = locked_acceleration(reduction, q, v, tau_full - damping_full * v)
        lock_torque[0] = max(lock_torque[0], float(np.abs(lam).max(initial=0.0)))
        return a

    def problem(accel: object, robot: Robot) -> integrators.ArrayProblem:
        model = robot.model
        return integrators.ArrayProblem(
            accel,  # type: ignore[arg-type]
            robot.nq,
            robot.nv,
            integrate_fn=None if robot.nq_equals_nv else (lambda q, dq: dynamics.integrate(model, q, dq)),
        )

    start = time.perf_counter()
    sol_red = integrators.solve(problem(accel_reduced, red), q0_, v0_, dt=dt, n_steps=n_steps, method=method)
    mid = time.perf_counter()
    sol_full = integrators.solve(
        problem(accel_full, full), reduction.full_q(q0_), reduction.full_v(v0_), dt=dt, n_steps=n_steps, method=method
    )
    end = time.perf_counter()
    locked_q = np.setdiff1d(np.arange(full.nq), reduction.kept_q)
    dq = np.array(
        [dynamics.difference(red.model, a, b) for a, b in zip(sol_red.q, sol_full.q[:, reduction.kept_q], strict=True)]
    )
    return ExactnessReport(
        t=sol_red.t,
        q_reduced=sol_red.q,
        v_reduced=sol_red.v,
        q_full=sol_full.q,
        v_full=sol_full.v,
        q_error=float(np.abs(dq).max()),
        v_error=float(np.abs(sol_red.v - sol_full.v[:, reduction.kept_v]).max()),
        lock_drift=float(np.abs(sol_full.q[:, locked_q] - reduction.q_reference[locked_q]).max(initial=0.0)),
        max_lock_torque=lock_torque[0],
        method=method,
        dt=dt,
        wall_time_reduced_s=mid - start,
        wall_time_full_s=end - mid,
    )


@dataclass(frozen=True)
class CostComparison:
    """Mean wall time per dynamics call [s] on the full and the reduced model.

    ``full`` and ``reduced`` map "M", "C", "G", "ABA" to seconds per call, measured on
    ``repeat`` seeded random states each.
    """

    nv_full: int
    nv_reduced: int
    full: dict[str, float]
    reduced: dict[str, float]
    repeat: int

    def speedup(self, what: str) -> float:
        """How many times faster the reduced model computes ``what``."""
        return self.full[what] / self.reduced[what]


def time_calls(robot: Robot, *, repeat: int = 200, seed: int = 0) -> dict[str, float]:
    """Mean wall time [s] of one M (CRBA), C, G and ABA call of ``robot`` over ``repeat`` states."""
    import time

    if repeat < 1:
        raise InputError(f"repeat must be >= 1, got {repeat}")
    rng = np.random.default_rng(seed)
    model, data = robot.model, robot.data
    states = [robot.random_state(rng) for _ in range(repeat)]
    taus = [rng.uniform(-1.0, 1.0, robot.nv) for _ in range(repeat)]
    calls: dict[str, Callable[[Array, Array, Array], object]] = {
        "M": lambda q, v, tau: dynamics.mass_matrix(model, data, q),
        "C": lambda q, v, tau: dynamics.coriolis_matrix(model, data, q, v),
        "G": lambda q, v, tau: dynamics.gravity(model, data, q),
        "ABA": lambda q, v, tau: dynamics.aba(model, data, q, v, tau),
    }
    out = {}
    for name, call in calls.items():
        call(*states[0], taus[0])  # warm up (first-call allocations)
        start = time.perf_counter()
        for (q, v), tau in zip(states, taus, strict=True):
            call(q, v, tau)
        out[name] = (time.perf_counter() - start) / repeat
    return out


def compare_cost(reduction: Reduction, *, repeat: int = 200, seed: int = 0) -> CostComparison:
    """Time M, C, G and ABA on the full and the reduced model side by side."""
    full = time_calls(reduction.full, repeat=repeat, seed=seed)
    reduced = time_calls(reduction.reduced, repeat=repeat, seed=seed)
    return CostComparison(reduction.full.nv, reduction.reduced.nv, full, reduced, repeat)
