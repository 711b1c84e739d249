"""A URDF document: validated before Pinocchio parses it, rewritten through yourdfpy.

Pinocchio's URDF parser (urdfdom) prints an error for a value such as ``ixx="abc"`` but then
builds the model anyway, with that inertial silently dropped; a joint whose parent link does
not exist, a link with two parent joints or a loop of joints give a model that differs from the
file, or none. :func:`validate_urdf` refuses such a file with one line naming the element and
what was expected: every number finite, every joint type known, the links and joints a tree
(one root link, every joint's links present, one parent per link, no cycle), every axis a
non-zero direction. It works on the ElementTree that :func:`robodyn.load` parsed, so what is
checked is what the dynamics are built from.

The check does not use yourdfpy: importing it (trimesh, scipy.spatial, networkx) costs about a
second, several times a whole ``load("talos")``, and its parser coerces what must be refused (a
missing ``ixx`` reads as 1, NaN passes). yourdfpy is the tool for writing a modified robot:
:func:`read_document` and :func:`write_document` round-trip a URDF through its dataclasses
(``yourdfpy.URDF``, without scene graph or meshes) and put back what its writer leaves out
(``<mimic>``, ``<transmission>``, ``<gazebo>``, ...).
"""

from __future__ import annotations

import copy
import difflib
import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robodyn.errors import ModelError

if TYPE_CHECKING:
    import yourdfpy

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
# Joints whose <axis> Pinocchio uses (urdfdom ignores it on fixed and floating joints).
_AXIS_JOINTS = ("revolute", "continuous", "prismatic", "planar")


def _owner(parents: dict[ET.Element, ET.Element], element: ET.Element) -> str:
    node: ET.Element | None = element
    while node is not None and node.tag not in ("link", "joint"):
        node = parents.get(node)
    return f"{node.tag} {node.get('name')!r}" if node is not None else "robot"


def validate_urdf(root: ET.Element, path: Path) -> None:
    """Raise :class:`ModelError` on the first malformed number, joint type, link tree or axis in ``root``."""
    _check_numbers(root, path)
    for joint in root.findall("joint"):
        kind = joint.get("type")
        if kind not in JOINT_TYPES:
            raise ModelError(
                f"joint {joint.get('name')!r}: type={kind!r}, expected one of {', '.join(JOINT_TYPES)}", path=path
            )
    _check_tree(root, path)
    _check_axes(root, path)


def _check_numbers(root: ET.Element, path: Path) -> None:
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


def _names(elements: list[ET.Element], tag: str, path: Path) -> list[str]:
    """The ``name=`` of each element, refusing a missing or repeated one."""
    names: list[str] = []
    seen: set[str] = set()
    for number, element in enumerate(elements, start=1):
        name = element.get("name")
        if not name:
            raise ModelError(f"<{tag}> number {number} has no name= (expected a unique {tag} name)", path=path)
        if name in seen:
            raise ModelError(f"two <{tag}> elements are named {name!r} (expected unique {tag} names)", path=path)
        seen.add(name)
        names.append(name)
    return names


def _link_of(joint: ET.Element, end: str, links: set[str], path: Path) -> str:
    """The link named by the joint's ``<parent link=...>`` or ``<child link=...>``, which must exist."""
    element = joint.find(end)
    name = element.get("link") if element is not None else None
    if not name:
        raise ModelError(
            f"joint {joint.get('name')!r} has no <{end} link=...> (expected the name of its {end} link)", path=path
        )
    if name not in links:
        close = difflib.get_close_matches(name, sorted(links), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ModelError(
            f"joint {joint.get('name')!r}: {end} link {name!r} is not a <link> of this robot "
            f"(expected one of its {len(links)} links){hint}",
            path=path,
        )
    return name


def _quoted(names: list[str], limit: int = 4) -> str:
    shown = ", ".join(repr(n) for n in names[:limit])
    return shown + (f" and {len(names) - limit} more" if len(names) > limit else "")


def _check_tree(root: ET.Element, path: Path) -> None:
    """The links and joints must form one tree: each link below the root has exactly one parent joint."""
    link_names = _names(root.findall("link"), "link", path)
    joints = root.findall("joint")
    _names(joints, "joint", path)
    links = set(link_names)
    parent_joint: dict[str, str] = {}  # child link -> the joint above it
    parent_link: dict[str, str] = {}  # joint -> its parent link
    children: dict[str, list[str]] = {}  # link -> child links
    for joint in joints:
        name = str(joint.get("name"))
        parent = _link_of(joint, "parent", links, path)
        child = _link_of(joint, "child", links, path)
        if parent == child:
            raise ModelError(
                f"joint {name!r}: parent and child are both link {parent!r} (expected two different links)", path=path
            )
        if child in parent_joint:
            raise ModelError(
                f"link {child!r} is the child of two joints, {parent_joint[child]!r} and {name!r} "
                "(expected one parent joint per link: the links must form a tree)",
                path=path,
            )
        parent_joint[child] = name
        parent_link[name] = parent
        children.setdefault(parent, []).append(child)
    roots = [n for n in link_names if n not in parent_joint]
    if len(roots) > 1:
        raise ModelError(
            f"{len(roots)} links have no parent joint: {_quoted(roots)} "
            "(expected exactly one root link: the links must form one connected tree)",
            path=path,
        )
    reached = set(roots)
    stack = list(roots)
    while stack:
        for child in children.get(stack.pop(), ()):
            reached.add(child)
            stack.append(child)
    if len(reached) < len(link_names):
        start = next(n for n in link_names if n not in reached)
        cycle = _quoted(_cycle(start, parent_joint, parent_link), 6)
        if roots:
            message = f"joints {cycle} form a cycle, cut off from the root link {roots[0]!r} (expected a tree)"
        else:
            message = f"joints {cycle} form a cycle that leaves no link without a parent (expected a tree with a root)"
        raise ModelError(message, path=path)


def _cycle(start: str, parent_joint: dict[str, str], parent_link: dict[str, str]) -> list[str]:
    """The joints of the loop met by climbing from link ``start`` (not reached from any root), top down."""
    order: list[str] = []
    seen: dict[str, int] = {}
    link = start
    while link not in seen:
        seen[link] = len(order)
        joint = parent_joint[link]
        order.append(joint)
        link = parent_link[joint]
    return order[seen[link] :][::-1]


def _check_axes(root: ET.Element, path: Path) -> None:
    for joint in root.findall("joint"):
        axis = joint.find("axis")
        if joint.get("type") not in _AXIS_JOINTS or axis is None:
            continue  # no <axis>: urdfdom's default 1 0 0
        text = axis.get("xyz", "1 0 0")
        if sum(float(x) ** 2 for x in text.split()) == 0.0:  # finite: checked with the numbers
            raise ModelError(
                f"joint {joint.get('name')!r}: <axis xyz={text!r}> is zero (expected a direction, a non-zero vector)",
                path=path,
            )


# --------------------------------------------------------------------------- yourdfpy round trip

# What yourdfpy's writer writes of each element; any other child is copied from the source.
_WRITTEN = {
    "robot": ("link", "joint", "material"),
    "link": ("inertial", "visual", "collision"),
    "joint": ("parent", "child", "origin", "axis", "limit", "dynamics"),
}


@dataclass(frozen=True)
class Document:
    """A URDF read through yourdfpy: ``urdf`` to edit, ``source`` (lxml) for what yourdfpy does not keep."""

    urdf: yourdfpy.URDF
    source: Any  # lxml.etree._Element, the file's <robot> without comments
    path: Path


def read_document(path: Path) -> Document:
    """Read ``path`` into yourdfpy's dataclasses (no scene graph, no meshes, filenames kept as written).

    Raises:
        ModelError: the file cannot be read or yourdfpy cannot parse it.
    """
    import yourdfpy
    from lxml import etree

    try:
        source = etree.parse(str(path), etree.XMLParser(remove_comments=True, remove_blank_text=True)).getroot()
        urdf = yourdfpy.URDF.load(
            str(path),
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
            filename_handler=yourdfpy.filename_handler_null,
        )
    except (OSError, etree.XMLSyntaxError) as exc:
        raise ModelError(f"cannot read the URDF: {exc}", path=path) from None
    except (AttributeError, KeyError, TypeError, ValueError, IndexError) as exc:
        raise ModelError(f"yourdfpy cannot parse this URDF: {type(exc).__name__}: {exc}", path=path) from None
    return Document(urdf, source, Path(path))


def _copy_extra(source: Any, written: Any, tag: str) -> None:
    """Append to ``written`` the children of ``source`` that yourdfpy does not write, and its other attributes."""
    for name, value in source.attrib.items():
        if name not in written.attrib:
            written.set(name, value)
    for child in source:
        if isinstance(child.tag, str) and child.tag not in _WRITTEN[tag]:
            written.append(copy.deepcopy(child))


def relocate_meshes(document: Document, target_dir: Path) -> None:
    """Rewrite relative mesh filenames of ``document.urdf`` so that they name the same files from ``target_dir``."""
    source_dir = document.path.parent
    if source_dir.resolve() == target_dir.resolve():
        return
    for link in document.urdf.robot.links:
        for element in (*link.visuals, *link.collisions):
            mesh = element.geometry.mesh if element.geometry is not None else None
            if mesh is None or not mesh.filename or "://" in mesh.filename or os.path.isabs(mesh.filename):
                continue
            mesh.filename = os.path.relpath(source_dir / mesh.filename, target_dir)


def write_document(document: Document, path: Path, *, comment: str | None = None) -> None:
    """Write ``document.urdf`` to ``path`` with yourdfpy, keeping what its writer leaves out.

    yourdfpy writes links (inertial, visuals, collisions), joints (parent, child, origin, axis,
    limit, dynamics) and materials; every other element of the source (``<mimic>``,
    ``<calibration>``, ``<safety_controller>``, ``<transmission>``, ``<gazebo>``, ...) is copied
    back into its link, joint or robot (see :func:`relocate_meshes` for a file written elsewhere).
    ``comment`` goes at the top of the file.
    """
    from lxml import etree

    try:
        tree = document.urdf.write_xml()
    except (AttributeError, TypeError, ValueError) as exc:  # e.g. a <texture> without filename
        raise ModelError(f"yourdfpy cannot write this URDF: {type(exc).__name__}: {exc}", path=document.path) from None
    root = tree.getroot()
    _copy_extra(document.source, root, "robot")
    for tag in ("link", "joint"):
        written = {e.get("name"): e for e in root.findall(tag)}
        for element in document.source.findall(tag):
            if element.get("name") in written:
                _copy_extra(element, written[element.get("name")], tag)
    if comment:
        root.addprevious(etree.Comment(f" {comment.replace('--', '- -')} "))
    tree.write(str(path), xml_declaration=True, encoding="utf-8", pretty_print=True)


def same_robot(document: Document, path: Path) -> bool:
    """True when the URDF at ``path`` reads back (yourdfpy, within 1e-8) as ``document.urdf``'s robot."""
    return bool(read_document(path).urdf.robot == document.urdf.robot)
