"""Closed kinematic loops: two frames held together, solved by Pinocchio's constraint dynamics.

A loop closes an open tree: ``bc_tip ~ collar (point)`` holds the origin of frame ``bc_tip``
on the origin of frame ``collar`` (3 rows), ``6d`` holds the two frames on each other (6 rows).
The acceleration of the closed chain comes from ``constraintDynamics``
(:class:`robodyn.constrained.ConstraintSolver`), so every explicit integrator steps it at its
own order. Two drift controls keep the loop closed:

* **Baumgarte**: the constraint acceleration is asked to be -KD (J v) - KP r instead of 0,
  a critically damped pull (time constant 1 / sqrt(KP) = 0.1 s) on the drift the integrator
  leaves;
* **projection** after a step whose residual exceeds ``PROJECT_ABOVE``: Gauss--Newton on the
  loop residual (minimum-norm steps in q), then v projected onto J v = 0 in the metric of M
  (the velocity a perfectly inelastic closing impulse would leave).

An initial state that violates a loop is projected the same way before the run; if the
frames cannot meet (Gauss--Newton does not bring the residual down), the run is refused.
A joint held at a stop while loops are present is welded in place
(:func:`robodyn.constrained.lock_model`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from robodyn import constrained, dynamics
from robodyn.errors import InputError, StepError, UnknownNameError

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.sim.constraints import Loop

Array = NDArray[np.float64]

# Baumgarte gains [1/s^2, 1/s]: critically damped (KD = 2 sqrt(KP)) with a 0.1 s time
# constant; measured on the 19.3 linkage with RK4 at dt = 1e-3: drift 2e-8 m without
# projection, against 8e-7 m with no correction at all.
KP = 100.0
KD = 20.0

# Project (q, v) back onto the loops after a step whose residual exceeds this [m | rad]:
# a few hundred ulps of a metre-sized mechanism; a step of RK4 at dt = 1e-3 drifts ~1e-11.
PROJECT_ABOVE = 1e-12

# Gauss--Newton stops below this residual [m | rad], or fails after PROJECTION_ITERATIONS.
PROJECTION_TOL = 1e-13
PROJECTION_ITERATIONS = 30


@dataclass(eq=False)
class Loops:
    """The loop closures of a robot: their constraint solver, residual, Jacobian and projection.

    ``held`` is the set of joint ids welded at their stop (changed by :meth:`hold`).
    """

    robot: Robot
    loops: tuple[Loop, ...]
    anchors: list[tuple[constrained.Anchor, constrained.Anchor]]
    kp: float = KP
    kd: float = KD
    held: tuple[int, ...] = ()
    solver: constrained.ConstraintSolver = field(init=False, repr=False)
    geometry: constrained.ConstraintSolver = field(init=False, repr=False)

    def __post_init__(self) -> None:
        model = self.robot.model
        closures = [self._closure(loop, a, b) for loop, (a, b) in zip(self.loops, self.anchors, strict=True)]
        self.geometry = constrained.ConstraintSolver(model, closures)
        self.solver = self.geometry
        self.rows = self.geometry.rows

    def _closure(self, loop: Loop, a: constrained.Anchor, b: constrained.Anchor) -> object:
        return constrained.loop_model(self.robot.model, loop.kind, a, b, self.kp, self.kd)

    def hold(self, q: Array, joints: tuple[int, ...]) -> None:
        """Weld the joints ``joints`` (ids) where they are at q; the others move (a new solver)."""
        if joints == self.held:
            return
        self.held = joints
        model = self.robot.model
        closures = [self._closure(loop, a, b) for loop, (a, b) in zip(self.loops, self.anchors, strict=True)]
        welds = [constrained.lock_model(model, self.geometry.data, j, q, self.kp, self.kd) for j in joints]
        self.solver = constrained.ConstraintSolver(model, [*closures, *welds])

    def acceleration(self, t: float, q: Array, v: Array, tau: Array) -> Array:
        """The closed chain's acceleration (nv,); a solver that does not converge is a StepError."""
        a, converged, residual = self.solver.acceleration(q, v, tau)
        if not converged:
            raise StepError(
                f"the loop constraint solver did not converge at t = {t:.6g} s (residual {residual:.3g})",
                time=t,
                reason=f"the loop constraint solver did not converge (residual {residual:.3g})",
            )
        return a

    def weld_forces(self, q: Array, held_iv: NDArray[np.intp]) -> Array:
        """The generalized force of the welds (the held stops) of the last solve, on ``held_iv`` (nv,).

        J_weld^T lambda_weld: the part of M a + C v + G - tau that the loops do not exert.
        """
        out = np.zeros(self.robot.nv)
        if len(self.solver.models) == len(self.geometry.models):
            return out
        lam = self.solver.forces()[self.rows :]  # read before the Jacobian refreshes the kinematics
        f = self.solver.jacobian(q)[self.rows :].T @ lam
        out[held_iv] = f[held_iv]
        return out

    def residual(self, q: Array) -> Array:
        """The loops' residuals (rows,) at q [m | rad]."""
        return self.geometry.residual(q)

    def jacobian(self, q: Array) -> Array:
        """The loops' Jacobian (rows, nv) at q."""
        return self.geometry.jacobian(q)

    def drift(self, Q: Array) -> float:
        """The worst loop residual norm over a batch Q (n, nq) [m | rad]: the maximum of :meth:`drift_series`."""
        return float(np.max(self.drift_series(Q), initial=0.0))

    def drift_series(self, Q: Array) -> Array:
        """The worst loop residual norm of each configuration of Q (n, nq), max over loops |r_loop| [m | rad], (n,)."""
        out = np.empty(len(Q))
        for k, q in enumerate(Q):
            out[k] = max((float(np.linalg.norm(r)) for r in _per_loop(self, q)), default=0.0)
        return out

    def project(self, q: Array, v: Array, free: NDArray[np.intp]) -> tuple[Array, Array, float]:
        """(q, v) moved onto the loops along the velocity indices ``free``; and the residual left [m | rad].

        Gauss--Newton with minimum-norm steps, then v projected onto J v = 0 in the metric of M.
        The residual left exceeds ``PROJECTION_TOL`` when the frames cannot meet.
        """
        model = self.robot.model
        r = self.residual(q)
        for _ in range(PROJECTION_ITERATIONS):
            if float(np.max(np.abs(r), initial=0.0)) <= PROJECTION_TOL:
                break
            J = self.jacobian(q)[:, free]
            dq = np.zeros(model.nv)
            dq[free] = -np.linalg.lstsq(J, r, rcond=1e-12)[0]
            q = dynamics.integrate(model, q, dq)
            r = self.residual(q)
        left = float(np.max(np.abs(r), initial=0.0))
        J = self.jacobian(q)[:, free]
        M = dynamics.mass_matrix(model, self.robot.data, q)[np.ix_(free, free)]
        Minv_Jt = np.linalg.solve(M, J.T)
        v = v.copy()
        v[free] = v[free] - Minv_Jt @ np.linalg.lstsq(J @ Minv_Jt, J @ v[free], rcond=1e-12)[0]
        return q, v, left

    def describe(self) -> list[str]:
        """One line per loop."""
        return [loop.describe() for loop in self.loops]


def loops_on(robot: Robot, loops: tuple[Loop, ...]) -> Loops | None:
    """Resolve ``loops`` on ``robot``'s frames; None when there are none.

    Raises:
        UnknownNameError: a frame the robot does not have (with close matches).
        InputError: both frames on the same body (the loop would constrain nothing), or a
            model with mimic joints (Pinocchio's ``constraintDynamics`` refuses them).
    """
    if not loops:
        return None
    model = robot.model
    if dynamics.has_mimic_joints(model):
        raise InputError(
            f"{robot.name}: loops and couplings (mimic joints) together are not supported: Pinocchio's "
            "constraintDynamics refuses mimic joints"
        )
    anchors = []
    names = constrained.frame_names(model)
    for i, loop in enumerate(loops):
        pair = []
        for key in ("frame_a", "frame_b"):
            name = getattr(loop, key)
            found = constrained.anchor(model, name)
            if found is None:
                raise UnknownNameError(f"frame (loops[{i}].{key})", name, names)
            pair.append(found)
        a, b = pair
        if a.joint == b.joint:
            raise InputError(
                f"loops[{i}] ({loop.describe()}): both frames move with joint {model.names[a.joint]!r}; "
                "a loop needs frames on two different bodies"
            )
        anchors.append((a, b))
    return Loops(robot, tuple(loops), anchors, kp=KP, kd=KD)


def close_initial_state(loops: Loops, q: Array, v: Array) -> tuple[Array, Array, dict[str, float]]:
    """(q0, v0) projected onto the loops, and what moved; a loop that cannot close is refused.

    Raises:
        InputError: the frames cannot meet: the residual left after Gauss--Newton, in metres.
    """
    before = float(np.max(np.abs(loops.residual(q)), initial=0.0))
    free = np.arange(loops.robot.nv)
    q1, v1, left = loops.project(q, v, free)
    if not left <= PROJECTION_TOL * 1e3:
        worst = int(np.argmax([np.max(np.abs(r)) for r in _per_loop(loops, q1)]))
        raise InputError(
            f"loops[{worst}] ({loops.loops[worst].describe()}): the frames cannot meet: after "
            f"{PROJECTION_ITERATIONS} Gauss-Newton steps from q0 (residual {before:.3g} m) the residual is "
            f"{left:.3g} m; check the link lengths and q0"
        )
    moved = float(np.max(np.abs(dynamics.difference(loops.robot.model, q, q1)), initial=0.0))
    return q1, v1, {"residual_m": before, "moved": moved, "dv": float(np.max(np.abs(v1 - v), initial=0.0))}


def _per_loop(loops: Loops, q: Array) -> list[Array]:
    r = loops.residual(q)
    sizes = [3 if loop.kind == "point" else 6 for loop in loops.loops]
    return np.split(r, np.cumsum(sizes)[:-1])
