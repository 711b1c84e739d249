"""Did a run balance? The one decision that the CLI's summary, the sweep's ``time_to_balance`` and the benchmark read.

A run of a cart-pole or a Pendubot has balanced when, over its last ``HOLD`` seconds, every
revolute coordinate stays within ``BALANCE_TOL`` of the upright (wrapped, so whole turns do not
count) and the torque stays within the effort limit (robodyn's controllers clip to it, so a
larger torque is a controller's bug, not the model's). ``time_to_balance`` is the first time from
which every later sample is inside: the sweep's measure of the same name.

A run that did not balance gets the reason where one is known, checked in this order:

* the effort limit is below what the swing needs (:func:`robodyn.control.swing_up.swing_need`, with
  how much is needed);
* the cart reached the end of its rail's usable interval (the rail is too short for the swing);
* an Acrobot's swing never came within ``ENERGY_SHORT`` of its upright energy (its elbow's coupling
  kappa, :func:`robodyn.control.acrobot.scales`, is too weak to pump it in the run's time);
* the hand-over never found the LQR's region of attraction (e^T P e never fell below rho);
* the LQR took over but the state left the region again (the swing-up then resumed);
* else none is known (the run was too short, or the swing-up is still on its way).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

# |angle error| below this [rad] counts as upright (0.05 rad, about 3 degrees).
BALANCE_TOL = 0.05
# A run has balanced when it stays upright over its last HOLD [s]: one second, many times the
# built-in kinds' LQR time constants (0.1 to 0.5 s), so a pass through the upright does not count.
HOLD = 1.0
# An Acrobot whose total energy never came within this fraction of W (the hold torque's energy,
# half the energy of a turn) of E_up never swung near the upright: the drawn Acrobots whose pump
# is too weak stay at 1.8 to 2 W short (hanging is 2 W short); those that reach the region pass
# within 0.01 W of it.
ENERGY_SHORT = 0.1


def angle_error(q: Array, upright: Array, angular: NDArray[np.bool_]) -> Array:
    """The largest |wrapped angle error| [rad] to ``upright`` of each state of q (n, nq), shape (n,)."""
    error = (q[:, angular] - upright[angular] + np.pi) % (2.0 * np.pi) - np.pi
    return np.asarray(np.max(np.abs(error), axis=1), dtype=np.float64)


def inside_upright(q: Array, upright: Array, angular: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Whether each state of q (n, nq) has every revolute coordinate within BALANCE_TOL of ``upright``."""
    return np.asarray(angle_error(q, upright, angular) < BALANCE_TOL)


def balanced_from(inside: NDArray[np.bool_], dt: float) -> float:
    """Time [s] from which every sample is ``inside`` (samples every ``dt`` from t = 0); NaN if the last is not."""
    if inside.size == 0 or not inside[-1]:
        return math.nan
    outside = np.flatnonzero(~inside)
    return 0.0 if outside.size == 0 else float(outside[-1] + 1) * dt


def is_balanced(time_to_balance: float, duration: float, *, hold: float = HOLD) -> bool:
    """The decision: upright from ``time_to_balance`` [s] on, for at least the last ``hold`` [s] of ``duration``."""
    return bool(np.isfinite(time_to_balance) and time_to_balance <= duration - hold + 1e-9)


@dataclass(frozen=True)
class Outcome:
    """Whether a run balanced, and from when.

    From ``time`` [s] (NaN: never), the largest angle ``error`` [rad] over the last ``hold`` [s], the
    ``peak_torque`` [N m | N] against the ``effort`` limit, both in ``unit`` (N m, or N for a
    prismatic joint's force), and the ``reason`` when it did not.
    """

    balanced: bool
    time: float
    error: float
    peak_torque: float
    effort: float
    hold: float
    reason: str | None
    unit: str = "N m"

    def line(self) -> str:
        """One line for a run's summary."""
        if self.balanced:
            return (
                f"outcome: balanced from t = {self.time:.3f} s (last {self.hold:g} s within {self.error:.2e} rad of "
                f"upright, tolerance {BALANCE_TOL:g} rad; "
                f"peak |u| = {self.peak_torque:.4g} {self.unit} of {self.effort:.4g} {self.unit})"
            )
        error = "not finite" if not np.isfinite(self.error) else f"{self.error:.3g} rad"
        why = f": {self.reason}" if self.reason else ""
        return f"outcome: did not balance (last {self.hold:g} s: largest angle error {error}){why}"

    def as_record(self) -> dict[str, Any]:
        """The outcome as JSON-ready values."""
        return {
            "balanced": self.balanced,
            "time_to_balance_s": None if not np.isfinite(self.time) else self.time,
            "final_error_rad": None if not np.isfinite(self.error) else self.error,
            "peak_torque": self.peak_torque,
            "effort": self.effort,
            "unit": self.unit,
            "reason": self.reason,
        }


def judge(controller: Any, t: Array, q: Array, v: Array, tau: Array, *, hold: float = HOLD) -> Outcome:
    """The :class:`Outcome` of a run of ``controller`` (a :class:`~robodyn.control.Switched` or an LQR).

    ``t`` (N,) [s], ``q``, ``v`` (N, n), ``tau`` (N, n) the generalized torques applied.
    """
    from robodyn.control.switch import Switched

    balance = controller.lqr if isinstance(controller, Switched) else controller
    plant = balance.plant
    upright, angular = balance.q_eq, plant.angular
    finite = bool(np.all(np.isfinite(q)) and np.all(np.isfinite(v)))
    dt = float(t[1] - t[0]) if t.size > 1 else 0.0
    time = balanced_from(inside_upright(q, upright, angular), dt) if finite else math.nan
    duration = float(t[-1] - t[0]) if t.size else 0.0
    last = t >= t[-1] - hold - 1e-12 if t.size else np.zeros(0, dtype=bool)
    error = float(np.max(angle_error(q[last], upright, angular))) if finite and np.any(last) else math.nan
    actuated = plant.robot.actuated
    applied = np.abs(tau[:, actuated]) if tau.size else np.zeros((0, 1))
    peak = float(np.max(applied)) if applied.size else 0.0
    effort = float(np.min(plant.effort))
    within = peak <= effort * (1.0 + 1e-9)
    balanced = finite and within and is_balanced(time, duration, hold=hold)
    reason = None if balanced else diagnose(controller, q, v, peak_ok=within)
    unit = "N" if _prismatic_drive(plant) else "N m"
    return Outcome(balanced, time if balanced else math.nan, error, peak, effort, hold, reason, unit)


def _prismatic_drive(plant: Any) -> bool:
    """True when an actuated joint of ``plant`` is prismatic (its effort is a force [N])."""
    return any(j.actuated and j.kind.startswith("JointModelP") for j in plant.robot.joints)


def diagnose(controller: Any, q: Array, v: Array, *, peak_ok: bool = True) -> str:
    """Why a run of ``controller`` over the states q, v (N, n) did not balance, in one clause."""
    from robodyn.control.swing_up import CartPoleEnergy, PendubotEnergy, swing_need
    from robodyn.control.switch import Switched

    if not peak_ok:
        return "the torque exceeded the effort limit"
    if not isinstance(controller, Switched):
        return "the LQR alone does not swing up: start inside its region of attraction, or use swing_up"
    law, plant = controller.swing_up, controller.lqr.plant
    effort = float(plant.effort[0])
    if isinstance(law, (PendubotEnergy, CartPoleEnergy)):
        need, how = swing_need(law)
        unit = "N" if isinstance(law, CartPoleEnergy) else "N m"
        if effort < need:
            return f"the effort limit {effort:.4g} {unit} is below the {need:.4g} {unit} the swing needs ({how})"
    if plant.rail is not None and plant.rail_index is not None:
        y = q[:, plant.rail_index]
        lo, hi = plant.rail
        if np.any(y <= lo) or np.any(y >= hi):
            limits = (
                plant.robot.model.lowerPositionLimit[plant.rail_index],
                plant.robot.model.upperPositionLimit[plant.rail_index],
            )
            reached = float(np.min(y)) if np.any(y <= lo) else float(np.max(y))
            return (
                f"the rail is too short: the cart reached y = {reached:.3f} m, "
                f"the end of its usable interval [{lo:.3f}, {hi:.3f}] m (joint limits [{limits[0]:g}, {limits[1]:g}] m)"
            )
    short = _acrobot_short(law, q, v)
    if short is not None:
        return short
    value = controller.lqr.value(q, v)
    rho = controller.region.rho
    if not np.any(value < rho):
        return (
            f"the hand-over never found the LQR's region of attraction (e^T P e fell to {float(np.nanmin(value)):.4g}, "
            f"the region is e^T P e < {rho:.4g})"
        )
    if value[-1] >= rho:
        return "the LQR took over but the state left its region of attraction; the swing-up resumed"
    return "the LQR holds the state in its region but it has not settled within tolerance by the end"


def _acrobot_short(law: Any, q: Array, v: Array) -> str | None:
    """The clause for an Acrobot whose energy never came within ``ENERGY_SHORT`` W of E_up, else None."""
    from robodyn.control.acrobot import AcrobotEnergy, scales

    if not isinstance(law, AcrobotEnergy) or q.shape[0] == 0:
        return None
    step = max(1, q.shape[0] // ENERGY_SAMPLES)
    energies = [law.energy(qi, vi) for qi, vi in zip(q[::step], v[::step], strict=True)]
    highest = float(np.nanmax(energies)) if np.any(np.isfinite(energies)) else math.nan
    if np.isfinite(highest) and highest >= law.energy_up - ENERGY_SHORT * law.hold_torque:
        return None
    _, _, kappa = scales(law.plant)
    return (
        f"the swing never reached the upright's energy (it came to {highest - law.energy_up:.4g} J of E_up, "
        f"2 W = {2 * law.hold_torque:.4g} J below it hanging): the elbow's coupling kappa = {kappa:.3g} "
        "pumps too little a swing"
    )


ENERGY_SAMPLES = 3000  # states of the run whose energy is evaluated (every k-th)
