"""Minimal models: lock the joints a scene does not move.

:func:`reduce` locks joints through ``pinocchio.buildReducedModel``: each locked joint
becomes a fixed joint at its locked value, and the bodies it carried are welded to their
parent. The joint parameters robodyn relies on (armature, rotor inertia and gear ratio,
damping, friction, position, velocity and effort limits) are copied by joint name from
the full model afterwards, so they survive whichever Pinocchio release did the reduction
(some were reported to drop armature).

:class:`Reduction` maps states between the two models, and :func:`locked_acceleration`
gives the full model's accelerations with the locked joints held by constraint (the KKT
system of constrained dynamics with a selection-matrix constraint Jacobian): the exactness
proof (:mod:`robodyn.studies.exactness`) compares it, and trajectories built on it, with
the reduced model.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
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
