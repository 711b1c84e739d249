"""Drake's reading of a URDF: ``pydrake.multibody.parsing.Parser`` on a continuous ``MultibodyPlant``.

The root link is welded to the world (fixed base); a root link named ``world`` is Drake's world body already.
Drake keeps links welded by fixed joints as bodies of their own; they are summed here into the moving body they hang
from. Drake reads rotor inertia from ``<drake:rotor_inertia>`` and ``<drake:gear_ratio>`` in a ``<transmission>``,
not from an SRDF. Drake has no option that changes how it reads inertia, so its trusted reading is its default one.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.errors import EngineRefusedError
from robodyn.other_engines.floating import FREE_FLYER, drake_base, to_pinocchio
from robodyn.other_engines.reading import (
    Array,
    BodyInertia,
    EngineReading,
    JointReading,
    WorldBody,
    engine_version,
    group_inertia,
    portable_copy,
    require,
)


def read(
    urdf: Path, package_dirs: Sequence[Path], reading: str, *, root_link: str, free_flyer: bool = False
) -> EngineReading:
    """Load ``urdf`` into a ``MultibodyPlant`` with ``root_link`` welded to the world, or floating (``free_flyer``).

    A floating root link is Drake's default: ``Finalize`` gives it a ``quaternion_floating`` joint.
    """
    require("pydrake", "drake")
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(0.0)
    with portable_copy(urdf, package_dirs) as path, _warnings_unsaid(path, urdf):
        try:
            Parser(plant).AddModels(path)
            if not free_flyer and root_link != "world":  # Drake's Parser welds a root link named world itself
                plant.WeldFrames(plant.world_frame(), plant.GetBodyByName(root_link).body_frame())
            plant.Finalize()
        except (RuntimeError, ValueError) as exc:
            said = _unlocated(" ".join(str(exc).split()), path, "")
            raise EngineRefusedError(f"drake refuses {urdf.name}: {said}") from None
    context = plant.CreateDefaultContext()
    joints = [plant.get_joint(i) for i in plant.GetJointIndices()]
    moving = [j for j in joints if j.num_velocities() == 1]
    free = [j for j in joints if j.num_velocities() == 6 and j.child_body().name() == root_link]
    if free_flyer and root_link == "world":
        raise EngineRefusedError(
            f"drake refuses to float {urdf.name}: it takes the root link named world as its world body, the robot "
            "is welded to it"
        )
    if free_flyer and (len(free) != 1 or free[0].type_name() != "quaternion_floating"):
        kinds = ", ".join(j.type_name() for j in free) or "none"
        raise EngineRefusedError(f"drake gives {root_link} no quaternion_floating joint (it has: {kinds})")
    return EngineReading(
        engine="drake",
        version=engine_version("drake"),
        reading=reading,
        option="Parser defaults; Drake has no option that changes how it reads inertia",
        names=tuple(j.name() for j in moving),
        bodies=_bodies(plant, context, joints, moving, free),
        joints={j.name(): _joint(plant, j) for j in moving},
        evaluate=_evaluator(plant, context, moving, free[0] if free_flyer else None),
    )


def _bodies(plant: Any, context: Any, joints: list[Any], moving: list[Any], free: list[Any]) -> dict[str, BodyInertia]:
    """Per moving joint (a floating base as Pinocchio's root_joint), its body and those welded below it."""
    inbound = {int(j.child_body().index()): j for j in joints}
    owner = {int(j.child_body().index()): j.name() for j in moving}
    owner |= {int(j.child_body().index()): FREE_FLYER for j in free}
    parts: dict[str, list[WorldBody]] = {name: [] for name in owner.values()}
    frames = {}
    for b in range(1, plant.num_bodies()):
        body = _body(plant, b)
        pose = plant.EvalBodyPoseInWorld(context, body)
        R, p = pose.rotation().matrix(), pose.translation()
        frames[b] = (R, p)
        a = b
        while a not in owner and a in inbound:
            a = int(inbound[a].parent_body().index())
        if a not in owner:
            continue  # welded to the world
        spatial = body.default_spatial_inertia()
        mass, com = float(spatial.get_mass()), np.array(spatial.get_com())
        about_origin = spatial.CalcRotationalInertia().CopyToFullMatrix3()
        about_com = about_origin - mass * (com @ com * np.eye(3) - np.outer(com, com))
        parts[owner[a]].append(WorldBody(body.name(), mass, R @ com + p, R @ about_com @ R.T))
    return {name: group_inertia(parts[name], *frames[b]) for b, name in owner.items()}


@contextmanager
def _warnings_unsaid(copy: Path, urdf: Path) -> Iterator[None]:
    """Hide Drake's warnings about tags it ignores (``safety_controller``...) and the joint friction it drops.

    The report names a dropped friction as a cause; Drake's other warnings (an inertia it replaces) still show,
    naming ``urdf`` where Drake names the temporary ``copy`` it parsed.
    """
    import logging

    unsaid = ("is currently unsupported and will be ignored", "does not currently support non-zero joint friction")

    def said(record: logging.LogRecord) -> bool:
        text = record.getMessage()
        record.msg, record.args = _unlocated(text, copy, f"{urdf.name}: "), ()
        return not any(words in text for words in unsaid)

    logger = logging.getLogger("drake")
    logger.addFilter(said)
    try:
        yield
    finally:
        logger.removeFilter(said)


def _unlocated(text: str, copy: Path, name: str) -> str:
    """``text`` with the temporary copy's path and line (neither means anything to the user) replaced by ``name``."""
    return re.sub(re.escape(str(copy)) + r"(:\d+)*: ", name, text)


def _body(plant: Any, b: int) -> Any:
    from pydrake.multibody.tree import BodyIndex

    return plant.get_body(BodyIndex(b))


def _joint(plant: Any, joint: Any) -> JointReading:
    axis = joint.revolute_axis() if joint.type_name() == "revolute" else joint.translation_axis()
    lower, upper = float(joint.position_lower_limits()[0]), float(joint.position_upper_limits()[0])
    armature, effort = 0.0, None  # no actuator (no <transmission>): Drake holds no effort limit
    for i in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(i)
        if actuator.joint().name() == joint.name():
            armature = float(actuator.default_reflected_inertia())
            limit = float(actuator.effort_limit())
            effort = limit if np.isfinite(limit) else np.nan
    speed = float(joint.velocity_upper_limits()[0])
    return JointReading(
        np.array(axis, dtype=float),
        lower if np.isfinite(lower) else np.nan,
        upper if np.isfinite(upper) else np.nan,
        float(joint.default_damping()),
        armature,
        effort=effort,
        velocity=speed if np.isfinite(speed) else np.nan,
        friction=0.0,  # MultibodyPlant has no joint friction (its parser warns and drops <dynamics friction>)
    )


def _evaluator(plant: Any, context: Any, moving: list[Any], free: Any) -> Any:
    """M, C v, G at (q, v); with a floating base, q and v begin with the base's in Pinocchio's convention."""
    qadr = [j.position_start() for j in moving]
    vadr = [j.velocity_start() for j in moving]
    if free is not None:  # the quaternion_floating joint's 7 positions and 6 velocities first
        qadr = [free.position_start() + i for i in range(7)] + qadr
        vadr = [free.velocity_start() + i for i in range(6)] + vadr

    def evaluate(q: Array, v: Array) -> tuple[Array, Array, Array]:
        u = v
        if free is not None:
            base_q, base_u, T, drift = drake_base(q[:7], v[:6])
            q, u = np.concatenate([base_q, q[7:]]), np.concatenate([base_u, v[6:]])
        positions = np.zeros(plant.num_positions())
        velocities = np.zeros(plant.num_velocities())
        positions[qadr], velocities[vadr] = q, u
        plant.SetPositions(context, positions)
        plant.SetVelocities(context, velocities)
        M = plant.CalcMassMatrix(context)[np.ix_(vadr, vadr)]
        Cv = plant.CalcBiasTerm(context)[vadr]
        G = -plant.CalcGravityGeneralizedForces(context)[vadr]
        return to_pinocchio(M, Cv, G, T, drift) if free is not None else (M, Cv, G)

    return evaluate
