"""Each kernel run once on a small tree, so that numba loads or compiles it before a timed run does.

Plain arrays in, nothing out: :mod:`robodyn.sim.tree` (``kernels``, ``step_kernels``,
``event_kernels``) passes its one-joint tree and the kernels' module. What is compiled is the
variant the arguments' types pick: the tree's ``flyer`` (None for a fixed base, True for a
free-flyer root) and the method's ``tab`` (None for RK4 and semi-implicit Euler, else a tableau).
"""

from __future__ import annotations

from types import ModuleType

import numpy as np
from numpy.typing import NDArray

from robodyn.engine.tree.layout import flyer_of

Array = NDArray[np.float64]

# (code, tableau) of the runs: RK4 (no tableau: its own arithmetic) and explicit Euler's tableau,
# as robodyn.sim.whole_run.method_code and its _tab give them
RK4_CODE: tuple[int, Array | None] = (1, None)
TABLEAU_CODE: tuple[int, Array | None] = (0, np.array([[0.0], [1.0], [0.0]]))


def inputs(itree: NDArray[np.int64], nq: int, nv: int) -> tuple[Array, Array, Array, Array]:
    """(q, v, forces (4, nv), springs (4, 0)) at rest (a free flyer's quaternion (0, 0, 0, 1)), a friction velocity."""
    q = np.zeros(nq)
    if flyer_of(itree) is not None:
        q[6] = 1.0
    forces = np.zeros((4, nv))
    forces[3, 0] = 1e-3
    return q, np.zeros(nv), forces, np.zeros((4, 0))


def algorithms(k: ModuleType, itree: NDArray[np.int64], ftree: Array, grav: Array, nq: int, nv: int) -> None:
    """ABA, the energies and one sample (``k``: :mod:`robodyn.engine.tree.steps`)."""
    flyer = flyer_of(itree)
    q, v, forces, springs = inputs(itree, nq, nv)
    ws, u = np.zeros((itree.shape[0], k.WCOLS)), np.zeros(nv + 2)
    k.aba(itree, ftree, grav, flyer, q, v, v, ws, np.zeros(nv))
    k.kinematics(itree, ftree, grav, flyer, q, v, ws)
    k.sample(itree, ftree, grav, flyer, 0.0, q, u, forces, springs, -1, np.zeros((2, 0)), 1e-12, u.copy())


def dynamics(k: ModuleType, itree: NDArray[np.int64], ftree: Array, grav: Array, nq: int, nv: int) -> None:
    """RNEA and CRBA (``k``: :mod:`robodyn.engine.tree.steps`)."""
    flyer = flyer_of(itree)
    q, v, _, _ = inputs(itree, nq, nv)
    ws = np.zeros((itree.shape[0], k.WCOLS))
    k.rnea(itree, ftree, grav, flyer, q, v, v, ws, np.zeros(nv))
    k.crba(itree, ftree, grav, flyer, q, ws, np.zeros((nv, nv)))


def run(
    k: ModuleType, itree: NDArray[np.int64], ftree: Array, grav: Array, nq: int, nv: int, *, tableau: bool, events: bool
) -> None:
    """Two steps of a whole run, the last row's joint with a stop at +-1 rad: ``k.run_events``, or ``k.run_steps``.

    ``k``: :mod:`robodyn.engine.tree.events`; ``tableau``: explicit Euler's tableau, else RK4.
    """
    q, _, forces, springs = inputs(itree, nq, nv)
    code, tab = TABLEAU_CODE if tableau else RK4_CODE
    md = (itree, ftree, grav, forces, springs, code, tab, -1, flyer_of(itree))
    n = 3
    ts, hs = 1e-3 * np.arange(n), np.full(n - 1, 1e-3)
    Q, U, A = np.tile(q, (n, 1)), np.zeros((n, nv + 2)), np.zeros((n, nv))
    kin, pot, wl = np.zeros(n), np.zeros(n), np.zeros(n)
    counts, par = np.zeros(k.NCOUNTS, dtype=np.int64), np.zeros(k.PCOLS)
    last = itree.shape[0] - 1
    stops = np.array([[itree[last, 2]], [itree[last, 3]], [-1.0], [1.0], [1e-14], [last]], dtype=np.float64)
    if events:
        held, side = np.zeros(2, dtype=np.int64), np.zeros(1, dtype=np.int64)
        records = np.zeros((1, 6))
        k.run_events(md, par, stops, held, side, counts, np.zeros(1), records, ts, hs, 0, n - 1, Q, U, A, kin, pot, wl)
    else:
        k.run_steps(md, par, stops, counts, np.zeros(1), ts, hs, 0, n - 1, Q, U, A, kin, pot, wl)
