"""The simulated basin of attraction of an LQR, on the CPU: which starts in one joint's phase plane it balances.

The sampled region of :mod:`robodyn.control.region` is an estimate from the Lyapunov function;
the basin is what the closed loop actually does. Starts fill a ``side`` x ``side`` grid of the
(q_j, v_j) plane of one joint, the other coordinates at the equilibrium and their velocities
zero (the plane a phase portrait draws); each is run for ``duration`` seconds by the vectorised
RK4 of :func:`robodyn.control.rollout.closed_loop` (the compiled closed form, ``backend="fast"``)
and counts as balanced when it ends with every coordinate within ``tolerance`` of the
equilibrium (revolute errors wrapped, [rad], prismatic [m]) and finite. The same map on a GPU,
for large grids, is ``examples/gpu/lqr_basin.py``.

    import robodyn
    from robodyn.control import basin
    b = basin.simulate(robodyn.load("pendubot"), side=21, duration=3.0)
    print(b.describe())
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn.control.lqr import LQR, design
from robodyn.control.rollout import closed_loop
from robodyn.errors import InputError, UnknownNameError
from robodyn.robot import Robot

Array = NDArray[np.float64]

DEFAULT_SIDE = 21
"""Starts per axis: 441 runs, a few seconds on one core."""
DEFAULT_DURATION_S = 3.0
"""Seconds of each run: the LQR settles the built-in kinds within about 2 s when it catches them."""
DEFAULT_DT_S = 1e-3
TOLERANCE = 0.05
"""Balanced: every coordinate ends within this of the equilibrium [rad | m] (as examples/gpu/lqr_basin.py)."""
DEFAULT_HALF_WIDTH = (0.6, 3.0)
"""Half-extent of the grid about the equilibrium: q_j [rad | m] and v_j [rad/s | m/s]."""


@dataclass(frozen=True, eq=False)
class Basin:
    """Which starts of the (q_j, v_j) grid the LQR balanced.

    Attributes:
        model, joint: the robot and the plane's joint.
        q: the joint's start values (n,) [rad | m]; v: its start velocities (n,) [rad/s | m/s].
        balanced: (n_v, n_q) booleans, row i at v[i], column k at q[k].
        q_eq: the LQR's equilibrium (nq,); the other coordinates start at ``reference`` (nq,).
        duration, dt: each run's length and step [s]; tolerance: the balanced test [rad | m].
        wall_time_s: the rollout's wall time [s].
    """

    model: str
    joint: str
    q: Array
    v: Array
    balanced: NDArray[np.bool_]
    q_eq: Array
    reference: Array
    duration: float
    dt: float
    tolerance: float
    wall_time_s: float

    @property
    def fraction(self) -> float:
        """The share of the grid balanced, 0 to 1."""
        return float(np.mean(self.balanced))

    def describe(self) -> str:
        """One line: how many starts the LQR balanced, on which grid, in how long."""
        n = self.balanced.size
        return (
            f"{self.model}: LQR balances {int(self.balanced.sum())} of {n} starts ({100 * self.fraction:.1f} %) "
            f"in the ({self.joint}, velocity) plane, q {self.q[0]:.3g} to {self.q[-1]:.3g}, "
            f"v {self.v[0]:.3g} to {self.v[-1]:.3g}; {self.duration:g} s each at dt = {self.dt:g} s, "
            f"balanced = within {self.tolerance:g} of the upright; {self.wall_time_s:.2g} s on the CPU"
        )


def simulate(
    robot: Robot,
    *,
    lqr: LQR | None = None,
    joint: str | None = None,
    side: int = DEFAULT_SIDE,
    q_range: tuple[float, float] | None = None,
    v_range: tuple[float, float] | None = None,
    duration: float = DEFAULT_DURATION_S,
    dt: float = DEFAULT_DT_S,
    tolerance: float = TOLERANCE,
    reference: ArrayLike | None = None,
) -> Basin:
    """Run the LQR (default: :func:`robodyn.control.design`'s) from a ``side`` x ``side`` grid of starts.

    Args:
        robot: a built-in kind (cart_pole, pendubot, ...): the compiled closed form runs the batch.
        lqr: the controller; default the designed LQR of ``robot``.
        joint: the plane's joint; default the first passive joint, else the first joint.
        side: starts per axis, 2 to 201.
        q_range: the grid's extent in q_j [rad | m]; default the equilibrium +- DEFAULT_HALF_WIDTH[0].
        v_range: the grid's extent in v_j [rad/s | m/s]; default +- DEFAULT_HALF_WIDTH[1].
        duration: each run's length [s].
        dt: the RK4 step [s].
        tolerance: balanced when every coordinate ends this close to the equilibrium [rad | m].
        reference: where the other coordinates start (nq,); default the equilibrium.

    Raises:
        InputError: a bad side, range, duration or tolerance; a model without a compiled closed form.
        UnknownNameError: a joint the model does not have.
    """
    if not isinstance(side, int) or isinstance(side, bool) or not 2 <= side <= 201:
        raise InputError(f"basin side must be an integer from 2 to 201 (starts per axis), got {side!r}")
    if not (np.isfinite(tolerance) and tolerance > 0):
        raise InputError(f"basin tolerance must be a positive number [rad | m], got {tolerance!r}")
    lqr = design(robot) if lqr is None else lqr
    names = list(robot.joint_names)
    name = joint if joint is not None else (robot.passive_joints[0] if robot.passive_joints else names[0])
    if name not in names:
        raise UnknownNameError(f"joint of {robot.name}", name, names)
    iq, iv = robot.joint(name).idx_q, robot.joint(name).idx_v
    centre = float(lqr.q_eq[iq])
    dq, dv = DEFAULT_HALF_WIDTH
    qs = np.linspace(*(q_range or (centre - dq, centre + dq)), side)
    vs = np.linspace(*(v_range or (-dv, dv)), side)
    if not (np.all(np.isfinite(qs)) and np.all(np.isfinite(vs)) and qs[0] < qs[-1] and vs[0] < vs[-1]):
        raise InputError(f"basin ranges must be two finite numbers each, low < high, got {q_range}, {v_range}")
    qq, vv = np.meshgrid(qs, vs)
    start = lqr.q_eq if reference is None else np.asarray(reference, dtype=np.float64)
    if start.shape != (robot.nq,) or not np.all(np.isfinite(start)):
        raise InputError(f"basin reference must be {robot.nq} finite numbers (one per coordinate), got {reference!r}")
    Q0 = np.tile(start, (qq.size, 1))
    V0 = np.zeros((qq.size, robot.nv))
    Q0[:, iq], V0[:, iv] = qq.ravel(), vv.ravel()
    run = closed_loop(robot, lqr.batch, Q0, V0, duration=duration, dt=dt, backend="fast")
    error = lqr.plant.error(run.q, run.v, lqr.q_eq)[:, : robot.nq]
    with np.errstate(invalid="ignore"):
        balanced = np.all(np.abs(error) < tolerance, axis=1) & np.all(np.isfinite(run.v), axis=1)
    return Basin(
        model=robot.name,
        joint=name,
        q=qs,
        v=vs,
        balanced=balanced.reshape(qq.shape),
        q_eq=np.asarray(lqr.q_eq, dtype=np.float64).copy(),
        reference=np.asarray(start, dtype=np.float64).copy(),
        duration=float(duration),
        dt=float(dt),
        tolerance=float(tolerance),
        wall_time_s=run.wall_time_s,
    )
