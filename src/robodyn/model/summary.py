"""What ``robodyn info`` reports about a robot, as a frozen dataclass of plain values.

:func:`summarize` reads the Pinocchio model (types, sizes, limits, armature, rotor
parameters, damping, masses), the URDF's XML for what Pinocchio does not keep (the joint's
URDF type, its axis, mimic couplings) and the physical-consistency findings of
:mod:`robodyn.model.consistency`. Meshes are looked for only with ``geometry=True``, and never
parsed.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from robodyn.model.consistency import Finding, all_findings
from robodyn.robot import Robot


@dataclass(frozen=True)
class JointSummary:
    """One moving joint.

    Units: limits [rad | m], velocity [rad/s | m/s], effort [N m | N], armature and rotor
    inertia [kg m^2], damping [N m s/rad | N s/m], friction [N m | N].
    """

    name: str
    type: str  # URDF type (revolute, continuous, prismatic, floating, ...)
    pinocchio_type: str
    axis: tuple[float, float, float] | None
    nq: int
    nv: int
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    velocity_limit: tuple[float, ...]
    effort_limit: tuple[float, ...]
    actuated: bool
    armature: tuple[float, ...]
    rotor_inertia: tuple[float, ...]
    gear_ratio: tuple[float, ...]
    damping: tuple[float, ...]
    friction: tuple[float, ...]
    mimic: str  # "" or "<joint> * multiplier + offset"


@dataclass(frozen=True)
class LinkSummary:
    """One URDF link: its name, the URDF joint whose child it is ("" for the root), its mass [kg]."""

    name: str
    joint: str
    mass: float


@dataclass(frozen=True)
class ModelSummary:
    """Everything ``robodyn info`` prints."""

    name: str
    urdf: str
    srdf: str
    nq: int
    nv: int
    total_mass: float  # every link of the URDF [kg]
    moving_mass: float  # the bodies the joints move (the base welded to the world left out) [kg]
    free_flyer: bool
    free_flyer_hint: bool
    joints: tuple[JointSummary, ...]
    links: tuple[LinkSummary, ...]
    findings: tuple[Finding, ...]
    skipped_passive: tuple[str, ...]
    geometry_checked: bool

    @property
    def errors(self) -> tuple[Finding, ...]:
        """Findings no real body can have."""
        return tuple(f for f in self.findings if f.severity == "error")

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-able values (``robodyn info --json``)."""
        out = asdict(self)
        out["findings"] = [f.as_dict() for f in self.findings]
        out["n_errors"] = len(self.errors)
        return out


def _urdf_joints(robot: Robot) -> dict[str, ET.Element]:
    if robot.urdf_path is None:
        return {}
    try:
        root = ET.parse(robot.urdf_path).getroot()
    except (ET.ParseError, OSError):
        return {}
    return {el.get("name", ""): el for el in root.findall("joint")}


def _axis(element: ET.Element | None) -> tuple[float, float, float] | None:
    if element is None or element.get("type") in ("fixed", "floating", "planar"):
        return None
    axis = element.find("axis")
    text = axis.get("xyz", "1 0 0") if axis is not None else "1 0 0"
    try:
        x, y, z = (float(v) for v in text.split())
    except ValueError:
        return None
    return (x, y, z)


def _mimic(element: ET.Element | None) -> str:
    mimic = element.find("mimic") if element is not None else None
    if mimic is None:
        return ""
    return f"{mimic.get('joint')} * {mimic.get('multiplier', '1')} + {mimic.get('offset', '0')}"


def _links(robot: Robot) -> tuple[LinkSummary, ...]:
    """Links of the URDF with their mass, and the URDF joint whose child each is."""
    if robot.urdf_path is None:
        return ()
    try:
        root = ET.parse(robot.urdf_path).getroot()
    except (ET.ParseError, OSError):
        return ()
    parent_joint = {}
    for joint in root.findall("joint"):
        child = joint.find("child")
        if child is not None:
            parent_joint[child.get("link", "")] = joint.get("name", "")
    links = []
    for link in root.findall("link"):
        mass_el = link.find("inertial/mass")
        try:
            mass = float(mass_el.get("value", "0")) if mass_el is not None else 0.0
        except ValueError:
            mass = float("nan")
        name = link.get("name", "")
        links.append(LinkSummary(name, parent_joint.get(name, ""), mass))
    return tuple(links)


def _urdf_type(element: ET.Element | None, kind: str) -> str:
    if element is not None:
        return element.get("type", "?")
    return "floating" if "FreeFlyer" in kind else kind.removeprefix("JointModel")


def summarize(robot: Robot, *, geometry: bool = False, free_flyer_hint: bool = False) -> ModelSummary:
    """Summarize ``robot``: joints, links, sizes, mass, joint parameters and findings."""
    from robodyn.model.load import unknown_passive_joints

    model = robot.model
    xml = _urdf_joints(robot)

    def vq(values: Any, j: Any) -> tuple[float, ...]:
        return tuple(float(x) for x in np.asarray(values)[j.idx_q : j.idx_q + j.nq])

    def vv(values: Any, j: Any) -> tuple[float, ...]:
        return tuple(float(x) for x in np.asarray(values)[j.idx_v : j.idx_v + j.nv])

    joints = []
    for j in robot.joints:
        element = xml.get(j.name)
        joints.append(
            JointSummary(
                name=j.name,
                type=_urdf_type(element, j.kind),
                pinocchio_type=j.kind,
                axis=_axis(element),
                nq=j.nq,
                nv=j.nv,
                lower=vq(model.lowerPositionLimit, j),
                upper=vq(model.upperPositionLimit, j),
                velocity_limit=vv(model.velocityLimit, j),
                effort_limit=vv(model.effortLimit, j),
                actuated=j.actuated,
                armature=vv(model.armature, j),
                rotor_inertia=vv(model.rotorInertia, j),
                gear_ratio=vv(model.rotorGearRatio, j),
                damping=vv(model.damping, j),
                friction=vv(model.friction, j),
                mimic=_mimic(element),
            )
        )
    links = _links(robot)
    findings = all_findings(model, urdf=robot.urdf_path, geometry=geometry)
    return ModelSummary(
        name=robot.name,
        urdf=str(robot.urdf_path or ""),
        srdf=str(robot.srdf_path or ""),
        nq=robot.nq,
        nv=robot.nv,
        total_mass=sum(link.mass for link in links) if links else robot.total_mass,
        moving_mass=robot.total_mass,
        free_flyer=any("FreeFlyer" in j.kind for j in robot.joints),
        free_flyer_hint=free_flyer_hint,
        joints=tuple(joints),
        links=links,
        findings=tuple(findings),
        skipped_passive=unknown_passive_joints(robot),
        geometry_checked=geometry,
    )
