"""From a URDF (+ SRDF) on disk, or a built-in name, to a :class:`robodyn.Robot`.

The built-in models live in the top-level ``models/`` folder of the source tree and are
shipped inside the wheel as ``robodyn/models``; variants of them (the geared arm with its
rotor as a body, the cart-pole with a point bob) live in ``models/variants/``. Every robot
of example-robot-data is reachable by name too (see :mod:`robodyn.robot_library`).

An SRDF with the same stem as the URDF (next to it, or in a sibling ``srdf/`` folder as
example-robot-data lays them out) is picked up automatically. From the SRDF robodyn reads

* ``<rotor_params>`` through ``pinocchio.loadRotorParameters`` (armature = J_m n^2),
* ``<passive_joint name="..."/>``: joints that no actuator drives (names of joints the
  model does not have are skipped: one SRDF often serves several URDFs of a robot), and
* ``<group_state>``: named configurations, see :func:`reference_configurations`.

``load(..., lock=..., keep=...)`` returns the minimal model of a scene: the joints not kept
are locked through ``pinocchio.buildReducedModel`` (see :mod:`robodyn.reduce`).

Dynamics never parses meshes: geometry is loaded only by :func:`load_geometry`.
"""

from __future__ import annotations

import difflib
import importlib.resources
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from robodyn.errors import InputError, ModelError, UnknownNameError
from robodyn.registry import Registry
from robodyn.robot import Robot
from robodyn.urdf_check import validate_urdf

if TYPE_CHECKING:
    from robodyn.reduce import Reduction

BUILTIN_NAMES = ("cart_pole", "geared_arm", "pendubot")

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
    return Path(__file__).resolve().parents[2] / "models"


_DESCRIPTIONS = {
    "geared_arm": "single link driven by a DC motor through an n:1 gear train (seed Example 6.1.1)",
    "cart_pole": "cart on a rail with a passive pole (seed Example 2)",
    "pendubot": "two-link planar arm, joint 1 actuated, joint 2 passive (Spong and Block)",
    "geared_arm_rotor": "geared_arm with the rotor as its own body, coupled to the link by a mimic joint",
    "cart_pole_point_bob": "cart_pole with the pole's mass as a point bob at its centre of mass",
}


def _builtin_sources() -> Registry[ModelSource]:
    registry: Registry[ModelSource] = Registry("model")
    for folder, names in ((models_dir(), BUILTIN_NAMES), (models_dir() / "variants", VARIANT_NAMES)):
        for name in names:
            urdf = folder / f"{name}.urdf"
            if not urdf.is_file():
                continue
            srdf = folder / f"{name}.srdf"
            registry.register(name, ModelSource(urdf, srdf if srdf.is_file() else None, _DESCRIPTIONS[name]))
    return registry


def model_sources() -> Registry[ModelSource]:
    """Every model reachable by name: the built-ins and variants, then example-robot-data."""
    from robodyn import robot_library

    registry = _builtin_sources()
    for name, source in robot_library.sources().items():
        if name not in registry:
            registry.register(name, source)
    return registry


def looks_like_path(name_or_path: str | Path) -> bool:
    """True when the argument should be read as a file path rather than a model name."""
    text = str(name_or_path)
    return isinstance(name_or_path, Path) or text.endswith((".urdf", ".xml")) or "/" in text or "\\" in text


def resolve(name_or_path: str | Path, *, srdf: str | Path | None = None) -> ModelSource:
    """Turn a built-in or library name, or a URDF path, into a :class:`ModelSource`."""
    if looks_like_path(name_or_path):
        urdf = Path(name_or_path)
        if not urdf.is_file():
            raise ModelError("no such URDF file (expected a path to a .urdf file or a model name)", path=urdf)
        found = Path(srdf) if srdf is not None else find_srdf(urdf)
        return ModelSource(urdf, found, f"URDF file {urdf.name}")
    sources = model_sources()
    if str(name_or_path) not in sources:
        raise UnknownModelError(str(name_or_path), sources.names())
    source = sources.get(str(name_or_path))
    if srdf is not None:
        return ModelSource(source.urdf, Path(srdf), source.description, source.free_flyer_hint)
    return source


class UnknownModelError(UnknownNameError):
    """A model name that is neither built in nor in example-robot-data: the close names first."""

    def __init__(self, name: str, choices: Iterable[str]) -> None:
        super().__init__("model", name, choices)
        close = difflib.get_close_matches(name, self.choices, n=5, cutoff=0.6)
        hint = f"did you mean {', '.join(close)}? " if close else ""
        self.args = (
            f"unknown model {name!r}; {hint}'robodyn info --list' names all {len(self.choices)} models "
            "(or give a path to a .urdf file)",
        )


def find_srdf(urdf: Path) -> Path | None:
    """The SRDF that goes with ``urdf``: same stem, next to it or in a sibling ``srdf/`` folder."""
    for candidate in (urdf.with_suffix(".srdf"), urdf.parent.parent / "srdf" / f"{urdf.stem}.srdf"):
        if candidate.is_file():
            return candidate
    return None


def _parse_xml(path: Path, what: str) -> ET.Element:
    try:
        return ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ModelError(f"malformed {what} XML: {exc}", path=path) from None
    except OSError as exc:
        raise ModelError(f"cannot read {what}: {exc.strerror}", path=path) from None


@dataclass(frozen=True)
class SrdfInfo:
    """What robodyn reads from an SRDF."""

    has_rotor_params: bool
    passive_joints: tuple[str, ...]


def read_srdf(path: Path) -> SrdfInfo:
    """Read rotor parameters' presence and passive joints from an SRDF file."""
    root = _parse_xml(path, "SRDF")
    _check_srdf_root(root, path)
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


def _check_urdf_root(root: ET.Element, path: Path) -> None:
    if root.tag != "robot":
        raise ModelError(f"root element is <{root.tag}>, expected <robot>", path=path)
    if not root.get("name"):
        raise ModelError("<robot> has no name attribute (an empty xacro stub?)", path=path)
    if root.find("link") is None:
        raise ModelError("the URDF has no <link>", path=path)


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

    Raises:
        ModelError: a missing or malformed file, or an impossible inertia.
        UnknownNameError: a name that is neither built in nor in example-robot-data, or a
            locked/kept joint the model does not have.
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
        ).reduced
    source = resolve(name_or_path, srdf=srdf)
    root = _parse_xml(source.urdf, "URDF")
    _check_urdf_root(root, source.urdf)
    validate_urdf(root, source.urdf)
    model = build_model(source.urdf, free_flyer=free_flyer, mimic=mimic)
    passive: tuple[str, ...] = ()
    if source.srdf is not None:
        if not source.srdf.is_file():
            raise ModelError("no such SRDF file", path=source.srdf)
        info = read_srdf(source.srdf)
        if info.has_rotor_params:
            _load_rotor_parameters(model, source.srdf)
        known = set(list(model.names)[1:])
        passive = tuple(name for name in info.passive_joints if name in known)
    if check_physics:
        refuse_impossible(model, source.urdf)
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
) -> Reduction:
    """As :func:`load` with ``lock``/``keep``, but return the whole :class:`robodyn.reduce.Reduction`.

    The full model is checked for impossible inertias except joints that move nothing (a
    joint that moves nothing makes M singular, unless it is locked); the reduced model must
    have none left.
    """
    from robodyn.reduce import reduce

    if lock is None and keep is None:
        raise InputError("load_reduction needs lock or keep (the joints to lock or to keep)")
    full = load(name_or_path, srdf=srdf, free_flyer=free_flyer, mimic=mimic, check_physics=False)
    if check_physics:
        refuse_impossible(full.model, full.urdf_path or Path(str(name_or_path)), skip=("massless_subtree",))
    reduction = reduce(full, lock=lock, keep=keep, reference=reference)
    if check_physics:
        refuse_impossible(reduction.reduced.model, full.urdf_path or Path(str(name_or_path)))
    return reduction


def refuse_impossible(model: pin.Model, urdf: Path, *, skip: tuple[str, ...] = ()) -> None:
    """Raise :class:`ModelError` on the first impossible finding whose code is not in ``skip``."""
    from robodyn.consistency import impossible_inertials

    problems = [f for f in impossible_inertials(model) if f.code not in skip]
    if problems:
        more = f" (and {len(problems) - 1} more; see robodyn info)" if len(problems) > 1 else ""
        raise ModelError(f"physically impossible model: {problems[0]}{more}", path=urdf)


def build_model(urdf: Path, *, free_flyer: bool = False, mimic: bool = False) -> pin.Model:
    """Parse ``urdf`` into a Pinocchio model (no geometry)."""
    try:
        if free_flyer:
            return pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer(), mimic=mimic)
        return pin.buildModelFromUrdf(str(urdf), mimic=mimic)
    except (RuntimeError, ValueError) as exc:
        raise ModelError(f"Pinocchio cannot parse this URDF: {pinocchio_message(exc)}", path=urdf) from None


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
    reflected = np.asarray(model.rotorInertia) * np.square(np.asarray(model.rotorGearRatio))
    armature = np.asarray(model.armature, dtype=np.float64)
    model.armature = np.where(armature == 0.0, reflected, armature)


def unknown_passive_joints(robot: Robot) -> tuple[str, ...]:
    """Passive joints named by the robot's SRDF that the model does not have (skipped at load)."""
    if robot.srdf_path is None or not robot.srdf_path.is_file():
        return ()
    known = set(robot.joint_names)
    return tuple(n for n in read_srdf(robot.srdf_path).passive_joints if n not in known)


def reference_configurations(robot: Robot) -> dict[str, np.ndarray]:
    """The SRDF's named ``<group_state>`` configurations of ``robot``, each shape (nq,).

    Joints a group state does not mention keep their neutral value. Empty without SRDF.
    Works on reduced robots too (the state is read joint by joint by name).
    """
    if robot.srdf_path is None or not robot.srdf_path.is_file():
        return {}
    root = _parse_xml(robot.srdf_path, "SRDF")
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


def joint_coordinates(kind: str, nq: int, values: ArrayLike) -> NDArray[np.float64]:
    """The nq coordinates of a joint from a user's values.

    One angle for a continuous joint (stored as cos, sin), one value for a 1-coordinate
    joint, or all nq values.
    """
    vals = np.asarray(values, dtype=np.float64).reshape(-1)
    if vals.size == nq:
        return vals
    if vals.size == 1 and nq == 2 and kind.startswith("JointModelRUB"):
        return np.array([np.cos(vals[0]), np.sin(vals[0])])
    raise InputError(f"a {kind} joint takes {nq} value(s), got {vals.size}")


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
    from robodyn import robot_library

    package_dirs = [str(d) for d in robot_library.package_dirs(robot.urdf_path)]
    try:
        return pin.buildGeomFromUrdf(robot.model, str(robot.urdf_path), geometry_type, package_dirs=package_dirs)
    except (RuntimeError, ValueError) as exc:
        raise ModelError(
            f"cannot load {kind} geometry: {str(exc).strip().splitlines()[0]}", path=robot.urdf_path
        ) from None


@dataclass(frozen=True)
class MeshReference:
    """One ``<mesh filename=...>`` of a URDF: the link, visual or collision, URI and file."""

    link: str
    kind: str  # "visual" or "collision"
    uri: str
    path: Path | None  # the file it resolves to, or None when no candidate exists


def mesh_references(urdf: Path) -> list[MeshReference]:
    """Every mesh a URDF refers to, resolved like :func:`load_geometry` would (no mesh is read)."""
    from robodyn import robot_library

    root = _parse_xml(urdf, "URDF")
    dirs = robot_library.package_dirs(urdf)
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
    import os

    return [Path(d) for d in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if d]
