"""Setting a built-in kind's parameters in its URDF (+ SRDF): the file edits that realise each parameter.

Each parameter is what :mod:`robodyn.kinds.params` reads, so an edit is the inverse of an
extraction (world directions at q = 0, as there):

* pendubot: ``m1``, ``m2`` the body's mass; ``lc1``, ``lc2`` its centre of mass moved along the
  link line (+x); ``I1``, ``I2`` its inertia about the centre of mass around the joint axis;
  ``l1`` joint 2's ``<origin>`` moved along the link line (link 2 and everything on it move along).
* cart_pole: ``m_cart`` the cart's mass; ``m``, ``l``, ``I`` the pole's mass, centre of mass along +z
  and inertia around +y.
* geared_arm: ``m``, ``l``, ``J_l`` the link's mass, centre of mass along -z and inertia about the
  joint axis, J_l = I + m l^2 (kept when only ``m`` or ``l`` change, so I = J_l - m l^2 follows);
  ``J_m``, ``n`` the joint's ``<rotor_params mass= gear_ratio=>`` in the SRDF.
* ``g`` is the model's gravity, not a URDF quantity: it cannot be set.

A moving joint's body is its child link plus the links fixed below it (Pinocchio merges them):
the edit sets the whole body's mass, centre of mass or inertia and writes the child link's
``<inertial>`` as that body minus the fixed links, which stay as they are. The inertia about the
axis is set by scaling the inertia tensor about the centre of mass (so it stays physically
possible), or, from zero, by adding a thin ring around the axis.

:func:`write_params` writes through yourdfpy (:mod:`robodyn.model.urdf`), then loads the written
file and extracts the parameters again: the set ones must equal the request and the others be
unchanged, to :data:`VERIFY_RTOL`, or nothing is written.
"""

from __future__ import annotations

import difflib
import os
import reprlib
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.errors import AssumptionError, InputError, ModelError, UnknownNameError
from robodyn.fileio import is_number, write_text_atomically
from robodyn.kinds import catalog
from robodyn.kinds.bodies import EX, EY, EZ
from robodyn.kinds.params import Params, extract
from robodyn.kinds.units import RENAMED
from robodyn.model.files import find_srdf
from robodyn.model.load import load
from robodyn.model.urdf import Document, read_document, relocate_meshes, same_robot, write_document
from robodyn.robot import Robot

if TYPE_CHECKING:
    import yourdfpy

Array = NDArray[np.float64]

# The written model must give back each requested value, and every other one, to this relative
# tolerance: the edits are exact up to a few roundings of rotations.
VERIFY_RTOL = 1e-12

SETTABLE: dict[str, tuple[str, ...]] = {
    "pendubot": ("m1", "m2", "l1", "lc1", "lc2", "I1", "I2"),
    "cart_pole": ("m_cart", "m", "l", "I"),
    "geared_arm": ("J_m", "J_l", "n", "m", "l"),
}
# What each non-negative parameter is, for the refusal of a negative value.
_NON_NEGATIVE = dict.fromkeys(("m1", "m2", "m_cart", "m"), "a mass") | dict.fromkeys(
    ("I1", "I2", "I", "J_l", "J_m"), "an inertia"
)
_POSITIVE = {"l1": "the length of link 1 (joint 2 lies along +x)", "n": "a gear ratio"}
# A body without mass has no centre of mass: these masses must stay > 0 to keep their length.
_COM_OF = {"pendubot": {"m1": "lc1", "m2": "lc2"}, "cart_pole": {"m": "l"}, "geared_arm": {"m": "l"}}


def check_changes(kind: str, assignments: Iterable[tuple[str, float]]) -> dict[str, float]:
    """The requested ``name -> value`` of ``kind``, each name settable, given once, with a valid value.

    Raises:
        UnknownNameError: a name that is not one of the kind's settable parameters.
        InputError: ``g``, a name given twice, a non-finite value or one of the wrong sign.
    """
    catalog.kind(kind)
    if kind not in SETTABLE:
        raise InputError(
            f"--set edits the URDF of the {' and the '.join(SETTABLE)}; the {kind}'s file edits are not written, "
            "so change its URDF by hand"
        )
    changes: dict[str, float] = {}
    for name, value in assignments:
        if name == "g":
            raise InputError(
                "g is gravity (the model's gravity vector), not a URDF quantity: it cannot be set in the file"
            )
        if name not in SETTABLE[kind]:
            raise _unknown(kind, name)
        if name in changes:
            raise InputError(f"{name} is set twice ({changes[name]!r} and {value!r}); set it once")
        if not is_number(value):
            raise InputError(f"{name} must be a finite number, got {reprlib.repr(value)}")
        if name in _NON_NEGATIVE and value < 0:
            raise InputError(f"{name} is {_NON_NEGATIVE[name]} and must be >= 0, got {value!r}")
        if value == 0 and name in _COM_OF[kind]:
            length = _COM_OF[kind][name]
            raise InputError(f"{name} = 0 leaves its body without a centre of mass ({length} is lost): give {name} > 0")
        if name in _POSITIVE and value <= 0:
            raise InputError(f"{name} is {_POSITIVE[name]} and must be > 0, got {value!r}")
        changes[name] = float(value)
    return changes


def _unknown(kind: str, name: str) -> UnknownNameError:
    """UnknownNameError whose hint also catches short names and case (``m3`` -> m1, m2; ``i1`` -> I1)."""
    error = UnknownNameError(f"{kind} parameter", name, SETTABLE[kind])
    lowered = difflib.get_close_matches(name.lower(), [n.lower() for n in SETTABLE[kind]], n=3, cutoff=0.5)
    close = [n for low in lowered for n in SETTABLE[kind] if n.lower() == low]
    if (kind, name) in RENAMED:  # an old name: M is only ever the mass matrix now
        close = [RENAMED[kind, name]]
    hint = f"did you mean {' or '.join(repr(c) for c in close)}? " if close else ""
    error.args = (f"unknown {kind} parameter {name!r}; {hint}expected one of: {', '.join(error.choices)}",)
    return error


# ----------------------------------------------------------------------------- bodies


def _ring(axis: Array) -> Array:
    """Inertia tensor of a thin ring of unit polar moment around ``axis`` (unit): 1 about it, 1/2 across."""
    outer = np.outer(axis, axis)
    return outer + 0.5 * (np.eye(3) - outer)


def _parallel(mass: float, com: Array) -> Array:
    """The parallel-axis term m ((c . c) 1 - c c^T): an inertia about the COM moved to the origin."""
    return mass * (float(com @ com) * np.eye(3) - np.outer(com, com))


@dataclass(frozen=True)
class _Body:
    """A moving joint's body as the edit sees it, in the joint frame (= its child link's frame)."""

    joint: str
    link: yourdfpy.Link
    R: Array  # world <- joint frame at q = 0
    axis: Array  # the joint's angular axis in world coordinates (zero for a prismatic joint)
    others: tuple[float, Array, Array]  # the fixed links' mass, first moment m c, second moment about the origin


def _inertial(link: yourdfpy.Link) -> tuple[float, Array, Array, Array]:
    """(mass, COM, inertia about the COM, rotation of the inertial frame), in the link frame."""
    inertial = link.inertial
    if inertial is None or inertial.mass is None:
        return 0.0, np.zeros(3), np.zeros((3, 3)), np.eye(3)
    origin = np.eye(4) if inertial.origin is None else np.asarray(inertial.origin, dtype=np.float64)
    inertia = np.zeros((3, 3)) if inertial.inertia is None else np.asarray(inertial.inertia, dtype=np.float64)
    rotation = origin[:3, :3]
    return float(inertial.mass), origin[:3, 3].copy(), rotation @ inertia @ rotation.T, rotation


def _bodies(robot: Robot, document: Document) -> dict[str, _Body]:
    """Each moving joint's body, by joint name, with the links fixed below its child link."""
    urdf = document.urdf
    below: dict[str, list[yourdfpy.Joint]] = {}
    for joint in urdf.robot.joints:
        below.setdefault(joint.parent, []).append(joint)
    frames = dynamics.joint_frames(robot.model, robot.data, robot.neutral())
    bodies: dict[str, _Body] = {}
    for info, (placement, _, axis) in zip(robot.joints, frames, strict=True):
        if info.name not in urdf.joint_map:
            continue
        child = urdf.link_map[urdf.joint_map[info.name].child]
        mass, first, second = 0.0, np.zeros(3), np.zeros((3, 3))
        stack = [(child.name, np.eye(4))]
        while stack:
            name, T = stack.pop()
            for joint in below.get(name, ()):
                if joint.type != "fixed":
                    continue
                T_child = T @ (np.eye(4) if joint.origin is None else np.asarray(joint.origin))
                m, c, I, _ = _inertial(urdf.link_map[joint.child])
                c = T_child[:3, :3] @ c + T_child[:3, 3]
                I = T_child[:3, :3] @ I @ T_child[:3, :3].T
                mass, first, second = mass + m, first + m * c, second + I + _parallel(m, c)
                stack.append((joint.child, T_child))
        R = np.asarray(placement)[:3, :3].copy()
        bodies[info.name] = _Body(info.name, child, R, np.asarray(axis), (mass, first, second))
    return bodies


AxisTarget = Callable[[float, Array], float]  # (new body mass, new COM in the joint frame) -> inertia about the axis


def _edit_body(
    body: _Body,
    *,
    mass: float | None = None,
    line: tuple[Array, float] | None = None,
    axis: Array | None = None,
    axis_inertia: AxisTarget | None = None,
) -> None:
    """Set the body's mass, its COM's signed distance along a world direction, its inertia around ``axis`` (world).

    Directions are world vectors at q = 0, as the extractors read them; the rest of the body is kept.
    """
    own_m, own_c, own_I, rotation = _inertial(body.link)
    other_m, other_h, other_K = body.others
    has_others = other_m > 0.0 or bool(np.any(other_K))
    if has_others:  # the whole body: own + fixed links, about its COM
        m = own_m + other_m
        c = (own_m * own_c + other_h) / m if m > 0 else np.zeros(3)
        I = own_I + _parallel(own_m, own_c) + other_K - _parallel(m, c)
    else:
        m, c, I = own_m, own_c, own_I
    new_m = m if mass is None else mass
    new_c = c
    if line is not None:
        direction = body.R.T @ line[0]
        new_c = c - float(c @ direction) * direction + line[1] * direction
    new_I = I
    if axis_inertia is not None and axis is not None:
        a = body.R.T @ axis
        target, old = axis_inertia(new_m, new_c), float(a @ I @ a)
        if target != old:
            new_I = I * (target / old) if old > 0 else I + target * _ring(a)
    if has_others:  # back to the child link alone: the body minus the fixed links
        own_m = new_m - other_m
        if own_m < 0:
            raise InputError(
                f"cannot give joint {body.joint}'s body a mass of {new_m!r} kg: the links fixed to "
                f"{body.link.name} weigh {other_m!r} kg on their own"
            )
        K = new_I + _parallel(new_m, new_c) - other_K
        own_c = (new_m * new_c - other_h) / own_m if own_m > 0 else np.zeros(3)
        own_I = K - _parallel(own_m, own_c)
    else:
        own_m, own_c, own_I = new_m, new_c, new_I
    _write_inertial(
        body.link,
        mass=own_m if (mass is not None or has_others) else None,
        com=own_c if (line is not None or has_others) else None,
        inertia=rotation.T @ own_I @ rotation if (new_I is not I or has_others) else None,
    )


def _write_inertial(link: yourdfpy.Link, *, mass: float | None, com: Array | None, inertia: Array | None) -> None:
    """Set the given parts of ``link``'s ``<inertial>`` (created if missing); the others stay as written."""
    import yourdfpy

    if mass is None and com is None and inertia is None:
        return
    if link.inertial is None:
        link.inertial = yourdfpy.Inertial(origin=np.eye(4), mass=0.0, inertia=np.zeros((3, 3)))
    inertial = link.inertial
    if mass is not None:
        inertial.mass = float(mass)
    if com is not None:
        origin = np.eye(4) if inertial.origin is None else np.array(inertial.origin, dtype=np.float64)
        origin[:3, 3] = com
        inertial.origin = origin
    if inertia is not None:
        inertial.inertia = 0.5 * (inertia + inertia.T)


def _move_joint(document: Document, body: _Body, direction: Array, old: float, new: float) -> None:
    """Move ``body``'s joint origin: its distance from the parent joint along ``direction`` (world) becomes ``new``."""
    joint = document.urdf.joint_map[body.joint]
    origin = np.array(joint.origin if joint.origin is not None else np.eye(4), dtype=np.float64)
    parent_rotation = body.R @ origin[:3, :3].T  # world <- the parent link's frame
    d = parent_rotation.T @ direction
    xyz = origin[:3, 3]
    along = float(xyz @ d)
    base = old - along  # the part of the distance that lies before the parent link's frame
    origin[:3, 3] = xyz - along * d + (new - base) * d
    joint.origin = origin


# ----------------------------------------------------------------------------- kinds


def _pendubot(robot: Robot, document: Document, before: Params, changes: Mapping[str, float]) -> None:
    bodies = _bodies(robot, document)
    names = robot.joint_names
    axis = -EY
    for i, name in enumerate(names, start=1):
        lc, inertia = changes.get(f"lc{i}"), changes.get(f"I{i}")
        line = None if lc is None else (EX, lc)
        _edit_body(bodies[name], mass=changes.get(f"m{i}"), line=line, axis=axis, axis_inertia=_constant(inertia))
    if "l1" in changes:
        _move_joint(document, bodies[names[1]], EX, before["l1"], changes["l1"])


def _cart_pole(robot: Robot, document: Document, before: Params, changes: Mapping[str, float]) -> None:
    bodies = _bodies(robot, document)
    cart, pole = robot.joint_names
    _edit_body(bodies[cart], mass=changes.get("m_cart"))
    line = None if "l" not in changes else (EZ, changes["l"])
    _edit_body(bodies[pole], mass=changes.get("m"), line=line, axis=EY, axis_inertia=_constant(changes.get("I")))


def _geared_arm(robot: Robot, document: Document, before: Params, changes: Mapping[str, float]) -> None:
    (name,) = robot.joint_names
    body = _bodies(robot, document)[name]
    if not {"m", "l", "J_l"} & set(changes):
        return
    J_l = changes.get("J_l", before["J_l"])
    a = body.R.T @ body.axis

    def about_com(mass: float, com: Array) -> float:  # J_l = I + m d^2, d the COM's distance from the axis
        off_axis = com - float(com @ a) * a
        value = J_l - mass * float(off_axis @ off_axis)
        if value < -VERIFY_RTOL * J_l:
            raise InputError(
                f"J_l = {J_l!r} kg m^2 is less than m l^2 = {J_l - value!r} kg m^2, the inertia of the mass "
                "alone at distance l from the axis: raise J_l, or lower m or l"
            )
        return max(value, 0.0)

    line = None if "l" not in changes else (-EZ, changes["l"])
    _edit_body(body, mass=changes.get("m"), line=line, axis=body.axis, axis_inertia=about_com)


def _constant(value: float | None) -> AxisTarget | None:
    return None if value is None else (lambda mass, com: value)


EDITORS: dict[str, Callable[[Robot, Document, Params, Mapping[str, float]], None]] = {
    "pendubot": _pendubot,
    "cart_pole": _cart_pole,
    "geared_arm": _geared_arm,
}


# ----------------------------------------------------------------------------- SRDF


def _rotor_srdf(robot: Robot, joint: str, J_m: float, n: float) -> str:
    """The SRDF text of ``robot`` (or a new one) with ``<rotor_params>`` of ``joint`` set to J_m and n."""
    if robot.srdf_path is not None:
        parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
        root = ET.parse(robot.srdf_path, parser=parser).getroot()
    else:
        root = ET.Element("robot", name=robot.name)
    rotor = root.find("rotor_params")
    if rotor is None:
        rotor = ET.SubElement(root, "rotor_params")
    entry = next((e for e in rotor.findall("joint") if e.get("name") == joint), None)
    if entry is None:
        entry = ET.SubElement(rotor, "joint", name=joint)
    entry.set("mass", repr(J_m))
    entry.set("gear_ratio", repr(n))
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _check_rotor(robot: Robot, before: Params, changes: Mapping[str, float]) -> None:
    if not {"J_m", "n"} & set(changes):
        return
    (info,) = robot.joints
    if float(robot.model.rotorInertia[info.idx_v]) == 0.0 and before["J_m"] != 0.0:
        raise InputError(
            f"joint {info.name}'s armature does not come from SRDF <rotor_params>: J_m and n cannot be set in the file"
        )
    J_m, n = changes.get("J_m", before["J_m"]), changes.get("n", before["n"])
    if J_m == 0.0 and n != 1.0:
        raise InputError(f"with J_m = 0 there is no rotor and the model reads n = 1, not {n!r}: set J_m > 0 as well")


# ----------------------------------------------------------------------------- writing and verifying


@dataclass(frozen=True)
class Written:
    """What :func:`write_params` wrote, and the parameters read back from it."""

    urdf: Path
    srdf: Path | None
    params: Params


def _same_file(a: Path, b: Path | None) -> bool:
    if b is None:
        return False
    if a.resolve() == b.resolve():
        return True
    return a.exists() and b.exists() and os.path.samefile(a, b)


def refuse_own_file(robot: Robot, path: Path) -> None:
    """Raise :class:`InputError` when ``path`` is ``robot``'s own URDF: a modified model goes elsewhere."""
    if _same_file(Path(path), robot.urdf_path):
        raise InputError(f"cannot write {path}: it is the model's own URDF (write the modified model elsewhere)")


def write_params(
    robot: Robot, kind: str, changes: Mapping[str, float], path: Path, *, free_flyer: bool = False
) -> Written:
    """Write ``robot``'s URDF with ``changes`` made to its ``kind`` parameters to ``path``, and verify it.

    The SRDF goes along when there is one (or when J_m or n is set), as ``path`` with the suffix
    ``.srdf``. The files are written under temporary names next to ``path``, loaded and
    extracted again; only when every parameter is right are they moved into place.

    Raises:
        InputError: bad names or values, or a ``path`` that is the model's own file.
        AssumptionError: ``robot`` is not a ``kind``.
        ModelError: the written model is refused, or gives other parameters than asked.
    """
    changes = check_changes(kind, changes.items())
    before = extract(robot, kind)
    if robot.urdf_path is None:
        raise InputError(f"robot {robot.name!r} was not loaded from a URDF: there is no file to modify")
    path = Path(path)
    refuse_own_file(robot, path)
    _check_rotor(robot, before, changes)
    srdf_text = _srdf_to_write(robot, before, changes, path)
    document = read_document(robot.urdf_path)
    relocate_meshes(document, path.parent)
    EDITORS[kind](robot, document, before, changes)
    summary = ", ".join(f"{k}={v!r}" for k, v in changes.items()) or "no change"
    fd, name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".urdf", dir=path.parent)
    os.close(fd)
    tmp, tmp_srdf = Path(name), Path(name).with_suffix(".srdf")
    try:
        write_document(document, tmp, comment=f"written by robodyn params from {robot.urdf_path} ({kind}: {summary})")
        _ordinary_mode(tmp)
        if srdf_text is not None:  # beside tmp under its stem (load finds it there), never through a planted link
            write_text_atomically(tmp_srdf, srdf_text)
        params = _verify(robot, kind, before, changes, document, tmp, path, free_flyer=free_flyer)
        os.replace(tmp, path)
        if srdf_text is not None:
            os.replace(tmp_srdf, path.with_suffix(".srdf"))
    finally:
        for leftover in (tmp, tmp_srdf):
            leftover.unlink(missing_ok=True)
    return Written(path, None if srdf_text is None else path.with_suffix(".srdf"), params)


def _srdf_to_write(robot: Robot, before: Params, changes: Mapping[str, float], path: Path) -> str | None:
    """The SRDF text to write next to ``path`` (None: none); never over the model's own, never leaving a stale one."""
    text: str | None = None
    if {"J_m", "n"} & set(changes):
        (info,) = robot.joints
        text = _rotor_srdf(robot, info.name, changes.get("J_m", before["J_m"]), changes.get("n", before["n"]))
    elif robot.srdf_path is not None:
        text = robot.srdf_path.read_text()
    srdf = path.with_suffix(".srdf")
    if text is not None and _same_file(srdf, robot.srdf_path):
        raise InputError(f"cannot write {srdf}: it is the model's own SRDF (write the modified model elsewhere)")
    stale = find_srdf(path) if text is None else None
    if stale is not None:
        raise InputError(
            f"cannot write {path}: {stale} would be read with it as its SRDF, and {robot.name} has none "
            "(remove it or write elsewhere)"
        )
    return text


def _ordinary_mode(path: Path) -> None:
    """Give ``path`` (made private by mkstemp) the permissions of a newly created file."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, 0o666 & ~umask)


def _verify(
    robot: Robot,
    kind: str,
    before: Params,
    changes: Mapping[str, float],
    document: Document,
    tmp: Path,
    path: Path,
    *,
    free_flyer: bool,
) -> Params:
    """Load the written file, extract ``kind`` again and compare with the request; ModelError otherwise."""

    def refuse(message: str) -> ModelError:
        return ModelError(f"{message.replace(f'{tmp}: ', '').replace(str(tmp), str(path))}; nothing written", path=path)

    if not same_robot(document, tmp):
        raise refuse("yourdfpy wrote a URDF that does not read back as the edited robot")
    try:
        written = load(tmp, free_flyer=free_flyer)
    except ModelError as exc:
        raise refuse(f"the modified model is refused: {exc}") from None
    try:
        after = extract(written, kind)
    except AssumptionError as exc:
        raise refuse(f"the modified model is no longer a {kind}: {exc}") from None
    for name, got in after.items():
        want = changes.get(name, before[name])
        scale = max(abs(want), abs(before[name]))
        if abs(got - want) > VERIFY_RTOL * scale:
            status = "as set" if name in changes else "unchanged"
            raise refuse(f"the written model has {name} = {got!r}, expected {want!r} ({status})")
    _check_untouched(robot, written, rotor="J_m" in changes or "n" in changes, refuse=refuse)
    return after


def _check_untouched(robot: Robot, written: Robot, *, rotor: bool, refuse: Callable[[str], ModelError]) -> None:
    """Joint names, limits, damping, friction and gravity as before (and armature unless a rotor was set)."""
    if written.joint_names != robot.joint_names:
        raise refuse(f"the written model's joints are {written.joint_names}, expected {robot.joint_names}")
    fields = ["lowerPositionLimit", "upperPositionLimit", "effortLimit", "velocityLimit", "damping", "friction"]
    if not rotor:
        fields += ["armature", "rotorInertia", "rotorGearRatio"]
    for field in fields:
        old, new = (np.asarray(getattr(r.model, field), dtype=np.float64) for r in (robot, written))
        if not np.allclose(new, old, rtol=VERIFY_RTOL, atol=0.0):
            raise refuse(f"the written model's {field} is {new.tolist()}, expected {old.tolist()}")
    if not np.array_equal(np.asarray(written.model.gravity.linear), np.asarray(robot.model.gravity.linear)):
        raise refuse("the written model's gravity differs")
