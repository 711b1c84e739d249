"""PyBullet's reading of a URDF: ``loadURDF`` in a DIRECT client, fixed base, default flags or trusting the file.

With its default flags PyBullet recomputes each link's inertia from its collision shape and gives a link
without ``<inertial>`` a mass of 1 kg; ``flags=URDF_USE_INERTIA_FROM_FILE`` (the trusted reading) keeps the
file's inertia. PyBullet keeps links welded by fixed joints as links of their own; they are summed here into
the moving link they hang from, as Pinocchio merges them. Gravity is set to Pinocchio's 9.81 m/s^2.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.errors import EngineRefusedError
from robodyn.other_engines.reading import (
    DEFAULT,
    Array,
    BodyInertia,
    EngineReading,
    JointReading,
    WorldBody,
    engine_version,
    group_inertia,
    joint_origins,
    portable_copy,
    quiet_native_output,
    require,
)

TRUST_OPTION = "flags=URDF_USE_INERTIA_FROM_FILE"
_MOVING = (0, 1)  # JOINT_REVOLUTE, JOINT_PRISMATIC
PYBULLET_GRAVITY = 9.81  # [m/s^2], Pinocchio's default


def _matrix(p: Any, quaternion: Sequence[float]) -> Array:
    return np.array(p.getMatrixFromQuaternion(quaternion)).reshape(3, 3)


def read(urdf: Path, package_dirs: Sequence[Path], reading: str) -> EngineReading:
    """Load ``urdf`` into a fresh DIRECT PyBullet client with its default flags or trusting the file."""
    require("pybullet", "pybullet")
    with quiet_native_output():
        import pybullet as p

        client = p.connect(p.DIRECT)
    flags = 0 if reading == DEFAULT else p.URDF_USE_INERTIA_FROM_FILE
    with portable_copy(urdf, package_dirs) as path:
        try:
            with quiet_native_output():
                body = p.loadURDF(str(path), useFixedBase=True, flags=flags, physicsClientId=client)
        except p.error as exc:
            p.disconnect(client)
            raise EngineRefusedError(f"pybullet refuses {urdf.name}: {' '.join(str(exc).split())}") from None
    p.setGravity(0, 0, -PYBULLET_GRAVITY, physicsClientId=client)
    info = [
        p.getJointInfo(body, i, physicsClientId=client) for i in range(p.getNumJoints(body, physicsClientId=client))
    ]
    moving = [i[0] for i in info if i[2] in _MOVING]
    names = tuple(info[i][1].decode() for i in moving)
    return EngineReading(
        engine="pybullet",
        version=engine_version("pybullet"),
        reading=reading,
        option="default flags" if reading == DEFAULT else TRUST_OPTION,
        names=names,
        bodies=_bodies(p, client, body, info, set(moving), urdf),
        joints={info[i][1].decode(): _joint(p, client, body, info[i]) for i in moving},
        evaluate=_evaluator(p, client, body, moving, len(info)),
    )


def _bodies(p: Any, client: int, body: int, info: list[Any], moving: set[int], urdf: Path) -> dict[str, BodyInertia]:
    """Per moving joint, its link and the links welded below it, in that link's frame.

    Each link's inertial comes from PyBullet (``getDynamicsInfo``: mass, principal moments and the inertial
    frame in the link's frame); the welded links are placed by the file's joint origins, exactly, rather than
    by PyBullet's forward kinematics, which rounds poses to ~1e-8.
    """
    origins = joint_origins(urdf)
    parts: dict[int, list[WorldBody]] = {i: [] for i in moving}
    for i in range(len(info)):
        a, R, t = i, np.eye(3), np.zeros(3)
        while a not in moving and a != -1:
            _, Rj, tj = origins[info[a][12].decode()]
            R, t = Rj @ R, Rj @ t + tj
            a = info[a][16]
        if a == -1:
            continue  # welded to the world
        dyn = p.getDynamicsInfo(body, i, physicsClientId=client)
        Ri = R @ _matrix(p, dyn[4])
        parts[a].append(
            WorldBody(info[i][12].decode(), float(dyn[0]), R @ np.array(dyn[3]) + t, Ri @ np.diag(dyn[2]) @ Ri.T)
        )
    return {info[i][1].decode(): group_inertia(parts[i], np.eye(3), np.zeros(3)) for i in sorted(moving)}


def _joint(p: Any, client: int, body: int, info: Any) -> JointReading:
    """The joint's axis in its link's frame (PyBullet gives it in the link's inertial frame), limits, damping."""
    inertial = _matrix(p, p.getDynamicsInfo(body, info[0], physicsClientId=client)[4])
    lower, upper = float(info[8]), float(info[9])
    effort, velocity = float(info[10]), float(info[11])  # jointMaxForce, jointMaxVelocity
    if lower > upper:  # PyBullet's mark of a joint without limits (a continuous joint)
        lower, upper = np.nan, np.nan
        if effort == velocity == 0.0:  # and no <limit> at all: 0 stands for none
            effort, velocity = np.nan, np.nan
    return JointReading(
        inertial @ np.array(info[13], dtype=float),
        lower,
        upper,
        float(info[6]),
        0.0,
        effort=effort,
        velocity=velocity,
        friction=float(info[7]),
    )


def _evaluator(p: Any, client: int, body: int, moving: list[int], count: int) -> Any:
    def evaluate(q: Array, v: Array) -> tuple[Array, Array, Array]:
        qs, vs, zero = [float(x) for x in q], [float(x) for x in v], [0.0] * len(moving)
        with quiet_native_output():  # its inverse dynamics prints b3Warnings (a non-unit axis) on stdout
            M = np.array(p.calculateMassMatrix(body, qs, physicsClientId=client))
            G = np.array(p.calculateInverseDynamics(body, qs, zero, zero, physicsClientId=client))
            bias = np.array(p.calculateInverseDynamics(body, qs, vs, zero, physicsClientId=client))
        return M, bias - G, G

    weakref.finalize(evaluate, p.disconnect, client)  # the client lives as long as its evaluator
    return evaluate
