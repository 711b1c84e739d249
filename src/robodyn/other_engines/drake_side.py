"""Drake's reading of a URDF: ``pydrake.multibody.parsing.Parser`` on a continuous ``MultibodyPlant``.

The root link is welded to the world (fixed base). Drake keeps links welded by fixed joints as bodies of
their own; they are summed here into the moving body they hang from. Drake reads rotor inertia from
``<drake:rotor_inertia>`` and ``<drake:gear_ratio>`` in a ``<transmission>``, not from an SRDF. Drake has
no option that changes how it reads inertia, so its trusted reading is its default one.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.errors import EngineRefusedError
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


def read(urdf: Path, package_dirs: Sequence[Path], reading: str, *, root_link: str) -> EngineReading:
    """Load ``urdf`` into a ``MultibodyPlant`` with ``root_link`` welded to the world."""
    require("pydrake", "drake")
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(0.0)
    with portable_copy(urdf, package_dirs) as path, _unsupported_tags_unsaid():
        try:
            Parser(plant).AddModels(path)
            plant.WeldFrames(plant.world_frame(), plant.GetBodyByName(root_link).body_frame())
            plant.Finalize()
        except (RuntimeError, ValueError) as exc:
            raise EngineRefusedError(f"drake refuses {urdf.name}: {' '.join(str(exc).split())}") from None
    context = plant.CreateDefaultContext()
    joints = [plant.get_joint(i) for i in plant.GetJointIndices()]
    moving = [j for j in joints if j.num_velocities() == 1]
    return EngineReading(
        engine="drake",
        version=engine_version("drake"),
        reading=reading,
        option="Parser defaults; Drake has no option that changes how it reads inertia",
        names=tuple(j.name() for j in moving),
        bodies=_bodies(plant, context, joints, moving),
        joints={j.name(): _joint(plant, j) for j in moving},
        evaluate=_evaluator(plant, context, moving),
    )


def _bodies(plant: Any, context: Any, joints: list[Any], moving: list[Any]) -> dict[str, BodyInertia]:
    inbound = {int(j.child_body().index()): j for j in joints}
    owner = {int(j.child_body().index()): j.name() for j in moving}
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
def _unsupported_tags_unsaid() -> Iterator[None]:
    """Hide Drake's warnings about tags it ignores (``safety_controller``...); its other warnings still show."""
    import logging

    def said(record: logging.LogRecord) -> bool:
        return "is currently unsupported and will be ignored" not in record.getMessage()

    logger = logging.getLogger("drake")
    logger.addFilter(said)
    try:
        yield
    finally:
        logger.removeFilter(said)


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


def _evaluator(plant: Any, context: Any, moving: list[Any]) -> Any:
    qadr = np.array([j.position_start() for j in moving])
    vadr = np.array([j.velocity_start() for j in moving])

    def evaluate(q: Array, v: Array) -> tuple[Array, Array, Array]:
        positions = np.zeros(plant.num_positions())
        velocities = np.zeros(plant.num_velocities())
        positions[qadr], velocities[vadr] = q, v
        plant.SetPositions(context, positions)
        plant.SetVelocities(context, velocities)
        M = plant.CalcMassMatrix(context)[np.ix_(vadr, vadr)]
        Cv = plant.CalcBiasTerm(context)[vadr]
        G = -plant.CalcGravityGeneralizedForces(context)[vadr]
        return M, Cv, G

    return evaluate
