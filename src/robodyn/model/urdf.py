r"""A URDF document: read as urdfdom reads it, validated before Pinocchio parses it, rewritten through yourdfpy.

Pinocchio's URDF parser (urdfdom 6.0 in pin 4.1) prints ``Error:`` for a value it cannot read
but builds the model anyway, with that link's inertial silently dropped. :func:`validate_urdf`
refuses such a file first, with one line naming the element, the attribute, the value and what
was expected. What urdfdom reads, measured on pin 4.1 (``urdf::strToDouble``: C++ stream
extraction in the C locale, nothing may follow the number; vectors split on U+0020 only):

* a number is ``[+-]digits[.digits][(e|E)[+-]digits]`` in ASCII digits, or ``.5``, ``1.``;
  ``nan``, ``inf``, ``0x1p3``, ``1_336``, ``1,5``, non-ASCII digits and any trailing character
  (a space, a TAB, U+00A0) are refused; leading ASCII white space is skipped; ``1e400``
  (overflow) is refused, ``1e-330`` reads as 0, subnormals as themselves;
* a vector (``xyz``, ``rpy``, ``size``, ``scale``, ``rgba``) is split on spaces, empty pieces
  skipped, each piece read as above (``"0.1\t0 0"`` is one bad piece).

robodyn is stricter: a scalar has no white space at all and a vector's pieces none but the
separating spaces, and every number must be finite. Pinocchio is then handed the text of the
tree robodyn read (:func:`urdf_text`), so XML-level differences (TABs and newlines in attributes,
character references, the declared encoding) cannot make urdfdom read another robot.

Beyond syntax: every joint type known, the links and joints a tree (one root link, every
joint's links present, one parent per link, no cycle), every axis a usable direction, each
``<inertial>`` complete (``<mass value>``, all six ``<inertia>`` terms, as urdfdom requires; an
``<inertial>`` with a mass and no ``<inertia>`` at all is a point mass, refused by the physics check
except where it cannot move),
and the sizes and magnitudes within the limits below, refused before Pinocchio is called.

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
import io
import math
import os
import re
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robodyn.errors import ModelError

if TYPE_CHECKING:
    import yourdfpy

# ----------------------------------------------------------------------------- limits
# Checked before Pinocchio is called; measured on pin 4.1. Its URDF parser recurses once per link
# of a chain and overflows the 8 MiB stack (SIGSEGV) between 3,000 and 4,000 revolute links (fixed
# joints: 3,500 parse, 5,000 crash); 1,000 links keeps a factor 3 (example-robot-data: at most 130).
MAX_LINKS = 1000
# pinocchio.Data grows as nv^3: its peak memory for a chain of nv revolute joints is 0.14 GB at
# nv = 100, 0.59 GB at 200, 1.1 GB at 256, 1.8 GB at 300 and 4.1 GB at 400 (createData alone).
# 200 keeps one Data under 0.6 GB, so a pool of three stays under 2 GB (example-robot-data: at
# most nv = 101, tiago_dual; +6 on a free flyer).
MAX_DOF = 200
# Masses [kg]: 0, or in [1e-12, 1e6] (never negative). example-robot-data ranges from 1e-9 kg (so101's
# gripper frame) to 116 kg (pr2's base); 1e-12 kg is a 5 um grain of steel, 1e6 kg a 1,000 t body.
# Outside, no robot is described, and the numerics break: 1e308 kg overflows M(q) to inf (NaN rows),
# a subnormal mass makes M singular to working precision (LinAlgError).
MASS_MIN, MASS_MAX = 1e-12, 1e6
# Inertia terms [kg m^2]: 0, or a normal double of magnitude at most 1e9 (1,000 t at a 30 m radius
# of gyration). Exporters leave dust down to 2.4e-35 (iCub), so only subnormals are refused below.
INERTIA_TINY, INERTIA_MAX = sys.float_info.min, 1e9
# Origins [m]: each coordinate within 10 km (example-robot-data: at most 1.57 m).
LENGTH_MAX = 1e4
# An axis is normalised by Pinocchio: its length must keep its square a normal double.
AXIS_MIN, AXIS_MAX = 1e-100, 1e100

# ----------------------------------------------------------------------------- grammar
_NUMBER = r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
# count -> the whole attribute: one number alone, or count numbers separated (and padded) by spaces
_FORMS = {1: re.compile(_NUMBER), **{n: re.compile(f" *{_NUMBER}(?: +{_NUMBER}){{{n - 1}}} *") for n in (3, 4)}}
_EXPECTED_NUMBER = "plain decimal such as 1.336 or -2.5e-3: ASCII digits, no spaces, '_' or ','"

# element tag -> (attribute, number of values) that urdfdom reads as doubles
_NUMERIC = {
    "mass": (("value", 1),),
    "inertia": tuple((name, 1) for name in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")),
    "origin": (("xyz", 3), ("rpy", 3)),
    "axis": (("xyz", 3),),
    "limit": (("lower", 1), ("upper", 1), ("effort", 1), ("velocity", 1)),
    "dynamics": (("damping", 1), ("friction", 1)),
    "box": (("size", 3),),
    "cylinder": (("radius", 1), ("length", 1)),
    "capsule": (("radius", 1), ("length", 1)),
    "sphere": (("radius", 1),),
    "mesh": (("scale", 3),),
    "color": (("rgba", 4),),
    "mimic": (("multiplier", 1), ("offset", 1)),
    "calibration": (("rising", 1), ("falling", 1)),
    "safety_controller": (("soft_lower_limit", 1), ("soft_upper_limit", 1), ("k_position", 1), ("k_velocity", 1)),
}
# urdfdom drops the inertial (mass and all) when one of these is missing.
_REQUIRED = {"mass": ("value",), "inertia": ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
# Velocity coordinates of each joint type in Pinocchio (a continuous joint: nq = 2, nv = 1).
JOINT_NV = {"revolute": 1, "continuous": 1, "prismatic": 1, "fixed": 0, "floating": 6, "planar": 3}
# Joints whose <axis> Pinocchio uses (urdfdom ignores it on fixed and floating joints).
_AXIS_JOINTS = ("revolute", "continuous", "prismatic", "planar")


def parse_numbers(text: str, count: int) -> tuple[float, ...] | None:
    """The ``count`` finite numbers of an attribute, read as urdfdom reads them; None if it is not that.

    A scalar (``count == 1``) is one number without white space; a vector, numbers separated by
    spaces (U+0020). Stricter than urdfdom, never looser (see the module docstring).
    """
    if not _FORMS[count].fullmatch(text):
        return None
    values = tuple(float(p) for p in text.split(" ") if p)
    return values if all(math.isfinite(x) for x in values) else None


def _owner(parents: dict[ET.Element, ET.Element], element: ET.Element) -> str:
    """``link 'x'`` or ``joint 'y'`` holding ``element``, else the robot-level ``material 'z'``."""
    node: ET.Element | None = element
    material = None
    while node is not None and node.tag not in ("link", "joint"):
        material = node if node.tag == "material" else material
        node = parents.get(node)
    node = node if node is not None else material
    return f"{node.tag} {node.get('name')!r}" if node is not None else "robot"


def validate_urdf(root: ET.Element, path: Path, *, free_flyer: bool = False) -> None:
    """Raise :class:`ModelError` on the first thing in ``root`` that Pinocchio would not read as written.

    In order: the number of links, every number, joint types, the degrees of freedom
    (``free_flyer`` adds 6), the link tree, the axes, and each link's inertial.
    """
    links = root.findall("link")
    if len(links) > MAX_LINKS:
        raise ModelError(
            f"{len(links)} <link> elements (expected at most {MAX_LINKS}: Pinocchio's URDF parser "
            "recurses once per link and crashes on a chain of a few thousand)",
            path=path,
        )
    _check_numbers(root, path)
    for joint in root.findall("joint"):
        kind = joint.get("type")
        if kind not in JOINT_TYPES:
            raise ModelError(
                f"joint {joint.get('name')!r}: type={kind!r}, expected one of {', '.join(JOINT_TYPES)}", path=path
            )
    nv = sum(JOINT_NV[str(j.get("type"))] for j in root.findall("joint")) + (6 if free_flyer else 0)
    if nv > MAX_DOF:
        raise ModelError(
            f"{nv} degrees of freedom (expected at most {MAX_DOF}: Pinocchio's data for nv joints "
            "grows as nv^3, 0.6 GB at nv = 200 and 4 GB at 400)",
            path=path,
        )
    _check_tree(root, path)
    _check_axes(root, path)
    _check_inertials(root, path)


def _check_numbers(root: ET.Element, path: Path) -> None:
    tops = (*root.findall("link"), *root.findall("joint"), *root.findall("material"))
    parents = {child: parent for top in tops for parent in top.iter() for child in parent}
    # Only the robot's own links, joints and materials: <transmission> and <gazebo> reuse tag names.
    for element in (e for top in tops for e in top.iter()):
        for attribute, count in _NUMERIC.get(element.tag, ()):
            text = element.get(attribute)
            if text is None:
                if attribute in _REQUIRED.get(element.tag, ()):
                    raise ModelError(
                        f"{_owner(parents, element)}: <{element.tag}> has no {attribute}= "
                        "(expected a number: urdfdom drops the whole inertial without it)",
                        path=path,
                    )
                continue
            if parse_numbers(text, count) is None:
                what = "a finite number" if count == 1 else f"{count} finite numbers"
                form = "a" if count == 1 else f"{count} numbers with spaces between, each a"
                raise ModelError(
                    f"{_owner(parents, element)}: <{element.tag} {attribute}={text!r}> is not {what} "
                    f"(expected {form} {_EXPECTED_NUMBER})",
                    path=path,
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


def check_mimic_targets(root: ET.Element, path: Path) -> None:
    """Refuse a ``<mimic joint=...>`` on a moving joint that names no joint of the robot (both joints named).

    Only when the couplings are kept (``mimic=True``): without it they are dropped and the file loads.
    """
    names = [str(j.get("name")) for j in root.findall("joint")]
    for joint in root.findall("joint"):
        mimic = joint.find("mimic")
        if mimic is None or joint.get("type") == "fixed":
            continue
        leader = mimic.get("joint")
        if leader in names:
            continue
        close = difflib.get_close_matches(str(leader), names, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ModelError(
            f"joint {joint.get('name')!r} mimics joint {leader!r}, which is not a joint of this robot "
            f"(expected one of its {len(names)} joints{hint}); without --mimic (mimic=False) the coupling is "
            "dropped and the file loads",
            path=path,
        )


def _check_axes(root: ET.Element, path: Path) -> None:
    for joint in root.findall("joint"):
        axis = joint.find("axis")
        if joint.get("type") not in _AXIS_JOINTS or axis is None:
            continue  # no <axis>: urdfdom's default 1 0 0
        text = axis.get("xyz", "1 0 0")
        length = math.hypot(*(parse_numbers(text, 3) or ()))  # the numbers were checked above
        if length == 0.0:
            raise ModelError(
                f"joint {joint.get('name')!r}: <axis xyz={text!r}> is zero (expected a direction, a non-zero vector)",
                path=path,
            )
        if not AXIS_MIN <= length <= AXIS_MAX:
            raise ModelError(
                f"joint {joint.get('name')!r}: <axis xyz={text!r}> has length {length:.3g} (expected a direction "
                f"of length between {AXIS_MIN:g} and {AXIS_MAX:g}: Pinocchio normalises it through its square)",
                path=path,
            )


def _single(parent: ET.Element, tag: str, where: str, path: Path, *, required: bool) -> ET.Element | None:
    """The one ``<tag>`` child of ``parent`` (urdfdom reads the first only: a second is refused)."""
    found = parent.findall(tag)
    if len(found) > 1:
        raise ModelError(f"{where}: {len(found)} <{tag}> elements (expected one: urdfdom reads the first)", path=path)
    if not found and required:
        raise ModelError(
            f"{where}: <{parent.tag}> has no <{tag}> (expected <mass value=...> and <inertia ixx=... izz=...>; "
            "urdfdom drops an incomplete inertial)",
            path=path,
        )
    return found[0] if found else None


def _check_inertials(root: ET.Element, path: Path) -> None:
    """Each link's inertial complete, its mass and inertia terms, and every origin, within the limits."""
    for link in root.findall("link"):
        where = f"link {link.get('name')!r}"
        inertial = _single(link, "inertial", where, path, required=False)
        if inertial is None:
            continue
        _single(inertial, "origin", where, path, required=False)
        mass = _single(inertial, "mass", where, path, required=True)
        inertia = _single(inertial, "inertia", where, path, required=False)  # none: a point mass (urdf_text)
        if mass is None:  # refused above: for the type checker
            continue
        value = float(mass.get("value", "0"))
        if not (value == 0 or MASS_MIN <= value <= MASS_MAX):
            # Pinocchio cannot hold a negative mass either: link1 at -1.336 kg got its centre at 3.6e30 m.
            what = "negative" if value < 0 else "out of range"
            raise ModelError(
                f"{where}: <mass value={mass.get('value')!r}> is {what} "
                f"(expected 0 or a mass between {MASS_MIN:g} and {MASS_MAX:g} kg)",
                path=path,
            )
        terms = {name: inertia.get(name) for name in _REQUIRED["inertia"]} if inertia is not None else {}
        for name, text in terms.items():
            term = float(text or "0")
            if abs(term) > INERTIA_MAX or 0 < abs(term) < INERTIA_TINY:
                raise ModelError(
                    f"{where}: <inertia {name}={text!r}> is out of range (expected 0 or a "
                    f"normal double of magnitude at most {INERTIA_MAX:g} kg m^2; subnormals are refused)",
                    path=path,
                )
    for top in (*root.findall("link"), *root.findall("joint")):
        for origin in top.iter("origin"):
            xyz = parse_numbers(origin.get("xyz", "0 0 0"), 3) or ()
            if any(abs(x) > LENGTH_MAX for x in xyz):
                raise ModelError(
                    f"{top.tag} {top.get('name')!r}: <origin xyz={origin.get('xyz')!r}> is out of range "
                    f"(expected each coordinate within {LENGTH_MAX:g} m)",
                    path=path,
                )


def urdf_text(root: ET.Element) -> str:
    """The XML text of ``root`` that Pinocchio is given: the tree robodyn read and validated.

    An ``<inertial>`` with a mass and no ``<inertia>`` (which urdfdom refuses) gets a zero one: a
    point mass, as robodyn reads it (:func:`robodyn.model.consistency.link_inertials`).
    """
    bare = [i for i in root.iter("inertial") if i.find("inertia") is None]
    if bare:
        root = copy.deepcopy(root)
        for inertial in (i for i in root.iter("inertial") if i.find("inertia") is None):
            ET.SubElement(inertial, "inertia", {name: "0" for name in _REQUIRED["inertia"]})
    return ET.tostring(root, encoding="unicode")


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

    from robodyn.model.prefixes import declare_unbound_prefixes

    try:
        data = declare_unbound_prefixes(Path(path).read_bytes())  # drake:... read as urdfdom reads it
        parser = etree.XMLParser(remove_comments=True, remove_blank_text=True)
        source = etree.fromstring(data, parser)
        urdf = yourdfpy.URDF.load(
            io.BytesIO(data),
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
