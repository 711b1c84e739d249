"""What ``robodyn info`` reports about a robot, as a frozen dataclass of plain values.

:func:`summarize` reads the Pinocchio model (types, sizes, limits, armature, rotor
parameters, damping, masses), the URDF's XML for what Pinocchio does not keep (the joint's
URDF type, its axis, mimic couplings) and the physical-consistency findings of
:mod:`robodyn.model.consistency`. Meshes are looked for only with ``geometry=True``, and never
parsed.

Each link with mass whose geometry (its collision elements, else its visual ones) is exactly
one primitive (box, cylinder, sphere) is compared with the inertia that primitive would have
at the link's mass and uniform density (:mod:`robodyn.inertia`), about the link's inertial
origin and in its inertial frame. A difference above :data:`PRIMITIVE_RTOL` is a finding
with code ``inertia_vs_shape`` and severity ``"note"``: legal (a wheel's mass sits in its rim,
a collision box wraps motors and cables, so most vendor URDFs differ from their boxes), but
worth knowing in a hand-written URDF, where a wrong formula or a missed parallel-axis term
shows up here.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from robodyn import inertia
from robodyn.model.consistency import Finding, all_findings
from robodyn.model.files import read_xml
from robodyn.robot import Robot

# A URDF inertia within 1 % of its primitive's (element by element, each on the scale
# sqrt(I_ii I_jj) of the primitive) agrees: hand-written inertias carry 3-6 significant digits,
# while a solid disk for a rim-heavy wheel, or a parallel-axis term forgotten, is off by tens of %.
PRIMITIVE_RTOL = 0.01

PRIMITIVES = ("box", "cylinder", "sphere")


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
class PrimitiveComparison:
    """A link's URDF inertia against the uniform-density inertia of its one geometric primitive.

    Both tensors are about the link's inertial origin, in its inertial frame [kg m^2].
    ``size`` is the primitive's URDF size [m]: box (x, y, z), cylinder (radius, length),
    sphere (radius,). ``relative_difference`` is the largest ``|I_urdf - I_uniform|_ij /
    sqrt(I_ii I_jj)`` (the primitive's diagonal), and ``element`` names where it sits.
    """

    link: str
    shape: str
    source: str  # "collision" or "visual"
    size: tuple[float, ...]
    mass: float
    urdf_inertia: tuple[tuple[float, float, float], ...]
    uniform_inertia: tuple[tuple[float, float, float], ...]
    relative_difference: float
    element: str  # e.g. "Iyy" or "Ixz"

    @property
    def differs(self) -> bool:
        """True above :data:`PRIMITIVE_RTOL`."""
        return not self.relative_difference <= PRIMITIVE_RTOL


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
    primitives: tuple[PrimitiveComparison, ...] = ()

    @property
    def errors(self) -> tuple[Finding, ...]:
        """Findings no real body can have."""
        return tuple(f for f in self.findings if f.severity == "error")

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-able values (``robodyn info --json``)."""
        out = asdict(self)
        out["findings"] = [f.as_dict() for f in self.findings]
        out["primitives"] = [dict(asdict(c), differs=c.differs) for c in self.primitives]
        out["primitive_rtol"] = PRIMITIVE_RTOL
        out["n_errors"] = len(self.errors)
        return out


def _urdf_joints(root: ET.Element | None) -> dict[str, ET.Element]:
    return {} if root is None else {el.get("name", ""): el for el in root.findall("joint")}


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


def _links(root: ET.Element | None) -> tuple[LinkSummary, ...]:
    """Links of the URDF with their mass, and the URDF joint whose child each is."""
    if root is None:
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


def _floats(text: str | None, n: int) -> tuple[float, ...] | None:
    try:
        values = tuple(float(x) for x in (text or "").split())
    except ValueError:
        return None
    return values if len(values) == n and all(np.isfinite(values)) else None


def _origin(element: ET.Element) -> tuple[np.ndarray, np.ndarray] | None:
    """(rotation (3, 3), position (3,)) of an element's ``<origin>`` in the link frame, or None if malformed."""
    origin = element.find("origin")
    if origin is None:
        return np.eye(3), np.zeros(3)
    xyz = _floats(origin.get("xyz", "0 0 0"), 3)
    rpy = _floats(origin.get("rpy", "0 0 0"), 3)
    if xyz is None or rpy is None:
        return None
    return rotation_rpy(*rpy), np.array(xyz)


def rotation_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw [rad]: ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    Rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    return Rz @ Ry @ Rx


def _one_primitive(link: ET.Element) -> tuple[str, str, tuple[float, ...], ET.Element] | None:
    """(source, shape, size, element) when the link's collision (else visual) geometry is one primitive."""
    for source in ("collision", "visual"):
        elements = link.findall(source)
        if not elements:
            continue
        if len(elements) != 1:
            return None
        geometry = elements[0].find("geometry")
        shapes = list(geometry) if geometry is not None else []
        if len(shapes) != 1 or shapes[0].tag not in PRIMITIVES:
            return None
        shape = shapes[0]
        if shape.tag == "box":
            size = _floats(shape.get("size"), 3)
        elif shape.tag == "cylinder":
            radius, length = _floats(shape.get("radius"), 1), _floats(shape.get("length"), 1)
            size = radius + length if radius is not None and length is not None else None
        else:
            size = _floats(shape.get("radius"), 1)
        if size is None or min(size) <= 0:
            return None
        return source, shape.tag, size, elements[0]
    return None


def _uniform_inertia(shape: str, mass: float, size: tuple[float, ...]) -> np.ndarray:
    """The primitive's inertia about its centre, in its own axes [kg m^2]."""
    if shape == "box":
        return inertia.box(mass, size)
    if shape == "cylinder":
        return inertia.cylinder(mass, size[0], size[1])
    return inertia.sphere(mass, size[0])


def _urdf_inertia(inertial: ET.Element) -> np.ndarray | None:
    el = inertial.find("inertia")
    if el is None:
        return None
    try:
        xx, xy, xz, yy, yz, zz = (float(el.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"))
    except ValueError:
        return None
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def compare_primitive(link: ET.Element) -> PrimitiveComparison | None:
    """Compare a URDF ``<link>``'s inertia with its one primitive's at uniform density (None: nothing to compare).

    Skipped: no ``<inertial>``, mass <= 0, geometry that is not exactly one box, cylinder or
    sphere, and malformed numbers (other checks report those).
    """
    inertial = link.find("inertial")
    primitive = _one_primitive(link)
    if inertial is None or primitive is None:
        return None
    source, shape, size, geometry = primitive
    mass_el = inertial.find("mass")
    mass = _floats(mass_el.get("value") if mass_el is not None else None, 1)
    I_urdf = _urdf_inertia(inertial)
    frame_i, frame_g = _origin(inertial), _origin(geometry)
    if mass is None or mass[0] <= 0 or I_urdf is None or frame_i is None or frame_g is None:
        return None
    (R_i, p_i), (R_g, p_g) = frame_i, frame_g
    # The primitive's tensor in the link's axes about its centre, moved to the inertial origin,
    # then expressed in the inertial frame's axes.
    in_link = inertia.parallel_axis(inertia.rotated(_uniform_inertia(shape, mass[0], size), R_g), mass[0], p_i - p_g)
    I_uniform = inertia.rotated(in_link, R_i.T)
    scale = np.sqrt(np.outer(np.diag(I_uniform), np.diag(I_uniform)))
    ratio = np.abs(I_urdf - I_uniform) / scale
    i, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    axes = "xyz"
    return PrimitiveComparison(
        link=link.get("name", ""),
        shape=shape,
        source=source,
        size=size,
        mass=mass[0],
        urdf_inertia=tuple((float(a), float(b), float(c)) for a, b, c in I_urdf),
        uniform_inertia=tuple((float(a), float(b), float(c)) for a, b, c in I_uniform),
        relative_difference=float(ratio[i, j]),
        element=f"I{axes[min(i, j)]}{axes[max(i, j)]}",
    )


def _primitives(root: ET.Element | None) -> tuple[PrimitiveComparison, ...]:
    if root is None:
        return ()
    found = (compare_primitive(link) for link in root.findall("link"))
    return tuple(c for c in found if c is not None)


def primitive_text(shape: str, size: tuple[float, ...]) -> str:
    """``box 0.3 x 0.2 x 0.1 m``, ``cylinder r = 0.33 m, length 0.12 m``, ``sphere r = 0.1 m``."""
    if shape == "box":
        return "box " + " x ".join(f"{x:g}" for x in size) + " m"
    if shape == "cylinder":
        return f"cylinder r = {size[0]:g} m, length {size[1]:g} m"
    return f"sphere r = {size[0]:g} m"


def primitive_finding(c: PrimitiveComparison) -> Finding:
    """The ``inertia_vs_shape`` note of a link whose inertia differs from its primitive's."""
    k = "xyz".index(c.element[1]), "xyz".index(c.element[2])
    urdf, uniform = c.urdf_inertia[k[0]][k[1]], c.uniform_inertia[k[0]][k[1]]
    return Finding(
        c.link,
        "note",
        f"inertia differs from a uniform {primitive_text(c.shape, c.size)} of {c.mass:g} kg ({c.source} geometry) "
        f"by {100 * c.relative_difference:.3g} % (> {100 * PRIMITIVE_RTOL:g} %): {c.element} = {urdf:.6g} kg m^2 "
        f"in the URDF, {uniform:.6g} for the uniform {c.shape} (about the inertial origin, in its frame)",
        "inertia_vs_shape",
    )


def _urdf_type(element: ET.Element | None, kind: str) -> str:
    if element is not None:
        return element.get("type", "?")
    return "floating" if "FreeFlyer" in kind else kind.removeprefix("JointModel")


def summarize(robot: Robot, *, geometry: bool = False, free_flyer_hint: bool = False) -> ModelSummary:
    """Summarize ``robot``: joints, links, sizes, mass, joint parameters and findings."""
    from robodyn.model.load import unknown_passive_joints

    model = robot.model
    # One reading of the URDF (linear-time, within robodyn's limits) for what Pinocchio does not keep.
    root = read_xml(robot.urdf_path, "URDF") if robot.urdf_path is not None else None
    xml = _urdf_joints(root)

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
    links = _links(root)
    primitives = _primitives(root)
    findings = all_findings(model, urdf=robot.urdf_path, geometry=geometry)
    findings += [primitive_finding(c) for c in primitives if c.differs]
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
        primitives=primitives,
    )
