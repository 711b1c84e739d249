"""What :func:`robodyn.simulate` integrates: robot, backend, joint losses and torque source.

Together they are presented to the integrators as a
:class:`robodyn.integrators.SecondOrderProblem`.

The state the integrators see is q (nq,) and u = [v, w]: w holds the running integrals
of the ledger, w = [W_input, W_damping] [J], whose rates are the powers

* P_input = tau_in . v (the applied torque), and
* P_damping = tau_loss . v <= 0 with tau_loss = -D v - F tanh(v / v_friction)
  (URDF viscous damping D and Coulomb friction F, regularised below ``v_friction``),

so the works are integrated by the same method and to the same order as the motion, and
E(t) - E(0) - W_input(t) - W_damping(t) measures the integrator's error alone. When no
torque acts and the joints are lossless, w is empty and u is just v.

A constrained system or a controller-in-the-loop may replace :class:`RobotSystem` by any
object with the same attributes (``nq, nv, nw, flat, evaluations``) and methods
(``rates, integrate, jacobian``); torque callables tau(t, q, v) are the controller hook.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics
from robodyn.errors import InputError, RobodynError
from robodyn.kinds import formulas, params
from robodyn.registry import BACKENDS

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]
TorqueFn = Callable[[float, Array, Array], ArrayLike]


# M(q) is taken as singular when its smallest eigenvalue is below this fraction of its
# largest: ~1e4 ulps, far below any real robot's conditioning (Talos, Tiago, Solo: >= 1e-5)
# and far above the ~1e-16 of a direction that moves no mass, inertia or armature.
SINGULAR_MASS_RTOL = 1e-12

# Coulomb friction F sign(v) is smoothed to F tanh(v / V_FRICTION) so that the right-hand
# side stays differentiable for the integrators; [rad/s | m/s].
V_FRICTION = 1e-3

# A torque on a passive joint is refused when its magnitude exceeds this [N m | N]; exact
# zeros are what a well-formed controller returns there.
PASSIVE_TORQUE_TOL = 0.0


@dataclass(frozen=True)
class TorqueSource:
    """The input torque: none, a constant vector, or a callable tau(t, q, v).

    ``constant`` is the full (nv,) vector for a constant input (zeros for none); ``fn`` the
    callable, whose result may have nv entries or one per actuated joint.
    """

    kind: str  # "none" | "constant" | "callable"
    constant: Array
    fn: TorqueFn | None = None

    def describe(self) -> str:
        """One line for the metadata: 'none', the vector, or the callable's name."""
        if self.kind == "callable":
            return f"callable {getattr(self.fn, '__qualname__', type(self.fn).__name__)}"
        if self.kind == "constant":
            return "constant " + np.array2string(self.constant, separator=",")
        return "none"


def torque_source(robot: Robot, torque: ArrayLike | TorqueFn | None) -> TorqueSource:
    """Validate ``torque`` against ``robot``'s actuated joints.

    Args:
        robot: the robot.
        torque: None, a vector with nv entries or one per actuated joint [N m | N], or a
            callable tau(t [s], q (nq,), v (nv,)) returning either size.

    Raises:
        InputError: wrong length, non-finite values, or a torque on a passive joint.
    """
    nv = robot.nv
    if torque is None:
        return TorqueSource("none", np.zeros(nv))
    if callable(torque):
        return TorqueSource("callable", np.zeros(nv), torque)
    tau = expand_torque(robot, torque, where="torque")
    if not np.any(tau):
        return TorqueSource("none", np.zeros(nv))
    return TorqueSource("constant", tau)


def expand_torque(robot: Robot, value: ArrayLike, *, where: str) -> Array:
    """``value`` as a full (nv,) torque; one entry per actuated joint is spread over them."""
    mask = robot.actuated
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"{where} must be a vector of numbers, got {value!r}") from None
    n_act = int(mask.sum())
    if arr.size == robot.nv:
        tau = arr.copy()
    elif arr.size == n_act:
        tau = np.zeros(robot.nv)
        tau[mask] = arr
    else:
        sizes = f"{robot.nv} (one per velocity)" + (
            f" or {n_act} (one per actuated joint)" if n_act != robot.nv else ""
        )
        raise InputError(f"{where} must have {sizes} entries for {robot.name}, got {arr.size}")
    if not np.all(np.isfinite(tau)):
        raise InputError(f"{where} must be finite, got {tau}")
    check_passive(robot, tau, where=where)
    return tau


def check_passive(robot: Robot, tau: Array, *, where: str) -> None:
    """Raise :class:`InputError` if ``tau`` pushes on a joint that has no actuator."""
    for j in robot.joints:
        if not j.actuated:
            value = tau[j.idx_v : j.idx_v + j.nv]
            if np.any(np.abs(value) > PASSIVE_TORQUE_TOL):
                raise InputError(
                    f"{where} applies {np.array2string(value, precision=6)} to joint {j.name!r} of {robot.name}, "
                    f"which is passive (no actuator); actuated joints: "
                    f"{', '.join(x.name for x in robot.joints if x.actuated) or 'none'}"
                )


@dataclass(eq=False)
class RobotSystem:
    """A robot with a forward-dynamics backend, joint losses and a torque source.

    Satisfies :class:`robodyn.integrators.SecondOrderProblem`. Build with
    :func:`robot_system`. ``evaluations`` counts ``rates`` calls (each one forward
    dynamics), ``jacobian_evaluations`` the ABA-derivative calls of implicit methods.
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
    _forward: Callable[[Array, Array, Array], Array] = field(init=False, repr=False)
    _zero: Array = field(init=False, repr=False)
    _passive: NDArray[np.intp] = field(init=False, repr=False)
    _actuated: NDArray[np.intp] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._zero = np.zeros(self.nv)
        self._passive = np.flatnonzero(~self.robot.actuated)
        self._actuated = np.flatnonzero(self.robot.actuated)
        self._formula = _formula(self.robot) if self.backend == "formula" else None
        self._forward = _backend(self.robot, self.backend, self._formula)
        self._has_friction = bool(np.any(self.friction))
        self._lossy = self._has_friction or bool(np.any(self.damping))
        self._model, self._data = self.robot.model, self.robot.data
        if self.nw == 0:  # nothing to book: u is v, and the rates are the acceleration alone
            self.rates = self._rates_free_aba if self.backend == "aba" else self._rates_free  # type: ignore[method-assign]

    # ------------------------------------------------------------------ forces
    def input_torque(self, t: float, q: Array, v: Array) -> Array:
        """The applied torque tau_in(t, q, v) [N m | N], shape (nv,)."""
        if self.torque.kind != "callable":
            return self.torque.constant
        raw = self.torque.fn(t, q, v)  # type: ignore[misc]
        tau = np.asarray(raw, dtype=np.float64)
        if tau.shape != (self.nv,):
            tau = self._reshape_callable(tau, t)
        if self._passive.size and np.any(tau[self._passive]):
            check_passive(self.robot, tau, where=f"torque callable at t = {t:.6g} s")
        return tau

    def _reshape_callable(self, tau: Array, t: float) -> Array:
        if tau.shape == (self._actuated.size,):
            full = np.zeros(self.nv)
            full[self._actuated] = tau
            return full
        raise InputError(
            f"torque callable must return {self.nv} (or {self._actuated.size} actuated) entries, "
            f"got shape {tau.shape} at t = {t:.6g} s"
        )

    def loss_torque(self, v: Array) -> Array:
        """Joint losses -D v - F tanh(v / V_FRICTION) [N m | N], shape (nv,)."""
        if not self._has_friction:
            return -self.damping * v
        return -self.damping * v - self.friction * np.tanh(v / V_FRICTION)

    # ------------------------------------------------------------------ SecondOrderProblem
    def _rates_free(self, t: float, q: Array, u: Array) -> Array:
        self.evaluations += 1
        return self._forward(q, u, self._zero)

    def _rates_free_aba(self, t: float, q: Array, u: Array) -> Array:
        self.evaluations += 1
        return dynamics.aba(self._model, self._data, q, u, self._zero)

    def rates(self, t: float, q: Array, u: Array) -> Array:
        """du/dt = [a, P_input, P_damping] at (t, q, u)."""
        self.evaluations += 1
        nv = self.nv
        v = u[:nv]
        tau_in = self.input_torque(t, q, v)
        tau_loss = self.loss_torque(v) if self._lossy else self._zero
        out = np.empty(nv + 2)
        out[:nv] = self._forward(q, v, tau_in + tau_loss)
        out[nv] = tau_in @ v
        out[nv + 1] = tau_loss @ v
        return out

    def mass_matrix(self, q: Array) -> Array:
        """M(q) [kg m^2 | kg] (nv, nv) from the backend (CRBA, or the formula), armature included."""
        if self._formula is not None:
            return self._formula[0].mass_matrix(q, self._formula[1])
        return dynamics.mass_matrix(self._model, self._data, q)

    def mass_conditioning(self, q: Array) -> tuple[float, Array]:
        """(lambda_min / lambda_max of M(q), the unit eigenvector (nv,) of lambda_min).

        NaN for a non-finite M. A ratio below ``SINGULAR_MASS_RTOL`` means M is singular:
        that velocity direction moves no mass, no inertia and no armature.
        """
        M = self.mass_matrix(q)
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
        """[dp/dt, P_input, P_damping] with dp/dt = tau + C^T v - G for p = M(q) v."""
        self.evaluations += 1
        nv = self.nv
        v = u[:nv]
        tau_in = self.input_torque(t, q, v) if self.torque.kind != "none" else self._zero
        tau_loss = self.loss_torque(v) if self._lossy else self._zero
        out = np.empty(nv + self.nw)
        if self._formula is not None:
            formula, p = self._formula
            out[:nv] = formula.momentum_rate(q, v, tau_in + tau_loss, p)
        else:
            out[:nv] = dynamics.momentum_rate(self.robot.model, self.robot.data, q, v, tau_in + tau_loss)
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

        Backends other than ABA use forward differences. The torque callable's own
        dependence on (q, v) is not differentiated (the implicit methods then run a
        simplified Newton iteration, which still converges).
        """
        self.jacobian_evaluations += 1
        nv = self.nv
        v = u[:nv]
        tau = self.input_torque(t, q, v) + (self.loss_torque(v) if self._lossy else self._zero)
        if self.backend != "aba":  # CRBA serves mimic joints, which ABA derivatives refuse
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
        return {
            "backend": self.backend,
            "torque": self.torque.describe(),
            "damping": self.damping.tolist(),
            "friction": self.friction.tolist(),
            "friction_velocity": V_FRICTION if np.any(self.friction) else None,
        }


def _formula(robot: Robot) -> tuple[Any, Any]:
    """The seed kind's closed-form dynamics and parameters, or an InputError."""
    kind = params.detect_kind(robot)
    if kind is None:
        raise InputError(
            f"backend 'formula' needs one of the seed kinds ({', '.join(formulas.KINDS.names())}); "
            f"{robot.name} is none of them: use backend 'aba' or 'crba'"
        )
    return formulas.get(kind), params.extract(robot, kind)


def _backend(robot: Robot, name: str, formula: tuple[Any, Any] | None) -> Callable[[Array, Array, Array], Array]:
    """The forward-dynamics function a(q, v, tau) of backend ``name``."""
    model, data = robot.model, robot.data
    if name == "aba":
        return lambda q, v, tau: dynamics.aba(model, data, q, v, tau)
    if name == "crba":
        return lambda q, v, tau: dynamics.crba_solve(model, data, q, v, tau)
    if name == "formula" and formula is not None:
        f, p = formula
        return lambda q, v, tau: f.forward_dynamics(q, v, tau, p)
    BACKENDS.get(name)  # an unknown name lists the backends
    raise InputError(f"backend {name!r} needs a seed kind's formula, which {robot.name} has not")


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


def resolve_backend(robot: Robot, backend: str | None) -> str:
    """The forward-dynamics backend for ``robot``: ``backend``, or by default ``"aba"`` (``"crba"`` with mimic joints).

    Raises:
        UnknownNameError: an unknown backend.
        InputError: ``"aba"`` asked for a model with mimic joints, which Pinocchio's ABA refuses.
    """
    mimic = dynamics.has_mimic_joints(robot.model)
    if backend is None:
        return "crba" if mimic else "aba"
    BACKENDS.get(backend)  # an unknown name lists the backends
    if backend == "aba" and mimic:
        raise InputError(
            f"{robot.name} has mimic joints, which Pinocchio's ABA refuses: use backend 'crba' (--backend crba)"
        )
    return backend


def robot_system(
    robot: Robot,
    *,
    backend: str | None = None,
    torque: ArrayLike | TorqueFn | None = None,
    losses: bool = True,
) -> RobotSystem:
    """Assemble the system that :func:`robodyn.simulate` integrates.

    Args:
        robot: the robot.
        backend: ``"aba"`` (Pinocchio's articulated-body algorithm), ``"crba"`` (CRBA +
            Cholesky; serves mimic joints) or ``"formula"`` (the hand-derived closed form
            of a seed kind); None (the default) picks ``"aba"``, or ``"crba"`` on a model
            with mimic joints.
        torque: None, a constant vector [N m | N] or a callable tau(t, q, v).
        losses: apply the URDF's joint damping and friction (False: a lossless model).

    Raises:
        InputError: a bad torque or a backend that cannot serve this robot (``"aba"`` on
            mimic joints, ``"formula"`` on a model that is no seed kind).
        UnknownNameError: an unknown backend.
    """
    backend = resolve_backend(robot, backend)
    if backend == "formula" and robot.nq != robot.nv:
        raise InputError(f"backend 'formula' needs plain coordinates (nq == nv); {robot.name} has nq={robot.nq}")
    source = torque_source(robot, torque)
    damping = robot.damping if losses else np.zeros(robot.nv)
    friction = robot.friction if losses else np.zeros(robot.nv)
    if np.any(damping < 0) or np.any(friction < 0):
        raise InputError(f"{robot.name}: joint damping and friction must be >= 0, got {damping} and {friction}")
    has_work = source.kind != "none" or bool(np.any(damping)) or bool(np.any(friction))
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
