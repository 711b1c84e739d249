"""Validate the numbers of a URDF before Pinocchio parses it.

Pinocchio's URDF parser (urdfdom) prints an error for a value such as ``ixx="abc"`` but then
builds the model anyway, with that inertial silently dropped. robodyn refuses such a file
with one line naming the element, the attribute and what was expected.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

from robodyn.errors import ModelError

# element tag -> (attribute, number of values) that must parse as finite floats
_NUMERIC = {
    "mass": (("value", 1),),
    "inertia": tuple((name, 1) for name in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")),
    "origin": (("xyz", 3), ("rpy", 3)),
    "axis": (("xyz", 3),),
    "limit": (("lower", 1), ("upper", 1), ("effort", 1), ("velocity", 1)),
    "dynamics": (("damping", 1), ("friction", 1)),
    "box": (("size", 3),),
    "cylinder": (("radius", 1), ("length", 1)),
    "sphere": (("radius", 1),),
    "mimic": (("multiplier", 1), ("offset", 1)),
}
_REQUIRED = {"mass": ("value",), "inertia": ("ixx", "iyy", "izz")}
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")


def _owner(parents: dict[ET.Element, ET.Element], element: ET.Element) -> str:
    node: ET.Element | None = element
    while node is not None and node.tag not in ("link", "joint"):
        node = parents.get(node)
    return f"{node.tag} {node.get('name')!r}" if node is not None else "robot"


def validate_urdf(root: ET.Element, path: Path) -> None:
    """Raise :class:`ModelError` on the first malformed number or joint type in ``root``."""
    parents = {child: parent for parent in root.iter() for child in parent}
    # Only the robot's own links and joints: <transmission> and <gazebo> blocks reuse tag names.
    elements = [e for top in (*root.findall("link"), *root.findall("joint")) for e in top.iter()]
    for element in elements:
        for attribute, count in _NUMERIC.get(element.tag, ()):
            text = element.get(attribute)
            if text is None:
                if attribute in _REQUIRED.get(element.tag, ()):
                    raise ModelError(
                        f"{_owner(parents, element)}: <{element.tag}> has no {attribute}= (expected a number)",
                        path=path,
                    )
                continue
            parts = text.split()
            try:
                values = [float(x) for x in parts]
            except ValueError:
                values = []
            if len(values) != count or not all(math.isfinite(x) for x in values):
                expected = "a finite number" if count == 1 else f"{count} finite numbers"
                raise ModelError(
                    f"{_owner(parents, element)}: <{element.tag} {attribute}={text!r}> is not {expected}", path=path
                )
    for joint in root.findall("joint"):
        kind = joint.get("type")
        if kind not in JOINT_TYPES:
            raise ModelError(
                f"joint {joint.get('name')!r}: type={kind!r}, expected one of {', '.join(JOINT_TYPES)}", path=path
            )
