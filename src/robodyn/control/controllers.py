"""The controllers by name: ``make(name, robot, **gains)`` builds a torque callable tau(t, q, v) for one robot.

Built in:

* ``lqr``: LQR balance at the upright (or a given) equilibrium (:mod:`robodyn.control.lqr`);
  gains ``Q``, ``R``, ``K``, ``q_eq``, ``u_eq``;
* ``swing_up``: energy swing-up from anywhere, handing over to that LQR inside its estimated
  region of attraction (:mod:`robodyn.control.swing_up`, :mod:`robodyn.control.switch`); gains
  ``Q``, ``R``, ``K`` of the LQR, ``rho`` (the region's level; default estimated), ``samples`` and
  ``seed`` of that estimate, and the swing-up law's own: for the cart-pole ``k_energy``,
  ``accel_max``, ``k_position``, ``k_velocity``, ``kick``, ``energy_offset``; for the Pendubot
  ``k_energy``, ``accel_max``, ``k_p``, ``k_d``, ``kick``, ``energy_offset``, ``swing_effort``; for
  the Acrobot (a Pendubot with the elbow driven, :mod:`robodyn.control.acrobot`) ``k_p``, ``k_d``,
  ``k_energy``, ``amplitude``, ``kick``, ``energy_offset``, and its LQR's default ``Q``, ``R`` are
  scaled from the model (:func:`robodyn.control.acrobot.lqr_weights`).

A name that ends in ``.py`` or holds a path separator is a user's controller file
(:mod:`robodyn.control.user_controller`). An unknown name, or an unknown gain, raises
:class:`UnknownNameError` with the close matches.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.control import acrobot, lqr, region, swing_up
from robodyn.control.plant import plant
from robodyn.control.switch import Switched
from robodyn.control.user_controller import load_user_controller, looks_like_file
from robodyn.errors import AssumptionError, InputError, UnknownNameError
from robodyn.kinds import catalog, params
from robodyn.registry import Registry
from robodyn.robot import Robot

Array = NDArray[np.float64]
Controller = Callable[[float, Array, Array], Array]


@dataclass(frozen=True)
class ControllerSpec:
    """A built-in controller: what it does (one line) and the factory make(robot, **gains)."""

    summary: str
    factory: Callable[..., Controller]


CONTROLLERS: Registry[ControllerSpec] = Registry("controller")

LQR_GAINS = ("K", "Q", "R", "q_eq", "u_eq")
REGION_GAINS = ("rho", "samples", "seed")
SWING_UP_GAINS = {
    "cart_pole": ("accel_max", "energy_offset", "k_energy", "k_position", "k_velocity", "kick"),
    "pendubot": ("accel_max", "energy_offset", "k_d", "k_energy", "k_p", "kick", "swing_effort"),
    "acrobot": ("amplitude", "energy_offset", "k_d", "k_energy", "k_p", "kick"),
}


def names() -> tuple[str, ...]:
    """The built-in controller names, sorted."""
    return CONTROLLERS.names()


def make(name: str, robot: Robot, **gains: Any) -> Controller:
    """The controller ``name`` (or a user's controller file) for ``robot``, a callable tau(t, q, v) -> u (n_act,).

    Pass it to :func:`robodyn.simulate` as ``torque=``.

    Raises:
        UnknownNameError: an unknown controller or gain (with close matches).
        InputError: gains of the wrong shape or sign, a robot the controller cannot serve, or a
            controller file that fails (its file and line).
    """
    if looks_like_file(name):
        return load_user_controller(name, robot, **gains)
    return CONTROLLERS.get(name).factory(robot, **gains)


def _check_gains(controller: str, gains: dict[str, Any], allowed: tuple[str, ...]) -> None:
    """Raise unless every gain is one ``allowed`` and holds numbers (a list of them, a matrix).

    A null would quietly stand for the default and a true for 1 (``{"Q": true}``): each is refused,
    as are strings and empty lists.
    """
    for key, value in gains.items():
        if key not in allowed:
            raise UnknownNameError(f"gain of controller {controller!r}", key, allowed)
        bad = _not_a_number(value)
        if bad is not None:
            raise InputError(
                f"{controller} gain {key} holds {bad}; expected a number, a list of numbers or a matrix (lists of rows)"
            )


def _not_a_number(value: Any, depth: int = 0) -> str | None:
    """What in ``value`` is not a number (``"null"``, ``"true"``, ``"a string"``), or None when all are numbers."""
    if value is None:
        return "null"
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, float, np.integer, np.floating)):
        return None
    if isinstance(value, (list, tuple)) and depth < 2:
        if not value:
            return "an empty list"
        return next((bad for v in value if (bad := _not_a_number(v, depth + 1)) is not None), None)
    if isinstance(value, (list, tuple)):
        return "lists nested more than two deep"
    return f"a {type(value).__name__}"


def _make_lqr(robot: Robot, **gains: Any) -> lqr.LQR:
    _check_gains("lqr", gains, LQR_GAINS)
    return lqr.design(robot, **gains)


def _make_swing_up(robot: Robot, **gains: Any) -> Switched:
    p = plant(robot)
    kinds = ("cart_pole", "pendubot")
    if p.kind not in kinds:
        raise InputError(
            f"controller 'swing_up' knows the {' and the '.join(kinds)}; {robot.name} is neither "
            f"({'; '.join(_why_not(robot, kind) for kind in kinds)})"
        )
    law_kind = "acrobot" if acrobot.is_acrobot(p) else p.kind
    if law_kind != "acrobot":
        _require_drive(robot, p.kind)
    own = SWING_UP_GAINS[law_kind]
    _check_gains(f"swing_up ({law_kind})", gains, LQR_GAINS[:3] + REGION_GAINS + own)
    weights = {k: gains[k] for k in LQR_GAINS[:3] if k in gains}
    if law_kind == "acrobot" and not weights:  # its region must hold the straight arm's orbit (see lqr_weights)
        weights["Q"], weights["R"] = acrobot.lqr_weights(p)
    balance = lqr.design(robot, **weights)
    rho = gains.get("rho")
    estimated = region.estimate(
        balance,
        samples=_count(gains.get("samples", region.DEFAULT_SAMPLES), "samples"),
        seed=_count(gains.get("seed", 0), "seed", minimum=0),
    )
    if rho is not None:
        if isinstance(rho, bool) or not isinstance(rho, (int, float)) or not np.isfinite(rho) or rho <= 0:
            raise InputError(f"swing_up gain rho must be a positive number (a level of e^T P e), got {rho!r}")
        estimated = region.Region(float(rho), estimated.rho_lyapunov, estimated.rho_rail, estimated.c_max, 0, 0)
    law_gains = {k: gains[k] for k in own if k in gains}
    law: Controller
    if law_kind == "acrobot":
        law = acrobot.acrobot(p, **law_gains)
    else:
        law = swing_up.cart_pole(p, **law_gains) if p.kind == "cart_pole" else swing_up.pendubot(p, **law_gains)
    return Switched(law, balance, estimated)


def _why_not(robot: Robot, kind: str) -> str:
    """The first assumption of ``kind`` that ``robot`` breaks, as its reader says it ("not a pendubot: ...")."""
    try:
        params.extract(robot, kind)
    except AssumptionError as exc:
        return str(exc)
    return f"a {kind} by its parameters"  # read as one, but detected as an earlier kind


def _require_drive(robot: Robot, kind: str) -> None:
    """Refuse, in one line, a robot whose actuated joints are not the one the kind's law drives.

    The laws are collocated PFL on one driven joint with the other passive (an underactuated
    system): a robot read with more actuators (a URDF without the SRDF that declares the passive
    joint) would give the law a torque per actuator that it has no rule for.
    """
    balance = catalog.kind(kind).balance
    assert balance is not None  # a kind with a swing-up law has its Balance
    driven = robot.joint_names[balance.driven]  # every other joint must be passive
    if driven in robot.passive_joints:
        raise InputError(f"swing_up drives {driven} of the {kind}, but {robot.name} declares it passive")
    extra = [j.name for j in robot.joints if j.actuated and j.name != driven]
    if extra:
        raise InputError(
            f"swing_up drives {driven} of the {kind} alone (the others swing freely), but {robot.name} also "
            f"actuates {', '.join(extra)}: declare {'it' if len(extra) == 1 else 'them'} passive "
            f"(--passive {','.join(extra)}, [model] passive = {json.dumps(extra)} in a scene, or <passive_joint> "
            "in an SRDF)"
        )


def _count(value: Any, name: str, *, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise InputError(f"swing_up gain {name} must be a whole number >= {minimum}, got {value!r}")
    return int(value)


CONTROLLERS.register("lqr", ControllerSpec("LQR balance at the upright (or a given) equilibrium", _make_lqr))
CONTROLLERS.register(
    "swing_up", ControllerSpec("energy swing-up from hanging, handing over to LQR balance", _make_swing_up)
)
