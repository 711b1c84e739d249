"""From a URDF (+ SRDF) on disk, or a name, to a :class:`robodyn.Robot`: one reading of the file.

:func:`load` reads the file once (:func:`robodyn.model.files.read_xml`), validates that reading
(:mod:`robodyn.model.urdf`: numbers as urdfdom reads them, the tree, the limits), and hands
Pinocchio the text of that same tree, so the dynamics are built from what robodyn checked. Then,
belt and braces, :func:`check_model_matches_file` compares the model with the file: the joint
and link names, and each body's mass, first moment and inertia after Pinocchio's merge of the
links welded by fixed joints. urdfdom's messages (printed by C++ on file descriptor 2) are
captured while it parses (:func:`native_stderr`): they end the one-line error when the parse
fails, and a model built after an ``Error:`` (urdfdom dropped what it could not read) is refused.

It then reads the SRDF's rotor parameters and passive joints, and refuses physically impossible
inertials, of the bodies and of each link of the file. ``load(..., lock=..., keep=...)`` returns
the minimal model of a scene: the joints not kept are locked through
``pinocchio.buildReducedModel`` (see :mod:`robodyn.model.reduce`).

Dynamics never parses meshes: geometry is loaded only by :func:`load_geometry`.
"""

from __future__ import annotations

import os
import sys
import tempfile
import threading
import xml.etree.ElementTree as ET
from collections.abc import Collection, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from robodyn.errors import InputError, ModelError, UnknownNameError
from robodyn.model.consistency import LinkInertial, impossible_inertials, link_inertials, welded_to_root
from robodyn.model.files import _check_urdf_root, looks_like_path, package_dirs, read_srdf, read_xml
from robodyn.model.reduce import Reduction, reduce
from robodyn.model.sources import resolve
from robodyn.model.urdf import check_mimic_targets, parse_numbers, urdf_text, validate_urdf
from robodyn.robot import Robot


def load(
    name_or_path: str | Path,
    *,
    srdf: str | Path | None = None,
    free_flyer: bool = False,
    mimic: bool = False,
    check_physics: bool = True,
    lock: Mapping[str, float | Sequence[float]] | None = None,
    keep: Iterable[str] | None = None,
    reference: ArrayLike | str | None = None,
    passive: Iterable[str] = (),
) -> Robot:
    """Load a built-in model by name or any URDF by path into a :class:`Robot`.

    Args:
        name_or_path: a built-in name (``geared_arm``, ``cart_pole``, ``pendubot``), an
            example-robot-data name (``panda``, ``talos``...), or a path to a ``.urdf``.
        srdf: SRDF path; by default one with the URDF's stem is looked for.
        free_flyer: mount the root on a free-flyer joint (nq += 7, nv += 6).
        mimic: keep URDF mimic joints as mimic joints (ABA refuses them; use CRBA).
        check_physics: refuse physically impossible inertials (negative mass, an inertia
            that is not positive semi-definite or breaks the triangle inequality).
            ``robodyn info`` turns this off to report them instead.
        lock: joint name -> value [rad | m] at which that joint is locked (a sequence of
            nq values for a multi-coordinate joint). The returned robot is the reduced model.
        keep: names of the joints that stay; every other joint is locked at ``reference``
            (or at its value in ``lock``).
        reference: full configuration (nq,) or the name of an SRDF group state at which
            the locked joints are held; Pinocchio's neutral configuration by default.
        passive: names of joints without an actuator, added to the SRDF's ``<passive_joint>``
            entries (for a URDF that has no SRDF saying so: ``--passive`` on the command line).

    Raises:
        ModelError: a missing or malformed file, or an impossible inertia.
        UnknownNameError: a name that is neither built in nor in example-robot-data, a
            locked/kept joint the model does not have, or a ``passive`` joint it does not have.
        InputError: a lock value of the wrong size or outside the joint's limits.
    """
    if lock is not None or keep is not None:
        return load_reduction(
            name_or_path,
            srdf=srdf,
            free_flyer=free_flyer,
            mimic=mimic,
            check_physics=check_physics,
            lock=lock,
            keep=keep,
            reference=reference,
            passive=passive,
        ).reduced
    source = resolve(name_or_path, srdf=srdf)
    root = read_xml(source.urdf, "URDF")
    _check_urdf_root(root, source.urdf)
    validate_urdf(root, source.urdf, free_flyer=free_flyer)
    inertials = link_inertials(root)
    if mimic:
        check_mimic_targets(root, source.urdf)
    model = build_model(source.urdf, free_flyer=free_flyer, mimic=mimic, root=root)
    check_model_matches_file(model, root, inertials, source.urdf, free_flyer=free_flyer)
    declared: tuple[str, ...] = ()
    if source.srdf is not None:
        if not source.srdf.is_file():
            raise ModelError("no such SRDF file", path=source.srdf)
        info = read_srdf(source.srdf)
        if info.has_rotor_params:
            _load_rotor_parameters(model, source.srdf)
        declared = info.passive_joints
    passive = passive_joint_names(model, declared, passive)
    if check_physics:
        welded = () if free_flyer else welded_to_root(root)  # on a fixed base they are the world: never moved
        refuse_impossible(model, source.urdf, links=inertials, welded=welded)
    # A name keeps its name (built-in or library); a file is named by its <robot name=...>.
    name = str(name_or_path) if not looks_like_path(name_or_path) else str(root.get("name"))
    return Robot.from_model(
        model,
        name=name,
        urdf_path=source.urdf,
        srdf_path=source.srdf,
        passive_joints=passive,
    )


def load_reduction(
    name_or_path: str | Path,
    *,
    srdf: str | Path | None = None,
    free_flyer: bool = False,
    mimic: bool = False,
    check_physics: bool = True,
    lock: Mapping[str, float | Sequence[float]] | None = None,
    keep: Iterable[str] | None = None,
    reference: ArrayLike | str | None = None,
    passive: Iterable[str] = (),
) -> Reduction:
    """As :func:`load` with ``lock``/``keep``, but return the whole :class:`robodyn.model.reduce.Reduction`.

    The full model is checked for impossible inertias except joints that move nothing (a
    joint that moves nothing makes M singular, unless it is locked); the reduced model must
    have none left.
    """
    if lock is None and keep is None:
        raise InputError("load_reduction needs lock or keep (the joints to lock or to keep)")
    full = load(name_or_path, srdf=srdf, free_flyer=free_flyer, mimic=mimic, check_physics=False, passive=passive)
    if check_physics:
        root = read_xml(full.urdf_path, "URDF") if full.urdf_path is not None else None
        links = link_inertials(root) if root is not None else []
        welded = welded_to_root(root) if root is not None and not free_flyer else set()
        refuse_impossible(
            full.model,
            full.urdf_path or Path(str(name_or_path)),
            skip=("massless_subtree",),
            links=links,
            welded=welded,
        )
    reduction = reduce(full, lock=lock, keep=keep, reference=reference)
    if check_physics:
        refuse_impossible(reduction.reduced.model, full.urdf_path or Path(str(name_or_path)))
    return reduction


# What every physics refusal ends with: the way past it, on the command line and in Python.
PAST_PHYSICS = "--no-physics-check (check_physics=False in Python) loads the file's numbers as written"


def refuse_impossible(
    model: pin.Model,
    urdf: Path,
    *,
    skip: tuple[str, ...] = (),
    links: Sequence[LinkInertial] = (),
    welded: Collection[str] = (),
) -> None:
    """Raise :class:`ModelError` on the first impossible finding (model or file ``links``) not in ``skip``.

    ``welded``: links fixed to a fixed base, whose inertia never enters the dynamics (not refused).
    """
    problems = [f for f in impossible_inertials(model, links=links, welded=welded) if f.code not in skip]
    if problems:
        more = f" (and {len(problems) - 1} more; see robodyn info)" if len(problems) > 1 else ""
        raise ModelError(f"physically impossible model: {problems[0]}{more}; {PAST_PHYSICS}", path=urdf)


def build_model(
    urdf: Path, *, free_flyer: bool = False, mimic: bool = False, root: ET.Element | None = None
) -> pin.Model:
    """Build the Pinocchio model (no geometry) from ``root``, robodyn's reading of ``urdf`` (read if None).

    Raises:
        ModelError: Pinocchio refuses the text (urdfdom's own messages end the line), or urdfdom
            printed an ``Error:`` yet built a model, without what it could not read.
    """
    text = urdf_text(root if root is not None else read_xml(urdf, "URDF"))
    failure = None
    with native_stderr() as said:
        try:
            if free_flyer:
                model = pin.buildModelFromXML(text, pin.JointModelFreeFlyer(), mimic=mimic)
            else:
                model = pin.buildModelFromXML(text, mimic=mimic)
        except (RuntimeError, ValueError) as exc:
            failure = pinocchio_message(exc)
    errors = urdfdom_errors(said)
    if failure is not None:
        told = f" (urdfdom said: {'; '.join(errors)})" if errors else ""
        raise ModelError(f"Pinocchio cannot parse this URDF: {failure}{told}", path=urdf)
    if errors:
        raise ModelError(
            f"urdfdom reported an error yet built a model without the part it could not read: {'; '.join(errors)} "
            "(expected a URDF that urdfdom reads completely)",
            path=urdf,
        )
    return model


# Pinocchio merges the links welded by fixed joints with a few products and sums per link: the
# model and robodyn's own sum of the file's numbers agree to ~1e-16 relative; 1e-9 leaves room
# for a thousand links and is still far below any printed digit.
MODEL_RTOL = 1e-9


def _quoted(names: Sequence[str], limit: int = 4) -> str:
    shown = ", ".join(repr(n) for n in names[:limit])
    return shown + (f" and {len(names) - limit} more" if len(names) > limit else "")


def _origin(element: ET.Element | None) -> pin.SE3:
    """The placement an ``<origin xyz= rpy=>`` stands for (identity when absent)."""
    values = [parse_numbers(element.get(a, "0 0 0"), 3) if element is not None else None for a in ("xyz", "rpy")]
    xyz, rpy = (np.array(v if v is not None else (0.0, 0.0, 0.0)) for v in values)
    return pin.SE3(pin.rpy.rpyToMatrix(rpy), xyz)


def _bodies(root: ET.Element) -> tuple[dict[str, str | None], dict[str, pin.SE3]]:
    """Each link's body (its nearest moving joint above, None for the root's) and its placement in that body."""
    children: dict[str, list[ET.Element]] = {}
    has_parent = set()
    for joint in root.findall("joint"):
        children.setdefault(str(joint.find("parent").get("link")), []).append(joint)  # type: ignore[union-attr]
        has_parent.add(str(joint.find("child").get("link")))  # type: ignore[union-attr]
    top = next(str(link.get("name")) for link in root.findall("link") if link.get("name") not in has_parent)
    body: dict[str, str | None] = {top: None}
    placement = {top: pin.SE3.Identity()}
    stack = [top]
    while stack:  # the tree was validated: each link is reached once
        link = stack.pop()
        for joint in children.get(link, ()):
            child = str(joint.find("child").get("link"))  # type: ignore[union-attr]
            if joint.get("type") == "fixed":
                body[child], placement[child] = body[link], placement[link] * _origin(joint.find("origin"))
            else:
                body[child], placement[child] = str(joint.get("name")), pin.SE3.Identity()
            stack.append(child)
    return body, placement


@dataclass
class _Body:
    """What the file says of one Pinocchio body: sums over its welded links, in the body frame."""

    links: list[str] = field(default_factory=list)
    mass: float = 0.0  # [kg]
    moment: np.ndarray = field(default_factory=lambda: np.zeros(3))  # m c [kg m]
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))  # about the frame's origin [kg m^2]
    scale: np.ndarray = field(default_factory=lambda: np.zeros(3))  # sums of magnitudes: the rounding scale

    def add(self, link: str, mass: float, com: np.ndarray, inertia: np.ndarray) -> None:
        """Add a link of ``mass`` [kg] with centre ``com`` [m] and ``inertia`` about it [kg m^2]."""
        moment, about_origin = _moments(mass, com, inertia)
        self.links.append(link)
        self.mass, self.moment, self.inertia = self.mass + mass, self.moment + moment, self.inertia + about_origin
        self.scale += (abs(mass), float(np.abs(moment).max()), float(np.abs(about_origin).max()))


def _moments(mass: float, com: np.ndarray, inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First moment m c [kg m] and inertia about the frame's origin [kg m^2] of a body."""
    return mass * com, inertia + mass * (float(com @ com) * np.eye(3) - np.outer(com, com))


def check_model_matches_file(
    model: pin.Model,
    root: ET.Element,
    inertials: Sequence[LinkInertial],
    urdf: Path,
    *,
    free_flyer: bool = False,
) -> None:
    """Refuse ``model`` unless it is the robot of the file: joint and link names, and every body's inertia.

    Each body is compared after Pinocchio's merge: the links welded to one joint by fixed joints
    are summed (mass, first moment, inertia about the joint frame) from the file's numbers.
    """

    def differs(what: str) -> ModelError:
        return ModelError(f"the model Pinocchio built differs from the file: {what}", path=urdf)

    in_model = [str(n) for n in list(model.names)[2 if free_flyer else 1 :]]  # a free flyer is joint 1
    in_file = [str(j.get("name")) for j in root.findall("joint") if j.get("type") != "fixed"]
    for name in sorted(set(in_file) - set(in_model)):
        raise differs(f"joint {name!r} is in the file but not in the model")
    for name in sorted(set(in_model) - set(in_file)):
        raise differs(f"joint {name!r} is in the model but not in the file")
    frames = {str(f.name) for f in model.frames if f.type == pin.FrameType.BODY}
    for link in root.findall("link"):
        if link.get("name") not in frames:
            raise differs(f"link {link.get('name')!r} is in the file but not in the model")
    body_of, placement = _bodies(root)
    bodies: dict[str | None, _Body] = {}
    for item in inertials:
        where = placement[item.link]
        rotation = where.rotation @ pin.rpy.rpyToMatrix(np.array(item.rpy))
        com = where.rotation @ np.array(item.xyz) + where.translation
        bodies.setdefault(body_of[item.link], _Body()).add(
            item.link, item.mass, com, rotation @ item.inertia @ rotation.T
        )
    for key, body in bodies.items():
        inertia = model.inertias[model.getJointId(key) if key is not None else (1 if free_flyer else 0)]
        mass = float(inertia.mass)
        moment, about_origin = _moments(mass, np.array(inertia.lever), np.array(inertia.inertia))
        label = f"link {body.links[0]!r}" if len(body.links) == 1 else f"links {_quoted(body.links)} (welded)"
        if abs(mass - body.mass) > MODEL_RTOL * max(body.scale[0], abs(mass)):
            raise differs(f"{label}: mass {mass:.6g} kg in the model, {body.mass:.6g} kg in the file")
        gap = float(np.abs(moment - body.moment).max())
        if gap > MODEL_RTOL * max(body.scale[1], float(np.abs(moment).max())):
            raise differs(f"{label}: centre of mass (first moment m c) differs by up to {gap:.3g} kg m")
        gap = float(np.abs(about_origin - body.inertia).max())
        if gap > MODEL_RTOL * max(body.scale[2], float(np.abs(about_origin).max())):
            raise differs(f"{label}: inertia about the body frame differs by up to {gap:.3g} kg m^2")
    total_model, total_file = sum(float(i.mass) for i in model.inertias), sum(i.mass for i in inertials)
    if abs(total_model - total_file) > MODEL_RTOL * sum(abs(i.mass) for i in inertials):
        raise differs(f"total mass {total_model:.6g} kg in the model, {total_file:.6g} kg in the file")


_NATIVE_STDERR = threading.Lock()  # file descriptor 2 is the process's: one capture at a time


@contextmanager
def native_stderr() -> Iterator[list[str]]:
    """Capture what native code (urdfdom's console_bridge) writes to file descriptor 2 during the block.

    Yields a list that holds, once the block is left, the captured text (one string). Python's
    own ``sys.stderr`` is flushed first; the descriptor is restored however the block ends.
    Output that other threads write to descriptor 2 meanwhile is captured too.
    """
    said: list[str] = []
    with _NATIVE_STDERR, tempfile.TemporaryFile() as sink:
        sys.stderr.flush()
        try:
            saved = os.dup(2)
        except OSError:  # no descriptor 2: nothing to capture
            yield said
            return
        try:
            os.dup2(sink.fileno(), 2)
            yield said
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            said.append(sink.read(64 * 1024).decode("utf-8", "replace"))


def urdfdom_errors(said: list[str], *, limit: int = 3) -> list[str]:
    """The first ``limit`` distinct ``Error:`` messages in text captured by :func:`native_stderr`."""
    errors: list[str] = []
    for line in "".join(said).splitlines():
        head, sep, message = line.strip().partition("Error:")
        message = " ".join(message.split())
        if sep and not head and message and message not in errors:
            errors.append(message)
    return errors[:limit]


def pinocchio_message(exc: BaseException) -> str:
    """One line from a Pinocchio exception: its ``message:`` and ``hint:`` lines when it has them."""
    lines = [line.strip() for line in str(exc).strip().splitlines() if line.strip()]
    picked = [line for line in lines if line.startswith(("message:", "hint:"))]
    if picked:
        return " ".join(picked)
    return lines[0] if lines else type(exc).__name__


def _load_rotor_parameters(model: pin.Model, srdf: Path) -> None:
    try:
        pin.loadRotorParameters(model, str(srdf), False)
    except (RuntimeError, ValueError) as exc:
        raise ModelError(f"bad <rotor_params>: {str(exc).strip().splitlines()[0]}", path=srdf) from None
    # pin >= 3 sets armature itself; older releases only filled rotorInertia/rotorGearRatio.
    with np.errstate(over="ignore", invalid="ignore"):
        reflected = np.asarray(model.rotorInertia) * np.square(np.asarray(model.rotorGearRatio))
    armature = np.asarray(model.armature, dtype=np.float64)
    armature = np.where(armature == 0.0, reflected, armature)
    if not np.all(np.isfinite(armature)):  # J n^2 overflows (n = 1e308): an infinite inertia, not a model
        k = int(np.argmax(~np.isfinite(armature)))
        raise ModelError(
            f"bad <rotor_params>: the rotor inertia {float(model.rotorInertia[k]):g} kg m^2 times the gear ratio "
            f"{float(model.rotorGearRatio[k]):g} squared is {armature[k]} (expected a finite armature)",
            path=srdf,
        )
    model.armature = armature


PASSIVE_JOINT = "passive joint"
"""What an unknown ``passive`` name is called in its :class:`UnknownNameError` (``.what``)."""


def passive_joint_names(model: pin.Model, srdf: Iterable[str], given: Iterable[str]) -> tuple[str, ...]:
    """The passive joints of ``model``: the SRDF's ``<passive_joint>`` names it has, and the ``given`` ones.

    The two sources are one set: a joint named by both is passive once. An SRDF name the model
    lacks is skipped (an SRDF written for a larger robot; ``robodyn info`` lists it through
    :func:`unknown_passive_joints`); a ``given`` name it lacks is a typo and is refused.

    Raises:
        UnknownNameError: a ``given`` name that is not a joint of ``model`` (naming those that are).
    """
    moving = [str(name) for name in list(model.names)[1:]]
    known = set(moving)
    given = (given,) if isinstance(given, str) else tuple(given)  # one name, not its letters
    for name in given:
        if name not in known:
            raise UnknownNameError(PASSIVE_JOINT, str(name), moving)
    names = set(srdf) | set(given)
    return tuple(n for n in moving if n in names)


def unknown_passive_joints(robot: Robot) -> tuple[str, ...]:
    """Passive joints named by the robot's SRDF that the model does not have (skipped at load)."""
    if robot.srdf_path is None or not robot.srdf_path.is_file():
        return ()
    known = set(robot.joint_names)
    return tuple(n for n in read_srdf(robot.srdf_path).passive_joints if n not in known)


def load_geometry(robot: Robot, *, kind: str = "visual") -> pin.GeometryModel:
    """Load the visual or collision geometry of ``robot`` (parses meshes; slow on big robots).

    Works on reduced robots: the frames of locked links survive the reduction, so each
    mesh is attached where it belongs.
    """
    if kind not in ("visual", "collision"):
        raise InputError(f"geometry kind must be 'visual' or 'collision', got {kind!r}")
    if robot.urdf_path is None:
        raise InputError(f"robot {robot.name!r} was not loaded from a URDF: it has no geometry to load")
    geometry_type = pin.GeometryType.VISUAL if kind == "visual" else pin.GeometryType.COLLISION
    dirs = [str(d) for d in package_dirs(robot.urdf_path)]
    text = urdf_text(read_xml(robot.urdf_path, "URDF"))  # the reading the model was built from
    failure = None
    with native_stderr() as said:
        try:
            geometry = pin.buildGeomFromUrdfString(robot.model, text, geometry_type, package_dirs=dirs)
        except (RuntimeError, ValueError) as exc:
            failure = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    errors = urdfdom_errors(said)
    if failure is not None or errors:
        told = "; ".join(([failure] if failure else []) + errors)
        if "package://" in told:  # a ROS package robodyn cannot find: where its packages are is the user's to say
            told += (
                " (expected the folder that holds that package on ROS_PACKAGE_PATH, "
                "e.g. ROS_PACKAGE_PATH=/path/to/share; folders separated by ':')"
            )
        raise ModelError(f"cannot load {kind} geometry: {told}", path=robot.urdf_path)
    return geometry
