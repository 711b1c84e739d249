"""Example 19.3's reduced Lagrangian in the independent coordinate theta (joint_a), as a user formula file.

    M(theta) = I_ab + I_bc + (m_ab + m_bc) l^2 / 4 + 2 (m_bc + 2 m_c) l^2 sin^2(theta)
             = 2/3 m l^2 + 2 (m + 2 m_C) l^2 sin^2(theta)          (the book's slender bars)
    C(theta, omega) = 1/2 dM/dtheta omega = 2 (m_bc + 2 m_c) l^2 sin(theta) cos(theta) omega
    G(theta) = dV/dtheta = -g l (m_ab / 2 + 3 m_bc / 2 + 2 m_c) sin(theta) + k (theta - rest)

so that M theta'' + C theta' + G = tau_A on the loop. The formulas are closed_form.py's (written
once); this file puts them in the format of ``robodyn check --formula``:

    robodyn check examples/textbook/linkage/linkage.toml --formula examples/textbook/linkage/reduced_formula.py

(linkage.toml names this file in [check] formula, so ``robodyn run`` checks it too.) The
contract of a constrained formula (robodyn.checker.constrained_kind):

* ``KIND = "constrained"``; ``INDEPENDENT`` names the URDF joints of the formula's coordinates;
* ``parameters(scene)`` -> {name: number}: here the URDF's masses and lengths and the scene's spring;
* ``mass_matrix(q, p)``, ``coriolis_matrix(q, v, p)``, ``gravity(q, p)`` (springs included) and
  ``potential_energy(q, p)`` in the independent coordinates (q, v are (1,) arrays here);
* ``on_the_loop(q, v, p)`` -> ({joint: q}, {joint: v}): every joint's state on the loop.

The checker samples theta within joint_a's URDF limits, maps each sample onto the loop with
``on_the_loop`` and compares against Pinocchio's constrained dynamics there (S^T M S, the
reduced bias, S^T (G + spring), constraintDynamics' acceleration, V).
"""

import importlib.util
from pathlib import Path

import numpy as np

KIND = "constrained"
INDEPENDENT = ("joint_a",)

_spec = importlib.util.spec_from_file_location("linkage_closed_form", Path(__file__).with_name("closed_form.py"))
_closed_form = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_closed_form)

parameters = _closed_form.parameters


def mass_matrix(q, p):
    return np.array([[_closed_form.reduced_mass(q[0], p)]])


def coriolis_matrix(q, v, p):
    return np.array([[0.5 * _closed_form.reduced_mass_slope(q[0], p) * v[0]]])


def gravity(q, p):
    return np.array([_closed_form.generalized_gravity(q[0], p)])


def potential_energy(q, p):
    return float(_closed_form.potential_energy(q[0], p))


def on_the_loop(q, v, p):
    """The full state ({joint: q}, {joint: v}) on the loop for the independent (theta,), (omega,)."""
    return _closed_form.on_the_loop(q[0], v[0], p)
