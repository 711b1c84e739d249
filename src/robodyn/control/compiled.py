"""The built-in controllers as a compiled law's parameter vector: what the GPU (and the sweep's batch) evaluates.

:func:`law_of` packs an :class:`~robodyn.control.LQR`, or a :class:`~robodyn.control.Switched` over
the Pendubot's or the cart-pole's energy swing-up, into the float64 parameter vector of a law of
:mod:`robodyn.engine.torque_laws` (the one body NumPy, numba and CUDA evaluate).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.control.lqr import LQR
from robodyn.control.swing_up import CartPoleEnergy, PendubotEnergy
from robodyn.control.switch import Switched
from robodyn.engine import torque_laws as tl
from robodyn.sim.fast import FastDynamics

Array = NDArray[np.float64]


def law_of(controller: Any, fast: FastDynamics | None) -> tuple[str, Array] | None:
    """(law name, parameter vector c) of :mod:`robodyn.engine.torque_laws` for ``controller``, or None.

    None unless the robot is a two-degree-of-freedom built-in kind (cart-pole, Pendubot) with one
    actuated joint and the controller an :class:`~robodyn.control.LQR` or a :class:`~robodyn.control.Switched`
    over the kind's own energy swing-up.
    """
    if fast is None or fast.kind not in tl.LAW_KINDS["lqr"]:
        return None
    if isinstance(controller, LQR):
        name, lqr, rho = "lqr", controller, np.inf
    elif isinstance(controller, Switched) and isinstance(controller.swing_up, (PendubotEnergy, CartPoleEnergy)):
        name = "pendubot_energy" if isinstance(controller.swing_up, PendubotEnergy) else "cart_pole_energy"
        if fast.kind not in tl.LAW_KINDS[name] or controller.swing_up.plant.kind != fast.kind:
            return None
        lqr, rho = controller.lqr, controller.region.rho
    else:
        return None
    plant = lqr.plant
    if plant.n != 2 or plant.n_act != 1 or lqr.K.shape != (1, 4):
        return None
    c = np.zeros(tl.SIZE)
    c[tl.ACT] = float(np.flatnonzero(plant.robot.actuated)[0])
    c[tl.EFFORT] = plant.effort[0]
    c[tl.U_EQ] = lqr.u_eq[0]
    c[tl.K : tl.K + 4] = lqr.K[0]
    c[tl.Q_EQ : tl.Q_EQ + 2] = lqr.q_eq
    c[tl.ANGULAR : tl.ANGULAR + 2] = plant.angular
    c[tl.P : tl.P + 16] = np.asarray(lqr.P, dtype=np.float64).reshape(-1)
    c[tl.RHO] = rho
    law = getattr(controller, "swing_up", None)
    if isinstance(law, PendubotEnergy):
        if int(law.pfl.act[0]) != int(c[tl.ACT]):
            return None
        gains = [law.k_energy, law.accel_max, law.k_p, law.k_d, law.kick, law.weight, law.inertia, law.energy_up]
        gains += [law.swing_effort]
        c[tl.GAINS : tl.GAINS + len(gains)] = gains
    elif isinstance(law, CartPoleEnergy):
        if int(law.pfl.act[0]) != int(c[tl.ACT]):
            return None
        rail = law.plant.rail
        lo, hi = rail if rail is not None else (-np.inf, np.inf)
        gains = [law.k_energy, law.accel_max, law.k_position, law.k_velocity, law.kick, law.m, law.l, law.J, law.g]
        gains += [law.energy_up, float(rail is not None), lo, hi]
        c[tl.GAINS : tl.GAINS + len(gains)] = gains
    return name, c
