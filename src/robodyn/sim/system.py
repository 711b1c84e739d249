"""What :func:`robodyn.simulate` integrates: one step's forces as a pipeline of named stages.

:class:`RobotSystem` is presented to the integrators as a
:class:`robodyn.integrators.SecondOrderProblem`. Its ``rates`` read as the pipeline of a step:

1. **positions** -- joint springs, tau_spring = -k (q - rest) (:mod:`robodyn.sim.springs`);
2. **velocities** -- joint losses, tau_loss = -D v - F tanh(v / v_friction);
3. **actuation** -- the commanded torque, clamped at the URDF efforts (:mod:`robodyn.sim.actuation`);
4. **smooth acceleration** -- M a = tau - C v - G by the backend (ABA, CRBA or the closed form);
5. **constraint solve** -- joints held at their stops (:mod:`robodyn.sim.limits`), or the loop
   closures, which Pinocchio's ``constraintDynamics`` solves together with step 4
   (:mod:`robodyn.sim.loops`).

Impacts at the stops are velocity jumps between steps, taken by :mod:`robodyn.sim.events`;
couplings are mimic joints of the model itself (:mod:`robodyn.sim.couplings`).

The state the integrators see is q (nq,) and u = [v, w]: w holds the running integrals
of the ledger, w = [W_input, W_damping] [J], whose rates are the powers

* P_input = tau_in . v (the applied torque, clamped), and
* P_damping = tau_loss . v <= 0 (URDF viscous damping D and Coulomb friction F, regularised
  below ``v_friction``),

so the works are integrated by the same method and to the same order as the motion; the
springs' energy is potential energy. When no torque acts and the joints are lossless, w is
empty and u is just v. Torque callables tau(t, q, v) are the controller hook.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics
from robodyn.errors import InputError, RobodynError
from robodyn.sim import limits
from robodyn.sim.actuation import (
    PASSIVE_TORQUE_TOL,
    EffortLimits,
    TorqueFn,
    TorqueSource,
    check_passive,
    effort_limits,
    expand_torque,
    torque_source,
)
from robodyn.sim.constraints import Constraints
from robodyn.sim.couplings import CouplingMap, couple
from robodyn.sim.limits import Stops, no_stops, stops_of
from robodyn.sim.loops import Loops, loops_on
from robodyn.sim.smooth import backend_function, formula_of, resolve_backend
from robodyn.sim.springs import Springs, no_springs, springs_on

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

__all__ = [
    "PASSIVE_TORQUE_TOL",
    "SINGULAR_MASS_RTOL",
    "V_FRICTION",
    "RobotSystem",
    "TorqueFn",
    "TorqueSource",
    "check_passive",
    "coordinate_units",
    "expand_torque",
    "resolve_backend",
    "robot_system",
    "torque_source",
    "velocity_names",
]


# M(q) is taken as singular when its smallest eigenvalue is below this fraction of its
# largest: ~1e4 ulps, far below any real robot's conditioning (Talos, Tiago, Solo: >= 1e-5)
# and far above the ~1e-16 of a direction that moves no mass, inertia or armature.
SINGULAR_MASS_RTOL = 1e-12

# Coulomb friction F sign(v) is smoothed to F tanh(v / V_FRICTION) so that the right-hand
# side stays differentiable for the integrators; [rad/s | m/s].
V_FRICTION = 1e-3


@dataclass(eq=False)
class RobotSystem:
    """A robot with a forward-dynamics backend, its passive forces, its actuation and its constraints.

    Satisfies :class:`robodyn.integrators.SecondOrderProblem`. Build with
    :func:`robot_system`. ``evaluations`` counts ``rates`` calls (each one forward
    dynamics), ``jacobian_evaluations`` the ABA-derivative calls of implicit methods.
    ``held`` maps each stop row held by the run (limited joint k -> side) and is changed
    only through :meth:`hold`, which also sets the rows the constraint solve locks.
    """

    robot: Robot
    backend: str
    torque: TorqueSource
    damping: Array
    friction: Array
    nq: int
    nv: int
    nw: int
    flat: bool
    evaluations: int = 0
    jacobian_evaluations: int = 0
    springs: Springs = field(default_factory=no_springs)
    effort: EffortLimits = field(default_factory=lambda: EffortLimits(np.zeros(0, dtype=np.intp), np.zeros(0)))
    stops: Stops = field(default_factory=no_stops)
    loops: Loops | None = None
    couplings: CouplingMap | None = None
    constraints: Constraints = field(default_factory=Constraints)
    held: dict[int, int] = field(default_factory=dict)
    command: Array | None = None  # a constant torque as commanded, before the effort clamp
    _forward: Callable[[Array, Array, Array], Array] = field(init=False, repr=False)
    _zero: Array = field(init=False, repr=False)
    _passive: NDArray[np.intp] = field(init=False, repr=False)
    _actuated: NDArray[np.intp] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._zero = np.zeros(self.nv)
        self._passive = np.flatnonzero(~self.robot.actuated)
        self._actuated = np.flatnonzero(self.robot.actuated)
        self._formula = formula_of(self.robot) if self.backend == "formula" else None
        self._forward = backend_function(self.robot, self.backend, self._formula)
        self._has_friction = bool(np.any(self.friction))
        self._lossy = self._has_friction or bool(np.any(self.damping))
        self._sprung = not self.springs.empty
        self._clamp = self.torque.kind == "callable" and not self.effort.empty
        self._model, self._data = self.robot.model, self.robot.data
        self._held_iv = np.zeros(0, dtype=np.intp)
        self._free_iv = np.arange(self.nv, dtype=np.intp)
        self._commanded = self.command if self.command is not None else self.torque.constant
        # Fixed at construction: with no works to book (u is v), no springs and no loops, the rates
        # are the smooth acceleration alone while no stop is held (``_bare``, kept by :meth:`hold`).
        self._smooth_only = self.nw == 0 and not self._sprung and self.loops is None
        self._bare = self._smooth_only

    @property
    def constrained(self) -> bool:
        """True while the constraint solve has work: a joint held at a stop, or loops."""
        return bool(self._held_iv.size) or self.loops is not None

    def hold(self, held: dict[int, int], q: Array) -> None:
        """Hold the stop rows ``held`` (limited joint k -> side) from configuration q on."""
        self.held = dict(held)
        self._held_iv = np.array(sorted(self.stops.iv[k] for k in held), dtype=np.intp)
        self._free_iv = np.setdiff1d(np.arange(self.nv), self._held_iv).astype(np.intp)
        self._bare = self._smooth_only and not self._held_iv.size
        if self.loops is not None:
            ids = tuple(sorted(int(self._model.getJointId(self.stops.names[k])) for k in held))
            self.loops.hold(q, ids)

    # ------------------------------------------------------------------ stages
    def input_torque(self, t: float, q: Array, v: Array) -> Array:
        """The applied torque tau_in(t, q, v) [N m | N], shape (nv,): commanded, clamped at the efforts."""
        if self.torque.kind != "callable":
            return self.torque.constant  # clamped once, when the system was built
        raw = self.torque.fn(t, q, v)  # type: ignore[misc]
        tau = np.asarray(raw, dtype=np.float64)
        if tau.shape != (self.nv,):
            tau = self._reshape_callable(tau, t)
        if self._passive.size and np.any(tau[self._passive]):
            check_passive(self.robot, tau, where=f"torque callable at t = {t:.6g} s")
        return self.effort.clamp(tau) if self._clamp else tau

    def commanded_torque(self, t: float, q: Array, v: Array) -> Array:
        """The torque before the effort clamp [N m | N], shape (nv,)."""
        if self.torque.kind != "callable":
            return self._commanded
        tau = np.asarray(self.torque.fn(t, q, v), dtype=np.float64)  # type: ignore[misc]
        return tau if tau.shape == (self.nv,) else self._reshape_callable(tau, t)

    def _reshape_callable(self, tau: Array, t: float) -> Array:
        if tau.shape == (self._actuated.size,):
            full = np.zeros(self.nv)
            full[self._actuated] = tau
            return full
        if self.couplings is not None and tau.shape == (self.couplings.full.nv,):
            return self.couplings.torque(tau)  # a torque on a follower acts on its leader
        raise InputError(
            f"torque callable must return {self.nv} (or {self._actuated.size} actuated) entries, "
            f"got shape {tau.shape} at t = {t:.6g} s"
        )

    def loss_torque(self, v: Array) -> Array:
        """Joint losses -D v - F tanh(v / V_FRICTION) [N m | N], shape (nv,)."""
        if not self._has_friction:
            return -self.damping * v
        return -self.damping * v - self.friction * np.tanh(v / V_FRICTION)

    def spring_torque(self, q: Array) -> Array:
        """Joint springs -k (q - rest) [N m | N], shape (nv,)."""
        return self.springs.torque(q, self.nv) if self._sprung else self._zero

    def acceleration(self, t: float, q: Array, v: Array, tau: Array) -> Array:
        """The smooth acceleration M^-1 (tau - C v - G), then the constraint solve [rad/s^2 | m/s^2]."""
        if self.loops is not None:  # smooth dynamics and loop closures in one Pinocchio call
            return self.loops.acceleration(t, q, v, tau)
        if self._held_iv.size:
            return limits.hold(self.mass_matrix_free(q), self._force(q, v, tau), self._held_iv, self._free_iv)[0]
        return self._forward(q, v, tau)

    def _force(self, q: Array, v: Array, tau: Array) -> Array:
        """The smooth force tau - C v - G = M a_smooth [N m | N]: by RNEA, or from the closed form."""
        if self._formula is not None:
            return self.mass_matrix_free(q) @ self._forward(q, v, tau)
        return tau - dynamics.nonlinear_effects(self._model, self._data, q, v)

    def stop_forces(self, t: float, q: Array, u: Array) -> Array:
        """The generalized force of the held stops at (t, q, u) [N m | N], shape (nv,).

        f = M a - (tau - C v - G): zero off the held joints (loops add theirs elsewhere).
        """
        v = u[: self.nv]
        tau = self.input_torque(t, q, v) + self.spring_torque(q)
        if self._lossy:
            tau = tau + self.loss_torque(v)
        self.evaluations += 1
        if self.loops is not None:
            self.loops.acceleration(t, q, v, tau)
            return self.loops.weld_forces(q, self._held_iv)
        return limits.hold(self.mass_matrix_free(q), self._force(q, v, tau), self._held_iv, self._free_iv)[1]

    # ------------------------------------------------------------------ SecondOrderProblem
    def rates(self, t: float, q: Array, u: Array) -> Array:
        """du/dt at (t, q, u): [a] when u is v, [a, P_input, P_damping] when the works are booked.

        One fixed dispatch, no path swapped at run time: with works to book, the stages of
        :meth:`booked_rates`; with nothing but the smooth dynamics (no springs, no loops, no
        stop held now), the backend alone; otherwise the springs' torque into the smooth
        acceleration and the constraint solve.
        """
        self.evaluations += 1
        if self._bare:  # u is v, and the rates are the acceleration alone
            return self._forward(q, u, self._zero)
        if self.nw:
            return self.booked_rates(t, q, u)
        return self.acceleration(t, q, u, self.spring_torque(q))

    def booked_rates(self, t: float, q: Array, u: Array) -> Array:
        """[a, P_input, P_damping] at (t, q, u) (nv + 2,): the stages of one step, in order (not counted)."""
        nv = self.nv
        v = u[:nv]
        tau_in = self.input_torque(t, q, v)  # actuation, clamped at the efforts
        tau_loss = self.loss_torque(v) if self._lossy else self._zero  # velocities
        tau = tau_in + tau_loss
        if self._sprung:  # positions
            tau = tau + self.spring_torque(q)
        out = np.empty(nv + 2)
        out[:nv] = self.acceleration(t, q, v, tau)  # smooth acceleration, then the constraint solve
        out[nv] = tau_in @ v
        out[nv + 1] = tau_loss @ v
        return out

    def mass_matrix_free(self, q: Array) -> Array:
        """M(q) [kg m^2 | kg] (nv, nv) from the backend (CRBA, or the formula), armature included."""
        if self._formula is not None:
            return self._formula[0].mass_matrix(q, self._formula[1])
        return dynamics.mass_matrix(self._model, self._data, q)

    def mass_matrix(self, q: Array) -> Array:
        """M(q) of the momentum p = M v the symplectic methods step; a held joint's row and column are e_j.

        A held joint has v_j = 0, so p_j = v_j = 0 stays put and the rest is M_ff v_f.
        """
        M = self.mass_matrix_free(q)
        if self._held_iv.size:
            M[self._held_iv, :] = 0.0
            M[:, self._held_iv] = 0.0
            M[self._held_iv, self._held_iv] = 1.0
        return M

    def mass_conditioning(self, q: Array) -> tuple[float, Array]:
        """(lambda_min / lambda_max of M(q), the unit eigenvector (nv,) of lambda_min).

        NaN for a non-finite M. A ratio below ``SINGULAR_MASS_RTOL`` means M is singular:
        that velocity direction moves no mass, no inertia and no armature.
        """
        M = self.mass_matrix_free(q)
        if not np.all(np.isfinite(M)):
            return float("nan"), np.full(self.nv, np.nan)
        w, vectors = np.linalg.eigh(M)
        largest = float(np.max(np.abs(w)))
        return (float(w[0]) / largest if largest > 0 else 0.0), np.array(vectors[:, 0])

    def singular_direction(self, vector: Array) -> str:
        """A velocity direction (nv,) in joint words: '0.71 root_joint[4] + 0.71 joint1'."""
        names = velocity_names(self.robot)
        big = np.flatnonzero(np.abs(vector) >= 0.1 * np.max(np.abs(vector)))
        return " + ".join(f"{vector[i]:.2g} {names[i]}" for i in big).replace("+ -", "- ")

    def momentum_rates(self, t: float, q: Array, u: Array) -> Array:
        """[dp/dt, P_input, P_damping] with dp/dt = tau + C^T v - G (+ the constraint force) for p = M(q) v."""
        self.evaluations += 1
        nv = self.nv
        v = u[:nv]
        tau_in = self.input_torque(t, q, v) if self.torque.kind != "none" else self._zero
        tau_loss = self.loss_torque(v) if self._lossy else self._zero
        tau = tau_in + tau_loss + self.spring_torque(q)
        out = np.empty(nv + self.nw)
        if self._formula is not None:
            formula, p = self._formula
            out[:nv] = formula.momentum_rate(q, v, tau, p)
        else:
            out[:nv] = dynamics.momentum_rate(self.robot.model, self.robot.data, q, v, tau)
        if self.constrained:  # + J^T lambda = M a - (tau - C v - G); a held joint's momentum stays 0
            a = self.acceleration(t, q, v, tau)
            out[:nv] += self.mass_matrix_free(q) @ a - self._force(q, v, tau)
            out[self._held_iv] = 0.0
        if self.nw:
            out[nv] = tau_in @ v
            out[nv + 1] = tau_loss @ v
        return out

    def integrate(self, q: Array, dq: Array) -> Array:
        """Retraction q (+) dq: addition for plain coordinates, ``pin.integrate`` on a manifold."""
        if self.flat:
            return q + dq
        return dynamics.integrate(self.robot.model, q, dq)

    def jacobian(self, t: float, q: Array, u: Array) -> tuple[Array, Array]:
        """(da/dq, da/dv) from Pinocchio's analytical ABA derivatives, losses included.

        Backends other than ABA, springs and constraints use forward differences. The torque
        callable's own dependence on (q, v) is not differentiated (the implicit methods then
        run a simplified Newton iteration, which still converges).
        """
        self.jacobian_evaluations += 1
        nv = self.nv
        v = u[:nv]
        tau = self.input_torque(t, q, v) + (self.loss_torque(v) if self._lossy else self._zero)
        if self.backend != "aba" or self._sprung or self.constrained:
            from robodyn.integrators import finite_difference_jacobian

            return finite_difference_jacobian(self, t, q, u)
        da_dq, da_dv, Minv = dynamics.aba_derivatives(self.robot.model, self.robot.data, q, v, tau)
        if self._lossy:
            dloss_dv = -self.damping
            if self._has_friction:
                dloss_dv = dloss_dv - self.friction / V_FRICTION / np.cosh(v / V_FRICTION) ** 2
            da_dv = da_dv + Minv * dloss_dv  # Minv @ diag(dloss_dv)
        return da_dq, da_dv

    # ------------------------------------------------------------------ metadata
    def describe(self) -> dict[str, Any]:
        """The system's settings, for a trajectory's metadata."""
        names = velocity_names(self.robot)
        return {
            "backend": self.backend,
            "torque": self.torque.describe(),
            "damping": self.damping.tolist(),
            "friction": self.friction.tolist(),
            "friction_velocity": V_FRICTION if np.any(self.friction) else None,
            "constraints": self.constraints.describe(),
            "stops": self.stops.describe(),
            "free_joints": {name: reason for name, reason in self.stops.free},
            "effort_limits": self.effort.describe(names),
            "springs": self.springs.describe(),
            "loops": self.loops.describe() if self.loops is not None else [],
            "couplings": self.couplings.describe() if self.couplings is not None else [],
        }


def velocity_names(robot: Robot) -> list[str]:
    """One name per velocity (nv,): the joint's name, with a component for multi-DoF joints.

    A free flyer's components are ``.vx .vy .vz`` (linear) and ``.wx .wy .wz`` (angular).
    """
    names: list[str] = []
    for j in robot.joints:
        if j.nv == 1:
            names.append(j.name)
        elif j.kind == "JointModelFreeFlyer":
            names += [f"{j.name}.{c}" for c in ("vx", "vy", "vz", "wx", "wy", "wz")]
        else:
            names += [f"{j.name}[{k}]" for k in range(j.nv)]
    return names


def coordinate_units(robot: Robot) -> tuple[list[str], list[str]]:
    """The unit of every entry of q (nq,) and v (nv,): 'rad', 'm', 'rad/s', 'm/s', or '' (dimensionless).

    Revolute angles are [rad], prismatic and free-flyer positions [m]; the cos/sin pair of
    a ``continuous`` joint and the quaternion of a free flyer or spherical joint have no unit.
    """
    q_units: list[str] = []
    v_units: list[str] = []
    for j in robot.joints:
        kind = j.kind
        if kind == "JointModelFreeFlyer":
            q, v = ["m"] * 3 + [""] * 4, ["m/s"] * 3 + ["rad/s"] * 3
        elif kind == "JointModelPlanar":
            q, v = ["m", "m", "", ""], ["m/s", "m/s", "rad/s"]
        elif kind == "JointModelSpherical":
            q, v = [""] * 4, ["rad/s"] * 3
        elif kind == "JointModelTranslation":
            q, v = ["m"] * 3, ["m/s"] * 3
        elif kind.startswith(("JointModelRUB", "JointModelRevoluteUnbounded")):
            q, v = ["", ""], ["rad/s"]
        elif kind.startswith(("JointModelR", "JointModelSphericalZYX", "JointModelUniversal", "JointModelH")):
            q, v = ["rad"] * j.nq, ["rad/s"] * j.nv
        elif kind.startswith("JointModelP"):
            q, v = ["m"] * j.nq, ["m/s"] * j.nv
        else:
            q, v = [""] * j.nq, [""] * j.nv
        q_units += q[: j.nq]
        v_units += v[: j.nv]
    return q_units, v_units


def robot_system(
    robot: Robot,
    *,
    backend: str | None = None,
    torque: ArrayLike | TorqueFn | None = None,
    losses: bool = True,
    constraints: Constraints | None = None,
) -> RobotSystem:
    """Assemble the system that :func:`robodyn.simulate` integrates.

    Args:
        robot: the robot.
        backend: ``"aba"`` (Pinocchio's articulated-body algorithm), ``"crba"`` (CRBA +
            Cholesky; serves mimic joints) or ``"formula"`` (the hand-derived closed form
            of a built-in kind); None (the default) picks ``"aba"``, or ``"crba"`` on a model
            with mimic joints (couplings included).
        torque: None, a constant vector [N m | N] or a callable tau(t, q, v); with
            couplings it may also have one entry per velocity of the uncoupled robot.
        losses: apply the URDF's joint damping and friction (False: a lossless model).
        constraints: stops, efforts, loops, couplings and springs (default: the URDF's stops
            and efforts). With couplings, ``system.robot`` is the coupled robot.

    Raises:
        InputError: a robot with no moving joint (nothing to integrate), a bad torque or a
            backend that cannot serve this robot (``"aba"`` on mimic joints, ``"formula"`` on
            a model that is of no built-in kind or with loops).
        UnknownNameError: an unknown backend, joint or frame.
    """
    if robot.nv == 0:
        raise InputError(
            f"{robot.urdf_path or robot.name}: {robot.name} has no moving joint, so there is no motion to simulate "
            "(a lone body: load it with free_flyer=True, --free-flyer on the command line)"
        )
    spec = constraints if constraints is not None else Constraints()
    coupling = couple(robot, spec.couplings)
    if coupling is not None:
        robot = coupling.coupled
    backend = resolve_backend(robot, backend)
    if backend == "formula" and robot.nq != robot.nv:
        raise InputError(f"backend 'formula' needs plain coordinates (nq == nv); {robot.name} has nq={robot.nq}")
    if backend == "formula" and spec.loops:
        raise InputError("backend 'formula' has no loop closures: use backend 'aba' with loops")
    if coupling is not None and torque is not None and not callable(torque) and np.size(torque) == coupling.full.nv:
        torque = coupling.torque(np.asarray(torque, dtype=np.float64).reshape(-1))
    source = torque_source(robot, torque)
    effort = effort_limits(robot, enabled=spec.effort_limits)
    command = None
    if source.kind == "constant" and not effort.empty:
        command = source.constant
        source = TorqueSource("constant", effort.clamp(source.constant))
    damping = robot.damping if losses else np.zeros(robot.nv)
    friction = robot.friction if losses else np.zeros(robot.nv)
    if np.any(damping < 0) or np.any(friction < 0):
        raise InputError(f"{robot.name}: joint damping and friction must be >= 0, got {damping} and {friction}")
    has_work = source.kind != "none" or bool(np.any(damping)) or bool(np.any(friction))
    followers = coupling.followers if coupling is not None else None
    system = RobotSystem(
        robot=robot,
        backend=backend,
        torque=source,
        damping=damping,
        friction=friction,
        nq=robot.nq,
        nv=robot.nv,
        nw=2 if has_work else 0,
        flat=robot.nq == robot.nv,
        springs=springs_on(robot, spec.spring_map, followers) if spec.springs else no_springs(),
        effort=effort,
        stops=stops_of(robot, restitution=spec.restitution) if spec.limits else no_stops(),
        loops=loops_on(robot, spec.loops),
        couplings=coupling,
        constraints=spec,
        command=command,
    )
    if source.kind == "callable":
        q0 = dynamics.neutral(robot.model)
        try:
            system.input_torque(0.0, q0, np.zeros(robot.nv))
        except RobodynError:
            raise
        except Exception as exc:
            raise InputError(f"torque callable fails at the neutral state: {type(exc).__name__}: {exc}") from None
    return system
