"""The :class:`Robot`: a loaded Pinocchio model with validated, unit-documented dynamics."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics
from robodyn.errors import InputError, UnknownNameError
from robodyn.registry import BACKENDS

if TYPE_CHECKING:
    import pinocchio as pin

Array = NDArray[np.float64]

# A state is an equilibrium when |nle(q) - S u| stays below this fraction of the weight scale
# m_total |g| (1 m) [N m | N]: round-off in G at an exact equilibrium is ~1e-16 of it, while an
# angle off by a microradian leaves ~1e-6.
EQUILIBRIUM_TOL = 1e-9


_FLOAT64 = np.dtype(np.float64)


def as_vector(value: ArrayLike, size: int, name: str) -> Array:
    """``value`` as a float64 vector of length ``size``, or an :class:`InputError` naming ``name``.

    A float64 array of the right shape (what robodyn's own loops pass) takes a fast path: finite
    exactly when the sum of its entries is (a NaN or an infinity makes the sum NaN or infinite;
    only finite entries whose sum overflows go on to the full test). Python's float sum over
    ``tolist()``: 0.2 us for the Panda's 9 entries, half a dot product's cost, and silent where
    NumPy would count an overflow warning. The array is returned as given, not copied: Pinocchio
    reads it and nothing here keeps it.
    """
    if type(value) is np.ndarray and value.dtype is _FLOAT64 and value.shape == (size,):
        if math.isfinite(sum(value.tolist())):
            return value
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a vector of {size} numbers, got {value!r}") from None
    if arr.ndim == 0 and size == 1:
        arr = arr.reshape(1)
    if arr.shape != (size,):
        raise InputError(f"{name} must have {size} entries, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be finite, got {arr}")
    return arr


@dataclass(frozen=True, eq=False)
class JointInfo:
    """One moving joint: its name, Pinocchio type, index ranges in q and v, and axis."""

    name: str
    kind: str
    idx_q: int
    nq: int
    idx_v: int
    nv: int
    actuated: bool


@dataclass(frozen=True, eq=False)
class Robot:
    """A rigid-body model loaded into Pinocchio.

    Create with :func:`robodyn.load`. Every method validates its inputs and returns fresh
    float64 arrays. Units: q [rad | m], v [rad/s | m/s], tau [N m | N], M [kg m^2 | kg].

    ``forward_dynamics`` and ``inverse_dynamics`` are the rigid-body equations
    M a + C v + G = tau; joint damping and friction are applied by :func:`robodyn.simulate`.
    """

    name: str
    model: pin.Model = field(repr=False)
    urdf_path: Path | None
    srdf_path: Path | None
    joints: tuple[JointInfo, ...]
    data: pin.Data = field(repr=False)

    def __repr__(self) -> str:
        """One line: ``Robot(name='pendubot', nq=2, nv=2)`` (the Pinocchio model's repr runs over pages)."""
        return f"Robot(name={self.name!r}, nq={self.nq}, nv={self.nv})"

    @classmethod
    def from_model(
        cls,
        model: pin.Model,
        *,
        name: str,
        urdf_path: Path | None = None,
        srdf_path: Path | None = None,
        passive_joints: tuple[str, ...] = (),
    ) -> Robot:
        """Wrap a Pinocchio model; ``passive_joints`` names joints without an actuator."""
        joints = tuple(
            JointInfo(
                name=str(model.names[j]),
                kind=str(model.joints[j].shortname()),
                idx_q=int(model.joints[j].idx_q),
                nq=int(model.joints[j].nq),
                idx_v=int(model.joints[j].idx_v),
                nv=int(model.joints[j].nv),
                actuated=str(model.names[j]) not in passive_joints,
            )
            for j in range(1, model.njoints)
        )
        return cls(name, model, urdf_path, srdf_path, joints, model.createData())

    # ----------------------------------------------------------------- sizes and names
    @functools.cached_property
    def nq(self) -> int:
        """Size of the configuration vector q (read once from the model: every call validates against it)."""
        return int(self.model.nq)

    @functools.cached_property
    def nv(self) -> int:
        """Size of the velocity vector v (degrees of freedom)."""
        return int(self.model.nv)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Names of the moving joints, in model order."""
        return tuple(j.name for j in self.joints)

    @property
    def actuated(self) -> NDArray[np.bool_]:
        """Boolean mask over v: True where an actuator can apply torque."""
        mask = np.zeros(self.nv, dtype=bool)
        for j in self.joints:
            mask[j.idx_v : j.idx_v + j.nv] = j.actuated
        return mask

    @property
    def passive_joints(self) -> tuple[str, ...]:
        """Names of the joints that no actuator drives."""
        return tuple(j.name for j in self.joints if not j.actuated)

    @property
    def damping(self) -> Array:
        """Viscous joint damping from the URDF [N m s/rad | N s/m], shape (nv,)."""
        return np.array(self.model.damping, dtype=np.float64)

    @property
    def friction(self) -> Array:
        """Coulomb joint friction from the URDF [N m | N], shape (nv,)."""
        return np.array(self.model.friction, dtype=np.float64)

    @property
    def armature(self) -> Array:
        """Reflected rotor inertia J_m n^2 added to M's diagonal [kg m^2], shape (nv,)."""
        return np.array(self.model.armature, dtype=np.float64)

    @property
    def total_mass(self) -> float:
        """The moving mass [kg]: the sum over the bodies the joints carry, what M, G and V see.

        Links welded to the world (a fixed base, say) are left out, as Pinocchio's centre of mass
        and potential energy leave them out: the UR5's 4 kg base is not in its 16.99 kg. With
        ``free_flyer=True`` every link moves, and this is the URDF's whole mass. ``robodyn info``
        prints both (``total mass = ... kg (moving ... kg)``).
        """
        return float(sum(self.model.inertias[j].mass for j in range(1, self.model.njoints)))

    @property
    def nq_equals_nv(self) -> bool:
        """True when every coordinate is a plain number (no quaternion or cos/sin pair)."""
        return self.nq == self.nv

    def joint(self, name: str) -> JointInfo:
        """The moving joint called ``name``."""
        for j in self.joints:
            if j.name == name:
                return j
        raise UnknownNameError("joint", name, self.joint_names)

    def neutral(self) -> Array:
        """The neutral configuration, shape (nq,)."""
        return dynamics.neutral(self.model)

    # ----------------------------------------------------------------- validation
    def q_(self, q: ArrayLike) -> Array:
        """Validate a configuration (nq,)."""
        return as_vector(q, self.nq, "q")

    def v_(self, v: ArrayLike, name: str = "v") -> Array:
        """Validate a velocity-sized vector (nv,)."""
        return as_vector(v, self.nv, name)

    # ----------------------------------------------------------------- dynamics
    def M(self, q: ArrayLike) -> Array:
        """Mass matrix M(q) [kg m^2 | kg], shape (nv, nv), armature included."""
        return dynamics.mass_matrix(self.model, self.data, self.q_(q))

    def C(self, q: ArrayLike, v: ArrayLike) -> Array:
        """Christoffel-form Coriolis matrix C(q, v), shape (nv, nv)."""
        return dynamics.coriolis_matrix(self.model, self.data, self.q_(q), self.v_(v))

    def G(self, q: ArrayLike) -> Array:
        """Generalised gravity G(q) [N m | N], shape (nv,)."""
        return dynamics.gravity(self.model, self.data, self.q_(q))

    def nle(self, q: ArrayLike, v: ArrayLike) -> Array:
        """Nonlinear effects C(q, v) v + G(q) [N m | N], shape (nv,)."""
        return dynamics.nonlinear_effects(self.model, self.data, self.q_(q), self.v_(v))

    def inverse_dynamics(self, q: ArrayLike, v: ArrayLike, a: ArrayLike) -> Array:
        """Tau = M(q) a + C(q, v) v + G(q) by RNEA [N m | N], shape (nv,)."""
        return dynamics.rnea(self.model, self.data, self.q_(q), self.v_(v), self.v_(a, "a"))

    def forward_dynamics(self, q: ArrayLike, v: ArrayLike, tau: ArrayLike, *, backend: str | None = None) -> Array:
        """Accelerations a = M^-1 (tau - C v - G) [rad/s^2 | m/s^2], shape (nv,).

        ``backend`` is ``"aba"`` (Pinocchio's articulated-body algorithm) or ``"crba"``
        (CRBA + Cholesky, which also serves models with mimic joints); by default ABA, or
        CRBA on a model with mimic joints, which ABA refuses.
        """
        q_, v_, tau_ = self.q_(q), self.v_(v), self.v_(tau, "tau")
        if backend is None:
            backend = "crba" if dynamics.has_mimic_joints(self.model) else "aba"
        if backend == "aba":
            try:
                return dynamics.aba(self.model, self.data, q_, v_, tau_)
            except RuntimeError as exc:
                raise InputError(f"ABA refuses this model ({exc}); use backend='crba'") from None
        if backend == "crba":
            return dynamics.crba_solve(self.model, self.data, q_, v_, tau_)
        BACKENDS.get(backend)  # an unknown name lists the backends
        raise InputError(
            f"backend {backend!r} is not a method of Robot: it needs a built-in kind's formula; use "
            f"robodyn.simulate(..., backend={backend!r}) or robodyn.formulas.get(kind).forward_dynamics"
        )

    def linearize(
        self, q: ArrayLike, v: ArrayLike, tau: ArrayLike, *, equilibrium: bool = True, losses: bool = True
    ) -> tuple[Array, Array]:
        """State-space linearisation (A, B) of x' = f(x, u) at (q, v, tau), from Pinocchio's ABA derivatives.

        State and input ordering:

        * x = [q_1 .. q_n, v_1 .. v_n] (n = nq = nv; models with cos/sin pairs or quaternions are refused),
          so A is (2n, 2n);
        * u = the torques on the actuated joints only, in model order [N m | N], so B is (2n, n_act)
          with one column per actuated joint.

        A = [[0, I], [da/dq, da/dv]], B = [[0], [M^-1 S]] with S (nv, n_act) selecting the actuated
        joints, a = ABA(q, v, S u - D v). ``losses`` includes the URDF's viscous joint damping D as
        :func:`robodyn.simulate` applies it (da/dv gains -M^-1 D). Coulomb friction is left out: it is
        not differentiable at v = 0 (simulate smooths it over 1e-3 rad/s, a slope no linear design
        should rest on).

        Args:
            q: configuration (nq,) [rad | m].
            v: velocity (nv,) [rad/s | m/s].
            tau: torque, nv entries (zero on passive joints) or one per actuated joint [N m | N].
            equilibrium: require (q, v, tau) to be an equilibrium: v = 0 and nle(q) - S u = 0 to
                ``EQUILIBRIUM_TOL`` times the weight scale m_total |g| (1 m); False linearises anywhere.
            losses: include the joint damping (as simulate does by default).

        Raises:
            InputError: nq != nv, bad vectors, a torque on a passive joint, or (with ``equilibrium``)
                a state that is not an equilibrium: the message gives the residual nle(q) - S u.
        """
        if not self.nq_equals_nv:
            raise InputError(
                f"linearize needs plain coordinates (nq == nv); {self.name} has nq={self.nq}, nv={self.nv}"
            )
        q_, v_ = self.q_(q), self.v_(v)
        u = self.input_vector(tau)
        S = self.input_matrix()
        damping = self.damping if losses else np.zeros(self.nv)
        if equilibrium:
            self._require_equilibrium(q_, v_, S @ u)
        da_dq, da_dv, Minv = dynamics.aba_derivatives(self.model, self.data, q_, v_, S @ u - damping * v_)
        if not np.array_equal(Minv, Minv.T):  # should a release fill only the upper triangle
            Minv = np.triu(Minv) + np.triu(Minv, 1).T
        n = self.nv
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = da_dq
        A[n:, n:] = da_dv - Minv * damping  # d(-D v)/dv = -D: Minv @ diag(-D)
        B = np.zeros((2 * n, S.shape[1]))
        B[n:] = Minv @ S
        return A, B

    def input_matrix(self) -> Array:
        """S (nv, n_act): column k is the unit vector of the k-th actuated velocity; tau = S u."""
        return np.eye(self.nv)[:, self.actuated]

    def input_vector(self, tau: ArrayLike, name: str = "tau") -> Array:
        """The actuated torques u (n_act,) from nv entries (zero on passive joints) or n_act entries."""
        mask = self.actuated
        n_act = int(mask.sum())
        if n_act != self.nv and np.size(tau) == n_act:
            return as_vector(tau, n_act, name)
        full = as_vector(tau, self.nv, name)
        if np.any(full[~mask]):
            raise InputError(
                f"{name} = {full} pushes on passive joint(s) {', '.join(self.passive_joints)} of {self.name}; "
                f"give zeros there or one entry per actuated joint ({n_act})"
            )
        return full[mask]

    def _require_equilibrium(self, q: Array, v: Array, tau: Array) -> None:
        """Raise :class:`InputError` unless v = 0 and nle(q, 0) = tau within the tolerance."""
        if np.any(v):
            raise InputError(f"{self.name}: v = {v} is not an equilibrium: the velocity must be 0")
        residual = dynamics.nonlinear_effects(self.model, self.data, q, v) - tau
        scale = self.total_mass * float(np.linalg.norm(self.model.gravity.linear)) * 1.0
        tol = EQUILIBRIUM_TOL * max(scale, 1.0)
        if np.max(np.abs(residual)) > tol:
            raise InputError(
                f"{self.name}: q = {np.array2string(q, precision=6)} with tau = {np.array2string(tau, precision=6)} "
                f"is not an equilibrium: residual nle(q) - B u = {np.array2string(residual, precision=6)} "
                f"[N m | N], max |.| {np.max(np.abs(residual)):.3g} > {tol:.3g}"
            )

    def kinetic_energy(self, q: ArrayLike, v: ArrayLike) -> float:
        """Kinetic energy 1/2 v^T M(q) v [J] (includes rotor armature)."""
        return dynamics.kinetic_energy(self.model, self.data, self.q_(q), self.v_(v))

    def potential_energy(self, q: ArrayLike) -> float:
        """Gravitational potential energy [J], zero at world height 0."""
        return dynamics.potential_energy(self.model, self.data, self.q_(q))

    def integrate(self, q: ArrayLike, dq: ArrayLike) -> Array:
        """Q (+) dq on the configuration manifold (plain addition for angles and slides)."""
        return dynamics.integrate(self.model, self.q_(q), self.v_(dq, "dq"))

    def random_state(self, rng: np.random.Generator, *, speed: float = 2.0) -> tuple[Array, Array]:
        """A configuration and a velocity (uniform in [-speed, speed]) drawn with ``rng``."""
        q = dynamics.random_configuration(self.model, rng)
        v = rng.uniform(-speed, speed, self.nv)
        return q, v


def joint_coordinates(kind: str, nq: int, values: ArrayLike) -> NDArray[np.float64]:
    """The nq coordinates of a joint from a user's values.

    One angle for a continuous joint (stored as cos, sin), one value for a 1-coordinate
    joint, or all nq values.
    """
    vals = np.asarray(values, dtype=np.float64).reshape(-1)
    if vals.size == nq:
        return vals
    if vals.size == 1 and nq == 2 and kind.startswith("JointModelRUB"):
        return np.array([np.cos(vals[0]), np.sin(vals[0])])
    raise InputError(f"a {kind} joint takes {nq} value(s), got {vals.size}")
