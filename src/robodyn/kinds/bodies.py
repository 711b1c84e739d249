"""A model as a kind reads its parameters: the moving bodies at q = 0 in world coordinates, plain arrays.

:func:`robodyn.kinds.params.extract` builds the :class:`Body` list from a loaded model (through
Pinocchio) and hands it, with the gravity vector, to the kind's reader (``Kind.read``). A reader
checks the kind's assumptions with the helpers here (joint types and axes, the link line, the
centre of mass on it, no armature where the formula has none) and raises
:class:`~robodyn.errors.AssumptionError` naming the first one broken. Nothing here imports
Pinocchio, so a kind's module (closed form and reader) stays free of it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import AssumptionError

Array = NDArray[np.float64]

# Geometric tests (axes parallel, COM on the link line) allow this much [m or unit-vector
# component]: URDF numbers are printed to ~1e-9 at best.
GEOMETRY_TOL = 1e-9

EX, EY, EZ = np.eye(3)


@dataclass(frozen=True)
class Body:
    """One moving joint and the body it carries, at q = neutral, in world coordinates."""

    name: str
    kind: str  # the joint model's name (JointModelRY, ...)
    nq: int
    origin: Array  # joint origin [m]
    linear_axis: Array
    angular_axis: Array
    mass: float  # [kg]
    com: Array  # centre of mass [m]
    inertia_com: Array  # (3, 3) about the COM, world axes [kg m^2]
    armature: float  # [kg m^2]
    parent: int
    rotor_inertia: float  # the SRDF's rotor_params mass, J_m [kg m^2]
    gear_ratio: float  # the SRDF's rotor_params gear_ratio, n [1]


def fail(kind: str, message: str) -> AssumptionError:
    """``not a <kind>: <message>``."""
    return AssumptionError(f"not a {kind}: {message}")


def same(a: Array, b: Array) -> bool:
    """Equal to :data:`GEOMETRY_TOL`."""
    return bool(np.allclose(a, b, rtol=0.0, atol=GEOMETRY_TOL))


def fmt(x: Array) -> str:
    """``(x y z)`` to 6 digits."""
    return "(" + " ".join(f"{c + 0.0:.6g}" for c in x) + ")"  # + 0.0 prints -0 as 0


def require_joints(kind: str, bodies: Sequence[Body], expected: tuple[str, ...]) -> None:
    """Check count, chain and type ('R' revolute with a plain angle, 'P' prismatic)."""
    if len(bodies) != len(expected):
        names = ", ".join(f"{b.name} ({b.kind})" for b in bodies) or "none"
        raise fail(kind, f"expected {len(expected)} moving joint(s), found {len(bodies)}: {names}")
    for i, (body, want) in enumerate(zip(bodies, expected, strict=True)):
        if body.parent != i:
            raise fail(kind, f"joint {body.name} must be a child of {'the base' if i == 0 else bodies[i - 1].name}")
        if body.nq != 1:
            raise fail(
                kind,
                f"joint {body.name} ({body.kind}) has nq = {body.nq}; the formula needs a plain coordinate "
                "(use type revolute or prismatic, not continuous)",
            )
        revolute = np.linalg.norm(body.angular_axis) > 0.5 and np.linalg.norm(body.linear_axis) < GEOMETRY_TOL
        prismatic = np.linalg.norm(body.linear_axis) > 0.5 and np.linalg.norm(body.angular_axis) < GEOMETRY_TOL
        if (want == "R" and not revolute) or (want == "P" and not prismatic):
            raise fail(kind, f"joint {body.name} ({body.kind}) must be {'revolute' if want == 'R' else 'prismatic'}")


def require_axis(kind: str, body: Body, axis: Array, which: str) -> None:
    """The joint's ``which`` ("angular" or "linear") axis must be ``axis``."""
    got = body.angular_axis if which == "angular" else body.linear_axis
    if not same(got, axis):
        raise fail(kind, f"joint {body.name} axis is {fmt(got)} in world, expected {fmt(axis)}")


def require_gravity(kind: str, gravity: Array) -> float:
    """|g| [m/s^2]; gravity must point along -z."""
    g = float(np.linalg.norm(gravity))
    if g == 0.0 or not same(gravity / g, -EZ):
        raise fail(kind, f"gravity is {fmt(gravity)} m/s^2, expected along -z")
    return g


def require_no_armature(kind: str, bodies: Sequence[Body]) -> None:
    """No joint may carry armature (the formula has no rotor inertia)."""
    for body in bodies:
        if body.armature != 0.0:
            raise fail(
                kind,
                f"joint {body.name} has armature {body.armature:.6g} kg m^2; the {kind} formula has no rotor inertia",
            )


def in_plane(vector: Array, axis: Array) -> Array:
    """Component of ``vector`` perpendicular to ``axis`` (offsets along an axis change nothing)."""
    return vector - (vector @ axis) * axis


def along(kind: str, what: str, vector: Array, direction: Array, axis: Array) -> float:
    """Signed length of ``vector`` along ``direction``; it must have nothing else in the plane."""
    planar = in_plane(vector, axis)
    length = float(planar @ direction)
    off = planar - length * direction
    if np.linalg.norm(off) > GEOMETRY_TOL:
        raise fail(kind, f"{what} is off the line {fmt(direction)} by {fmt(off)} m at q = 0")
    return length


def axis_inertia(body: Body, axis: Array) -> float:
    """The moment of inertia about the centre of mass around ``axis`` [kg m^2]: a^T I a."""
    return float(axis @ body.inertia_com @ axis)
