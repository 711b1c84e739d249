"""The energy and work ledger of a simulated motion.

The principle of work and energy for a system of rigid bodies, U12 = T2 - T1, with the
work of gravity moved to the left as a potential V, reads

    E(t) - E(0) = W_input(t) + W_damping(t) + W_limits(t),   E = T + V,

and its rate form P = dE/dt = tau_in . v + tau_loss . v between impacts; each impact at a
joint stop changes T by the (booked) jump W_limits. V includes the joint springs'
1/2 k (q - rest)^2 (added by the run, :mod:`robodyn.sim.springs`). ``T = 1/2 v^T M(q) v`` [J] with
M from CRBA, which includes the rotors' reflected inertia (armature); Pinocchio's own
``computeKineticEnergy`` leaves that out on non-canonical axes, so robodyn never relies on
a single energy routine: :func:`cross_check` compares CRBA with RNEA for T and
``computePotentialEnergy`` with the centre of mass for V before every run, and
:class:`EnergyMeter` uses Pinocchio's fast ``computeMechanicalEnergy`` along a trajectory
only on models where it matches 1/2 v^T M v (else one CRBA per sample).

Pinocchio's energy routines refuse mimic joints. On such a model V is -m g . c(q) from the
centre of mass, cross-checked against the sum of -m_i g . c_i(q) over the bodies placed by
forward kinematics, and T is always 1/2 v^T M v from CRBA (checked against RNEA).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.errors import ModelError

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

# Two routes to the same energy agree to this relative tolerance (different algorithms,
# same float64 arithmetic on O(1) numbers: ~100 ulps).
CROSS_CHECK_RTOL = 1e-10

# The energy scale of a robot at rest: lifting its whole mass by this height [m].
REFERENCE_HEIGHT = 0.1


@dataclass(frozen=True)
class EnergyCheck:
    """The two routes to T and V at one state, and their largest relative disagreement."""

    kinetic_crba: float
    kinetic_rnea: float
    potential_pinocchio: float
    potential_com: float
    relative_error: float


def kinetic(robot: Robot, q: Array, v: Array) -> Array:
    """T = 1/2 v^T M(q) v [J] for a batch q (n, nq), v (n, nv) -> (n,)."""
    return dynamics.kinetic_energies(robot.model, robot.data, q, v)


def potential(robot: Robot, q: Array) -> Array:
    """Gravitational potential energy V(q) [J] for a batch q (n, nq) -> (n,)."""
    return dynamics.potential_energies(robot.model, robot.data, q)


def cross_check(robot: Robot, q: Array, v: Array) -> EnergyCheck:
    """Compare T by CRBA with T by RNEA, and V by Pinocchio with -m g . c(q), at one state.

    On a model with mimic joints (which ``computePotentialEnergy`` refuses) V by the
    centre of mass is compared with V summed body by body from forward kinematics; the
    ``potential_pinocchio`` field then holds the latter.

    Raises:
        ModelError: the two routes disagree by more than ``CROSS_CHECK_RTOL`` (relative to
            the larger of |T|, |V| and the reference energy m g h_ref).
    """
    model, data = robot.model, robot.data
    t_crba = float(dynamics.kinetic_energies(model, data, q[None, :], v[None, :])[0])
    t_rnea = dynamics.kinetic_energy_rnea(model, data, q, v)
    mimic = dynamics.has_mimic_joints(model)
    if mimic:
        v_pin, first = dynamics.potential_energy_bodies(model, data, q), "bodies"
    else:
        v_pin, first = dynamics.potential_energy(model, data, q), "Pinocchio"
    v_com = -robot.total_mass * float(dynamics.gravity_vector(model) @ dynamics.center_of_mass(model, data, q))
    scale = max(abs(t_crba), abs(v_pin), reference_energy(robot))
    err = max(abs(t_crba - t_rnea), abs(v_pin - v_com)) / scale
    check = EnergyCheck(t_crba, t_rnea, v_pin, v_com, err)
    if err > CROSS_CHECK_RTOL:
        raise ModelError(
            f"energy routines disagree on {robot.name}: T = {t_crba:.12g} J (CRBA) vs {t_rnea:.12g} J (RNEA), "
            f"V = {v_pin:.12g} J ({first}) vs {v_com:.12g} J (centre of mass)",
            path=robot.urdf_path,
        )
    return check


@dataclass(frozen=True)
class EnergyMeter:
    """Energies along a trajectory by the fastest route that agrees with 1/2 v^T M v.

    ``fast`` is True when ``computeMechanicalEnergy`` matched CRBA's 1/2 v^T M v (to
    ``CROSS_CHECK_RTOL``) at probe states with every joint moving, so that it counts the
    armature of this model; otherwise every sample takes a CRBA.
    """

    robot: Robot
    fast: bool

    @classmethod
    def for_robot(cls, robot: Robot, q: Array) -> EnergyMeter:
        """Probe ``robot`` at q with two fixed velocity patterns and choose the route.

        A model with mimic joints always takes the CRBA route (Pinocchio's energy routines
        refuse mimic joints).
        """
        model, data = robot.model, robot.data
        if dynamics.has_mimic_joints(model):
            return cls(robot, False)
        nv = robot.nv
        probes = np.stack([np.linspace(1.0, 2.0, nv), np.where(np.arange(nv) % 2 == 0, 1.0, -1.5)])
        Q = np.stack([q, q])
        t_crba = dynamics.kinetic_energies(model, data, Q, probes)
        t_pin, _ = dynamics.mechanical_energies(model, data, Q, probes)
        fast = bool(np.all(np.abs(t_pin - t_crba) <= CROSS_CHECK_RTOL * np.abs(t_crba)))
        return cls(robot, fast)

    def __call__(self, q: Array, v: Array) -> tuple[Array, Array]:
        """(T, V) [J] for a batch q (n, nq), v (n, nv)."""
        model, data = self.robot.model, self.robot.data
        if self.fast:
            return dynamics.mechanical_energies(model, data, q, v)
        return dynamics.kinetic_energies(model, data, q, v), dynamics.potential_energies(model, data, q)


def reference_energy(robot: Robot) -> float:
    """m_total |g| h_ref [J]: the energy scale of a robot that starts at rest."""
    g = float(np.linalg.norm(dynamics.gravity_vector(robot.model)))
    return max(robot.total_mass * max(g, 1.0) * REFERENCE_HEIGHT, 1e-12)


def energy_scale(robot: Robot, kinetic0: float, potential0: float) -> float:
    """Scale against which energy errors are judged [J]: max(T0 + |V0|, m |g| h_ref)."""
    return max(kinetic0 + abs(potential0), reference_energy(robot))


def ledger_residual(energy: Array, work_input: Array, work_damping: Array, work_limits: Array | None = None) -> Array:
    """E(t) - E(0) - W_input(t) - W_damping(t) - W_limits(t) [J]: zero up to the integrator's error."""
    residual = energy - energy[0] - work_input - work_damping
    return residual if work_limits is None else residual - work_limits
