"""Controllers over a batch of states, for the sweep's vectorised closed-loop chunks: LQR and the swing-up.

:func:`batch_policy` turns a controller that :func:`robodyn.control.make` built into a function
policy(q (m, n), v (m, n)) -> u (m, n_act) [N m | N] that gives, row by row, the torque the
controller's own ``__call__`` gives:

* :class:`~robodyn.control.LQR`: u = sat(u_eq - K e), e the wrapped state error;
* :class:`~robodyn.control.Switched` over the Pendubot's or the cart-pole's energy swing-up
  (:mod:`robodyn.control.swing_up`): the LQR where e^T P e < rho, else the energy law through
  collocated PFL, with M, C v, G from the kind's closed form (:mod:`robodyn.kinds.pendubot`,
  :mod:`robodyn.kinds.cart_pole`; the same functions the compiled fast path uses, checked against
  Pinocchio's ABA when it was built) instead of Pinocchio's CRBA and RNEA: the same formulas,
  equal to round-off.

On the two-degree-of-freedom built-in kinds (one actuated joint) both run through
:func:`robodyn.engine.torque_laws.law`, the one body that numba also compiles for the GPU
(:func:`robodyn.control.compiled.law_of` packs the controller's numbers into its parameter vector); an LQR of any other
robot uses :func:`lqr_torque` (any size, NumPy only).

Any other controller (a user's controller file, a scene's PD law or a custom callable) is an
opaque Python function of one state, so it has no batch form: its chunks run one by one.

Every operation acts on each row alone: sums over the state are written out term by term
(no matrix product across the batch, whose blocking could depend on the batch's size), so a run's
torque, and so its whole trajectory, does not depend on the chunk it is computed in.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.control import LQR
from robodyn.control.compiled import law_of
from robodyn.engine import torque_laws as tl
from robodyn.sim.fast import FastDynamics

Array = NDArray[np.float64]
Policy = Callable[[Array, Array], Array]


def batch_policy(controller: Any, fast: FastDynamics | None) -> Policy | None:
    """The batch form of ``controller`` (see the module docstring), or None when it has none.

    ``fast`` is the robot's compiled closed form (None for a robot of no built-in kind); the swing-up
    needs it for M, C v and G.
    """
    found = law_of(controller, fast)
    if found is not None:
        assert fast is not None  # law_of finds a law only on a built-in kind
        name, c = found
        torque = tl.law(fast.kind, name)
        p, b = fast.param_vector, _pad(fast.damping)

        def policy(q: Array, v: Array) -> Array:
            u = torque(c, p, b, q[:, 0], q[:, 1], v[:, 0], v[:, 1])
            return np.asarray(u, dtype=np.float64).reshape(q.shape[0], 1)

        return policy
    if isinstance(controller, LQR):
        return lambda q, v: lqr_torque(controller, q, v)
    return None


def _pad(x: Array) -> Array:
    """The damping of one or two joints as a 2-vector."""
    out = np.zeros(2)
    out[: x.size] = x
    return out


def lqr_torque(lqr: LQR, q: Array, v: Array) -> Array:
    """The LQR torques sat(u_eq - K e) (m, n_act), the product with K summed column by column."""
    e = lqr.plant.error(q, v, lqr.q_eq)
    u = np.repeat(lqr.u_eq[None, :], q.shape[0], axis=0)
    for j in range(e.shape[1]):
        u = u - e[:, j : j + 1] * lqr.K[:, j]
    return lqr.plant.saturate(u)
