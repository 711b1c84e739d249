"""robodyn's per-link table: what a hand derivation of a tree robot needs, one row per moving joint.

A formula file with ``KIND = "any"`` may define ``parameters(robot) -> dict``; ``robot`` is then
the :class:`LinkTable` of the model the formula describes (the joints it names moving, every other
joint locked and its bodies welded to their parent). Each :class:`Link` is the body one moving
joint carries, everything welded to it included, written in that joint's own frame (the URDF
joint frame, which is the child link's frame):

* ``mass`` [kg], ``com`` (3,) the centre of mass [m] and ``inertia`` (3, 3) the inertia about the
  centre of mass [kg m^2], both in the joint frame;
* ``origin`` (3,) [m] and ``rotation`` (3, 3): where the joint frame sits in its parent joint's
  frame (the base frame for a joint on the base), as the URDF ``<origin xyz rpy>`` of the joint
  composes with the fixed joints between; ``rpy`` (3,) [rad] the same rotation as roll-pitch-yaw;
* ``axis`` (3,): the unit joint axis in the joint frame; ``joint_type`` ``"revolute"``,
  ``"continuous"`` or ``"prismatic"``; ``parent`` the parent link's joint (None on the base);
* ``armature`` [kg m^2 | kg]: rotor inertia reflected onto the joint (added to M's diagonal).

``LinkTable.gravity`` (3,) [m/s^2] is gravity in the base frame, ``LinkTable.g`` its magnitude.
Links are in model order (parents before children): ``robot.links[0]`` or ``robot["shoulder"]``.

The table is plain numbers, so it travels to a formula file's own process
(:mod:`robodyn.checker.sandbox`) as JSON (:meth:`LinkTable.as_dict`, :meth:`LinkTable.from_dict`).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import InputError

Array = NDArray[np.float64]

# Pinocchio joint types (shortname) -> the URDF type a link table names. Continuous joints are
# the unbounded revolutes (nq = 2: cos, sin).
JOINT_TYPES = {
    "JointModelRX": "revolute",
    "JointModelRY": "revolute",
    "JointModelRZ": "revolute",
    "JointModelRevoluteUnaligned": "revolute",
    "JointModelRUBX": "continuous",
    "JointModelRUBY": "continuous",
    "JointModelRUBZ": "continuous",
    "JointModelRevoluteUnboundedUnaligned": "continuous",
    "JointModelPX": "prismatic",
    "JointModelPY": "prismatic",
    "JointModelPZ": "prismatic",
    "JointModelPrismaticUnaligned": "prismatic",
}


def _frozen(values: Any, shape: tuple[int, ...]) -> Array:
    out = np.array(values, dtype=np.float64).reshape(shape)
    out.flags.writeable = False
    return out


@dataclass(frozen=True)
class Link:
    """The body one moving joint carries, in that joint's frame (SI units; see the module docstring)."""

    joint: str
    joint_type: str  # "revolute", "continuous" or "prismatic"
    parent: str | None  # the joint of the parent link; None: the link hangs on the base
    mass: float  # [kg]
    com: Array  # (3,) centre of mass in the joint frame [m]
    inertia: Array  # (3, 3) about the centre of mass, joint-frame axes [kg m^2]
    origin: Array  # (3,) joint origin in the parent joint's frame [m]
    rotation: Array  # (3, 3) joint-frame axes in the parent joint's frame
    axis: Array  # (3,) unit joint axis in the joint frame
    armature: float = 0.0  # [kg m^2 | kg]

    def __post_init__(self) -> None:
        for name, shape in (("com", (3,)), ("inertia", (3, 3)), ("origin", (3,)), ("rotation", (3, 3)), ("axis", (3,))):
            object.__setattr__(self, name, _frozen(getattr(self, name), shape))
        if self.joint_type not in ("revolute", "continuous", "prismatic"):
            raise ValueError(f"joint_type must be revolute, continuous or prismatic, got {self.joint_type!r}")

    @property
    def rpy(self) -> Array:
        """``rotation`` as URDF roll, pitch, yaw [rad] (R = Rz(yaw) Ry(pitch) Rx(roll))."""
        R = self.rotation
        pitch = float(np.arctan2(-R[2, 0], np.hypot(R[0, 0], R[1, 0])))
        if np.hypot(R[0, 0], R[1, 0]) < 1e-12:  # gimbal lock: put the whole turn in roll
            return np.array([float(np.arctan2(-R[1, 2], R[1, 1])), pitch, 0.0]) + 0.0
        return np.array([float(np.arctan2(R[2, 1], R[2, 2])), pitch, float(np.arctan2(R[1, 0], R[0, 0]))]) + 0.0

    @property
    def inertia_about_axis(self) -> float:
        """Moment of inertia about the joint axis through the centre of mass [kg m^2]: a^T I a."""
        return float(self.axis @ self.inertia @ self.axis)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: every field, arrays as (nested) lists."""
        return {
            "joint": self.joint,
            "joint_type": self.joint_type,
            "parent": self.parent,
            "mass": self.mass,
            "com": self.com.tolist(),
            "inertia": self.inertia.tolist(),
            "origin": self.origin.tolist(),
            "rotation": self.rotation.tolist(),
            "axis": self.axis.tolist(),
            "armature": self.armature,
        }


@dataclass(frozen=True)
class LinkTable(Mapping[str, Link]):
    """Every moving joint's :class:`Link`, in model order, and gravity; a mapping joint name -> Link."""

    name: str  # the robot's name
    links: tuple[Link, ...]
    gravity: Array = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))  # (3,) base frame [m/s^2]

    def __post_init__(self) -> None:
        object.__setattr__(self, "links", tuple(self.links))
        object.__setattr__(self, "gravity", _frozen(self.gravity, (3,)))

    @property
    def g(self) -> float:
        """|gravity| [m/s^2]."""
        return float(np.linalg.norm(self.gravity))

    @property
    def joints(self) -> tuple[str, ...]:
        """The moving joints, in model order."""
        return tuple(link.joint for link in self.links)

    def __getitem__(self, joint: str) -> Link:
        for link in self.links:
            if link.joint == joint:
                return link
        raise KeyError(f"{joint!r} is not a moving joint of {self.name}; the joints are {', '.join(self.joints)}")

    def __iter__(self) -> Iterator[str]:
        return iter(self.joints)

    def __len__(self) -> int:
        return len(self.links)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: name, gravity and the links."""
        return {"name": self.name, "gravity": self.gravity.tolist(), "links": [link.as_dict() for link in self.links]}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> LinkTable:
        """The inverse of :meth:`as_dict`."""
        return cls(str(data["name"]), tuple(Link(**link) for link in data["links"]), np.array(data["gravity"]))


def _axis(joint_model: Any, q: Array, prismatic: bool) -> Array:
    """The unit axis of a 1-DoF joint in its own frame: its motion subspace S (linear; angular), at ``q``."""
    data = joint_model.createData()
    joint_model.calc(data, q)
    S = np.array(data.S, dtype=np.float64).reshape(6)
    return S[:3] if prismatic else S[3:]


def link_table(robot: Any) -> LinkTable:
    """The per-link table of a :class:`robodyn.Robot` (lock joints first, :func:`robodyn.model.reduce.reduce`).

    Reads the Pinocchio model's numbers only (no dynamics is computed), so this module never loads
    Pinocchio itself and a formula's process can rebuild a table (:meth:`LinkTable.from_dict`).

    Raises:
        InputError: a moving joint is not revolute, continuous or prismatic (a free flyer, a
            spherical or planar joint, a mimic joint): the table has no row for it.
    """
    model = robot.model
    neutral = robot.neutral()
    links = []
    for j, info in enumerate(robot.joints, start=1):
        joint_type = JOINT_TYPES.get(info.kind)
        if joint_type is None:
            raise InputError(
                f"{robot.name}: joint {info.name!r} is a {info.kind}; the link table covers revolute, continuous "
                "and prismatic joints (lock the others)"
            )
        inertia = model.inertias[j]
        parent = int(model.parents[j])
        links.append(
            Link(
                joint=info.name,
                joint_type=joint_type,
                parent=robot.joints[parent - 1].name if parent > 0 else None,
                mass=float(inertia.mass),
                com=np.array(inertia.lever),
                inertia=np.array(inertia.inertia),
                origin=np.array(model.jointPlacements[j].translation),
                rotation=np.array(model.jointPlacements[j].rotation),
                axis=_axis(model.joints[j], neutral, joint_type == "prismatic"),
                armature=float(model.armature[info.idx_v]),
            )
        )
    return LinkTable(robot.name, tuple(links), np.array(model.gravity.linear))
