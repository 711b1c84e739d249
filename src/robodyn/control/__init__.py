"""Control of the built-in kinds: LQR balance, energy swing-up, and the hand-over between them.

Controllers are torque callables tau(t, q, v) -> u (one entry per actuated joint) that
:func:`robodyn.simulate` takes as ``torque=``; :func:`make` builds one by name for a robot::

    import robodyn, robodyn.control
    robot = robodyn.load("cart_pole")
    controller = robodyn.control.make("swing_up", robot)
    trajectory = robodyn.simulate(robot, [0, 3.14159], [0, 0], duration=10, dt=1e-3, torque=controller)

Modules, one concept each: :mod:`~robodyn.control.plant` (equilibria, wrapped errors, limits),
:mod:`~robodyn.control.lqr`, :mod:`~robodyn.control.region` (the LQR's region of attraction),
:mod:`~robodyn.control.pfl` (collocated partial feedback linearisation),
:mod:`~robodyn.control.swing_up`, :mod:`~robodyn.control.switch`,
:mod:`~robodyn.control.controllers` (the names), :mod:`~robodyn.control.user_controller` (a user's file),
:mod:`~robodyn.control.rollout` (batches under control), :mod:`~robodyn.control.symbolic`
(the sympy reference linearisation).
"""

from robodyn.control.controllers import CONTROLLERS, make, names
from robodyn.control.lqr import LQR, design
from robodyn.control.plant import Plant, plant
from robodyn.control.region import Region, estimate
from robodyn.control.switch import Switched
from robodyn.control.user_controller import load_user_controller

__all__ = [
    "CONTROLLERS",
    "LQR",
    "Plant",
    "Region",
    "Switched",
    "design",
    "estimate",
    "load_user_controller",
    "make",
    "names",
    "plant",
]
