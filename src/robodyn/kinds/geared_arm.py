"""One link driven by a DC motor through an n:1 gear train.

The motor shaft turns n times per turn of the link: theta_m = n theta_l. With J_m the
rotor's inertia and J_l the link's inertia about the joint axis,

    T = 1/2 J_m theta_m'^2 + 1/2 J_l theta_l'^2 = 1/2 (J_m + J_l / n^2) theta_m'^2
    V = M g l (1 - cos theta_l)

Motor coordinate (the seed's):  (J_m + J_l / n^2) theta_m'' + (M g l / n) sin(theta_m / n) = tau_m
Link coordinate (Pinocchio's):  (J_l + n^2 J_m) theta_l'' + M g l sin theta_l = tau_l

The two are one equation: theta_l = theta_m / n, tau_l = n tau_m (ideal gears), so
M_l = n^2 M_m, C_l = n^2 C_m, G_l = n G_m. n^2 J_m is the reflected rotor inertia that
Pinocchio calls armature. C = 0: M is constant.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robodyn.kinds.formulas import Array, Formula, Params

PARAMS = ("J_m", "J_l", "n", "M", "l", "g")


def mass_matrix(q: Array, p: Params) -> Array:
    """M [kg m^2] in the link coordinate, (1, 1)."""
    return np.array([[p["J_l"] + p["n"] ** 2 * p["J_m"]]])


def coriolis_matrix(q: Array, v: Array, p: Params) -> Array:
    """C = 0 (constant inertia), (1, 1)."""
    return np.zeros((1, 1))


def gravity(q: Array, p: Params) -> Array:
    """G [N m] in the link coordinate, (1,)."""
    return np.array([p["M"] * p["g"] * p["l"] * np.sin(q[0])])


def potential_energy(q: Array, p: Params) -> float:
    """V [J], zero hanging straight down."""
    return float(p["M"] * p["g"] * p["l"] * (1.0 - np.cos(q[0])))


# ------------------------------------------------------------------ motor coordinate
def mass_matrix_motor(theta_m: Array, p: Params) -> Array:
    """M_m = J_m + J_l / n^2 [kg m^2] in the motor coordinate, (1, 1)."""
    return np.array([[p["J_m"] + p["J_l"] / p["n"] ** 2]])


def coriolis_matrix_motor(theta_m: Array, omega_m: Array, p: Params) -> Array:
    """C_m = 0, (1, 1)."""
    return np.zeros((1, 1))


def gravity_motor(theta_m: Array, p: Params) -> Array:
    """G_m = (M g l / n) sin(theta_m / n) [N m] at the motor shaft, (1,)."""
    return np.array([p["M"] * p["g"] * p["l"] / p["n"] * np.sin(theta_m[0] / p["n"])])


def potential_energy_motor(theta_m: Array, p: Params) -> float:
    """V [J] as a function of the motor angle."""
    return float(p["M"] * p["g"] * p["l"] * (1.0 - np.cos(theta_m[0] / p["n"])))


def link_to_motor(q: Array, v: Array, p: Params) -> tuple[Array, Array]:
    """(theta_l, theta_l') -> (theta_m, theta_m') = n (theta_l, theta_l')."""
    return p["n"] * np.asarray(q), p["n"] * np.asarray(v)


def from_motor_coordinates(
    M_m: Callable[..., Array],
    C_m: Callable[..., Array],
    G_m: Callable[..., Array],
    V_m: Callable[..., Array] | None,
) -> tuple[Callable[..., Array], Callable[..., Array], Callable[..., Array], Callable[..., Array] | None]:
    """Turn motor-coordinate functions into link-coordinate ones (M n^2, C n^2, G n, V)."""

    def M(q: Array, p: Params) -> Array:
        return p["n"] ** 2 * M_m(p["n"] * q, p)

    def C(q: Array, v: Array, p: Params) -> Array:
        return p["n"] ** 2 * C_m(p["n"] * q, p["n"] * v, p)

    def G(q: Array, p: Params) -> Array:
        return p["n"] * G_m(p["n"] * q, p)

    if V_m is None:
        return M, C, G, None
    potential = V_m

    def V(q: Array, p: Params) -> Array:
        return potential(p["n"] * q, p)

    return M, C, G, V


FORMULA = Formula(
    "geared_arm", "robodyn.kinds.geared_arm", PARAMS, mass_matrix, coriolis_matrix, gravity, potential_energy, 1
)
