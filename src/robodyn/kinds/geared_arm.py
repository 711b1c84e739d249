"""One link driven by a DC motor through an n:1 gear train (closed form written once, in the link coordinate).

The motor shaft turns n times per turn of the link: theta_m = n theta_l. With J_m the
rotor's inertia and J_l the link's inertia about the joint axis,

    T = 1/2 J_m theta_m'^2 + 1/2 J_l theta_l'^2 = 1/2 (J_l + n^2 J_m) theta_l'^2
    V = m g l (1 - cos theta_l)

Link coordinate (Pinocchio's):  (J_l + n^2 J_m) theta_l'' + m g l sin theta_l = tau_l
Motor coordinate (the textbook's): (J_m + J_l / n^2) theta_m'' + (m g l / n) sin(theta_m / n) = tau_m

The two are one equation: theta_l = theta_m / n, tau_l = n tau_m (ideal gears), so
M_l = n^2 M_m, C_l = n^2 C_m, G_l = n G_m. n^2 J_m is the reflected rotor inertia that
Pinocchio calls armature. C = 0: M is constant.

The closed form is written once, in the link coordinate; the motor-coordinate forms are that
same closed form carried through the coordinate map (:func:`to_motor_coordinates`), and a user's
motor-coordinate derivation comes back through :func:`from_motor_coordinates`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from robodyn.kinds.bodies import (
    EZ,
    GEOMETRY_TOL,
    Body,
    along,
    axis_inertia,
    fail,
    fmt,
    in_plane,
    require_gravity,
    require_joints,
)
from robodyn.kinds.formula import Array, ClosedForm, Params, Scalar
from robodyn.kinds.kind import Kind

PARAMS = ("J_m", "J_l", "n", "m", "l", "g")


def mass(p: Scalar, q: Scalar) -> tuple[Scalar]:
    """(M,) = (J_l + n^2 J_m,) [kg m^2] in the link coordinate."""
    return (p[1] + p[2] * p[2] * p[0] + 0.0 * q,)


def coriolis(p: Scalar, q: Scalar, v: Scalar) -> tuple[Scalar]:
    """(C,) = (0,): M is constant."""
    return (0.0 * p[0] * v,)


def gravity(p: Scalar, q: Scalar) -> tuple[Scalar]:
    """(G,) = (m g l sin q,) [N m] in the link coordinate."""
    return (p[3] * p[5] * p[4] * np.sin(q),)


def potential(p: Scalar, q: Scalar) -> Scalar:
    """V [J], zero hanging straight down."""
    return p[3] * p[5] * p[4] * (1.0 - np.cos(q))


def read(bodies: Sequence[Body], gravity_vector: Array) -> dict[str, float]:
    """The parameters of a model that is a geared arm: hanging down at q = 0, a horizontal axis."""
    kind = "geared_arm"
    require_joints(kind, bodies, ("R",))
    (arm,) = bodies
    axis = arm.angular_axis
    if abs(axis @ EZ) > GEOMETRY_TOL:
        raise fail(kind, f"joint {arm.name} axis {fmt(axis)} must be horizontal (perpendicular to gravity)")
    g = require_gravity(kind, gravity_vector)
    l = along(kind, f"the link's centre of mass ({arm.name})", arm.com - arm.origin, -EZ, axis)
    J_m, n = arm.rotor_inertia, arm.gear_ratio
    if J_m == 0.0:
        # Armature given without rotor parameters: read it as a rotor on a 1:1 drive.
        J_m, n = arm.armature, 1.0
    elif not np.isclose(arm.armature, J_m * n**2, rtol=1e-12, atol=0.0):
        raise fail(
            kind,
            f"armature {arm.armature:.6g} kg m^2 of joint {arm.name} is not J_m n^2 = {J_m * n**2:.6g} "
            "(load rotor parameters once, from the SRDF)",
        )
    J_l = axis_inertia(arm, axis) + arm.mass * float(np.sum(in_plane(arm.com - arm.origin, axis) ** 2))
    return {"J_m": J_m, "J_l": J_l, "n": n, "m": arm.mass, "l": l, "g": g}


CLOSED_FORM = ClosedForm(PARAMS, 1, mass, coriolis, gravity, potential)
KIND = Kind(
    "geared_arm",
    CLOSED_FORM,
    read,
    {"J_m": "kg m^2", "J_l": "kg m^2", "n": "1", "m": "kg", "l": "m", "g": "m/s^2"},
    code=2,
    renamed={"M": ("m", "the link's mass")},
)
FORMULA = KIND.formula


# ------------------------------------------------------------------ motor coordinate
def link_to_motor(q: Array, v: Array, p: Params) -> tuple[Array, Array]:
    """(theta_l, theta_l') -> (theta_m, theta_m') = n (theta_l, theta_l')."""
    return p["n"] * np.asarray(q), p["n"] * np.asarray(v)


Fn = Callable[..., Any]


def to_motor_coordinates(M_l: Fn, C_l: Fn, G_l: Fn, V_l: Fn | None) -> tuple[Fn, Fn, Fn, Fn | None]:
    """Link-coordinate functions -> motor-coordinate ones: M_m = M_l / n^2, C_m = C_l / n^2, G_m = G_l / n."""

    def M(theta_m: Array, p: Params) -> Array:
        return M_l(theta_m / p["n"], p) / p["n"] ** 2

    def C(theta_m: Array, omega_m: Array, p: Params) -> Array:
        return C_l(theta_m / p["n"], omega_m / p["n"], p) / p["n"] ** 2

    def G(theta_m: Array, p: Params) -> Array:
        return G_l(theta_m / p["n"], p) / p["n"]

    if V_l is None:
        return M, C, G, None
    potential_l = V_l

    def V(theta_m: Array, p: Params) -> Array:
        return potential_l(theta_m / p["n"], p)

    return M, C, G, V


def from_motor_coordinates(M_m: Fn, C_m: Fn, G_m: Fn, V_m: Fn | None) -> tuple[Fn, Fn, Fn, Fn | None]:
    """Motor-coordinate functions -> link-coordinate ones: M_l = n^2 M_m, C_l = n^2 C_m, G_l = n G_m."""

    def M(q: Array, p: Params) -> Array:
        return p["n"] ** 2 * M_m(p["n"] * q, p)

    def C(q: Array, v: Array, p: Params) -> Array:
        return p["n"] ** 2 * C_m(p["n"] * q, p["n"] * v, p)

    def G(q: Array, p: Params) -> Array:
        return p["n"] * G_m(p["n"] * q, p)

    if V_m is None:
        return M, C, G, None
    potential_m = V_m

    def V(q: Array, p: Params) -> Array:
        return potential_m(p["n"] * q, p)

    return M, C, G, V


mass_matrix_motor, coriolis_matrix_motor, gravity_motor, potential_energy_motor = to_motor_coordinates(
    FORMULA.mass_matrix, FORMULA.coriolis_matrix, FORMULA.gravity, FORMULA.potential_energy
)
