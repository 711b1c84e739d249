"""A robot with its per-link values changed by given factors: the parameter sets ``check --explain`` compares at.

``--explain`` (:mod:`robodyn.checker.explain`) names a wrong term by a product of the formula's
parameters that equals its coefficient at several parameter sets, not at one: the model's per-link
values are varied and the formula's parameters with them. :func:`varied` builds one such model.
Each per-link value is a :data:`Quantity` ``(joint index, field, component)``:

* ``("mass", 0)`` the body's mass [kg];
* ``("com", i)`` component i of its centre of mass in the joint frame [m];
* ``("origin", i)`` component i of the joint's origin in its parent's frame [m];
* ``("inertia", 0)`` its rotational inertia about the centre of mass [kg m^2], varied as a body
  whose mass distribution is stretched along the joint frame's axes by three factors (the second
  moments Sigma = tr(I)/2 - I become D Sigma D, so the inertia stays physical);
* ``("armature", 0)`` the rotor inertia reflected onto the joint [kg m^2 | kg] (the rotor's own
  inertia with it, the gear ratio kept); ``("gear", 0)`` the rotor's gear ratio n, where the joint has
  a rotor (the armature J_m n^2 with it);

and ``GRAVITY`` scales gravity's vector. A quantity without a factor is kept. Rotations, axes and
joint types are never changed, so every assumption a formula makes of the model still holds.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from robodyn.robot import Robot

Quantity = tuple[int, str, int]  # (joint index in the model, 1-based; field; component)
GRAVITY: Quantity = (0, "gravity", 0)
FIELDS = ("mass", "com", "origin", "inertia", "armature")


def quantities(robot: Robot) -> list[Quantity]:
    """Every per-link value :func:`varied` can change, in model order, then gravity."""
    out: list[Quantity] = []
    for j in range(1, robot.model.njoints):
        out.append((j, "mass", 0))
        out += [(j, "com", i) for i in range(3)]
        out += [(j, "origin", i) for i in range(3)]
        out += [(j, "inertia", i) for i in range(3)]
        out.append((j, "armature", 0))
        out.append((j, "gear", 0))
    out.append(GRAVITY)
    return out


def varied(robot: Robot, factors: Mapping[Quantity, float]) -> Robot:
    """A copy of ``robot`` with each quantity of ``factors`` multiplied by its factor (> 0); ``robot`` is untouched."""
    model = pin.Model(robot.model)
    for j in range(1, model.njoints):
        inertia = model.inertias[j]
        mass = float(inertia.mass) * factors.get((j, "mass", 0), 1.0)
        lever = np.array(inertia.lever) * [factors.get((j, "com", i), 1.0) for i in range(3)]
        rotational = np.array(inertia.inertia)
        stretch = np.array([factors.get((j, "inertia", i), 1.0) for i in range(3)])
        if np.any(stretch != 1.0):
            second = 0.5 * np.trace(rotational) * np.eye(3) - rotational  # sum m r r^T about the centre of mass
            second = stretch[:, None] * second * stretch[None, :]
            rotational = np.trace(second) * np.eye(3) - second
        model.inertias[j] = pin.Inertia(mass, lever, rotational)
        placement = model.jointPlacements[j]
        origin = np.array(placement.translation) * [factors.get((j, "origin", i), 1.0) for i in range(3)]
        model.jointPlacements[j] = pin.SE3(np.array(placement.rotation), origin)
        armature, gear = factors.get((j, "armature", 0), 1.0), factors.get((j, "gear", 0), 1.0)
        joint = model.joints[j]
        rotor = np.zeros(model.nv, dtype=bool)
        rotor[joint.idx_v : joint.idx_v + joint.nv] = True
        if armature != 1.0:  # the rotor's inertia, and the armature J_m n^2 with it
            model.armature = np.where(rotor, np.array(model.armature) * armature, model.armature)
            model.rotorInertia = np.where(rotor, np.array(model.rotorInertia) * armature, model.rotorInertia)
        has_rotor = rotor & (np.array(model.rotorInertia) != 0)
        if gear != 1.0 and has_rotor.any():  # the gear ratio n, and the armature J_m n^2 with it
            model.rotorGearRatio = np.where(has_rotor, np.array(model.rotorGearRatio) * gear, model.rotorGearRatio)
            model.armature = np.where(has_rotor, np.array(model.armature) * gear**2, model.armature)
    model.gravity = pin.Motion(np.array(model.gravity.linear) * factors.get(GRAVITY, 1.0), np.zeros(3))
    passive = tuple(j.name for j in robot.joints if not j.actuated)
    return Robot.from_model(
        model, name=robot.name, urdf_path=robot.urdf_path, srdf_path=robot.srdf_path, passive_joints=passive
    )
