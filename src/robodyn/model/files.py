"""Facts about model files on disk: the built-in folder, SRDF pairing and contents, mesh URIs.

Nothing here builds a Pinocchio model. The built-in models live in the top-level
``models/`` folder of the source tree and are shipped inside the wheel as ``robodyn/models``;
variants of them live in ``models/variants/``. An SRDF with the same stem as the URDF (next to
it, or in a sibling ``srdf/`` folder as example-robot-data lays them out) goes with it. From the
SRDF robodyn reads ``<rotor_params>`` (through Pinocchio, at load), ``<passive_joint>`` and
``<group_state>`` (named configurations, :func:`reference_configurations`).

Every URDF and SRDF is read by :func:`read_xml`, within limits stated there: at most
:data:`MAX_FILE_BYTES`, elements nested at most :data:`MAX_XML_DEPTH` deep, no ``<!DOCTYPE>``
(so no entity of any kind), in an encoding that Python's expat knows. Two things that cannot touch
the dynamics are read anyway, each with a :class:`~robodyn.errors.ModelWarning`: white space before
the ``<?xml ...?>`` declaration (urdfdom reads it, expat refuses it), and a visual or collision
``<mesh scale="x y z 1">``, read as ``x y z`` (urdfdom drops that geometry). A NUL byte is refused by
name; a namespace prefix used without its declaration (``drake:``) is declared, as urdfdom reads it
(:mod:`robodyn.model.prefixes`). The file is handed to expat in one piece: fed in 64 KiB chunks
(``ET.parse``), expat 2.5 rescans an unfinished token from its start at each chunk, so a 20 MB
comment took 4.6 s instead of 0.1 s.
"""

from __future__ import annotations

import importlib.metadata
import importlib.resources
import os
import warnings
import xml.etree.ElementTree as ET
import xml.parsers.expat
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from robodyn.errors import InputError, ModelError, ModelWarning
from robodyn.model.prefixes import declare_unbound_prefixes
from robodyn.model.urdf import parse_numbers
from robodyn.robot import Robot, joint_coordinates

# Variants of the built-ins, for the fidelity study (models/variants/<name>.urdf).
VARIANT_NAMES = ("cart_pole_point_bob", "geared_arm_rotor")


@dataclass(frozen=True)
class ModelSource:
    """Where a named model comes from: its URDF, optional SRDF and a one-line description.

    ``free_flyer_hint`` is True for robots that example-robot-data mounts on a free flyer
    (legged robots, humanoids, drones); robodyn loads them fixed-base unless asked.
    """

    urdf: Path
    srdf: Path | None
    description: str
    free_flyer_hint: bool = False


def models_dir() -> Path:
    """Folder holding the built-in URDF/SRDF files (installed wheel or source checkout)."""
    packaged = Path(str(importlib.resources.files("robodyn"))) / "models"
    if packaged.is_dir():
        return packaged
    return Path(__file__).resolve().parents[3] / "models"


def examples_dir() -> Path:
    """Folder holding the examples (scenes, URDFs, formula files, the textbook's and the grading examples).

    They ship inside the wheel as ``robodyn/examples`` so that a notebook downloaded alone runs after
    ``pip install robodyn``; a source checkout reads the repository's ``examples/``.
    """
    packaged = Path(str(importlib.resources.files("robodyn"))) / "examples"
    if packaged.is_dir():
        return packaged
    return Path(__file__).resolve().parents[3] / "examples"


def example(relative: str | Path = "") -> Path:
    """The path of one shipped example, e.g. ``example("textbook/linkage/linkage.toml")``.

    Raises:
        InputError: ``relative`` names no file or folder of the examples; the message lists the top level.
    """
    root = examples_dir()
    path = root / relative
    if Path(relative).is_absolute() or ".." in Path(relative).parts or not path.exists():
        choices = ", ".join(sorted(p.name for p in root.iterdir() if not p.name.startswith((".", "_"))))
        raise InputError(f"example {str(relative)!r}: no such file; expected a path under one of {choices}")
    return path


BUILTIN_NAMES = tuple(sorted(path.stem for path in models_dir().glob("*.urdf")))
"""The built-in models: every URDF in ``models/`` (one per kind, :mod:`robodyn.kinds.catalog`)."""


def opening_line(urdf: Path) -> str:
    """The first line of a built-in URDF's opening comment, less its ``name:`` (its one-line description)."""
    text = urdf.read_text(encoding="utf-8")
    start = text.find("<!--")
    if start < 0:
        return "built-in model"
    line = next((s.strip() for s in text[start + 4 :].splitlines() if s.strip()), "")
    return line.removeprefix(f"{urdf.stem}:").strip().rstrip(".") or "built-in model"


# Suffixes that make a bare name a file: robodyn's own, and the two formats it names to refuse them.
FILE_SUFFIXES = (".urdf", ".xml", ".xacro", ".sdf")
XACRO = "http://www.ros.org/wiki/xacro"  # the namespace of xacro's macros


def looks_like_path(name_or_path: str | Path) -> bool:
    """True when the argument should be read as a file path rather than a model name."""
    text = str(name_or_path)
    return isinstance(name_or_path, Path) or text.endswith(FILE_SUFFIXES) or "/" in text or "\\" in text


def not_urdf(path: Path) -> str | None:
    """Why ``path`` is no URDF judging by its suffix (a xacro or an SDFormat file), with the way to one; else None."""
    if path.suffix == ".xacro":
        return f"a xacro file: robodyn reads URDF; {_expand(path)}"
    if path.suffix == ".sdf":
        return "an SDFormat file: robodyn reads URDF only (SDFormat is not supported; export a URDF from its source)"
    return None


def find_srdf(urdf: Path) -> Path | None:
    """The SRDF that goes with ``urdf``: same stem, next to it or in a sibling ``srdf/`` folder."""
    for candidate in (urdf.with_suffix(".srdf"), urdf.parent.parent / "srdf" / f"{urdf.stem}.srdf"):
        if candidate.is_file():
            return candidate
    return None


# The largest URDF of example-robot-data (tiago_dual.urdf) is 206 KiB; 8 MiB is 40 times that,
# and keeps every later reading of the file (ElementTree, yourdfpy, urdfdom) well under a second.
MAX_FILE_BYTES = 8 * 2**20

# URDF elements nest about 7 deep (robot/link/visual/geometry/mesh); 64 leaves room for
# namespaced extensions, and keeps recursive readers (ET.tostring, yourdfpy) far from
# Python's recursion limit.
MAX_XML_DEPTH = 64


_UNBOUND_PREFIX = xml.parsers.expat.errors.codes[xml.parsers.expat.errors.XML_ERROR_UNBOUND_PREFIX]


class _DoctypeError(Exception):
    """Raised from inside expat when the document declares a ``<!DOCTYPE>``."""


class _TreeBuilder(ET.TreeBuilder):
    """ElementTree's builder, refusing a ``<!DOCTYPE>`` before expat reads any entity declaration."""

    def doctype(self, name: str, pubid: str | None, system: str | None) -> None:
        raise _DoctypeError(name)


def read_xml(path: Path, what: str) -> ET.Element:
    """The root element of the XML file ``path`` (a URDF or SRDF: ``what`` names it in messages).

    Comments and processing instructions are dropped; character references are resolved.

    Raises:
        ModelError: the file cannot be read, is larger than :data:`MAX_FILE_BYTES`, is empty,
            declares a DTD, names an unknown encoding, is not well-formed XML, or nests
            elements deeper than :data:`MAX_XML_DEPTH`.
    """
    try:
        with open(path, "rb") as stream:
            data = stream.read(MAX_FILE_BYTES + 1)
    except IsADirectoryError:
        raise ModelError(f"is a directory (expected a {what} file)", path=path) from None
    except OSError as exc:
        raise ModelError(f"cannot read {what}: {exc.strerror or exc}", path=path) from None
    if len(data) > MAX_FILE_BYTES:
        raise ModelError(
            f"the {what} is larger than {MAX_FILE_BYTES // 2**20} MiB (expected at most that: "
            "robodyn refuses bigger files before parsing them)",
            path=path,
        )
    if not data.strip():
        raise ModelError(f"the {what} file is empty (expected XML with a <robot> element)", path=path)
    data = _skip_blank_prefix(data, path, what)
    try:
        try:
            root = _parse(data)
        except ET.ParseError as exc:
            if exc.code != _UNBOUND_PREFIX:
                raise
            root = _parse(declare_unbound_prefixes(data))  # drake:... as urdfdom reads it: a name it ignores
    except _DoctypeError as exc:
        raise ModelError(
            f"<!DOCTYPE {exc}> declared (expected none: robodyn refuses DTDs and entity declarations, "
            "which urdfdom would not expand)",
            path=path,
        ) from None
    except ET.ParseError as exc:
        raise ModelError(f"malformed {what} XML: {_nul_byte(data) or exc}", path=path) from None
    except LookupError as exc:  # <?xml encoding="bogus"?>
        raise ModelError(f"the XML declaration names an {exc} (expected UTF-8)", path=path) from None
    except (UnicodeError, ValueError) as exc:  # e.g. a multi-byte codec expat cannot use
        raise ModelError(f"cannot decode the {what}: {exc} (expected UTF-8)", path=path) from None
    _check_depth(root, path)
    if what == "URDF":
        _read_homogeneous_scales(root, path)
        _skip_unknown_geometry(root, path)
    return root


def _parse(data: bytes) -> ET.Element:
    parser = ET.XMLParser(target=_TreeBuilder())
    parser.feed(data)  # in one piece: linear time (see the module docstring)
    return parser.close()


def _skip_blank_prefix(data: bytes, path: Path, what: str) -> bytes:
    """``data`` without the white space before its ``<?xml ...?>`` declaration, with a warning; else as is.

    expat refuses a declaration that is not the first thing in the file; urdfdom (TinyXML) reads it.
    White space carries nothing, so skipping it is unambiguous.
    """
    stripped = data.lstrip(b" \t\r\n")
    if stripped is data or len(stripped) == len(data) or not stripped.startswith(b"<?xml"):
        return data
    lines = data[: len(data) - len(stripped)].count(b"\n")
    warnings.warn(
        ModelWarning(
            f"{path}: {lines} blank line(s) before the <?xml ...?> declaration, skipped (XML puts the declaration "
            f"first; urdfdom reads the {what} so too)"
        ),
        stacklevel=3,
    )
    return stripped


def _nul_byte(data: bytes) -> str | None:
    """Where a NUL byte is in ``data`` ("a NUL byte (0x00) at line 288, column 0, after </robot>"), or None."""
    at = data.find(b"\0")
    if at < 0:
        return None
    line = data.count(b"\n", 0, at) + 1
    column = at - (data.rfind(b"\n", 0, at) + 1)
    after = ", after </robot>" if data[:at].rstrip().endswith(b"</robot>") else ""
    return (
        f"a NUL byte (0x00) on line {line}, column {column}{after} (expected text: XML allows no NUL byte; "
        "a tool may have padded the file, remove it)"
    )


def _read_homogeneous_scales(root: ET.Element, path: Path) -> None:
    """Read a geometry's ``<mesh scale="x y z 1">`` as ``"x y z"``, with a warning (it is geometry, not dynamics).

    urdfdom refuses the fourth number and drops the whole visual or collision; a trailing 1 is a
    homogeneous coordinate, unambiguous. Any other fourth number stays, for validation to refuse.
    """
    changed: list[tuple[str, str]] = []
    for link in root.findall("link"):
        for kind in ("visual", "collision"):
            for element in link.iter(kind):
                for mesh in element.iter("mesh"):
                    text = mesh.get("scale")
                    values = parse_numbers(text, 4) if text is not None else None
                    if text is None or values is None or values[3] != 1.0:
                        continue
                    mesh.set("scale", " ".join(text.split()[:3]))
                    changed.append((str(link.get("name")), text))
    if changed:
        links = sorted({name for name, _ in changed})
        shown = ", ".join(repr(n) for n in links[:3]) + (f" and {len(links) - 3} more" if len(links) > 3 else "")
        warnings.warn(
            ModelWarning(
                f"{path}: {len(changed)} <mesh scale={changed[0][1]!r}> with a fourth number 1 (link {shown}) read "
                "as its first three numbers (geometry only: masses, inertias, joints and frames are not touched)"
            ),
            stacklevel=3,
        )


# The shapes of a URDF <geometry> (urdfdom 6: capsule too); pybullet adds its own (plane, cdf, ...).
GEOMETRY_SHAPES = ("box", "cylinder", "sphere", "mesh", "capsule")


def _skip_unknown_geometry(root: ET.Element, path: Path) -> None:
    """Drop a link's ``<visual>`` or ``<collision>`` whose geometry is no URDF shape, with a warning.

    urdfdom drops it too, with an ``Error:`` (pybullet's ``<plane>``, ``<cdf>``); it is geometry,
    never a mass, an inertia, a joint or a frame of the dynamics.
    """
    skipped: list[str] = []
    for link in root.findall("link"):
        for kind in ("visual", "collision"):
            for element in link.findall(kind):
                geometry = element.find("geometry")
                shapes = [str(child.tag) for child in geometry] if geometry is not None else []
                if shapes and not any(shape in GEOMETRY_SHAPES for shape in shapes):
                    link.remove(element)
                    skipped.append(f"link {link.get('name')!r} <{kind}> <{shapes[0][:40]}>")
    if skipped:
        more = f" and {len(skipped) - 2} more" if len(skipped) > 2 else ""
        warnings.warn(
            ModelWarning(
                f"{path}: {', '.join(skipped[:2])}{more}: not a URDF shape (expected one of "
                f"{', '.join(GEOMETRY_SHAPES)}), skipped as urdfdom skips it (geometry only: masses, inertias, "
                "joints and frames are not touched)"
            ),
            stacklevel=3,
        )


def _check_depth(root: ET.Element, path: Path) -> None:
    """Refuse elements nested deeper than :data:`MAX_XML_DEPTH` (iteratively: no recursion)."""
    stack = [(root, 1)]
    while stack:
        element, depth = stack.pop()
        if depth > MAX_XML_DEPTH:
            raise ModelError(
                f"<{str(element.tag)[:40]}> is nested {depth} elements deep "
                f"(expected at most {MAX_XML_DEPTH}; a URDF nests about 7)",
                path=path,
            )
        stack.extend((child, depth + 1) for child in element)


_parse_xml = read_xml  # the name used before read_xml was public


@dataclass(frozen=True)
class SrdfInfo:
    """What robodyn reads from an SRDF."""

    has_rotor_params: bool
    passive_joints: tuple[str, ...]


def read_srdf(path: Path) -> SrdfInfo:
    """Read rotor parameters' presence and passive joints from an SRDF file."""
    root = read_xml(path, "SRDF")
    _check_srdf_root(root, path)
    rotors = [str(el.get("name")) for el in root.iterfind("rotor_params/joint")]
    twice = sorted({name for name in rotors if rotors.count(name) > 1})
    if twice:  # Pinocchio adds both rotors' J n^2 to the armature but keeps the last J and n: refuse, not guess
        raise ModelError(f"<rotor_params> names joint {twice[0]!r} twice (expected one rotor per joint)", path=path)
    passive = tuple(el.get("name", "") for el in root.iter("passive_joint"))
    return SrdfInfo(root.find("rotor_params") is not None, passive)


def _check_srdf_root(root: ET.Element, path: Path) -> None:
    """An SRDF is a ``<robot>`` of groups and states; a file with links or typed joints is a URDF."""
    if root.tag != "robot":
        raise ModelError(f"SRDF root element is <{root.tag}>, expected <robot>", path=path)
    if root.find("link") is not None or any(j.get("type") for j in root.findall("joint")):
        raise ModelError(
            "this is a URDF (it has <link> or <joint type=...>), not an SRDF (<group_state>, <passive_joint>, "
            "<rotor_params>, ...): give it as the model, or pass the robot's .srdf to --srdf",
            path=path,
        )


def _expand(path: Path) -> str:
    """``expand it first: xacro arm.urdf.xacro > arm.urdf (pip install xacro)``."""
    if path.name.endswith(".urdf.xacro"):
        target = path.stem
    elif path.suffix == ".xacro":
        target = f"{path.stem}.urdf"
    else:  # macros in a file named as a URDF: the expanded one needs another name
        target = f"{path.stem}_expanded.urdf"
    return f"expand it first: xacro {path.name} > {target} (pip install xacro)"


def _check_urdf_root(root: ET.Element, path: Path) -> None:
    if root.tag == "sdf":
        raise ModelError("root element is <sdf>, expected <robot>: " + str(not_urdf(Path("x.sdf"))), path=path)
    if root.tag != "robot":
        raise ModelError(f"root element is <{root.tag}>, expected <robot>", path=path)
    if any(element.tag.startswith(f"{{{XACRO}}}") for element in root.iter()):
        raise ModelError(f"holds xacro macros (<xacro:...>): robodyn reads plain URDF; {_expand(path)}", path=path)
    if not root.get("name"):
        raise ModelError("<robot> has no name attribute (an empty xacro stub?)", path=path)
    if root.find("link") is None:
        raise ModelError("the URDF has no <link>", path=path)


def reference_configurations(robot: Robot) -> dict[str, np.ndarray]:
    """The SRDF's named ``<group_state>`` configurations of ``robot``, each shape (nq,).

    Joints a group state does not mention keep their neutral value. Empty without SRDF.
    Works on reduced robots too (the state is read joint by joint by name).
    """
    if robot.srdf_path is None or not robot.srdf_path.is_file():
        return {}
    root = read_xml(robot.srdf_path, "SRDF")
    _check_srdf_root(root, robot.srdf_path)
    neutral = robot.neutral()
    states: dict[str, np.ndarray] = {}
    for group_state in root.iter("group_state"):
        name = group_state.get("name")
        if not name:
            continue
        q = neutral.copy()
        for el in group_state.iter("joint"):
            joint_name, value = el.get("name", ""), el.get("value", "")
            if joint_name not in robot.joint_names:
                continue
            joint = robot.joint(joint_name)
            try:
                values = [float(x) for x in value.split()]
            except ValueError:
                raise ModelError(
                    f"<group_state {name!r}> joint {joint_name!r} has value {value!r}, expected numbers",
                    path=robot.srdf_path,
                ) from None
            q[joint.idx_q : joint.idx_q + joint.nq] = joint_coordinates(joint.kind, joint.nq, values)
        states.setdefault(name, q)
    return states


@dataclass(frozen=True)
class MeshReference:
    """One ``<mesh filename=...>`` of a URDF: the link, visual or collision, URI and file."""

    link: str
    kind: str  # "visual" or "collision"
    uri: str
    path: Path | None  # the file it resolves to, or None when no candidate exists


def mesh_references(urdf: Path) -> list[MeshReference]:
    """Every mesh a URDF refers to, resolved like :func:`load_geometry` would (no mesh is read)."""
    root = read_xml(urdf, "URDF")
    dirs = package_dirs(urdf)
    refs: list[MeshReference] = []
    for link in root.findall("link"):
        for kind in ("visual", "collision"):
            for element in link.iter(kind):
                for mesh in element.iter("mesh"):
                    uri = mesh.get("filename", "")
                    refs.append(MeshReference(link.get("name", ""), kind, uri, resolve_resource(uri, dirs)))
    return refs


def resolve_resource(uri: str, package_dirs: Sequence[Path]) -> Path | None:
    """The file a URDF ``filename`` URI names, found the way Pinocchio finds it, or None.

    Mirrors ``pinocchio::retrieveResourcePath``: for ``package://`` and ``model://`` the
    part after ``://`` is appended to each package folder in turn (so ``package:///a/b``
    and ``package://a/b`` both look for ``<dir>/a/b``); ``file://`` is a plain path; a
    relative path is looked for next to the URDF, then in each package folder; an absolute
    path is taken as is. Folders of ``ROS_PACKAGE_PATH`` are searched after
    ``package_dirs``, as Pinocchio does. An unknown scheme finds nothing.
    """
    dirs = [*package_dirs, *_ros_package_dirs()]
    scheme, sep, rest = uri.partition("://")
    if sep:
        if scheme in ("package", "model"):
            relative = rest.lstrip("/")
            candidates = [Path(d) / relative for d in dirs]
        elif scheme == "file":
            candidates = [Path(rest)]
        else:
            return None
    else:
        path = Path(uri)
        candidates = [path] if path.is_absolute() else [Path(d) / path for d in dirs]
    for candidate in candidates:
        if candidate.is_file():
            return candidate
    return None


def _ros_package_dirs() -> list[Path]:
    """The folders of ``ROS_PACKAGE_PATH`` (Pinocchio adds them to every resource search)."""
    return [Path(d) for d in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if d]


@lru_cache(maxsize=1)
def robots_dir() -> Path | None:
    """The ``robots`` folder of the installed example-robot-data, or None if absent."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return None
    folder = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    return folder if folder.is_dir() else None


def package_dirs(urdf: Path) -> list[Path]:
    """Folders in which ``package://name/...`` URIs of ``urdf`` are resolved."""
    dirs = [urdf.resolve().parent, urdf.resolve().parent.parent, urdf.resolve().parent.parent.parent]
    folder = robots_dir()
    if folder is not None:
        # URIs read package://example-robot-data/robots/...: resolved from the share/ folder.
        dirs += [folder, folder.parent.parent]
    return dirs
