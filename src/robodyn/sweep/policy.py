"""Controllers over a batch of states, for the sweep's vectorised closed-loop chunks: LQR and the swing-up.

:func:`batch_policy` turns a controller that :func:`robodyn.control.make` built into a function
policy(q (m, n), v (m, n)) -> u (m, n_act) [N m | N] that gives, row by row, the torque the
controller's own ``__call__`` gives:

* :class:`~robodyn.control.LQR`: u = sat(u_eq - K e), e the wrapped state error;
* :class:`~robodyn.control.Switched` over the Pendubot's or the cart-pole's energy swing-up
  (:mod:`robodyn.control.swing_up`): the LQR where e^T P e < rho, else the energy law through
  collocated PFL, written here over the batch with M, C v, G from the kind's closed form
  (:mod:`robodyn.kinds.pendubot`, :mod:`robodyn.kinds.cart_pole`; the same functions the
  compiled fast path uses, checked against Pinocchio's ABA when it was built) instead of
  Pinocchio's CRBA and RNEA: the same formulas, equal to round-off.

Any other controller (a user's controller file, a scene's PD law or a custom callable) is an
opaque Python function of one state, so it has no batch form: its chunks run one by one.

Every operation acts on each row alone: sums over the state are written out column by column
(no matrix product across the batch, whose blocking could depend on the batch's size), so a run's
torque, and so its whole trajectory, does not depend on the chunk it is computed in.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.control import LQR, Switched
from robodyn.control.plant import wrap
from robodyn.control.swing_up import CartPoleEnergy, PendubotEnergy
from robodyn.kinds import cart_pole, pendubot
from robodyn.sim.fast import FastDynamics

Array = NDArray[np.float64]
Policy = Callable[[Array, Array], Array]

CLOSED_FORMS = {"pendubot": pendubot, "cart_pole": cart_pole}


def batch_policy(controller: Any, fast: FastDynamics | None) -> Policy | None:
    """The batch form of ``controller`` (see the module docstring), or None when it has none.

    ``fast`` is the robot's compiled closed form (None for a robot of no built-in kind); the swing-up
    needs it for M, C v and G.
    """
    if isinstance(controller, LQR):
        return lambda q, v: lqr_torque(controller, q, v)
    if not isinstance(controller, Switched):
        return None
    law = controller.swing_up
    energy_law: Policy
    if isinstance(law, PendubotEnergy) and fast is not None and fast.kind == law.plant.kind == "pendubot":
        energy_law = _pendubot_law(law, fast)
    elif isinstance(law, CartPoleEnergy) and fast is not None and fast.kind == law.plant.kind == "cart_pole":
        energy_law = _cart_pole_law(law, fast)
    else:
        return None
    switched = controller

    def policy(q: Array, v: Array) -> Array:
        inside = quadratic(switched.lqr.plant.error(q, v, switched.lqr.q_eq), switched.lqr.P) < switched.region.rho
        return np.where(inside[:, None], lqr_torque(switched.lqr, q, v), energy_law(q, v))

    return policy


def lqr_torque(lqr: LQR, q: Array, v: Array) -> Array:
    """The LQR torques sat(u_eq - K e) (m, n_act), the product with K summed column by column."""
    e = lqr.plant.error(q, v, lqr.q_eq)
    u = np.repeat(lqr.u_eq[None, :], q.shape[0], axis=0)
    for j in range(e.shape[1]):
        u = u - e[:, j : j + 1] * lqr.K[:, j]
    return lqr.plant.saturate(u)


def quadratic(e: Array, P: Array) -> Array:
    """e^T P e of each row of e (m, k), summed term by term in a fixed order."""
    out = np.zeros(e.shape[0])
    for i in range(e.shape[1]):
        for j in range(e.shape[1]):
            out = out + e[:, i] * P[i, j] * e[:, j]
    return out


def _reduced(
    fast: FastDynamics, act: int, pas: int, q: Array, v: Array
) -> tuple[Array, Array, tuple[Any, Any, Any], Array]:
    """(Mbar, hbar, (m11, m12, m22), V) of the collocated PFL, h = C v + G + B v, from the closed form.

    An entry of M that does not depend on q (the cart-pole's M11, M22) comes back as a number.
    """
    form = CLOSED_FORMS[fast.kind]
    p = fast.param_vector
    m11, m12, m22 = form.mass(p, q[:, 0], q[:, 1])
    c11, c12, c21, c22 = form.coriolis(p, q[:, 0], q[:, 1], v[:, 0], v[:, 1])
    g1, g2 = form.gravity(p, q[:, 0], q[:, 1])
    b = fast.damping
    h = ((c11 * v[:, 0] + c12 * v[:, 1]) + g1 + b[0] * v[:, 0], (c21 * v[:, 0] + c22 * v[:, 1]) + g2 + b[1] * v[:, 1])
    M = ((m11, m12), (m12, m22))
    ratio = M[act][pas] / M[pas][pas]
    Mbar = M[act][act] - ratio * M[pas][act]
    hbar = h[act] - ratio * h[pas]
    return Mbar, hbar, (m11, m12, m22), np.asarray(form.potential(p, q[:, 0], q[:, 1]))


def _pendubot_law(law: PendubotEnergy, fast: FastDynamics) -> Policy:
    """:class:`PendubotEnergy` over a batch: w from the energy error, u = sat(Mbar w + hbar)."""
    act, pas = int(law.pfl.act[0]), int(law.pfl.pas[0])

    def torque(q: Array, v: Array) -> Array:
        Mbar, hbar, (m11, m12, m22), potential = _reduced(fast, act, pas, q, v)
        kinetic = 0.5 * (m11 * v[:, 0] * v[:, 0] + 2.0 * m12 * v[:, 0] * v[:, 1] + m22 * v[:, 1] * v[:, 1])
        e = kinetic + (potential + fast.potential_offset) - law.energy_up
        q1_error = wrap(q[:, 0] - np.pi / 2)
        numerator = law.k_v * v[:, 0] + law.k_p * q1_error + law.k_energy * e * hbar
        w = -numerator / (law.k_energy * e * Mbar + law.k_d)
        return law.plant.saturate((Mbar * w + hbar)[:, None])

    return torque


def _cart_pole_law(law: CartPoleEnergy, fast: FastDynamics) -> Policy:
    """:class:`CartPoleEnergy` over a batch: the Astrom-Furuta cart acceleration, rail guard, collocated PFL."""
    act, pas = int(law.pfl.act[0]), int(law.pfl.pas[0])
    rail = law.plant.rail

    def torque(q: Array, v: Array) -> Array:
        y, theta, vy, omega = q[:, 0], q[:, 1], v[:, 0], v[:, 1]
        energy = 0.5 * law.J * omega**2 + law.m * law.g * law.l * (np.cos(theta) - 1.0)
        sigma = omega * np.cos(theta) + law.kick
        pump = np.clip(law.k_energy * (energy - law.energy_up) * sigma, -1.0, 1.0)
        accel = law.accel_max * pump - law.k_position * y - law.k_velocity * vy
        if rail is not None:  # robodyn.control.swing_up.rail_guard, row by row
            lo, hi = rail
            brake = law.accel_max
            stop = y + vy * np.abs(vy) / (2.0 * brake)
            accel = np.where((vy > 0) & (stop >= hi), np.minimum(accel, -brake), accel)
            accel = np.where((vy < 0) & (stop <= lo), np.maximum(accel, brake), accel)
        Mbar, hbar, _, _ = _reduced(fast, act, pas, q, v)
        return law.plant.saturate((Mbar * accel + hbar)[:, None])

    return torque
