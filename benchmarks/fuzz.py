"""Fuzz robodyn with hostile input: mutated URDFs, command lines and scene files, each in a child process.

    python benchmarks/fuzz.py [--cases 10000] [--seed 0] [--jobs 2] [--out DIR (default bench-out)]
                              [--time-limit 60] [--memory-gib 4] [--only INDEX]

Each case is drawn from ``(seed, index)`` alone (``--only INDEX`` replays one), written into a
folder of its own and run in a child forked from this warm process (robodyn, Pinocchio, the
CLI and its lazy imports already loaded: a fork costs ~5 ms, a fresh Python ~0.4 s) under an
address-space cap (``RLIMIT_AS``) and an alarm, with file descriptors 1 and 2 captured to files.
Cases:

* ``api``, ``info``, ``check``: a URDF mutated from the built-ins and every example-robot-data
  robot (numbers, vectors, structure, inertia, XML, valid rewrites, big chains), through
  ``robodyn.load`` and through ``robodyn info`` / ``robodyn check`` (in the child, ``main([...])``);
* ``cli``: hostile command lines for ``simulate``, ``info``, ``check``, ``view --html`` and
  ``run --no-view`` (every flag of each parser, valid values and hostile ones);
* ``scene``: random TOML scenes (and unreadable ones) through ``robodyn run --no-view``.

The table counts exit codes, one-line violations (a refusal whose stderr is not exactly one
line, or a load that leaks native output), refusals that name none of their inputs (no flag, value,
file or scene string of the case appears in the line), files changed by a refusal, signals (by name), hangs
(past the time limit), tracebacks, unexpected exit codes, and accepted-but-wrong models: exit 0
while the loaded model differs from the file as an independent reading sees it (lxml/libxml2
and a strict number grammar, the links placed at q = 0 and summed per Pinocchio body, compared
in the world frame: :func:`model_differences`). ``--out`` gets ``fuzz.json`` (the table and
every finding) and ``failures/<index>/`` (each failing case's inputs, command and output).

The mutation catalogue and the oracle are shared with ``tests/test_properties.py``: they draw
through a :class:`Chooser`, which Hypothesis implements there and :class:`RandomChooser` here.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy: one thread per forked child

import argparse
import contextlib
import hashlib
import json
import math
import random
import re
import resource
import shutil
import signal
import sys
import tempfile
import time
import traceback
import xml.etree.ElementTree as ET
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, TypeVar

import numpy as np

if str(Path(__file__).resolve().parent) not in sys.path:  # the sibling modules, also when loaded by path (tests)
    sys.path.insert(0, str(Path(__file__).resolve().parent))

from _fuzz_scenes import toml_value  # after the path: the TOML writer the scene families share too

T = TypeVar("T")
ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"
BUILTIN_FILES = ("pendubot", "cart_pole", "geared_arm", "variants/cart_pole_point_bob", "variants/geared_arm_rotor")

# A child that raised out of robodyn (the traceback is on its stderr) exits with this code.
TRACEBACK_EXIT = 99
# Exit codes each command may return on any input: 1 only from check (a mismatch), 3 only from a run.
ALLOWED_EXITS = {
    "api": {0, 2},
    "info": {0, 2},
    "view": {0, 2},
    "check": {0, 1, 2},
    "simulate": {0, 2, 3},
    "run": {0, 1, 2, 3},  # 1: a [check] or closed form found a mismatch
    "sweep": {0, 2},
    "params": {0, 2},
}
# Pinocchio sums the links welded to a body with a few products per link, robodyn's loader and this
# oracle place them by other products: they agree to ~1e-15 of the body's scale; 1e-9 leaves room
# for a 1,000-link chain and is far below any printed digit.
ORACLE_RTOL = 1e-9


class Chooser(Protocol):
    """Where a case's random decisions come from (random.Random here, Hypothesis in the tests)."""

    def choice(self, options: Sequence[T]) -> T:
        """One of ``options``."""
        ...

    def integer(self, low: int, high: int) -> int:
        """A whole number in [low, high]."""
        ...

    def real(self, low: float, high: float) -> float:
        """A number in [low, high]."""
        ...


class RandomChooser:
    """:class:`Chooser` over ``random.Random(seed)``."""

    def __init__(self, seed: str | int) -> None:
        self.rng = random.Random(seed)

    def choice(self, options: Sequence[T]) -> T:
        return options[self.rng.randrange(len(options))]

    def integer(self, low: int, high: int) -> int:
        return self.rng.randint(low, high)

    def real(self, low: float, high: float) -> float:
        return self.rng.uniform(low, high)


# ============================================================================ the oracle


class UnreadableError(Exception):
    """The independent reading cannot read the file as a URDF."""


_STRICT_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def _numbers(element: Any, attribute: str, count: int, default: str) -> np.ndarray:
    """``count`` finite numbers of an attribute: plain ASCII decimals, a vector's separated by spaces."""
    text = element.get(attribute, default) if element is not None else default
    pieces = [p for p in text.split(" ") if p] if count > 1 else [text]
    if len(pieces) != count or not all(_STRICT_NUMBER.fullmatch(p) for p in pieces):
        raise UnreadableError(f"<{element.tag} {attribute}={text!r}> is not {count} plain number(s)")
    values = np.array([float(p) for p in pieces])
    if not np.all(np.isfinite(values)):
        raise UnreadableError(f"<{element.tag} {attribute}={text!r}> is not finite")
    return values


def _rpy(rpy: np.ndarray) -> np.ndarray:
    """URDF roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    (cr, cp, cy), (sr, sp, sy) = np.cos(rpy), np.sin(rpy)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _placement(origin: Any) -> tuple[np.ndarray, np.ndarray]:
    if origin is None:
        return np.eye(3), np.zeros(3)
    return _rpy(_numbers(origin, "rpy", 3, "0 0 0")), _numbers(origin, "xyz", 3, "0 0 0")


@dataclass
class BodySum:
    """Mass [kg], first moment m c [kg m] and inertia about the world origin [kg m^2] of some links at q = 0."""

    links: list[str] = field(default_factory=list)
    mass: float = 0.0
    moment: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    scale: float = 0.0  # sum of magnitudes: the rounding scale

    def add(self, mass: float, com: np.ndarray, inertia_about_com: np.ndarray) -> None:
        about_origin = inertia_about_com + mass * (float(com @ com) * np.eye(3) - np.outer(com, com))
        self.mass += mass
        self.moment = self.moment + mass * com
        self.inertia = self.inertia + about_origin
        self.scale += abs(mass) + float(np.abs(mass * com).max()) + float(np.abs(about_origin).max())


@dataclass
class FileRobot:
    """The robot of a URDF as read independently of robodyn: names, and each body's sums at q = 0."""

    links: set[str]
    moving_joints: set[str]
    bodies: dict[str | None, BodySum]  # moving joint name (None: the root link's body) -> its links' sums


def read_file_robot(path: Path) -> FileRobot:
    """Read ``path`` with lxml (libxml2, no DTD, no entities) and a strict number grammar.

    Raises:
        UnreadableError: not XML, not a tree of links and joints, or a number that is not plain.
    """
    from lxml import etree

    parser = etree.XMLParser(resolve_entities=False, load_dtd=False, no_network=True, remove_comments=True)
    try:
        tree = etree.parse(str(path), parser)
    except (etree.XMLSyntaxError, OSError, ValueError) as exc:
        raise UnreadableError(f"lxml: {exc}") from None
    if tree.docinfo.internalDTD is not None or tree.docinfo.doctype:
        raise UnreadableError("the file declares a DTD: urdfdom expands no entity, so it reads other numbers")
    root = tree.getroot()
    links = {str(link.get("name")): link for link in root.findall("link")}
    joints = root.findall("joint")
    parent_of: dict[str, Any] = {}
    for joint in joints:
        child = joint.find("child")
        if child is None or child.get("link") in parent_of:
            raise UnreadableError(f"joint {joint.get('name')!r}: no child, or a child with two parents")
        parent_of[str(child.get("link"))] = joint
    roots = [name for name in links if name not in parent_of]
    if len(roots) != 1 or len(links) != len(root.findall("link")):
        raise UnreadableError(f"not one tree: roots {roots[:3]}, {len(root.findall('link'))} links")
    placed: dict[str, tuple[np.ndarray, np.ndarray, str | None]] = {roots[0]: (np.eye(3), np.zeros(3), None)}
    children: dict[str, list[Any]] = {}
    for joint in joints:
        children.setdefault(str(joint.find("parent").get("link")), []).append(joint)
    stack = [roots[0]]
    while stack:  # place every link at q = 0; its body is the nearest moving joint above it
        link = stack.pop()
        rotation, position, body = placed[link]
        for joint in children.get(link, ()):
            child = str(joint.find("child").get("link"))
            if child in placed:
                raise UnreadableError(f"link {child!r} is reached twice")
            R, p = _placement(joint.find("origin"))
            moving = joint.get("type") != "fixed"
            placed[child] = (rotation @ R, position + rotation @ p, str(joint.get("name")) if moving else body)
            stack.append(child)
    if len(placed) != len(links):
        raise UnreadableError("a cycle: some links are not below the root")
    bodies: dict[str | None, BodySum] = {}
    for name, link in links.items():
        rotation, position, body = placed[name]
        inertial = link.find("inertial")
        total = bodies.setdefault(body, BodySum())
        total.links.append(name)
        if inertial is None:
            continue
        R, p = _placement(inertial.find("origin"))
        mass = float(_numbers(inertial.find("mass"), "value", 1, "")[0])
        el = inertial.find("inertia")
        i = {k: float(_numbers(el, k, 1, "")[0]) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        tensor = np.array(
            [[i["ixx"], i["ixy"], i["ixz"]], [i["ixy"], i["iyy"], i["iyz"]], [i["ixz"], i["iyz"], i["izz"]]]
        )
        world = rotation @ R
        total.add(mass, position + rotation @ p, world @ tensor @ world.T)
    moving = {str(j.get("name")) for j in joints if j.get("type") != "fixed"}
    return FileRobot(set(links), moving, bodies)


def model_differences(model: Any, path: Path) -> list[str]:
    """How the Pinocchio ``model`` differs from the URDF at ``path`` (empty: the same robot).

    Compared: the moving joints' names, the links' names (Pinocchio body frames), and for each
    body its mass, first moment and inertia about the world origin at the neutral configuration.
    A free-flyer root (``root_joint``, not in the file) carries the root link's body.
    """
    import pinocchio as pin

    try:
        robot = read_file_robot(path)
    except UnreadableError as exc:
        return [f"accepted a file that an independent reading refuses: {exc}"]
    names = [str(n) for n in model.names]
    free = "root_joint" in names and "root_joint" not in robot.moving_joints
    in_model = set(names[1:]) - ({"root_joint"} if free else set())
    out = []
    if in_model != robot.moving_joints:
        out.append(f"joints: model has {sorted(in_model ^ robot.moving_joints)[:4]} differently")
    frames = {str(f.name) for f in model.frames if f.type == pin.FrameType.BODY}
    if not robot.links <= frames:
        out.append(f"links missing from the model: {sorted(robot.links - frames)[:4]}")
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    for key, expected in robot.bodies.items():
        index = (names.index("root_joint") if free else 0) if key is None else names.index(key) if key in names else -1
        if index < 0:
            continue  # reported with the joint names
        world = data.oMi[index].act(model.inertias[index])
        got = BodySum()
        got.add(float(world.mass), np.array(world.lever), np.array(world.inertia))
        tol = ORACLE_RTOL * max(expected.scale, got.scale, 1e-300)
        where = f"body {key or '(root)'} ({', '.join(expected.links[:3])})"
        if abs(got.mass - expected.mass) > tol:
            out.append(f"{where}: mass {got.mass!r} in the model, {expected.mass!r} in the file")
        elif float(np.abs(got.moment - expected.moment).max()) > tol:
            out.append(f"{where}: first moment {got.moment} in the model, {expected.moment} in the file")
        elif float(np.abs(got.inertia - expected.inertia).max()) > tol:
            out.append(f"{where}: inertia differs by {float(np.abs(got.inertia - expected.inertia).max()):.3g}")
    return out


# ============================================================================ URDF mutations

ARABIC, FULLWIDTH = (str.maketrans("0123456789", d) for d in ("٠١٢٣٤٥٦٧٨٩", "０１２３４５６７８９"))
NUMBER_ATTRIBUTES = "value|ixx|ixy|ixz|iyy|iyz|izz|xyz|rpy|lower|upper|effort|velocity|damping|friction|radius|length"
_ATTRIBUTE = re.compile(rf'(\s(?:{NUMBER_ATTRIBUTES}|size|scale|rgba|multiplier|offset)=")([^"]*)(")')
VECTORS = ("xyz=", "rpy=", "size=", "scale=", "rgba=")


def _underscore(v: str) -> str:
    return re.sub(r"([0-9])([0-9.])", r"\1_\2", v, count=1) if re.search(r"[0-9][0-9.]", v) else v + "_0"


# (label, rewrite of one number as it appears in the file); some are refused, some must load as written
NUMBER_FORMS: list[tuple[str, Callable[[str], str]]] = [
    ("spaces", lambda v: f" {v} "),
    ("leading space", lambda v: " " + v),
    ("trailing tab", lambda v: v + "\t"),
    ("tab reference", lambda v: v + "&#9;"),
    ("newline reference", lambda v: "&#10;" + v),
    ("underscore", _underscore),
    ("arabic digits", lambda v: v.translate(ARABIC)),
    ("fullwidth digits", lambda v: v.translate(FULLWIDTH)),
    ("no-break space", lambda v: v + "\u00a0"),
    ("no-break space reference", lambda v: "&#160;" + v),
    ("decimal comma", lambda v: v.replace(".", ",") if "." in v else v + ",5"),
    ("hexadecimal", lambda v: "0x1p-3"),
    ("nan", lambda v: "nan"),
    ("NaN", lambda v: "NaN"),
    ("inf", lambda v: "inf"),
    ("-inf", lambda v: "-inf"),
    ("overflow", lambda v: "1e400"),
    ("underflow", lambda v: "1e-400"),
    ("subnormal", lambda v: "1e-310"),
    ("smallest subnormal", lambda v: "4.9e-324"),
    ("huge", lambda v: "1e308"),
    ("large", lambda v: "1e30"),
    ("negative", lambda v: "-" + v.lstrip("+-")),
    ("plus sign", lambda v: "+" + v.lstrip("+-")),
    ("zero", lambda v: "0"),
    ("minus zero", lambda v: "-0"),
    ("empty", lambda v: ""),
    ("junk suffix", lambda v: v + "x"),
    ("two dots", lambda v: "1..2"),
    ("exponent alone", lambda v: "e5"),
    ("character references", lambda v: "".join(f"&#{ord(c)};" for c in v)),
    ("leading zeros", lambda v: "00" + v.lstrip("+-")),
    ("repr", lambda v: repr(float(v)) if _STRICT_NUMBER.fullmatch(v) else v),
    ("exponent form", lambda v: f"{float(v):.17e}" if _STRICT_NUMBER.fullmatch(v) else v),
    ("mass limits", lambda v: "1e-12"),
    ("below the mass limit", lambda v: "9.9e-13"),
    ("at the mass limit", lambda v: "1e6"),
    ("past the mass limit", lambda v: "1000001"),
    ("inertia limit", lambda v: "1e9"),
    ("past the inertia limit", lambda v: "1.1e9"),
    ("smallest normal", lambda v: "2.2250738585072014e-308"),
    ("length limit", lambda v: "1e4"),
    ("past the length limit", lambda v: "10001"),
]
SEPARATOR_FORMS: list[tuple[str, Callable[[list[str]], str]]] = [
    ("tab separator", lambda p: "\t".join(p)),
    ("tab reference separator", lambda p: "&#9;".join(p)),
    ("double spaces", lambda p: "  ".join(p)),
    ("padded", lambda p: "  " + " ".join(p) + " "),
    ("no-break space separator", lambda p: "\u00a0".join(p)),
    ("comma separator", lambda p: ",".join(p)),
    ("missing component", lambda p: " ".join(p[:-1])),
    ("extra component", lambda p: " ".join([*p, "0"])),
    ("newline separator", lambda p: "\n".join(p)),
]


def _attribute(text: str, pick: Chooser, *, vector: bool = False) -> re.Match[str] | None:
    """One numeric attribute of ``text`` (a vector one with ``vector``), or None."""
    matches = [m for m in _ATTRIBUTE.finditer(text) if not vector or _is_vector(m)]
    return matches[pick.integer(0, len(matches) - 1)] if matches else None


def _is_vector(m: re.Match[str]) -> bool:
    return m.group(1).strip().rstrip('"').endswith(VECTORS)


def _pieces(m: re.Match[str]) -> list[str]:
    value = m.group(2)
    pieces = [p for p in value.split(" ") if p] if _is_vector(m) else [value]
    return pieces or [""]


def _replaced(text: str, m: re.Match[str], new: str) -> str:
    return text[: m.start(2)] + new + text[m.end(2) :]


def mutate_number(text: str, pick: Chooser, forms: Sequence[tuple[str, Callable[[str], str]]] = ()) -> tuple[str, str]:
    """One numeric attribute of ``text`` rewritten: a number's form, or a vector's separators."""
    m = _attribute(text, pick)
    if m is None:
        return "number: none", text
    pieces = _pieces(m)
    if len(pieces) > 1 and not forms and pick.integer(0, 2) == 0:
        label, form = pick.choice(SEPARATOR_FORMS)
        return f"number: {label}", _replaced(text, m, form(pieces))
    label, rewrite = pick.choice(forms or NUMBER_FORMS)
    k = pick.integer(0, len(pieces) - 1)
    pieces[k] = rewrite(pieces[k])
    return f"number: {label}", _replaced(text, m, " ".join(pieces))


def _tree(text: str) -> ET.Element:
    return ET.fromstring(text.encode("utf-8"))


def _text(root: ET.Element) -> str:
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode")


def _below(root: ET.Element, link: str) -> list[str]:
    """``link`` and every link below it."""
    children: dict[str, list[str]] = {}
    for j in root.findall("joint"):
        p, c = j.find("parent"), j.find("child")
        if p is not None and c is not None:
            children.setdefault(str(p.get("link")), []).append(str(c.get("link")))
    out, stack = [], [link]
    while stack and len(out) < 10_000:
        name = stack.pop()
        out.append(name)
        stack.extend(children.get(name, ()))
    return out


def _inertial(mass: str, tensor: np.ndarray, xyz: str = "0 0 0") -> str:
    t = [[float(x) for x in row] for row in tensor]
    return (
        f'<inertial><origin xyz="{xyz}" rpy="0 0 0"/><mass value="{mass}"/>'
        f'<inertia ixx="{t[0][0]!r}" ixy="{t[0][1]!r}" ixz="{t[0][2]!r}" iyy="{t[1][1]!r}" '
        f'iyz="{t[1][2]!r}" izz="{t[2][2]!r}"/></inertial>'
    )


PRINCIPAL_MOMENTS = [
    ("valid", (1e-3, 2e-3, 2.5e-3)),
    ("valid thin rod", (0.0, 4e-3, 4e-3)),
    ("valid equal", (2e-3, 2e-3, 2e-3)),
    ("triangle broken (1, 1, 3)", (1e-3, 1e-3, 3e-3)),
    ("negative moment", (1e-3, 2e-3, -5e-4)),
    ("zero", (0.0, 0.0, 0.0)),
    ("dust", (1e-40, 1e-40, 1e-40)),
    ("huge", (1e10, 1e10, 1e10)),
]


def mutate_inertia(
    text: str, pick: Chooser, *, valid: bool = False, moments: tuple[str, tuple[float, ...]] | None = None
) -> tuple[str, str]:
    """One link's inertia replaced by R diag(principal ``moments``) R^T, rotated by random angles."""
    root = _tree(text)
    links = [link for link in root.findall("link") if link.find("inertial") is not None] or root.findall("link")
    link = pick.choice(links)
    label, moments = moments or pick.choice(
        [m for m in PRINCIPAL_MOMENTS if m[0].startswith("valid")] if valid else PRINCIPAL_MOMENTS
    )
    R = _rpy(np.array([pick.real(-math.pi, math.pi) for _ in range(3)]))
    tensor = R @ np.diag(moments) @ R.T
    mass = pick.choice(["1.0", "0.25"] if valid else ["1.0", "0.25", "0", "-1", "1e-12"])
    for old in link.findall("inertial"):
        link.remove(old)
    link.append(ET.fromstring(_inertial(mass, tensor)))
    return f"inertia: {label}, mass {mass}", _text(root)


def _joint_of(root: ET.Element, pick: Chooser) -> ET.Element | None:
    joints = root.findall("joint")
    return pick.choice(joints) if joints else None


def _set_link(joint: ET.Element | None, end: str, name: str) -> None:
    if joint is not None and joint.find(end) is not None:
        joint.find(end).set("link", name)  # type: ignore[union-attr]


def _rename(root: ET.Element, old: str, new: str) -> None:
    for link in root.findall("link"):
        if link.get("name") == old:
            link.set("name", new)
    for joint in root.findall("joint"):
        for end in ("parent", "child"):
            el = joint.find(end)
            if el is not None and el.get("link") == old:
                el.set("link", new)


def mutate_structure(text: str, pick: Chooser, *, op: str | None = None, valid: bool = False) -> tuple[str, str]:
    """One change to the tree: cycles, self-loops, names, missing parts, joint types, axes, inertials."""
    root = _tree(text)
    links, joint = root.findall("link"), _joint_of(root, pick)
    link = pick.choice(links)
    name = str(link.get("name"))
    op = op or pick.choice(STRUCTURE_OPS)
    if op == "cycle" and joint is not None:
        _set_link(joint, "parent", pick.choice(_below(root, str(joint.find("child").get("link")))))  # type: ignore[union-attr]
    elif op == "self-loop" and joint is not None:
        _set_link(joint, "parent", str(joint.find("child").get("link")))  # type: ignore[union-attr]
    elif op == "two parents" and joint is not None:
        _set_link(joint, "child", name)
    elif op == "duplicate link name" and len(links) > 1:
        links[-1].set("name", str(links[0].get("name")))
    elif op == "duplicate joint name" and len(root.findall("joint")) > 1:
        root.findall("joint")[-1].set("name", str(root.findall("joint")[0].get("name")))
    elif op == "missing parent link":
        _set_link(joint, "parent", "no_such_link")
    elif op == "no parent element" and joint is not None and joint.find("parent") is not None:
        joint.remove(joint.find("parent"))  # type: ignore[arg-type]
    elif op == "orphan link":
        root.append(ET.fromstring('<link name="orphan"/>'))
    elif op == "joint removed" and joint is not None:
        root.remove(joint)
    elif op == "joint type" and joint is not None:
        joint.set(
            "type", pick.choice(["fixed", "continuous", "prismatic", "revolute", "floating", "planar", "ball", ""])
        )
    elif op == "axis" and joint is not None:
        axis = joint.find("axis")
        if axis is None:
            axis = ET.SubElement(joint, "axis")
        axis.set("xyz", pick.choice(["0 0 0", "nan 0 0", "1e-200 0 0", "1e200 0 0", "0 0 1e-101", "1 1 1", "0 -1 0"]))
    elif op == "inertial removed" and link.find("inertial") is not None:
        link.remove(link.find("inertial"))  # type: ignore[arg-type]
    elif op == "mass removed" and link.find("inertial/mass") is not None:
        link.find("inertial").remove(link.find("inertial/mass"))  # type: ignore[union-attr, arg-type]
    elif op == "inertia term removed" and link.find("inertial/inertia") is not None:
        del link.find("inertial/inertia").attrib[pick.choice(["ixx", "ixy", "iyz", "izz"])]  # type: ignore[union-attr]
    elif op == "second inertial" and link.find("inertial") is not None:
        link.append(ET.fromstring(_inertial("2.0", np.diag([1e-3, 1e-3, 1e-3]))))
    elif op == "root mass negative":
        top = _root_link(root)
        if top is not None:
            for old in top.findall("inertial"):
                top.remove(old)
            top.append(ET.fromstring(_inertial("-3", np.diag([1e-3, 1e-3, 1e-3]))))
    elif op == "welded link":
        mass = pick.choice(["0.5", "0.5", "-1", "0", "1e-13", "2e6"] if not valid else ["0.5", "0"])
        xyz = pick.choice(["0.1 0 0", "0 0.2 -0.1", "0 0 0", "1e5 0 0"] if not valid else ["0.1 0 0", "0 0.2 -0.1"])
        rpy = pick.choice(["0 0 0", "0.3 -0.2 1.1"])
        root.append(ET.fromstring(f'<link name="welded">{_inertial(mass, np.diag([2e-4, 3e-4, 4e-4]), xyz)}</link>'))
        root.append(
            ET.fromstring(
                f'<joint name="weld" type="fixed"><parent link="{name}"/><child link="welded"/>'
                f'<origin xyz="0.05 0.01 0" rpy="{rpy}"/></joint>'
            )
        )
    elif op == "names":
        _rename(root, name, pick.choice(["a\nb", "x" * 5000, "é_link", "<&>", " ", "universe", "root_joint", ""]))
    elif op == "mimic" and joint is not None:
        ET.SubElement(joint, "mimic", joint=pick.choice([str(joint.get("name")), "no_such_joint"]), multiplier="2")
    elif op == "reordered":
        children = list(root)
        for child in children:
            root.remove(child)
        for k in sorted(range(len(children)), key=lambda k: (k * 7919) % (len(children) + 1)):
            root.append(children[k])
    return f"structure: {op}", _text(root)


def _root_link(root: ET.Element) -> ET.Element | None:
    children = {str(c.get("link")) for j in root.findall("joint") for c in j.findall("child")}
    return next((link for link in root.findall("link") if link.get("name") not in children), None)


STRUCTURE_OPS = [
    "cycle", "self-loop", "two parents", "duplicate link name", "duplicate joint name", "missing parent link",
    "no parent element", "orphan link", "joint removed", "joint type", "axis", "inertial removed", "mass removed",
    "inertia term removed", "second inertial", "root mass negative", "welded link", "welded link", "names",
    "mimic", "reordered",
]  # fmt: skip


def mutate_xml(text: str, pick: Chooser, *, op: str | None = None) -> tuple[str, bytes]:
    """A change at the XML level: DTDs and entities, encodings, nesting, size, broken bytes."""
    op = op or pick.choice(XML_OPS)
    body = re.sub(r"^\s*<\?xml[^>]*\?>\s*", "", text)
    decl = '<?xml version="1.0"?>\n'
    if op == "internal entity":
        body = re.sub(r'(<mass value=")[^"]*', r"\1&m;", body, count=1)
        return op, (decl + '<!DOCTYPE robot [<!ENTITY m "1.336">]>\n' + body).encode()
    if op == "external entity":
        body = body.replace("<link ", "<link data='&x;' ", 1)
        return op, (decl + '<!DOCTYPE robot [<!ENTITY x SYSTEM "file:///etc/hostname">]>\n' + body).encode()
    if op == "billion laughs":
        ents = '<!ENTITY a "aaaaaaaaaa">' + "".join(
            f'<!ENTITY {c} "{("&" + p + ";") * 10}">' for p, c in zip("abcde", "bcdef", strict=True)
        )
        return op, (decl + f"<!DOCTYPE robot [{ents}]>\n" + body.replace("<link ", "<link data='&f;' ", 1)).encode()
    if op == "latin-1":
        body = re.sub(r'<robot name="([^"]*)"', r'<robot name="\1_é"', body, count=1)
        return op, ('<?xml version="1.0" encoding="ISO-8859-1"?>\n' + body).encode("latin-1", "replace")
    if op == "utf-16":
        return op, ('<?xml version="1.0" encoding="UTF-16"?>\n' + body).encode("utf-16")
    if op == "unknown encoding":
        return op, ('<?xml version="1.0" encoding="x-bogus-8"?>\n' + body).encode()
    if op == "declared utf-16, written utf-8":
        return op, ('<?xml version="1.0" encoding="UTF-16"?>\n' + body).encode()
    if op == "byte order mark":
        return op, b"\xef\xbb\xbf" + (decl + body).encode()
    if op == "deep nesting":
        depth = pick.choice([10, 70, 5000])
        return f"{op} {depth}", (
            decl + body.replace("</robot>", "<a>" * depth + "</a>" * depth + "</robot>", 1)
        ).encode()
    if op == "long comment":
        size = pick.choice([10_000, 2_000_000, 9_000_000])
        return f"{op} {size}", (decl + body.replace("<link ", f"<!-- {'c' * size} --><link ", 1)).encode()
    if op == "long attribute":
        return op, (decl + body.replace("<robot ", f'<robot data="{"a" * 3_000_000}" ', 1)).encode()
    data = (decl + body).encode()
    if op == "truncated":
        return op, data[: pick.integer(0, len(data) - 1)]
    if op == "byte changed":
        k = pick.integer(0, len(data) - 1)
        return op, data[:k] + bytes([pick.integer(0, 255)]) + data[k + 1 :]
    if op == "junk inserted":
        k = pick.integer(0, len(data))
        return op, data[:k] + pick.choice([b"<", b"&", b"\x00", b"]]>", b"<!--", "\ufffe".encode(), b"\xff"]) + data[k:]
    if op == "empty":
        return op, pick.choice([b"", b"   \n", b"<robot/>", b'<robot name="r"/>', b"<?xml version='1.0'?>"])
    if op == "not a robot":
        return op, pick.choice(
            [b"<html></html>", b"\x89PNG\r\n\x1a\n\x00\x00", b'{"robot": 1}', b"<robot name='r'><link/>"]
        )
    if op == "processing instruction and CDATA":
        return op, (decl + body.replace("</robot>", "<?robodyn x?><![CDATA[ <link name='x'/> ]]></robot>", 1)).encode()
    if op == "namespaces":
        return op, (decl + body.replace("<robot ", '<robot xmlns:x="urn:x" x:flag="1" ', 1)).encode()
    return op, data


XML_OPS = [
    "internal entity", "external entity", "billion laughs", "latin-1", "utf-16", "unknown encoding",
    "declared utf-16, written utf-8", "byte order mark", "deep nesting", "long comment", "long attribute",
    "truncated", "byte changed", "junk inserted", "empty", "not a robot", "processing instruction and CDATA",
    "namespaces",
]  # fmt: skip


VALID_FORMS = [f for f in NUMBER_FORMS if f[0] in ("repr", "exponent form", "plus sign", "leading zeros")] + [
    ("character references", lambda v: "".join(f"&#{ord(c)};" for c in v)),
    ("scaled x2", lambda v: repr(2.0 * float(v)) if _STRICT_NUMBER.fullmatch(v) else v),
    ("scaled x1.0000001", lambda v: repr(1.0000001 * float(v)) if _STRICT_NUMBER.fullmatch(v) else v),
]


def mutate_valid(text: str, pick: Chooser) -> tuple[str, str | bytes]:
    """A rewrite that keeps the file a valid URDF (a changed number included): it must load as written."""
    op = pick.choice(["number", "number", "padded vector", "inertia", "welded link", "reordered", "comment", "xml"])
    if op == "number":
        return mutate_number(text, pick, VALID_FORMS)
    if op == "padded vector":
        m = _attribute(text, pick, vector=True)
        return "valid: padded vector", text if m is None else _replaced(text, m, "  " + "  ".join(_pieces(m)) + " ")
    if op == "inertia":
        return mutate_inertia(text, pick, valid=True)
    if op in ("welded link", "reordered"):
        return mutate_structure(text, pick, op=op, valid=True)
    if op == "comment":
        ends = [m.end() for m in re.finditer(r"/>|</link>|</joint>", text)]
        k = pick.choice(ends) if ends else len(text)
        return "valid: comment", text[:k] + "<!-- a comment -->" + text[k:]
    label, data = mutate_xml(text, pick, op=pick.choice(VALID_XML_OPS))
    return f"valid: {label}", data


VALID_XML_OPS = ["latin-1", "utf-16", "byte order mark", "processing instruction and CDATA", "namespaces"]


def chain(links: int, *, moving_every: int = 1) -> str:
    """A serial chain of ``links`` links; every ``moving_every``-th joint revolutes, the others are fixed."""
    inertial = _inertial("0.1", np.diag([1e-4, 1e-4, 1e-4]), "0 0 0.05")
    parts = ['<?xml version="1.0"?>\n<robot name="chain">']
    for k in range(links):
        parts.append(f'<link name="l{k}">{inertial}</link>')
        if k:
            kind = "revolute" if k % moving_every == 0 else "fixed"
            parts.append(
                f'<joint name="j{k}" type="{kind}"><parent link="l{k - 1}"/><child link="l{k}"/>'
                '<origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 1 0"/>'
                '<limit lower="-3" upper="3" effort="10" velocity="10"/></joint>'
            )
    return "\n".join([*parts, "</robot>\n"])


BIG = [("chain 150", 150, 1), ("chain 202 (201 DOF)", 202, 1), ("chain 1000 half fixed", 1000, 2),
       ("chain 1001", 1001, 2), ("chain 5000", 5000, 1)]  # fmt: skip


def urdf_mutation(text: str, pick: Chooser) -> tuple[str, str, bytes]:
    """One mutation of the URDF ``text``: (its family, what was done, the bytes of the file)."""
    family = pick.choice(
        ["number"] * 4 + ["structure"] * 3 + ["inertia"] * 2 + ["xml"] * 2 + ["twice", "valid"] + ["valid"] * 4
    )
    out: str | bytes
    if family == "valid":
        label, out = mutate_valid(text, pick)
        label = label.removeprefix("valid: ")
    elif family == "number":
        label, out = mutate_number(text, pick)
    elif family == "structure":
        label, out = mutate_structure(text, pick)
    elif family == "inertia":
        label, out = mutate_inertia(text, pick)
    elif family == "xml":
        label, out = mutate_xml(text, pick)
    else:
        first, out = mutate_number(text, pick)
        second, out = mutate_structure(out, pick) if "&" not in out else mutate_number(out, pick)
        label = f"{first} + {second}"
    return family, label.removeprefix(f"{family}: "), out if isinstance(out, bytes) else out.encode("utf-8")


# ============================================================================ command lines and scenes

HOSTILE_VALUES = [
    "0", "-1", "-0", "1e9", "1e308", "1e309", "nan", "inf", "-inf", "", " ", "abc", "1,2", "1,,2", ",", "1e-320",
    "0x10", "1_0", "٣", "１", "\u00a01", "9" * 400, "a" * 5000, "-", "--", "\n", "x\ny", "=", "1e2,nan",
    "1e200,0", "-3.0,4", "0.3,-0.2,0.1,0.5", "2", "0.5", "1e-9",
]  # fmt: skip
PATHS = ["x.npz", "x.partial.npz", "sub/x.npz", "x.csv", "/nonexistent/x.npz", "model.urdf", "t.npz", ".", "p.json",
         "x.html", "scene.toml", "nested/deeper/x.npz"]  # fmt: skip
FLAG_VALUES: dict[str, list[str]] = {
    "--duration": ["0.05", "0.2", "0.1"],
    "--dt": ["0.01", "0.001", "0.05", "0.3"],
    "--q0": ["0.3,-0.2", "0.1", "0.1,0.2,0.3", "1,0,0", "0,0,0,0"],
    "--v0": ["0,0", "1e200,0", "0.5,0.5", "3"],
    "--torque": ["0.1,0", "1e6,0", "0", "joint1=0.5", "nope=1"],
    "--integrator": [
        "rk4",
        "euler",
        "dopri5",
        "semi_implicit_euler",
        "implicit_midpoint",
        "scipy_rk45",
        "list",
        "nope",
    ],
    "--backend": ["aba", "crba", "formula", "nope"],
    "--rtol": ["1e-6", "1e-9", "1e-300"],
    "--atol": ["1e-8", "1"],
    "--max-energy-growth": ["1", "1e-9", "100"],
    "--samples": ["1", "2", "3"],
    "--seed": ["0", "7", "-1", "18446744073709551616"],
    "--formula": ["pendubot", "cart_pole", "geared_arm", "auto", "nope", "missing.py"],
    "--params": ["p.json", "deep.json", "zero.json", "nope.json", "model.urdf", "bad.json"],
    "--formula-timeout": ["5", "0", "1e9"],
    "--srdf": ["x.srdf", "nope.srdf", "model.urdf", "deep.json"],
    "--speed": ["1", "2", "0", "1e9"],
    "--fps": ["30", "1", "1e9", "100000"],
    "--q": ["0.1,0.2", "0", "1,2,3"],
    "--trace": ["link2", "nope", ""],
    "--lock": ["joint1=0.3", "joint2=1e9", "nope=0", "joint1"],
    "--keep": ["joint1", "joint2", "nope", "joint1,joint2"],
    "--reference": ["default", "nope"],
}
FORBIDDEN_FLAGS = {"--view", "--open", "--zmq-url", "--port", "--no-view", "--html", "-h", "--help", "--version"}
VALID_MODELS = ["pendubot", "cart_pole", "geared_arm", "model.urdf", "ur5"]
MODELS_GIVEN = ["pendubot", "cart_pole", "geared_arm", "ur5", "model.urdf", "nope", "", ".", "t.npz", "p.json",
                "a" * 300, "pendubot\n", "model.urdf/", "/nonexistent/m.urdf"]  # fmt: skip


def _options(command: str) -> list[tuple[str, Any]]:
    """(flag, action) of every option of ``command`` (from robodyn's own parser)."""
    from robodyn.cli import get_argument_parser

    parser = get_argument_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return [(a.option_strings[-1], a) for a in sub.choices[command]._actions if a.option_strings]


def command_line(pick: Chooser, options: dict[str, list[tuple[str, Any]]]) -> tuple[str, list[str]]:
    """A hostile or valid command line for simulate, info, check, view (--html) or run (--no-view)."""
    command = pick.choice(["simulate", "simulate", "info", "check", "check", "view", "run"])
    if command == "run":
        argv = ["run", pick.choice(["scene.toml", "scene.toml", "nope.toml", "model.urdf", "deep.json"]), "--no-view"]
        if pick.integer(0, 1):
            argv += ["--out", pick.choice(["out", "model.urdf", "t.npz", "/nonexistent/o", "scene.toml", "."])]
        return command, argv
    argv = [command, pick.choice(VALID_MODELS if pick.integer(0, 2) else MODELS_GIVEN)]
    if command == "check" and pick.integer(0, 3) == 0:
        argv.append(pick.choice(MODELS_GIVEN))
    if command == "view":
        if pick.integer(0, 3):
            argv.append(pick.choice(["t.npz", "t.npz", "bad.npz", "shadow.npz", "nope.npz", "model.urdf"]))
        argv += [
            "--html",
            pick.choice(["v.html", "v.html", "t.npz", "model.urdf", "sub/v.html", "/nonexistent/v.html"]),
        ]
    usable = [(f, a) for f, a in options[command] if f not in FORBIDDEN_FLAGS]
    for _ in range(pick.integer(0, 4)):
        flag, action = pick.choice(usable)
        if action.nargs == 0:
            argv.append(flag)
            continue
        known = FLAG_VALUES.get(flag, [])
        pool = list(action.choices or []) + known if pick.integer(0, 3) else HOSTILE_VALUES + PATHS
        argv += [flag, pick.choice(pool or HOSTILE_VALUES)]
    if command == "simulate" and "--duration" not in argv:
        argv += ["--duration", "0.05"]  # the default, 2 s, is a valid but slower run
    if command == "check" and "--samples" not in argv:
        argv += ["--samples", "2"]
    return command, argv


NUMBERS: list[Any] = [0.05, 0.2, 0.01, 0.001, 0, -1, 1e9, float("nan"), float("inf"), 2**63, 2**64, 1.5, "abc", True]
SCENE_KEYS: dict[str, dict[str, list[Any]]] = {
    "model": {
        "name": ["pendubot", "cart_pole", "geared_arm", "ur5", "nope", 3, ""],
        "urdf": ["model.urdf", "nope.urdf", "t.npz", ""],
        "srdf": ["x.srdf", "nope.srdf"],
        "free_flyer": [True, False, "yes"],
        "mimic": [True, False],
        "keep": [["joint1"], ["nope"], [], "joint1", [1]],
        "lock": [{"joint1": 0.3}, {"joint2": 1e9}, {"nope": 0}, [0.3]],
        "reference": ["default", "nope"],
    },
    "initial": {
        "q": [[0.1, 0.2], [0.3], {"joint1": 0.3}, [float("nan"), 0], "abc", [[[[0.1]]]], {"nope": 1}],
        "v": [[0.0, 0.0], [1e200, 0], [float("inf"), 0], {"joint2": -1}],
    },
    "control": {
        "kind": ["none", "constant", "pd", "nope"],
        "torque": [[0.1, 0], {"joint1": 1e6}, [float("nan")], "x"],
        "kp": [50.0, -1, float("inf")],
        "kd": [5.0, -1],
        "target": [{"joint1": 0.0}, [0.1, 0.2], {"nope": 0}],
        "gravity_compensation": [True, False, 1],
    },
    "simulate": {
        "duration": [0.05, 0.2, 0, -1, 1e9, float("nan"), "abc"],
        "dt": [0.01, 0.001, 0.05, 0, 1e-12, float("inf")],
        "integrator": ["rk4", "euler", "dopri5", "symplectic_euler", "nope", 4],
        "backend": ["aba", "crba", "formula", "nope"],
    },
    "check": {
        "samples": [2, 0, 100_000_000, -1, 1.5],
        "seed": [0, -1, 2**63, 2**64],
        "formula": ["pendubot", "nope", "auto"],
        "exactness": [True, False],
    },
    "bench": {"repeat": [1, 3, 0, 10**9]},
    "view": {"html": ["v.html", "t.npz"], "port": [70000, 0, 8080], "open": [False, True]},
    "output": {"dir": ["out", "", "model.urdf", "/nonexistent/o"]},
}


SIM = {"duration": 0.05, "dt": 0.001, "integrator": "rk4"}
VALID_SCENES: list[dict[str, dict[str, Any]]] = [
    {"model": {"name": "pendubot"}, "simulate": dict(SIM)},
    {"model": {"urdf": "model.urdf"}, "initial": {"q": [0.3, -0.2]}, "simulate": dict(SIM), "check": {"samples": 2}},
    {
        "model": {"name": "cart_pole"},
        "control": {"kind": "pd", "kp": 5.0, "kd": 1.0, "target": {"hinge": 0.0}},
        "simulate": dict(SIM),
    },
    {
        "model": {"name": "ur5", "keep": ["shoulder_lift_joint", "elbow_joint"]},
        "simulate": dict(SIM),
        "check": {"samples": 2, "exactness": True},
    },
    {"model": {"name": "geared_arm"}, "control": {"kind": "constant", "torque": [0.1]}, "simulate": dict(SIM)},
    {"model": {"name": "pendubot"}, "simulate": dict(SIM), "view": {"html": "v.html"}, "output": {"dir": "out"}},
    {"model": {"name": "pendubot", "lock": {"joint2": 0.3}}, "initial": {"q": {"joint1": 0.2}}, "bench": {"repeat": 2}},
]
UNREADABLE_SCENES = [
    ("not UTF-8", b"[model]\nname = '\xff\xfe'\n"),
    ("deep", b"[model]\nname = 'pendubot'\n[initial]\nq = " + b"[" * 5000 + b"]" * 5000 + b"\n"),
    ("huge", b"# " + b"x" * (1024 * 1024 + 10) + b"\n"),
    ("not TOML", b"[model\nname = \n"),
    ("empty", b""),
    ("binary", bytes(range(256))),
]


def scene_text(pick: Chooser) -> tuple[str, bytes]:
    """A valid scene with up to three hostile edits (values, unknown keys, tables left out), or unreadable bytes."""
    if pick.integer(0, 9) == 0:
        label, data = pick.choice(UNREADABLE_SCENES)
        return f"scene: {label}", data
    scene = {table: dict(body) for table, body in pick.choice(VALID_SCENES).items()}
    edits = []
    for _ in range(pick.integer(0, 3)):
        table = pick.choice(list(SCENE_KEYS))
        key = pick.choice(list(SCENE_KEYS[table]))
        op = pick.integer(0, 9)
        if op == 0:
            scene.setdefault(table, {})["nope"] = 1
            edits.append(f"unknown key in [{table}]")
        elif op == 1:
            scene.pop(table, None)
            edits.append(f"no [{table}]")
        else:
            value = pick.choice(SCENE_KEYS[table][key]) if op > 3 else pick.choice(NUMBERS)
            scene.setdefault(table, {})[key] = value
            edits.append(f"{table}.{key}")
    return "scene: " + (", ".join(edits) or "valid"), scene_bytes(scene)


def scene_bytes(scene: dict[str, dict[str, Any]]) -> bytes:
    """The TOML text of ``scene`` (table -> key -> value)."""
    lines = []
    for table, body in scene.items():
        lines.append(f"[{table}]")
        lines += [f"{key} = {toml_value(value)}" for key, value in body.items()]
    return ("\n".join(lines) + "\n").encode()


# ============================================================================ cases


def _module_of(kind: str) -> Any:
    """The family module beside this file that runs cases of ``kind`` itself (its ``execute``), or None."""
    for name in ("_fuzz_scenes", "_fuzz_files"):
        module = sys.modules.get(name)
        if module is not None and kind in getattr(module, "KINDS", {}) and hasattr(module, "execute"):
            return module
    return None


@dataclass
class Case:
    """One fuzz case: the files of its folder, and what runs there."""

    index: int
    kind: str  # the family's name (a row of the table): api, info, check, cli, scene, ...
    family: str  # what was done: number, structure, inertia, xml, valid, twice, big; cli <command>; scene ...
    label: str
    command: str  # api, info, check, simulate, view, run
    files: dict[str, bytes]
    argv: list[str] | None  # None: robodyn.load("model.urdf")
    compare: bool  # on exit 0, model.urdf must load as the file says
    # On exit 0 (called in the child, in the case's folder, with the exit code): what is wrong with the result
    # (empty: right). A family's own oracle: a sweep's rows against simulate's verdict, say.
    oracle: Callable[[int], list[str]] | None = None
    # Called with the case's work folder once its files are written, before the child starts: what bytes cannot
    # say (a FIFO, a folder, a link to a device where a file is expected).
    setup: Callable[[Path], None] | None = None


@dataclass(frozen=True)
class Inputs:
    """What every case draws from: the base URDFs and the fixture files of command-line cases."""

    bases: list[tuple[str, str]]
    fixtures: dict[str, bytes]
    options: dict[str, list[tuple[str, Any]]]


def _urdf_case(kind: str) -> Callable[[int, Chooser, Inputs], Case]:
    """Cases of ``kind`` api, info or check: a mutated URDF through robodyn.load, ``info`` or ``check``."""

    def make(index: int, pick: Chooser, inputs: Inputs) -> Case:
        base, text = pick.choice(inputs.bases)
        if pick.integer(0, 199) == 0:
            label, links, every = pick.choice(BIG)
            family, data = "big", chain(links, moving_every=every).encode()
        else:
            family, label, data = urdf_mutation(text, pick)
        label = f"{base}: {family}: {label}"
        argv = None
        if kind == "info":
            argv = ["info", "model.urdf", *pick.choice([[], [], ["--json"], ["--mimic"], ["--free-flyer"]])]
        elif kind == "check":
            argv = ["check", "model.urdf", "--samples", "2", *pick.choice([[], [], ["--formula", "auto"], ["--mimic"]])]
        return Case(index, kind, family, label, kind, {"model.urdf": data}, argv, compare=True)

    return make


def _scene_case(index: int, pick: Chooser, inputs: Inputs) -> Case:
    """A random TOML scene (or unreadable bytes) through ``robodyn run --no-view``."""
    files = dict(inputs.fixtures)
    label, files["scene.toml"] = scene_text(pick)
    argv = ["run", "scene.toml", "--no-view", *pick.choice([[], [], ["--out", "out"], ["--out", "model.urdf"]])]
    what = label.removeprefix("scene: ")
    family = "scene " + (what if what == "valid" else "unreadable" if what in dict(UNREADABLE_SCENES) else "edited")
    return Case(index, "scene", family, label, "run", files, argv, compare=False)


def _cli_case(index: int, pick: Chooser, inputs: Inputs) -> Case:
    """A hostile or valid command line (:func:`command_line`)."""
    files = dict(inputs.fixtures)
    command, argv = command_line(pick, inputs.options)
    if command == "run":
        files["scene.toml"] = scene_text(pick)[1]
    compare = argv[1:2] == ["model.urdf"] and not {"--lock", "--keep"} & set(argv)
    return Case(index, "cli", f"cli {command}", f"cli: {command}", command, files, argv, compare)


@dataclass(frozen=True)
class Family:
    """A kind of case, one row of the table: its name, how often it is drawn (a weight) and how one is made.

    ``make(index, pick, inputs)`` returns the :class:`Case` (its ``kind`` is the family's name), drawing every
    decision from ``pick``; ``inputs.fixtures`` holds the files a case may put beside its own.
    """

    name: str
    weight: int
    make: Callable[[int, Chooser, Inputs], Case]


# Every family of cases. A new file kind appends one Family here (or in benchmarks/_fuzz_files.py,
# whose ``families(fuzz)`` returns its own list, given this module). ``--families`` picks some by name.
FAMILIES: list[Family] = [
    Family("api", 9, _urdf_case("api")),
    Family("info", 3, _urdf_case("info")),
    Family("check", 2, _urdf_case("check")),
    Family("cli", 4, _cli_case),
    Family("scene", 2, _scene_case),
]


# Modules beside this file whose ``families(fuzz)`` adds families: scene, sweep, params and constraint files;
# trajectory, controller, gains and formula files.
FAMILY_MODULES = ("_fuzz_scenes", "_fuzz_files")


def _more_families() -> list[Family]:
    """The families of the :data:`FAMILY_MODULES` present (each given this module)."""
    import importlib

    here = str(Path(__file__).resolve().parent)
    if here not in sys.path:
        sys.path.insert(0, here)
    out: list[Family] = []
    for name in FAMILY_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name != name:
                raise
            continue
        out += module.families(sys.modules[__name__])
    return out


def families(names: str | None = None) -> list[Family]:
    """Every registered family, or those named in the comma-separated ``names``."""
    known = [*FAMILIES, *_more_families()]
    if not names:
        return known
    wanted = [n.strip() for n in names.split(",") if n.strip()]
    missing = [n for n in wanted if n not in {f.name for f in known}]
    if missing:
        expected = ", ".join(f.name for f in known)
        raise SystemExit(f"fuzz.py: unknown family {missing[0]!r}; expected some of: {expected}")
    return [f for f in known if f.name in wanted]


def make_case(index: int, seed: int, inputs: Inputs, chosen: Sequence[Family] | None = None) -> Case:
    """Case ``index`` of the campaign ``seed`` over the families ``chosen`` (default: all; the same gives the same)."""
    pick = RandomChooser(f"{seed}:{index}")
    pool = [f for f in (chosen if chosen is not None else families()) for _ in range(f.weight)]
    return pick.choice(pool).make(index, pick, inputs)


def base_models(*, library: bool = True) -> list[tuple[str, str]]:
    """(name, text) of the built-in URDFs and, with ``library``, every distinct example-robot-data robot."""
    out = [(Path(stem).name, (MODELS / f"{stem}.urdf").read_text(encoding="utf-8")) for stem in BUILTIN_FILES]
    if library:
        from robodyn.model import sources

        table = sources.sources()
        out += [(name, table[name].urdf.read_text(encoding="utf-8")) for name in sources.distinct_robots()]
    return out


# The names of the files :func:`fixtures` puts in every command-line case's folder (not saved with a failure).
FIXTURE_NAMES = ("model.urdf", "t.npz", "shadow.npz", "bad.npz", "p.json", "zero.json", "deep.json", "bad.json",
                 "x.srdf", "sub/.keep")  # fmt: skip


def fixtures(folder: Path) -> dict[str, bytes]:
    """The files a command-line case finds in its folder: a model, a trajectory (good, bad, hostile), params."""
    from robodyn.cli import main

    pendubot = (MODELS / "pendubot.urdf").read_bytes()
    traj = folder / "t.npz"
    code = main(["simulate", "pendubot", "--duration", "0.2", "--out", str(traj)])
    assert code == 0, code
    with np.load(traj) as npz:
        arrays = {k: npz[k] for k in npz.files}
    info = json.loads(str(arrays["metadata"]))
    info["t"] = [0.0, 1.0]  # metadata that shadows an array
    shadow = folder / "shadow.npz"
    np.savez(shadow, **{**arrays, "metadata": np.array(json.dumps(info))})
    params = {"m1": 1.336, "m2": 0.5, "l1": 0.15, "lc1": 0.1, "lc2": 0.126, "I1": 6.19e-3, "I2": 2.65e-3, "g": 9.81}
    return {
        "model.urdf": pendubot,
        "t.npz": traj.read_bytes(),
        "shadow.npz": shadow.read_bytes(),
        "bad.npz": b"PK\x03\x04" + bytes(range(200)),
        "p.json": json.dumps({"params": params}).encode(),
        "zero.json": json.dumps(dict.fromkeys(params, 0)).encode(),
        "deep.json": b"[" * 100_000 + b"]" * 100_000,
        "bad.json": b'{"m1": "\xff"}',
        "x.srdf": b'<robot name="pendubot"><rotor_params><joint name="joint1" mass="nan"/></rotor_params></robot>',
        "sub/.keep": b"",
    }


# ============================================================================ running a case


def _execute(case: Case) -> tuple[int, list[str]]:
    """Run ``case`` in this (child) process from its folder: the exit code and the oracle's findings."""
    import robodyn
    from robodyn.cli import main
    from robodyn.errors import RobodynError

    module = _module_of(case.kind)
    if module is not None:
        return module.execute(case)  # type: ignore[no-any-return]
    if case.argv is None:
        try:
            robot = robodyn.load("model.urdf")
        except RobodynError as exc:
            print(f"robodyn.load: error: {exc}", file=sys.stderr)
            return exc.exit_code, []
        return 0, model_differences(robot.model, Path("model.urdf"))
    try:
        code = main(list(case.argv))
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 2
    if code in (0, 1) and case.oracle is not None:
        sys.stdout.flush()
        return code, case.oracle(code)
    if code != 0 or not case.compare:
        return code, []
    sys.stdout.flush()
    try:
        robot = robodyn.load(
            "model.urdf", free_flyer="--free-flyer" in case.argv, mimic="--mimic" in case.argv, check_physics=False
        )
    except RobodynError as exc:
        return code, [f"the command accepted model.urdf but robodyn.load refuses it: {exc}"]
    return code, model_differences(robot.model, Path("model.urdf"))


def _child(case: Case, folder: Path, time_limit: int, memory: int) -> None:
    """The forked child: capture fds 1 and 2, cap memory and time, run, record, exit (never returns)."""
    code = TRACEBACK_EXIT
    try:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, signal.SIG_DFL)
        for fd, name in ((1, "stdout.txt"), (2, "stderr.txt")):
            out = os.open(folder / name, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            os.dup2(out, fd)
            os.close(out)
        os.chdir(folder / "work")
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
        signal.alarm(time_limit)
        code, wrong = _execute(case)
        (folder / "result.json").write_text(json.dumps({"code": code, "wrong": wrong}))
    except BaseException:  # anything escaping robodyn is the finding
        traceback.print_exc()
        code = TRACEBACK_EXIT
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


def names_an_input(line: str, argv: Sequence[str], files: Sequence[str] = ()) -> bool:
    """A refusal names something given: a flag or a value of ``argv`` (a long one by its start, quoted or not), or
    one of the ``files`` of the folder (a scene names them)."""
    given = [t for t in (*argv[1:], *files) if t != "--no-view"]
    parts = [p for t in given for p in re.split(r"[=,]", t) if "=" in t]  # --lock NAME=VALUE names NAME
    forms = [f for t in (*given, *parts) for f in (t, repr(t), repr(t)[1:-1], t.strip(), t.lstrip("-")) if f.strip()]
    return ": error: argument " in line or any(_mentions(line, form) for form in forms)  # argparse names it


def _mentions(line: str, form: str) -> bool:
    """``form`` (its first 10 characters when longer than 20) appears in ``line`` as a whole word: "2" is not in
    "2048"."""
    head = form if len(form) <= 20 else form[:10]
    left = r"(?<![\w.])" if head[0].isalnum() else ""
    right = r"(?!\w)" if len(form) <= 20 and head[-1].isalnum() else ""
    return re.search(left + re.escape(head) + right, line) is not None


def signature(err: str) -> str:
    """Where a traceback left robodyn, and what it raised: ``cli/simulate.py:175 OSError``."""
    frames = re.findall(r'File "[^"]*/src/robodyn/([^"]+)", line (\d+)', err)
    last = err.strip().splitlines()[-1] if err.strip() else ""
    where = f"{frames[-1][0]}:{frames[-1][1]} " if frames else ""
    return where + last.split(":")[0][:60]


def given_names(files: dict[str, bytes]) -> list[str]:
    """What a case gives besides its command line: its files' names, the strings of its scene, its robot's name."""
    scene = files.get("scene.toml", b"").decode("utf-8", "replace")
    robot = re.findall(r'<robot\s[^>]*?name="([^"]+)"', files.get("model.urdf", b"")[:4096].decode("utf-8", "replace"))
    return [*files, *re.findall(r'"([^"\n]+)"', scene), *robot]


def pattern(line: str) -> str:
    """A refusal's words without its numbers and quoted names: ``robodyn view: error: q must have # entries``."""
    return re.sub(r"'[^']*'|\[[^\]]*\]|\([^)]*\)|[-+]?\d[\d.e+-]*", "#", line)[:90]


def snapshot(folder: Path) -> dict[str, str]:
    """Every entry under ``folder``: a file's sha256, a link's target."""
    out = {}
    for path in sorted(folder.rglob("*")):
        name = str(path.relative_to(folder))
        if path.is_symlink():
            out[name] = "-> " + os.readlink(path)
        elif path.is_file():
            out[name] = hashlib.sha256(path.read_bytes()).hexdigest()
        else:
            out[name] = "folder"
    return out


@dataclass
class Running:
    case: Case
    folder: Path
    before: dict[str, str]
    started: float
    killed: bool = False


def start(case: Case, root: Path, time_limit: int, memory: int) -> tuple[int, Running]:
    """Write ``case``'s files under ``root/<index>/work`` and fork its child; (pid, bookkeeping)."""
    folder = root / f"{case.index:06d}"
    for name, data in case.files.items():
        path = folder / "work" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    (folder / "work").mkdir(parents=True, exist_ok=True)
    if case.setup is not None:
        case.setup(folder / "work")
    before = snapshot(folder / "work")
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:
        _child(case, folder, time_limit, memory)
    return pid, Running(case, folder, before, time.monotonic())


def classify(run: Running, status: int) -> dict[str, Any]:
    """The outcome of a finished case: its exit (or signal) and every violation found."""
    case, folder = run.case, run.folder
    err = (folder / "stderr.txt").read_text(errors="replace") if (folder / "stderr.txt").exists() else ""
    out = (folder / "stdout.txt").read_text(errors="replace") if (folder / "stdout.txt").exists() else ""
    outcome: dict[str, Any] = {
        "seconds": round(time.monotonic() - run.started, 2),
        "index": case.index,
        "kind": case.kind,
        "family": case.family,
        "label": case.label,
        "command": case.command,
    }
    problems: list[str] = []
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        if sig == signal.SIGALRM or run.killed:
            outcome["exit"], problems = "hang", ["hang"]
        else:
            outcome["exit"] = f"signal {signal.Signals(sig).name}"
            problems = [f"signal {signal.Signals(sig).name}"]
        outcome["problems"] = problems
        outcome["stderr"] = err[-2000:]
        return outcome
    code = os.WEXITSTATUS(status)
    outcome["exit"] = code
    if code == TRACEBACK_EXIT or "Traceback (most recent call last)" in err:
        problems.append("traceback")
        outcome["signature"] = signature(err)
    elif code not in ALLOWED_EXITS[case.command]:
        problems.append(f"unexpected exit {code}")
    lines = refusal_lines(err)
    outcome["line"] = lines[0][:300] if lines else ""  # what a refusal said (the table's clean refusals, by reason)
    if code in (2, 3) and len(lines) != 1:
        problems.append("one-line violation")
    if case.argv is None and code == 0 and err:
        problems.append("one-line violation")  # the API loaded a model but something wrote to fd 2
    if (
        code == 2
        and lines
        and not names_an_input(lines[0], case.argv or ["load", "model.urdf"], given_names(case.files))
    ):
        problems.append("refusal names no input")
        outcome["signature"] = pattern(lines[0])
    if code == 2 and snapshot(folder / "work") != run.before:
        problems.append("files changed on refusal")
    if code == 1 and "FAIL" not in out:
        problems.append("exit 1 without a mismatch")
    result = folder / "result.json"
    if code == 0 and not result.exists():  # something ended the process (os._exit) before robodyn returned
        problems.append("accepted-but-wrong")
        outcome["wrong"] = ["exit 0 before robodyn returned (the process ended without a result)"]
    if code not in (TRACEBACK_EXIT,) and result.exists():
        wrong = json.loads(result.read_text())["wrong"]
        if wrong:
            problems.append("accepted-but-wrong")
            outcome["wrong"] = wrong
    outcome["problems"] = problems
    if problems:
        outcome["stderr"] = err[-2000:]
    return outcome


ACKNOWLEDGED = ": warning: --no-physics-check: "
"""The one warning line of a model loaded with --no-physics-check: the user asked for it, it is not a refusal's."""


def refusal_lines(err: str) -> list[str]:
    """stderr's lines less the acknowledgement of an explicit ``--no-physics-check``."""
    return [line for line in err.splitlines() if ACKNOWLEDGED not in line]


COLUMNS = ("one-line violation", "refusal names no input", "files changed on refusal", "signal", "hang", "traceback",
           "unexpected exit", "exit 1 without a mismatch", "accepted-but-wrong")  # fmt: skip


# The table per family: each case counts in one column, the first of these that applies.
TABLE_COLUMNS = ("clean refusal", "accepted and right", "traceback", "hang", "silently wrong", "multi-line refusal",
                 "refusal that left files", "other problem")  # fmt: skip


def verdict(outcome: dict[str, Any]) -> str:
    """The column of the table that ``outcome`` counts in."""
    problems = outcome["problems"]
    for column, problem in (("traceback", "traceback"), ("hang", "hang"), ("silently wrong", "accepted-but-wrong"),
                            ("multi-line refusal", "one-line violation"),
                            ("refusal that left files", "files changed on refusal")):  # fmt: skip
        if problem in problems:
            return column
    if problems:
        return "other problem"
    return "accepted and right" if outcome["exit"] == 0 else "clean refusal"


def table(outcomes: list[dict[str, Any]], wall: float) -> dict[str, Any]:
    """The summary: exit codes, and each kind of violation (signals by name), in total and per case kind."""
    exits = Counter(str(o["exit"]) for o in outcomes)
    found = Counter(p.split(" ")[0] if p.startswith("signal") else p for o in outcomes for p in o["problems"])
    signals = Counter(p for o in outcomes for p in o["problems"] if p.startswith("signal"))
    kinds = {
        kind: {
            "cases": sum(o["kind"] == kind for o in outcomes),
            "exits": dict(Counter(str(o["exit"]) for o in outcomes if o["kind"] == kind)),
            "problems": sum(bool(o["problems"]) for o in outcomes if o["kind"] == kind),
        }
        for kind in dict.fromkeys(o["kind"] for o in outcomes)
    }
    rows: dict[str, Counter[str]] = {}
    for o in outcomes:
        rows.setdefault(o["kind"], Counter())[verdict(o)] += 1
    families = Counter((o["kind"], o["family"], str(o["exit"])) for o in outcomes)
    by_family: dict[str, dict[str, int]] = {}
    for (kind, name, code), n in sorted(families.items()):
        by_family.setdefault(f"{kind}: {name}", {})[code] = n
    tracebacks = Counter(o["signature"] for o in outcomes if "traceback" in o["problems"])
    unnamed = Counter(o["signature"] for o in outcomes if "refusal names no input" in o["problems"])
    slowest = sorted(outcomes, key=lambda o: -o["seconds"])[:5]
    return {
        "by_family": by_family,
        "traceback_signatures": dict(tracebacks),
        "unnamed_refusals": dict(unnamed),
        "slowest": [{k: o[k] for k in ("index", "label", "exit", "seconds")} for o in slowest],
        "cases": len(outcomes),
        "wall_time_s": round(wall, 1),
        "cases_per_s": round(len(outcomes) / wall, 2) if wall else None,
        "exits": dict(sorted(exits.items())),
        "violations": {c: found.get(c, 0) for c in COLUMNS},
        "signals": dict(signals),
        "by_kind": kinds,
        "table": {kind: {c: row.get(c, 0) for c in TABLE_COLUMNS} for kind, row in rows.items()},
    }


def print_table(summary: dict[str, Any]) -> None:
    print(f"{summary['cases']} cases in {summary['wall_time_s']} s ({summary['cases_per_s']} cases/s)")
    print("exit codes: " + ", ".join(f"{k}: {v}" for k, v in summary["exits"].items()))
    width = max(len(c) for c in COLUMNS)
    for column in COLUMNS:
        extra = f"  {summary['signals']}" if column == "signal" and summary["signals"] else ""
        print(f"  {column:<{width}}  {summary['violations'][column]:>6}{extra}")
    for where, n in summary["traceback_signatures"].items():
        print(f"  traceback x{n}: {where}")
    for words, n in summary["unnamed_refusals"].items():
        print(f"  names no input x{n}: {words}")
    print(
        "slowest cases: "
        + ", ".join(f"{o['index']} {o['seconds']:.1f} s ({o['label'][:40]})" for o in summary["slowest"])
    )
    print("by kind: " + "; ".join(f"{k} {v['cases']} (exits {v['exits']}, {v['problems']} with problems)"
                                  for k, v in summary["by_kind"].items()))  # fmt: skip
    width = max([len("family"), *(len(k) for k in summary["table"])])
    print(f"| {'family':<{width}} | " + " | ".join(TABLE_COLUMNS) + " |")
    print(f"|{'-' * (width + 2)}|" + "|".join("-" * (len(c) + 1) + ":" for c in TABLE_COLUMNS) + "|")
    for kind, row in summary["table"].items():
        print(f"| {kind:<{width}} | " + " | ".join(f"{row[c]:>{len(c)}}" for c in TABLE_COLUMNS) + " |")


def save_failure(run: Running, outcome: dict[str, Any], out: Path) -> None:
    """Keep a failing case: its input files, command line, output and outcome, under ``out/failures/<index>``."""
    target = out / "failures" / f"{run.case.index:06d}"
    target.mkdir(parents=True, exist_ok=True)
    inputs = target / "inputs"
    inputs.mkdir(exist_ok=True)
    for name, data in run.case.files.items():
        own = run.case.kind not in ("cli", "scene") and name not in FIXTURE_NAMES
        if name in ("model.urdf", "scene.toml") or own:
            (inputs / name.replace("/", "_")).write_bytes(data)
    for name in ("stdout.txt", "stderr.txt"):
        if (run.folder / name).exists():
            shutil.copy(run.folder / name, target / name)
    (target / "case.json").write_text(json.dumps({**outcome, "argv": run.case.argv}, indent=2))


def _shared() -> Any:
    """``benchmarks/_common.py``: the --out folder, its guard and the run facts (found beside this file)."""
    here = str(Path(__file__).resolve().parent)
    if here not in sys.path:
        sys.path.insert(0, here)
    import _common

    return _common


def campaign(args: argparse.Namespace) -> dict[str, Any]:
    """Run the cases with ``args.jobs`` children at a time; print progress and the table; save fuzz.json."""
    from robodyn.cli import main

    common = _shared()
    out = common.output_folder(Path(args.out), overwrite_committed=args.overwrite_committed).resolve()
    facts = common.run_facts()
    cases_dir = Path(tempfile.mkdtemp(prefix="cases-", dir=out))
    warm = cases_dir / "warm"
    warm.mkdir()
    with open(os.devnull, "w") as sink, contextlib.redirect_stdout(sink):
        inputs = Inputs(
            base_models(library=not args.builtins_only),
            fixtures(warm),
            {c: _options(c) for c in ("simulate", "info", "check", "view")},
        )
        for argv in (
            ["info", "pendubot", "--json"],
            ["check", "pendubot", "--samples", "1", "--formula", "pendubot"],
            ["view", "pendubot", str(warm / "t.npz"), "--html", str(warm / "v.html")],
        ):
            main(argv)  # warm every lazy import before the first fork
    print(f"fuzz: {args.cases} cases, seed {args.seed}, {args.jobs} jobs, {len(inputs.bases)} base URDFs, "
          f"limits {args.time_limit} s and {args.memory_gib} GiB per case; output in {out}", flush=True)  # fmt: skip
    chosen = families(args.families)
    indices = [args.only] if args.only is not None else list(range(args.cases))
    running: dict[int, Running] = {}
    outcomes: list[dict[str, Any]] = []

    def watchdog(signum: int, frame: Any) -> None:  # a child past its alarm (it blocked SIGALRM): kill it
        now = time.monotonic()
        for pid, run in running.items():
            if now - run.started > args.time_limit + 10 and not run.killed:
                run.killed = True
                os.kill(pid, signal.SIGKILL)

    signal.signal(signal.SIGALRM, watchdog)
    signal.setitimer(signal.ITIMER_REAL, 1.0, 1.0)
    begin = time.monotonic()
    todo = iter(indices)
    pending = True
    while pending or running:
        while pending and len(running) < args.jobs:
            index = next(todo, None)
            if index is None:
                pending = False
                break
            case = make_case(index, args.seed, inputs, chosen)
            pid, run = start(case, cases_dir, args.time_limit, args.memory_gib * 2**30)
            running[pid] = run
        if not running:
            break
        pid, status = os.waitpid(-1, 0)
        run = running.pop(pid)
        outcome = classify(run, status)
        outcomes.append(outcome)
        if outcome["problems"]:
            save_failure(run, outcome, out)
            print(f"  case {run.case.index} ({run.case.label}): {', '.join(outcome['problems'])}", flush=True)
        shutil.rmtree(run.folder, ignore_errors=True)
        done = len(outcomes)
        if done % args.progress == 0:
            rate = done / (time.monotonic() - begin)
            bad = sum(bool(o["problems"]) for o in outcomes)
            print(f"{done}/{len(indices)} cases, {rate:.1f} cases/s, ~{(len(indices) - done) / rate:.0f} s left, "
                  f"{bad} with problems", flush=True)  # fmt: skip
    signal.setitimer(signal.ITIMER_REAL, 0)
    summary = table(outcomes, time.monotonic() - begin)
    summary["findings"] = [o for o in outcomes if o["problems"]]
    common.write_json(out, "fuzz", summary, facts)
    shutil.rmtree(cases_dir, ignore_errors=True)
    print_table(summary)
    print(f"saved {out / 'fuzz.json'}" + (f" and {len(summary['findings'])} failing cases in {out / 'failures'}"
                                          if summary["findings"] else ""))  # fmt: skip
    return summary


def main(argv: Sequence[str] | None = None) -> int:
    """Parse the options and run the campaign; exit 1 when any case found a problem."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--cases", type=int, default=10_000, help="number of cases (default 10,000)")
    parser.add_argument("--seed", type=int, default=0, help="campaign seed: case i is drawn from (seed, i)")
    parser.add_argument("--jobs", type=int, default=2, help="children at a time (default 2)")
    _shared().add_out_arguments(parser)
    parser.add_argument("--time-limit", type=int, default=60, help="seconds per case before it counts as a hang")
    parser.add_argument("--memory-gib", type=int, default=4, help="address-space cap per case [GiB]")
    parser.add_argument("--only", type=int, default=None, help="run only case INDEX (to reproduce it)")
    parser.add_argument(
        "--families",
        default=None,
        help="comma-separated families to draw from (default: all): " + ", ".join(f.name for f in families()),
    )
    parser.add_argument("--builtins-only", action="store_true", help="mutate the built-in models only")
    parser.add_argument("--progress", type=int, default=250, help="a progress line every this many cases")
    args = parser.parse_args(argv)
    summary = campaign(args)
    return 1 if summary["findings"] else 0


if __name__ == "__main__":
    sys.exit(main())
