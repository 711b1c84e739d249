"""The one place that calls Pinocchio's algorithms.

Every function takes a Pinocchio ``model`` and a ``data`` made from it, checks nothing
(the :class:`robodyn.Robot` methods validate user input), and returns fresh float64
arrays: values read from ``data`` are live views that the next call overwrites, so they
are copied before they leave this module.

Units: q [rad | m], v [rad/s | m/s], a [rad/s^2 | m/s^2], tau [N m | N],
M [kg m^2 | kg], energies [J].
"""

from __future__ import annotations

import functools
import weakref
from collections.abc import Callable

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

Array = NDArray[np.float64]


def mass_matrix(model: pin.Model, data: pin.Data, q: Array) -> Array:
    """Joint-space inertia matrix M(q) by CRBA (armature included), shape (nv, nv).

    pin's Python ``crba`` fills both triangles (pin 3 and 4: the binding mirrors the upper one);
    :func:`crba_fills_both_triangles` asks the installed release once per process, and should it
    return only the upper triangle, the matrix is symmetrised from it. Symmetric by construction,
    so no per-call symmetry test (an ``array_equal(M, M.T)`` cost as much as CRBA on the Panda).
    """
    M = pin.crba(model, data, q).copy()
    if not crba_fills_both_triangles():
        M = np.triu(M) + np.triu(M, 1).T
    return M


@functools.cache
def crba_fills_both_triangles() -> bool:
    """Whether this Pinocchio's Python ``crba`` returns M with both triangles filled, probed once.

    On Pinocchio's sample manipulator (6 revolute joints) at a configuration away from the
    neutral one, where most off-diagonal entries of M are non-zero: an upper-only release leaves
    the strict lower triangle all zero.
    """
    model = pin.buildSampleModelManipulator()
    data = model.createData()
    q = pin.integrate(model, pin.neutral(model), np.linspace(0.3, 1.1, model.nv))
    M = np.array(pin.crba(model, data, q))
    lower = M[np.tril_indices(model.nv, -1)]
    return bool(np.any(lower != 0.0) and np.array_equal(M, M.T))


def coriolis_matrix(model: pin.Model, data: pin.Data, q: Array, v: Array) -> Array:
    """Christoffel-form Coriolis matrix C(q, v): dM/dt - 2C is skew. Shape (nv, nv).

    Pinocchio's ``computeCoriolisMatrix`` is that matrix on ordinary models (it matches
    :func:`christoffel_coriolis` to 1e-15), but not on a model with mimic joints: on the Panda
    with its finger mimic it is off by 10 % of C's largest entry, C v + G no longer equals
    RNEA(q, v, 0) and dM/dt - 2C is not skew (pin 4.1, measured). There C is computed by
    :func:`christoffel_coriolis` from RNEA, which handles mimic joints.
    """
    if has_mimic_joints(model):
        return christoffel_coriolis(model, data, q, v)
    return np.array(pin.computeCoriolisMatrix(model, data, q, v))


def pinocchio_coriolis_matrix(model: pin.Model, data: pin.Data, q: Array, v: Array) -> Array:
    """Pinocchio's own ``computeCoriolisMatrix`` on any model, mimic joints included (for the check's comparison)."""
    return np.array(pin.computeCoriolisMatrix(model, data, q, v))


def christoffel_coriolis(model: pin.Model, data: pin.Data, q: Array, v: Array) -> Array:
    """The Christoffel C(q, v) [kg m^2/s | kg/s] from RNEA alone: 2 nv calls of ``pin.rnea``.

    c(x) = RNEA(q, x, 0) - G(q) = C(q, x) x is a quadratic form in x whose symmetric bilinear
    form b(x, y) = (c(x + y) - c(x - y)) / 4 has b_i(x, y) = sum_jk Gamma_ijk x_j y_k with the
    Christoffel symbols Gamma_ijk = 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i). Column j of C is
    b(e_j, v) (e_j scaled to |v| so that both terms weigh alike).
    """
    nv = model.nv
    zero = np.zeros(nv)
    s = max(float(np.linalg.norm(v)), 1.0)
    C = np.empty((nv, nv))
    for j in range(nv):
        e = np.zeros(nv)
        e[j] = s
        plus = np.array(pin.rnea(model, data, q, e + v, zero))
        minus = np.array(pin.rnea(model, data, q, e - v, zero))
        C[:, j] = (plus - minus) / (4.0 * s)
    return C


def gravity(model: pin.Model, data: pin.Data, q: Array) -> Array:
    """Generalised gravity G(q) = dV/dq [N m | N], shape (nv,)."""
    return np.array(pin.computeGeneralizedGravity(model, data, q))


def nonlinear_effects(model: pin.Model, data: pin.Data, q: Array, v: Array) -> Array:
    """C(q, v) v + G(q) by RNEA with zero acceleration, shape (nv,)."""
    return np.array(pin.nonLinearEffects(model, data, q, v))


def rnea(model: pin.Model, data: pin.Data, q: Array, v: Array, a: Array) -> Array:
    """Inverse dynamics tau = M a + C v + G by RNEA, shape (nv,)."""
    return np.array(pin.rnea(model, data, q, v, a))


def aba(model: pin.Model, data: pin.Data, q: Array, v: Array, tau: Array) -> Array:
    """Forward dynamics by the articulated-body algorithm, shape (nv,)."""
    return pin.aba(model, data, q, v, tau).copy()  # a copy of the live view (.copy() is faster than np.array)


def aba_function(model: pin.Model, data: pin.Data) -> Callable[[Array, Array, Array], Array]:
    """:func:`aba` on ``model`` and ``data`` as a function a(q, v, tau) (nv,): one call less per evaluation."""
    forward = pin.aba

    def aba_of(q: Array, v: Array, tau: Array) -> Array:
        return forward(model, data, q, v, tau).copy()  # a copy of the live view

    return aba_of


def crba_solve(model: pin.Model, data: pin.Data, q: Array, v: Array, tau: Array) -> Array:
    """Forward dynamics as M^-1 (tau - nle) with CRBA and a Cholesky solve.

    Serves models whose ABA is refused (mimic joints) and is an independent check of ABA.
    """
    M = mass_matrix(model, data, q)
    b = nonlinear_effects(model, data, q, v)
    factor = np.linalg.cholesky(M)
    y = np.linalg.solve(factor, tau - b)
    return np.linalg.solve(factor.T, y)


def aba_derivatives(model: pin.Model, data: pin.Data, q: Array, v: Array, tau: Array) -> tuple[Array, Array, Array]:
    """Analytical derivatives of ABA: (da/dq, da/dv, da/dtau), each (nv, nv)."""
    pin.computeABADerivatives(model, data, q, v, tau)
    return np.array(data.ddq_dq), np.array(data.ddq_dv), np.array(data.Minv)


def kinetic_energy(model: pin.Model, data: pin.Data, q: Array, v: Array) -> float:
    """Kinetic energy 1/2 v^T M v [J], the one to trust: it includes rotor armature."""
    M = pin.crba(model, data, q)  # read at once, so the live view needs no copy
    if not crba_fills_both_triangles():
        M = np.triu(M) + np.triu(M, 1).T
    return 0.5 * float(v.dot(M.dot(v)))


def pinocchio_kinetic_energy(model: pin.Model, data: pin.Data, q: Array, v: Array) -> float:
    """Pinocchio's ``computeKineticEnergy`` [J], kept for cross-checking only.

    In pin 4.1 it leaves out armature on revolute joints with a non-canonical axis.
    """
    return float(pin.computeKineticEnergy(model, data, q, v))


def potential_energy(model: pin.Model, data: pin.Data, q: Array) -> float:
    """Gravitational potential energy [J] (zero at world height 0), from Pinocchio.

    Pinocchio's ``computePotentialEnergy`` refuses mimic joints; on such a model the
    energy is -m g . c(q) from the centre of mass instead (:func:`potential_energy_com`).
    """
    try:
        return float(pin.computePotentialEnergy(model, data, q))
    except RuntimeError:
        if not has_mimic_joints(model):
            raise
        return potential_energy_com(model, data, q)


def integrate(model: pin.Model, q: Array, dq: Array) -> Array:
    """Configuration q (+) dq on the configuration manifold, shape (nq,) (a fresh array: no copy needed)."""
    return pin.integrate(model, q, dq)


def difference(model: pin.Model, q0: Array, q1: Array) -> Array:
    """Tangent vector dq with q0 (+) dq = q1, shape (nv,)."""
    return np.array(pin.difference(model, q0, q1))


def neutral(model: pin.Model) -> Array:
    """The neutral configuration, shape (nq,)."""
    return np.array(pin.neutral(model))


def random_configuration(model: pin.Model, rng: np.random.Generator) -> Array:
    """A configuration drawn with ``rng``: joint angles uniform in [-pi, pi] around neutral.

    Pinocchio's own random generator is not seeded through NumPy, so this draws a tangent
    vector from ``rng`` and integrates it from the neutral configuration.
    """
    dq = rng.uniform(-np.pi, np.pi, model.nv)
    return integrate(model, neutral(model), dq)


def frame_placements(model: pin.Model, data: pin.Data, q: Array) -> list[Array]:
    """Homogeneous transforms (4, 4) of every frame in world, in ``model.frames`` order."""
    pin.framesForwardKinematics(model, data, q)
    return [np.array(f.homogeneous) for f in data.oMf]


def geometry_placements(model: pin.Model, data: pin.Data, geom_model: pin.GeometryModel, q: Array) -> list[Array]:
    """World transforms (4, 4) of every geometry object at configuration q."""
    geom_data = geom_model.createData()
    pin.forwardKinematics(model, data, q)
    pin.updateGeometryPlacements(model, data, geom_model, geom_data)
    return [np.array(m.homogeneous) for m in geom_data.oMg]


def center_of_mass(model: pin.Model, data: pin.Data, q: Array) -> Array:
    """Whole-body centre of mass in world [m], shape (3,)."""
    return np.array(pin.centerOfMass(model, data, q))


def joint_frames(model: pin.Model, data: pin.Data, q: Array) -> list[tuple[Array, Array, Array]]:
    """For every joint j >= 1: (world placement (4, 4), linear axis, angular axis) at q.

    The axes are the joint's motion subspace S (its first column) expressed in world
    coordinates: a revolute joint has angular axis = its unit axis and linear axis 0, a
    prismatic joint the reverse. Multi-DoF joints report their first column.
    """
    pin.computeJointJacobians(model, data, q)
    frames = []
    for j in range(1, model.njoints):
        oMi = data.oMi[j]
        J = np.array(pin.getJointJacobian(model, data, j, pin.ReferenceFrame.LOCAL)).reshape(6, model.nv)
        S = J[:, model.joints[j].idx_v]
        R = np.array(oMi.rotation)
        frames.append((np.array(oMi.homogeneous), R @ S[:3], R @ S[3:]))
    return frames


def aba_batch(pool: pin.ModelPool, q: Array, v: Array, tau: Array, *, threads: int) -> Array:
    """Forward dynamics of a batch of states by ABA in C++ threads, shape (n, nv).

    ``q`` is (n, nq), ``v`` and ``tau`` (n, nv); ``pool`` a ``pin.ModelPool`` of at least
    ``threads`` model/data pairs. pin 4.1.0's ``abaInParallel`` crashes the process (SIGSEGV)
    on a model with one degree of freedom, so such models (and a batch of one) are evaluated
    state by state with ``pin.aba`` instead.
    """
    model = pool.getModel(0)
    if model.nv < 2 or q.shape[0] < 2:
        data = model.createData()
        return np.array([pin.aba(model, data, qi, vi, ti) for qi, vi, ti in zip(q, v, tau, strict=True)]).reshape(
            q.shape[0], model.nv
        )
    a = np.zeros((model.nv, q.shape[0]), order="F")
    threads = max(1, min(int(threads), int(pool.size())))
    pin.abaInParallel(threads, pool, np.asfortranarray(q.T), np.asfortranarray(v.T), np.asfortranarray(tau.T), a)
    return np.array(a.T)


def kinetic_energies(model: pin.Model, data: pin.Data, q: Array, v: Array) -> Array:
    """Kinetic energies 1/2 v_k^T M(q_k) v_k [J] of a batch: q (n, nq), v (n, nv) -> (n,).

    M comes from CRBA (armature included); one CRBA per sample, the quadratic forms at once.
    """
    n, nv = v.shape
    upper = np.empty((n, nv, nv))
    for k in range(n):
        pin.crba(model, data, q[k])
        upper[k] = data.M
    upper = np.triu(upper)  # CRBA fills the upper triangle; the lower one is not to be read
    return 0.5 * (2.0 * np.einsum("ni,nij,nj->n", v, upper, v) - np.einsum("nii,ni,ni->n", upper, v, v))


def potential_energies(model: pin.Model, data: pin.Data, q: Array) -> Array:
    """Gravitational potential energies [J] of a batch of configurations q (n, nq) -> (n,).

    On a model with mimic joints (which ``computePotentialEnergy`` refuses) each energy is
    -m g . c(q) from the centre of mass.
    """
    if has_mimic_joints(model):
        return np.array([potential_energy_com(model, data, qk) for qk in q], dtype=np.float64)
    return np.array([pin.computePotentialEnergy(model, data, qk) for qk in q], dtype=np.float64)


def kinetic_energy_rnea(model: pin.Model, data: pin.Data, q: Array, v: Array) -> float:
    """1/2 v^T (M v) with M v = rnea(q, 0, v) - G(q): an RNEA cross-check of the CRBA energy [J]."""
    zero = np.zeros(model.nv)
    Mv = np.array(pin.rnea(model, data, q, zero, v)) - np.array(pin.rnea(model, data, q, zero, zero))
    return 0.5 * float(v @ Mv)


def gravity_vector(model: pin.Model) -> Array:
    """The model's gravitational acceleration in world [m/s^2], shape (3,)."""
    return np.array(model.gravity.linear, dtype=np.float64)


def momentum_rate(model: pin.Model, data: pin.Data, q: Array, v: Array, tau: Array) -> Array:
    """dp/dt for the momentum p = M(q) v: tau + C(q, v)^T v - G(q) [N m | N], shape (nv,).

    From M a + C v + G = tau and dM/dt = C + C^T (Christoffel C): dp/dt = M a + dM/dt v.
    It is -dH/dq + tau, the force of Hamilton's equations that symplectic methods step.
    """
    C = coriolis_matrix(model, data, q, v)
    G = np.array(pin.computeGeneralizedGravity(model, data, q))
    return tau + C.T @ v - G


def mechanical_energies(model: pin.Model, data: pin.Data, q: Array, v: Array) -> tuple[Array, Array]:
    """Pinocchio's (kinetic, potential) energies [J] of a batch q (n, nq), v (n, nv): two (n,) arrays.

    One ``computeMechanicalEnergy`` per sample: fast, but its kinetic energy leaves out the
    armature on non-canonical revolute axes; trust it only where it matches
    :func:`kinetic_energies` (``robodyn.sim.energy`` checks that per model).
    """
    kinetic: list[float] = []
    potential: list[float] = []
    energy = pin.computeMechanicalEnergy
    for qk, vk in zip(q, v, strict=True):  # lists, then arrays: faster than an item set per sample
        energy(model, data, qk, vk)
        kinetic.append(data.kinetic_energy)
        potential.append(data.potential_energy)
    return np.array(kinetic, dtype=np.float64), np.array(potential, dtype=np.float64)


_MIMIC: dict[int, tuple[weakref.ref[pin.Model], bool]] = {}


def has_mimic_joints(model: pin.Model) -> bool:
    """True when ``model`` holds mimic joints (loaded with ``mimic=True``); ABA and the energy routines refuse them.

    Looked up once per model (a scan of Talos's joints takes ~30 us; this is asked on every step).
    """
    known = _MIMIC.get(id(model))
    if known is not None and known[0]() is model:
        return known[1]
    mimic = any(joint.shortname() == "JointModelMimic" for joint in model.joints)
    key = id(model)
    _MIMIC[key] = (weakref.ref(model, lambda _: _MIMIC.pop(key, None)), mimic)
    return mimic


def potential_energy_com(model: pin.Model, data: pin.Data, q: Array) -> float:
    """Gravitational potential energy -m g . c(q) [J] from the whole-body centre of mass.

    Works on every model, mimic joints included (``computePotentialEnergy`` refuses those).
    """
    com = np.array(pin.centerOfMass(model, data, q))
    return -float(data.mass[0]) * float(gravity_vector(model) @ com)


def gravity_scale(model: pin.Model, data: pin.Data, q: Array) -> float:
    """The energy scale |g| sum_i m_i |c_i(q)| [J]: each body's weight times its centre's distance from the origin.

    It bounds the terms that the potential energy and the gravity torques are summed from, so
    their round-off is a few eps times it, even where V or G is zero (``robodyn check``'s floor).
    """
    pin.forwardKinematics(model, data, q)
    g = float(np.linalg.norm(gravity_vector(model)))
    total = 0.0
    for j in range(1, model.njoints):
        inertia = model.inertias[j]
        c = np.array(data.oMi[j].act(np.array(inertia.lever)))
        total += abs(float(inertia.mass)) * float(np.linalg.norm(c))
    return g * total


def potential_energy_bodies(model: pin.Model, data: pin.Data, q: Array) -> float:
    """Gravitational potential energy -sum_i m_i g . c_i(q) [J], body by body from forward kinematics.

    An independent route to :func:`potential_energy_com` (each body's centre of mass placed
    by its joint's world transform), for cross-checking on models with mimic joints.
    """
    pin.forwardKinematics(model, data, q)
    g = gravity_vector(model)
    total = 0.0
    for j in range(1, model.njoints):
        inertia = model.inertias[j]
        c = np.array(data.oMi[j].act(np.array(inertia.lever)))
        total -= float(inertia.mass) * float(g @ c)
    return total
