"""A compiled path for any tree robot: the recursive algorithms in numba, over arrays read from the model.

:func:`extract` (:mod:`robodyn.sim.tree_arrays`) reads a Pinocchio model's data (``robot.model``:
parents, joint types and axes, joint placements, inertias, armature, gravity) into a
:class:`TreeModel` of three arrays; it calls no Pinocchio algorithm. The kernels of
:mod:`robodyn.engine.tree.algorithms` (articulated-body algorithm, RNEA, CRBA, energies) and of
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
ABA-CRBA spread, at a state where M is so ill-conditioned that the spread is larger). The
ABA's passes 2 and 3 work in world axes; on a model where those fail the check (iCub's neck: an
exact zero of the model only nearly one after rounding) or leave round-off where Pinocchio's ABA
at rest is exactly 0 (Stretch's wheels), :func:`compiled_of` checks them again in each joint's own
axes (:meth:`TreeModel.with_local_passes`: the Panda's step 22 % slower without its stops), and
refuses the model only if both fail the check. The check runs once per model and is cached while
the arrays read from the model stay the same.

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
from robodyn.engine.tree.layout import WCOLS
from robodyn.errors import AssumptionError, InputError, MissingDependencyError
from robodyn.sim.tree_arrays import TreeModel, extract, one_joint
from robodyn.sim.tree_arrays import unsupported as unsupported  # robodyn.sim.tree's since it was one module

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

# What a first compile of the tree kernels says it does (robodyn.engine.jit.announce): ABA, the energies,
# one sample and the loop of steps clear of the stops, for the tree's base (fixed, or a free-flyer root)
# and the run's method (RK4, or a tableau): about 20 s of CPU for the Pendubot (benchmarks/bench_first_run.py)
COMPILING = ("the tree-robot kernels", "about 20 s")
# ... and the stop events, when a run first meets a stop: the Panda's first run less the Pendubot's
COMPILING_EVENTS = ("the tree-robot kernels of joint stops", "about a minute")
# The two in s of CPU (a quiet 2-core machine), weighed against the Python loop (robodyn.sim.compile_choice)
COMPILE_S = (20.0, 60.0)


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

    @property
    def passes(self) -> str:
        """The axes the ABA's passes 2 and 3 work in: ``"world axes"`` or ``"joint axes"`` (:func:`compiled_of`)."""
        return "joint axes" if self.tree.local else "world axes"

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
            passes = f" (ABA in {self.passes})" if self.tree.local else ""
            raise AssumptionError(
                f"{robot.name}: the compiled tree algorithms{passes} differ from Pinocchio's ({what}, relative to the "
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


def _keeps_zeros_at_rest(compiled: CompiledDynamics, robot: Robot) -> bool:
    """Whether the compiled ABA at rest (the neutral pose, v = 0, no torque) is exactly 0 wherever Pinocchio's is.

    A joint whose bodies' weight passes through its axis (a wheel's centre of mass on its axis) has
    an exact 0 there in Pinocchio's local frames; the world axes' passes may leave 1e-30 of round-off,
    which passes the relative check but which stiff Coulomb friction amplifies 1e5-fold a step
    (Stretch's wheels: a compiled run blown up at its third step).
    """
    q, zero = robot.neutral(), np.zeros(robot.nv)
    ref = dynamics.aba(robot.model, robot.data, q, zero, zero)
    return bool(np.all(compiled.acceleration(q, zero, zero)[ref == 0.0] == 0.0))


_CACHE: weakref.WeakKeyDictionary[Any, CompiledDynamics] = weakref.WeakKeyDictionary()


def compiled_of(robot: Robot) -> CompiledDynamics:
    """The compiled dynamics of ``robot``, checked against Pinocchio (once while its model stays the same).

    The ABA's passes in world axes (the faster ones) where they pass the check and keep
    Pinocchio's exact zeros at rest (:func:`_keeps_zeros_at_rest`), else in each joint's own axes
    where those do (:attr:`CompiledDynamics.passes` says which).

    Raises:
        AssumptionError: the model has a joint the compiled path does not take, or the check fails
            in both axes (the message is the joint axes' check).
        MissingDependencyError: numba is not installed.
    """
    tree = extract(robot)
    cached = _CACHE.get(robot)
    if cached is not None and cached.tree.same_as(tree):
        return cached
    failed: AssumptionError | None = None
    try:
        check = CompiledDynamics(tree, {}).verify(robot, parts=RUN_PARTS)
    except AssumptionError as exc:
        failed = exc
    if failed is not None or not _keeps_zeros_at_rest(CompiledDynamics(tree, {}), robot):
        local = CompiledDynamics(tree.with_local_passes(), {})
        try:
            local_check = local.verify(robot, parts=RUN_PARTS)
        except AssumptionError:
            if failed is not None:
                raise
        else:
            if failed is not None or _keeps_zeros_at_rest(local, robot):
                tree, check = local.tree, local_check
    compiled = CompiledDynamics(tree, check, weakref.ref(robot))
    _CACHE[robot] = compiled
    return compiled
