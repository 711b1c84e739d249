"""Compile every kernel ahead of its first use: ``robodyn warmup``, for a classroom or a CI image.

Each group loads its kernels from numba's cache (:mod:`robodyn.engine.jit`) or compiles them, for
the argument types the runs use, so that no later run on this machine waits. The groups, in the
order :func:`warm` takes them:

* ``closed-forms``: the built-in kinds' closed-form runs (:mod:`robodyn.sim.fast`: sweeps, the
  Pendubot's controllers, the benchmarks' fast column);
* ``tree``: ABA, RNEA, CRBA and the energies of any tree robot (:func:`robodyn.sim.tree.dynamics_kernels`), fixed
  base and free-flyer root (the kernels' two variants);
* ``events``: the whole run that ``robodyn simulate`` takes on any tree robot, its steps clear
  of the stops (:func:`robodyn.sim.tree.step_kernels`) and its stop events
  (:func:`robodyn.sim.tree.event_kernels`, otherwise compiled when a run first meets a stop);
* ``batch``: many states at once (:func:`robodyn.sim.batch.rollout`), closed form and tree.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from robodyn.errors import UnknownNameError


def _closed_forms() -> None:
    from robodyn.sim import fast

    fast.warm_up()


def _tree() -> None:
    from robodyn.sim import tree

    for flyer in (False, True):  # the kernels' two variants: fixed base, free-flyer root
        tree.dynamics_kernels(flyer)


def _events() -> None:
    from robodyn.sim import tree

    for flyer in (False, True):  # fixed base, free-flyer root; RK4 and semi-implicit Euler, a tableau
        for tableau in (False, True):
            tree.step_kernels(flyer, tableau)
            tree.event_kernels(flyer, tableau)


def _batch() -> None:
    from robodyn import integrators
    from robodyn.sim import fast, tree, whole_run

    code = whole_run.method_code(integrators.get("rk4"))
    if code is None:  # pragma: no cover - rk4 is the kernels' own method
        return
    one = np.array([0, 1], dtype=np.int64)
    for flyer in (False, True):
        t = tree.one_joint(flyer)
        forces, springs = np.zeros((4, t.nv)), np.zeros((4, 0))
        forces[3, 0] = 1.0
        Q, V = np.zeros((1, t.nq)), np.zeros((1, t.nv))
        if flyer:
            Q[0, 6] = 1.0  # a free flyer's unit quaternion
        kernels = tree.kernels(flyer)
        kernels.batch_rollout(t.itree, t.ftree, t.grav, t.flyer, code[0], code[1], 1e-3, 0, Q, V, forces, springs, one)
    Q2, V2 = np.zeros((1, 2)), np.zeros((1, 2))
    fast.warm_up()["batch_rk4"](0, np.ones(6), np.zeros(2), 2, Q2, V2, 1e-3, 0, one)


@dataclass(frozen=True)
class Group:
    """A group of kernels ``robodyn warmup`` compiles: its name, what it serves, how to load it."""

    name: str
    serves: str
    load: Callable[[], None]


GROUPS = (
    Group("closed-forms", "the built-in kinds' closed-form runs (sweeps, controllers)", _closed_forms),
    Group("tree", "ABA, RNEA, CRBA and the energies of any tree robot", _tree),
    Group("events", "robodyn simulate's whole run, joint stops included", _events),
    Group("batch", "many states at once (robodyn bench, robodyn.sim.batch)", _batch),
)


def groups(names: list[str] | None = None) -> list[Group]:
    """The groups called ``names`` (all of them for None), in :data:`GROUPS`' order.

    Raises:
        UnknownNameError: a name that is no group (the message lists the groups).
    """
    known = [g.name for g in GROUPS]
    for name in names or []:
        if name not in known:
            raise UnknownNameError("kernel group", name, known)
    return [g for g in GROUPS if names is None or g.name in names]


def warm(group: Group) -> float:
    """Load or compile ``group``'s kernels; returns the wall time it took [s]."""
    start = time.perf_counter()
    group.load()
    return time.perf_counter() - start
