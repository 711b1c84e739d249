"""A compiled path for any tree robot: the recursive algorithms in numba, over arrays read from the model.

:func:`extract` reads a Pinocchio model's data (``robot.model``: parents, joint types and
axes, joint placements, inertias, armature, gravity) into a :class:`TreeModel` of three
arrays; it calls no Pinocchio algorithm. The kernels of :mod:`robodyn.engine.tree.algorithms`
(articulated-body algorithm, RNEA, CRBA, energies) and of
:mod:`robodyn.engine.tree.steps` (steps and whole runs) then run on those arrays.

It serves trees of revolute, prismatic and continuous joints (one degree of freedom each),
fixed to the world or mounted on a free flyer at the root (Pinocchio's ``JointModelFreeFlyer``:
q = [position; quaternion x, y, z, w], v = [linear; angular] in the body's frame). A free
flyer below another joint, a spherical or planar joint, or a mimic joint is not served:
:func:`unsupported` says why, and :func:`robodyn.simulate` then uses Pinocchio.

It is a second implementation, so it is checked before it is trusted: :func:`compiled_of`
compares ABA, RNEA and CRBA with Pinocchio's (:mod:`robodyn.dynamics`) on seeded random states
(``VERIFY_STATES`` of them) and refuses the model if any differs by more than ``VERIFY_RTOL``
relative to the largest entry (ABA: or by more than ``VERIFY_SPREAD`` times Pinocchio's own
ABA-CRBA spread, at a state where M is so ill-conditioned that the spread is larger). The check
runs once per model and is cached while the arrays read from the model stay the same.

numba is imported on first use (the kernels' module), never at ``import robodyn``.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics
from robodyn.engine import jit
from robodyn.engine.tree import warm
from robodyn.engine.tree.layout import (
    CONTINUOUS,
    F_ARM6,
    F_ARMATURE,
    F_AXIS,
    F_INERTIA,
    F_K,
    F_LEVER,
    F_MASS,
    F_N,
    F_POS,
    F_RA,
    F_ROT,
    F_TOTAL,
    FCOLS,
    FREEFLYER,
    PRISMATIC,
    REVOLUTE,
    WCOLS,
    flyer_of,
)
from robodyn.errors import AssumptionError, InputError, MissingDependencyError

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

# Compiled ABA / RNEA / CRBA against Pinocchio's, relative to the largest entry: two float64
# implementations of the same recursions (world axes at each joint's origin here, local frames
# there) differ by round-off amplified by M's conditioning; Talos (32 joints, armature 0.1) stays
# below 1e-13.
VERIFY_RTOL = 1e-12
VERIFY_STATES = 8
# Where M is so ill-conditioned (cond 1e7: a shoulder at gimbal lock) that Pinocchio's own ABA and
# its CRBA + Cholesky solve differ by more than VERIFY_RTOL (human.urdf: 2.6e-12), the compiled ABA
# may differ from Pinocchio's by this many times that spread: no float64 answer is nearer there.
VERIFY_SPREAD = 2.0
# What verify compares; a run uses only ABA and the energies: compiled_of checks those, RNEA and CRBA
# are checked at their first use (CompiledDynamics.inverse_dynamics, mass_matrix).
VERIFY_PARTS = ("aba", "rnea", "crba", "energy")
RUN_PARTS = ("aba", "energy")

# Joint types of the kernels (tree_layout), by Pinocchio's shortname; a free flyer has no axis.
_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
_TYPES: dict[str, tuple[int, tuple[float, float, float] | None]] = {
    **{f"JointModelR{a}": (REVOLUTE, _AXES[a]) for a in "XYZ"},
    **{f"JointModelP{a}": (PRISMATIC, _AXES[a]) for a in "XYZ"},
    **{f"JointModelRUB{a}": (CONTINUOUS, _AXES[a]) for a in "XYZ"},
    "JointModelRevoluteUnaligned": (REVOLUTE, None),
    "JointModelPrismaticUnaligned": (PRISMATIC, None),
    "JointModelRevoluteUnboundedUnaligned": (CONTINUOUS, None),
    "JointModelFreeFlyer": (FREEFLYER, (0.0, 0.0, 0.0)),
}
# What a first compile of the tree kernels says it does (robodyn.engine.jit.announce): ABA, the energies,
# one sample and the loop of steps clear of the stops, for the tree's base (fixed, or a free-flyer root)
# and the run's method (RK4, or a tableau): about 20 s of CPU for the Pendubot (benchmarks/bench_first_run.py)
COMPILING = ("the tree-robot kernels", "about 20 s")
# ... and the stop events, when a run first meets a stop: the Panda's first run less the Pendubot's
COMPILING_EVENTS = ("the tree-robot kernels of joint stops", "about a minute")
# The two in s of CPU (a quiet 2-core machine), weighed against the Python loop (robodyn.sim.compile_choice)
COMPILE_S = (20.0, 60.0)


@dataclass(frozen=True, eq=False)
class TreeModel:
    """A kinematic tree as arrays: ``itree`` (n, 4) int64, ``ftree`` (n, 57) float64, ``grav`` (3,) [m/s^2].

    Row i of ``itree``: parent row (-1 for the world), type (0 revolute, 1 prismatic, 2
    continuous, 3 free flyer), index in q, index in v. Row i of ``ftree``: unit joint axis (3),
    the joint placement in its parent's frame (rotation row-major (9), translation [m] (3)),
    mass [kg], lever (centre of mass in the joint frame) [m] (3), rotational inertia about the
    centre of mass [kg m^2] (9), armature [kg m^2 | kg], and from the placement R_p and the
    axis a: R_p [a]x (9), (R_p a) a^T (9) and R_p a (3), the terms of Rodrigues' formula the
    kernels turn the joint with; then a free flyer's six armatures [kg | kg m^2] (6) and its
    mass with every body below it [kg] (the whole tree: a free flyer is its root). A free
    flyer's row has no axis (zeros in the axis and Rodrigues columns) and armature 0 in the
    one-coordinate column.
    """

    name: str
    nq: int
    nv: int
    itree: NDArray[np.int64]
    ftree: Array
    grav: Array

    @property
    def flyer(self) -> bool | None:
        """The kernels' ``flyer`` argument: True when the root row is a free flyer, else None.

        With None the kernels compile no free-flyer code (:mod:`robodyn.engine.tree.algorithms`).
        """
        return flyer_of(self.itree)

    def same_as(self, other: TreeModel) -> bool:
        """True when both hold the same numbers (a model edited since extraction is not)."""
        return (
            self.nq == other.nq
            and np.array_equal(self.itree, other.itree)
            and np.array_equal(self.ftree, other.ftree)
            and np.array_equal(self.grav, other.grav)
        )


def unsupported(robot: Robot) -> str | None:
    """Why the compiled tree path cannot serve ``robot``, or None when it can."""
    parents = robot.model.parents
    for index, j in enumerate(robot.joints, start=1):
        if j.kind not in _TYPES:
            return (
                f"joint {j.name!r} is a {j.kind}; the compiled path takes revolute, prismatic and continuous "
                "joints, and a free flyer at the root"
            )
        if _TYPES[j.kind][0] == FREEFLYER:
            others = [k.name for n, k in enumerate(robot.joints, start=1) if n != index and int(parents[n]) == 0]
            if int(parents[index]) != 0 or others:
                where = (
                    f"below joint {robot.joints[int(parents[index]) - 1].name!r}"
                    if int(parents[index]) != 0
                    else f"beside the root joint {others[0]!r}"
                )
                return (
                    f"joint {j.name!r} is a free flyer {where}; the compiled path takes a free flyer only as "
                    "the root of the whole tree (parent: the world, every other joint below it)"
                )
    if robot.nv == 0:
        return "the model has no degree of freedom"
    return None


def _unaligned_axis(joint: Any) -> NDArray[np.float64]:
    """The unit axis of an unaligned joint, read from its motion subspace S at the neutral q.

    Pinocchio's binding of ``JointModelRevoluteUnboundedUnaligned`` has no ``axis`` (the
    aligned-free revolute and prismatic ones do), while S holds the axis for all three: the
    angular rows of a revolute joint, the linear rows of a prismatic one.
    """
    inner = joint.extract()
    if hasattr(inner, "axis"):
        return np.asarray(inner.axis, dtype=np.float64)
    data = joint.createData()
    q = np.zeros(joint.nq)
    q[0] = 1.0  # cos = 1, sin = 0: the neutral configuration of a continuous joint
    joint.calc(data, q)
    S = np.asarray(data.S, dtype=np.float64).reshape(6)
    return S[3:6] if np.linalg.norm(S[3:6]) > 0 else S[0:3]


def extract(robot: Robot) -> TreeModel:
    """Read ``robot.model``'s tree into arrays (no Pinocchio algorithm is called).

    Raises:
        AssumptionError: a joint the compiled path does not take (see :func:`unsupported`).
    """
    reason = unsupported(robot)
    if reason is not None:
        raise AssumptionError(f"{robot.name}: {reason}")
    model = robot.model
    n = model.njoints - 1
    itree = np.zeros((n, 4), dtype=np.int64)
    ftree = np.zeros((n, FCOLS))
    armature = np.asarray(model.armature, dtype=np.float64)
    for i in range(n):
        j = i + 1
        joint = model.joints[j]
        code, aligned = _TYPES[joint.shortname()]
        axis = np.asarray(aligned if aligned is not None else _unaligned_axis(joint), dtype=np.float64)
        placement = model.jointPlacements[j]
        inertia = model.inertias[j]
        itree[i] = (int(model.parents[j]) - 1, code, int(joint.idx_q), int(joint.idx_v))
        ftree[i, F_AXIS : F_AXIS + 3] = axis
        ftree[i, F_ROT : F_ROT + 9] = np.asarray(placement.rotation, dtype=np.float64).reshape(9)
        ftree[i, F_POS : F_POS + 3] = np.asarray(placement.translation, dtype=np.float64)
        ftree[i, F_MASS] = float(inertia.mass)
        ftree[i, F_LEVER : F_LEVER + 3] = np.asarray(inertia.lever, dtype=np.float64)
        ftree[i, F_INERTIA : F_INERTIA + 9] = np.asarray(inertia.inertia, dtype=np.float64).reshape(9)
        if code == FREEFLYER:
            ftree[i, F_ARM6 : F_ARM6 + 6] = armature[int(joint.idx_v) : int(joint.idx_v) + 6]
            ftree[i, F_TOTAL] = sum(float(model.inertias[k].mass) for k in range(j, model.njoints))
        else:
            ftree[i, F_ARMATURE] = armature[int(joint.idx_v)]
        # products of the placement with the axis (Rodrigues' formula of the joint's rotation)
        rot = ftree[i, F_ROT : F_ROT + 9].reshape(3, 3)
        cross = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
        ftree[i, F_K : F_K + 9] = (rot @ cross).reshape(9)
        ftree[i, F_N : F_N + 9] = np.outer(rot @ axis, axis).reshape(9)
        ftree[i, F_RA : F_RA + 3] = rot @ axis
    grav = np.asarray(model.gravity.linear, dtype=np.float64).copy()
    return TreeModel(robot.name, int(model.nq), int(model.nv), itree, ftree, grav)


def one_joint(flyer: bool = False) -> TreeModel:
    """A one-joint tree (a unit revolute about z), to load or compile the kernels with.

    With ``flyer``, the joint hangs below a free-flyer root (unit mass and inertia): the kernels'
    free-flyer variant.
    """
    rows = 2 if flyer else 1
    itree = np.array([[-1, FREEFLYER, 0, 0], [0, REVOLUTE, 7, 6]] if flyer else [[-1, REVOLUTE, 0, 0]], dtype=np.int64)
    ftree = np.zeros((rows, FCOLS))
    ftree[:, [F_ROT, F_ROT + 4, F_ROT + 8, F_MASS, F_INERTIA, F_INERTIA + 4, F_INERTIA + 8]] = 1.0
    ftree[-1, [F_AXIS + 2, F_RA + 2]] = 1.0  # the revolute's axis z; R_p = 1, so R_p a = a
    ftree[-1, F_K + 1], ftree[-1, F_K + 3], ftree[-1, F_N + 8] = -1.0, 1.0, 1.0  # R_p [z]x and (R_p z) z^T
    if flyer:
        ftree[0, F_TOTAL] = 2.0
    nq, nv = (8, 7) if flyer else (1, 1)
    return TreeModel("one joint", nq, nv, itree, ftree, np.array([0.0, 0.0, -9.81]))


def _module() -> ModuleType:
    """:mod:`robodyn.engine.tree.steps` (which re-exports the algorithms), imported."""
    try:
        from robodyn.engine.tree import steps
    except ImportError as exc:  # pragma: no cover - numba is a declared dependency
        raise MissingDependencyError(f"the compiled path needs numba: pip install numba ({exc})") from None
    return steps


def run_kernels(k: ModuleType) -> tuple[Any, ...]:
    """The kernels every run uses (ABA, the kinematics of the energies, one sample) of kernels module ``k``."""
    return (k.aba, k.kinematics, k.sample)


def variant(flyer: bool) -> Callable[[tuple[Any, ...]], bool]:
    """Whether a cached signature of an algorithm or ``sample`` (``flyer`` its 4th argument) is this variant's."""
    return lambda sig: (str(sig[3]) == "none") != flyer


def run_variant(flyer: bool, tableau: bool) -> Callable[[tuple[Any, ...]], bool]:
    """Whether a cached signature of a whole run (its ``md``: ``tab`` 7th, ``flyer`` 9th) is this variant's."""
    return lambda sig: (str(sig[0].types[8]) == "none") != flyer and (str(sig[0].types[6]) == "none") != tableau


@lru_cache(maxsize=2)
def kernels(flyer: bool = False) -> ModuleType:
    """The numba kernels (:mod:`robodyn.engine.tree.steps`), with those every run uses loaded or compiled.

    ABA, the energies and one sample of a run, for trees with a free-flyer root (``flyer``) or
    without (the kernels' ``flyer`` argument True or None: two compiled variants). RNEA and CRBA
    compile at their first use (:func:`dynamics_kernels`). A one-joint tree runs each kernel once
    here, so that no timed run pays for loading it.
    """
    k = _module()
    if not all(jit.is_cached(f, variant(flyer)) for f in run_kernels(k)):
        jit.announce(*COMPILING)
    t = one_joint(flyer)
    warm.algorithms(k, t.itree, t.ftree, t.grav, t.nq, t.nv)
    return k


@lru_cache(maxsize=2)
def dynamics_kernels(flyer: bool = False) -> ModuleType:
    """:func:`kernels` with RNEA and CRBA loaded or compiled too (no run uses them: :class:`CompiledDynamics` does)."""
    k = kernels(flyer)
    if not all(jit.is_cached(f, variant(flyer)) for f in (k.rnea, k.crba)):
        jit.announce(*COMPILING)
    t = one_joint(flyer)
    warm.dynamics(k, t.itree, t.ftree, t.grav, t.nq, t.nv)
    return k


@lru_cache(maxsize=4)
def step_kernels(flyer: bool = False, tableau: bool = False) -> ModuleType:
    """:mod:`robodyn.engine.tree.events` with its loop of steps clear of the stops (``run_steps``) loaded or compiled.

    Every whole run starts there; the stop events (:func:`event_kernels`) compile only when a
    run meets a stop. ``flyer``: for a tree with a free-flyer root; ``tableau``: for a method
    given by its tableau (RK4 and semi-implicit Euler have none: the kernels' ``tab`` None, and
    numba compiles no general-tableau code). A one-joint tree runs it once here, so that no timed
    run pays for loading it.
    """
    kernels(flyer)
    from robodyn.engine.tree import events as k

    if not jit.is_cached(k.run_steps, run_variant(flyer, tableau)):
        jit.announce(*COMPILING)
    t = one_joint(flyer)
    warm.run(k, t.itree, t.ftree, t.grav, t.nq, t.nv, tableau=tableau, events=False)
    return k


@lru_cache(maxsize=4)
def event_kernels(flyer: bool = False, tableau: bool = False) -> ModuleType:
    """The numba kernels of whole runs with stop events (:mod:`robodyn.engine.tree.events`), loaded or compiled.

    ``flyer`` and ``tableau`` as :func:`step_kernels`'s. A one-joint tree with a stop runs them once
    here, so that no timed run pays for loading them.
    """
    kernels(flyer)
    from robodyn.engine.tree import events as k

    if not jit.is_cached(k.run_events, run_variant(flyer, tableau)):
        jit.announce(*COMPILING_EVENTS)
    t = one_joint(flyer)
    warm.run(k, t.itree, t.ftree, t.grav, t.nq, t.nv, tableau=tableau, events=True)
    return k


@dataclass(frozen=True, eq=False)
class CompiledDynamics:
    """ABA, RNEA, CRBA and the energies of one tree, compiled; units as :class:`robodyn.Robot`'s.

    ``check`` holds the largest relative differences from Pinocchio found by :meth:`verify`, by
    part. Made by :func:`compiled_of` (``source``: the robot it was read from), ABA and the
    energies are checked before any use; RNEA and CRBA, which no run uses, at the first call of
    :meth:`inverse_dynamics` and :meth:`mass_matrix` (their kernels compile then too).
    """

    tree: TreeModel
    check: dict[str, float]
    source: weakref.ref[Robot] | None = field(default=None, repr=False)

    def _ws(self) -> Array:
        return np.zeros((self.tree.itree.shape[0], WCOLS))

    def ensure_checked(self, part: str) -> None:
        """Check ``part`` against Pinocchio before its first use, when :func:`compiled_of` made this object.

        Raises:
            AssumptionError: it differs from Pinocchio's (as :meth:`verify` says), or the robot's model
                was edited since this object was made (it holds the arrays read then).
        """
        robot = self.source() if self.source is not None else None
        if robot is not None and part not in self.check:
            if not extract(robot).same_as(self.tree):
                raise AssumptionError(
                    f"{robot.name}: its model was edited after its compiled dynamics were made; "
                    "expected robodyn.sim.tree.compiled_of(robot) again for the model as it is now"
                )
            self.check.update(self.verify(robot, parts=(part,)))

    def _state(self, q: ArrayLike, v: ArrayLike, name: str = "v") -> tuple[Array, Array]:
        q_ = np.ascontiguousarray(q, dtype=np.float64).reshape(-1)
        v_ = np.ascontiguousarray(v, dtype=np.float64).reshape(-1)
        if q_.shape != (self.tree.nq,) or v_.shape != (self.tree.nv,):
            raise InputError(
                f"q and {name} must have {self.tree.nq} and {self.tree.nv} entries, got {q_.size} and {v_.size}"
            )
        return q_, v_

    def acceleration(self, q: ArrayLike, v: ArrayLike, tau: ArrayLike) -> Array:
        """A = M(q)^-1 (tau - C(q, v) v - G(q)) [rad/s^2 | m/s^2], shape (nv,), by the compiled ABA."""
        q_, v_ = self._state(q, v)
        t_ = np.ascontiguousarray(tau, dtype=np.float64).reshape(-1)
        out = np.empty(self.tree.nv)
        t = self.tree
        kernels(t.flyer is not None).aba(t.itree, t.ftree, t.grav, t.flyer, q_, v_, t_, self._ws(), out)
        return out

    def inverse_dynamics(self, q: ArrayLike, v: ArrayLike, a: ArrayLike) -> Array:
        """Tau = M a + C v + G [N m | N], shape (nv,), by the compiled RNEA.

        Raises:
            AssumptionError: at the first call, RNEA fails its check against Pinocchio (:meth:`verify`).
        """
        self.ensure_checked("rnea")
        return self._rnea(q, v, a)

    def _rnea(self, q: ArrayLike, v: ArrayLike, a: ArrayLike) -> Array:
        q_, v_ = self._state(q, v)
        a_ = np.ascontiguousarray(a, dtype=np.float64).reshape(-1)
        out = np.empty(self.tree.nv)
        t = self.tree
        dynamics_kernels(t.flyer is not None).rnea(t.itree, t.ftree, t.grav, t.flyer, q_, v_, a_, self._ws(), out)
        return out

    def mass_matrix(self, q: ArrayLike) -> Array:
        """M(q) [kg m^2 | kg], shape (nv, nv), armature included, by the compiled CRBA.

        Raises:
            AssumptionError: at the first call, CRBA fails its check against Pinocchio (:meth:`verify`).
        """
        self.ensure_checked("crba")
        return self._crba(q)

    def _crba(self, q: ArrayLike) -> Array:
        q_, _ = self._state(q, np.zeros(self.tree.nv))
        M = np.zeros((self.tree.nv, self.tree.nv))
        t = self.tree
        dynamics_kernels(t.flyer is not None).crba(t.itree, t.ftree, t.grav, t.flyer, q_, self._ws(), M)
        return M

    def energies(self, q: ArrayLike, v: ArrayLike) -> tuple[float, float]:
        """(kinetic 1/2 v^T M v, gravitational potential, zero at world height 0) [J]."""
        q_, v_ = self._state(q, v)
        t = self.tree
        kin, pot = kernels(t.flyer is not None).kinematics(t.itree, t.ftree, t.grav, t.flyer, q_, v_, self._ws())
        return float(kin), float(pot)

    def verify(
        self, robot: Robot, *, seed: int = 0, states: int = VERIFY_STATES, parts: tuple[str, ...] = VERIFY_PARTS
    ) -> dict[str, float]:
        """Largest relative differences of ``parts`` (ABA, RNEA, CRBA, the energies) from Pinocchio on seeded states.

        Every part is compared at the same states (one seeded draw, whichever parts are asked).

        Raises:
            AssumptionError: one exceeds ``VERIFY_RTOL`` (ABA: or ``VERIFY_SPREAD`` x Pinocchio's own
                ABA-CRBA spread where that is larger; the message names which and by how much).
        """
        rng = np.random.default_rng(seed)
        model, data = robot.model, robot.data
        unknown = set(parts) - set(VERIFY_PARTS)
        if unknown:
            raise ValueError(f"verify: parts must be among {VERIFY_PARTS}, got {sorted(unknown)}")
        worst = dict.fromkeys(parts, 0.0)
        excess = dict.fromkeys(worst, 0.0)  # the largest difference over its state's allowance
        for _ in range(states):
            q, v = robot.random_state(rng)
            tau = rng.uniform(-1.0, 1.0, robot.nv)
            a = rng.uniform(-1.0, 1.0, robot.nv)
            M = dynamics.mass_matrix(model, data, q)
            ref_a = dynamics.aba(model, data, q, v, tau)
            spread = VERIFY_SPREAD * _spread(M, tau - dynamics.rnea(model, data, q, v, np.zeros(robot.nv)), ref_a)
            for name in parts:
                got, ref, allowed = self._pair(name, robot, q, v, tau, a, M, ref_a, spread)
                x = _relative(got, ref)
                worst[name] = max(worst[name], x)
                excess[name] = max(excess[name], x / allowed)
        bad = {k: worst[k] for k, x in excess.items() if not x <= 1.0}
        if bad:
            what = ", ".join(f"{k} by {x:.3g}" for k, x in bad.items())
            raise AssumptionError(
                f"{robot.name}: the compiled tree algorithms differ from Pinocchio's ({what}, relative to the "
                f"largest entry), expected <= {VERIFY_RTOL:g} (or {VERIFY_SPREAD:g} x Pinocchio's own ABA-CRBA "
                "spread where M is ill-conditioned)"
            )
        return worst

    def _pair(
        self, part: str, robot: Robot, q: Array, v: Array, tau: Array, a: Array, M: Array, ref_a: Array, spread: float
    ) -> tuple[Array, Array, float]:
        """(compiled, Pinocchio's, the difference allowed) of ``part`` at one state of :meth:`verify`."""
        model, data = robot.model, robot.data
        if part == "aba":
            return self.acceleration(q, v, tau), ref_a, max(VERIFY_RTOL, spread)
        if part == "rnea":
            return self._rnea(q, v, a), dynamics.rnea(model, data, q, v, a), VERIFY_RTOL
        if part == "crba":
            return self._crba(q), M, VERIFY_RTOL
        kin, pot = self.energies(q, v)
        ref = np.array([dynamics.kinetic_energy(model, data, q, v), dynamics.potential_energy(model, data, q)])
        return np.array([kin, pot]), ref, VERIFY_RTOL


def _spread(M: Array, rhs: Array, ref: Array) -> float:
    """Pinocchio's own round-off at a state: its ABA ``ref`` against its CRBA ``M`` solved for ``rhs`` (0: singular)."""
    try:
        with np.errstate(all="ignore"):
            solved = np.asarray(np.linalg.solve(M, rhs), dtype=np.float64)
    except np.linalg.LinAlgError:
        return 0.0
    x = _relative(solved, ref)
    return x if np.isfinite(x) else 0.0


def _relative(got: Array, ref: Array) -> float:
    scale = max(float(np.max(np.abs(ref))), 1.0)
    return float(np.max(np.abs(got - ref))) / scale if np.all(np.isfinite(got)) else float("inf")


_CACHE: weakref.WeakKeyDictionary[Any, CompiledDynamics] = weakref.WeakKeyDictionary()


def compiled_of(robot: Robot) -> CompiledDynamics:
    """The compiled dynamics of ``robot``, checked against Pinocchio (once while its model stays the same).

    Raises:
        AssumptionError: the model has a joint the compiled path does not take, or the check fails.
        MissingDependencyError: numba is not installed.
    """
    tree = extract(robot)
    cached = _CACHE.get(robot)
    if cached is not None and cached.tree.same_as(tree):
        return cached
    compiled = CompiledDynamics(tree, {})
    check = compiled.verify(robot, parts=RUN_PARTS)
    compiled = CompiledDynamics(tree, check, weakref.ref(robot))
    _CACHE[robot] = compiled
    return compiled
