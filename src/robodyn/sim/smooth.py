"""The smooth-acceleration stage: which backend computes a = M(q)^-1 (tau - C(q, v) v - G(q)).

``"aba"`` is Pinocchio's articulated-body algorithm, ``"crba"`` CRBA + Cholesky (it serves
mimic joints, which ABA refuses), ``"formula"`` the hand-derived closed form of a built-in kind,
``"numba"`` the articulated-body algorithm compiled by numba (:mod:`robodyn.sim.tree`, checked
against Pinocchio before use). Called from Python once per evaluation, the compiled ABA costs
about what Pinocchio's does (the call dominates on small models); its gain is the whole run in
one compiled loop (:mod:`robodyn.sim.whole_run`), which :func:`robodyn.simulate` takes by default.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.engine.tree.layout import WCOLS
from robodyn.errors import InputError, RobodynError
from robodyn.kinds import catalog, params
from robodyn.registry import BACKENDS
from robodyn.sim import tree

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]


def formula_of(robot: Robot) -> tuple[Any, Any]:
    """The built-in kind's closed-form dynamics and parameters, or an InputError."""
    kind = params.detect_kind(robot)
    if kind is None:
        raise InputError(
            f"backend 'formula' needs one of the built-in kinds ({catalog.listed()}); "
            f"{robot.name} is none of them: use backend 'aba' or 'crba'"
        )
    return catalog.get(kind), params.extract(robot, kind)


def backend_function(
    robot: Robot, name: str, formula: tuple[Any, Any] | None
) -> Callable[[Array, Array, Array], Array]:
    """The forward-dynamics function a(q, v, tau) of backend ``name``."""
    model, data = robot.model, robot.data
    if name == "aba":
        return dynamics.aba_function(model, data)
    if name == "crba":
        return functools.partial(dynamics.crba_solve, model, data)
    if name == "numba":
        return compiled_function(robot)
    if name == "formula" and formula is not None:
        f, p = formula
        return lambda q, v, tau: f.forward_dynamics(q, v, tau, p)
    BACKENDS.get(name)  # an unknown name lists the backends
    raise InputError(f"backend {name!r} needs a built-in kind's formula, which {robot.name} has not")


def compiled_function(robot: Robot) -> Callable[[Array, Array, Array], Array]:
    """a(q, v, tau) by the compiled ABA of :mod:`robodyn.sim.tree` (one workspace, a fresh result per call).

    Raises:
        InputError: the compiled path cannot serve ``robot`` (the reason), or its check against Pinocchio failed.
    """
    try:
        compiled = tree.compiled_of(robot)
    except RobodynError as exc:
        raise InputError(f"backend 'numba' cannot serve {robot.name}: {exc}; use backend 'aba'") from None
    t = compiled.tree
    kernel = tree.kernels(t.flyer is not None).aba
    itree, ftree, grav, flyer = t.itree, t.ftree, t.grav, t.flyer
    ws = np.zeros((itree.shape[0], WCOLS))

    def forward(q: Array, v: Array, tau: Array) -> Array:
        out = np.empty(t.nv)
        kernel(itree, ftree, grav, flyer, q, v, tau, ws, out)
        return out

    return forward


def resolve_backend(robot: Robot, backend: str | None) -> str:
    """The forward-dynamics backend for ``robot``: ``backend``, or by default ``"aba"`` (``"crba"`` with mimic joints).

    Raises:
        UnknownNameError: an unknown backend.
        InputError: ``"aba"`` asked for a model with mimic joints, which Pinocchio's ABA refuses.
    """
    mimic = dynamics.has_mimic_joints(robot.model)
    if backend is None:
        return "crba" if mimic else "aba"
    BACKENDS.get(backend)  # an unknown name lists the backends
    if backend == "aba" and mimic:
        raise InputError(
            f"{robot.name} has mimic joints, which Pinocchio's ABA refuses: use backend 'crba' (--backend crba)"
        )
    return backend
