"""MuJoCo's reading of a URDF: ``mujoco.MjModel.from_xml_path`` with its URDF compiler defaults, or trusting the file.

MuJoCo's URDF compiler fuses links welded by fixed joints into their parent (``fusestatic``), computes the
inertia of a link without ``<inertial>`` from its geometry (``inertiafromgeom="auto"``) and can balance
inertias that break the triangle inequality (``balanceinertia``). The trusted reading adds
``<mujoco><compiler fusestatic="false" balanceinertia="false" inertiafromgeom="false"/></mujoco>``
to a temporary copy of the file. Both copies set ``strippath="false"`` and give mesh files as absolute
paths, so that MuJoCo finds the meshes Pinocchio finds (no physical quantity changes).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.errors import EngineRefusedError
from robodyn.other_engines.floating import FREE_FLYER, mujoco_base, to_pinocchio
from robodyn.other_engines.reading import (
    DEFAULT,
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

TRUST = {"fusestatic": "false", "balanceinertia": "false", "inertiafromgeom": "false"}
TRUST_OPTION = '<mujoco><compiler fusestatic="false" balanceinertia="false" inertiafromgeom="false"/></mujoco>'


def read(urdf: Path, package_dirs: Sequence[Path], reading: str, *, free_flyer: bool = False) -> EngineReading:
    """Load ``urdf`` into MuJoCo with its defaults (``reading="default"``) or trusting the file.

    Fixed base, as MuJoCo's URDF compiler mounts the root link; with ``free_flyer`` the root body gets a
    ``<freejoint name="root_joint">``, as a MuJoCo user adds one to the model the compiler makes.
    """
    require("mujoco", "mujoco")
    import mujoco

    compiler = ET.Element("compiler", {"strippath": "false", **({} if reading == DEFAULT else TRUST)})
    extension = ET.Element("mujoco")
    extension.append(compiler)
    with portable_copy(urdf, package_dirs, extension) as path:
        try:
            spec = mujoco.MjSpec.from_file(str(path))
            if free_flyer:
                spec.worldbody.first_body().add_freejoint(name=FREE_FLYER)
            model = spec.compile()
        except ValueError as exc:
            said = " ".join(str(exc).split())
            raise EngineRefusedError(f"mujoco {mujoco.__version__} refuses {urdf.name}: {said}") from None
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    joints = [
        j
        for j in range(model.njnt)
        if int(model.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
    ]
    free = [j for j in range(model.njnt) if int(model.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE)]
    names = tuple(model.joint(j).name for j in joints)
    return EngineReading(
        engine="mujoco",
        version=engine_version("mujoco"),
        reading=reading,
        option="compiler defaults" if reading == DEFAULT else TRUST_OPTION,
        names=names,
        bodies=_bodies(model, data, free + joints, free[0] if free else None),
        joints={model.joint(j).name: _joint(model, j) for j in joints},
        evaluate=_evaluator(model, data, joints, free[0] if free else None),
    )


def _bodies(model: Any, data: Any, joints: list[int], free: int | None) -> dict[str, BodyInertia]:
    """Per moving joint (the free joint among them), its body and the bodies welded below it, in its frame."""
    owner = {int(model.jnt_bodyid[j]): model.joint(j).name for j in joints}
    parts: dict[str, list[WorldBody]] = {name: [] for name in owner.values()}
    for b in range(1, model.nbody):
        a = b
        while a not in owner and a != 0:
            a = int(model.body_parentid[a])
        if a == 0:
            continue  # welded to the world
        R = data.ximat[b].reshape(3, 3)
        parts[owner[a]].append(
            WorldBody(
                model.body(b).name,
                float(model.body_mass[b]),
                data.xipos[b].copy(),
                R @ np.diag(model.body_inertia[b]) @ R.T,
            )
        )
    # At qpos0 the free body sits at its placement in the root link's frame, which is the world's: the free flyer's
    # body is expressed in the world's axes, as Pinocchio holds it in the root link's.
    base = int(model.jnt_bodyid[free]) if free is not None else -1
    return {
        name: group_inertia(parts[name], np.eye(3), np.zeros(3))
        if b == base
        else group_inertia(parts[name], data.xmat[b].reshape(3, 3).copy(), data.xpos[b].copy())
        for b, name in owner.items()
    }


def _joint(model: Any, j: int) -> JointReading:
    limited = bool(model.jnt_limited[j])
    lower, upper = (float(x) for x in model.jnt_range[j]) if limited else (np.nan, np.nan)
    dof = int(model.jnt_dofadr[j])
    effort = float(model.jnt_actfrcrange[j][1]) if bool(model.jnt_actfrclimited[j]) else np.nan
    return JointReading(
        model.jnt_axis[j].copy(),
        lower,
        upper,
        float(model.dof_damping[dof]),
        float(model.dof_armature[dof]),
        effort=effort,  # <limit effort> becomes the joint's actuatorfrcrange
        velocity=None,  # MuJoCo holds no velocity limit
        friction=float(model.dof_frictionloss[dof]),
    )


def _evaluator(model: Any, data: Any, joints: list[int], free: int | None) -> Any:
    """M, C v, G at (q, v); with a free joint, q and v begin with the base's in Pinocchio's convention."""
    import mujoco

    qadr = [int(model.jnt_qposadr[j]) for j in joints]
    vadr = [int(model.jnt_dofadr[j]) for j in joints]
    offset = None
    if free is not None:  # the freejoint's 7 qpos and 6 qvel first
        qadr = [int(model.jnt_qposadr[free]) + i for i in range(7)] + qadr
        vadr = [int(model.jnt_dofadr[free]) + i for i in range(6)] + vadr
        # the free body's placement in the root link's frame: its pose at qpos0 (MuJoCo data at qpos0)
        body = int(model.jnt_bodyid[free])
        offset = (data.xmat[body].reshape(3, 3).copy(), data.xpos[body].copy(), data.xquat[body].copy())

    def evaluate(q: Array, v: Array) -> tuple[Array, Array, Array]:
        u = v
        if free is not None:
            base_q, base_u, T, drift = mujoco_base(q[:7], v[:6], offset)
            q, u = np.concatenate([base_q, q[7:]]), np.concatenate([base_u, v[6:]])
        data.qpos[:] = model.qpos0
        data.qpos[qadr] = q
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        G = data.qfrc_bias[vadr].copy()
        full = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, full)
        data.qvel[vadr] = u
        mujoco.mj_forward(model, data)
        M, Cv = full[np.ix_(vadr, vadr)], data.qfrc_bias[vadr] - G
        return to_pinocchio(M, Cv, G, T, drift) if free is not None else (M, Cv, G)

    return evaluate
