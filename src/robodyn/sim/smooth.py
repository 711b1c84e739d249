"""The smooth-acceleration stage: which backend computes a = M(q)^-1 (tau - C(q, v) v - G(q)).

``"aba"`` is Pinocchio's articulated-body algorithm, ``"crba"`` CRBA + Cholesky (it serves
mimic joints, which ABA refuses), ``"formula"`` the hand-derived closed form of a seed kind.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.errors import InputError
from robodyn.kinds import formulas, params
from robodyn.registry import BACKENDS

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]


def formula_of(robot: Robot) -> tuple[Any, Any]:
    """The seed kind's closed-form dynamics and parameters, or an InputError."""
    kind = params.detect_kind(robot)
    if kind is None:
        raise InputError(
            f"backend 'formula' needs one of the seed kinds ({', '.join(formulas.KINDS.names())}); "
            f"{robot.name} is none of them: use backend 'aba' or 'crba'"
        )
    return formulas.get(kind), params.extract(robot, kind)


def backend_function(
    robot: Robot, name: str, formula: tuple[Any, Any] | None
) -> Callable[[Array, Array, Array], Array]:
    """The forward-dynamics function a(q, v, tau) of backend ``name``."""
    model, data = robot.model, robot.data
    if name == "aba":
        return lambda q, v, tau: dynamics.aba(model, data, q, v, tau)
    if name == "crba":
        return lambda q, v, tau: dynamics.crba_solve(model, data, q, v, tau)
    if name == "formula" and formula is not None:
        f, p = formula
        return lambda q, v, tau: f.forward_dynamics(q, v, tau, p)
    BACKENDS.get(name)  # an unknown name lists the backends
    raise InputError(f"backend {name!r} needs a seed kind's formula, which {robot.name} has not")


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
