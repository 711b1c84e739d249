"""From a URDF (+ SRDF) on disk, or a built-in name, to a :class:`robodyn.Robot`.

The built-in models live in the top-level ``models/`` folder of the source tree and are
shipped inside the wheel as ``robodyn/models``. An SRDF with the same stem as the URDF
(next to it, or in a sibling ``srdf/`` folder as example-robot-data lays them out) is
picked up automatically. From the SRDF robodyn reads

* ``<rotor_params>`` through ``pinocchio.loadRotorParameters`` (armature += J_m n^2), and
* ``<passive_joint name="..."/>``: joints that no actuator drives.

Dynamics never parses meshes: geometry is loaded only by :func:`load_geometry`.
"""

from __future__ import annotations

import importlib.resources
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from robodyn.errors import InputError, ModelError
from robodyn.registry import Registry
from robodyn.robot import Robot

BUILTIN_NAMES = ("cart_pole", "geared_arm", "pendubot")


@dataclass(frozen=True)
class ModelSource:
    """Where a named model comes from: its URDF, optional SRDF and a one-line description."""

    urdf: Path
    srdf: Path | None
    description: str


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
}


def _builtin_sources() -> Registry[ModelSource]:
    registry: Registry[ModelSource] = Registry("model")
    folder = models_dir()
    for name in BUILTIN_NAMES:
        srdf = folder / f"{name}.srdf"
        registry.register(
            name,
            ModelSource(folder / f"{name}.urdf", srdf if srdf.is_file() else None, _DESCRIPTIONS[name]),
        )
    return registry


def model_sources() -> Registry[ModelSource]:
    """Every model reachable by name: the built-ins, then the robots of example-robot-data."""
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
    source = model_sources().get(str(name_or_path))
    if srdf is not None:
        return ModelSource(source.urdf, Path(srdf), source.description)
    return source


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
    passive = tuple(el.get("name", "") for el in root.iter("passive_joint"))
    return SrdfInfo(root.find("rotor_params") is not None, passive)


def _check_urdf_root(root: ET.Element, path: Path) -> None:
    if root.tag != "robot":
        raise ModelError(f"root element is <{root.tag}>, expected <robot>", path=path)
    if root.find("link") is None:
        raise ModelError("the URDF has no <link>", path=path)


def load(
    name_or_path: str | Path,
    *,
    srdf: str | Path | None = None,
    free_flyer: bool = False,
    mimic: bool = False,
    check_physics: bool = True,
) -> Robot:
    """Load a built-in model by name or any URDF by path into a :class:`Robot`.

    Args:
        name_or_path: a built-in name (``geared_arm``, ``cart_pole``, ``pendubot``), an
            example-robot-data name (``panda``, ``talos``...), or a path to a ``.urdf``.
        srdf: SRDF path; by default one with the URDF's stem is looked for.
        free_flyer: mount the root on a free-flyer joint (nq += 7, nv += 6).
        mimic: keep URDF mimic joints as mimic joints (ABA refuses them; use CRBA).
        check_physics: refuse physically impossible inertials (non-positive mass with
            inertia, an inertia that is not positive semi-definite or breaks the triangle
            inequality). ``robodyn info`` turns this off to report them instead.

    Raises:
        ModelError: a missing or malformed file, or an impossible inertia.
        UnknownNameError: a name that is neither built in nor in example-robot-data.
    """
    source = resolve(name_or_path, srdf=srdf)
    _check_urdf_root(_parse_xml(source.urdf, "URDF"), source.urdf)
    model = build_model(source.urdf, free_flyer=free_flyer, mimic=mimic)
    passive: tuple[str, ...] = ()
    if source.srdf is not None:
        if not source.srdf.is_file():
            raise ModelError("no such SRDF file", path=source.srdf)
        info = read_srdf(source.srdf)
        if info.has_rotor_params:
            _load_rotor_parameters(model, source.srdf)
        passive = info.passive_joints
    if check_physics:
        from robodyn.consistency import impossible_inertials

        problems = impossible_inertials(model)
        if problems:
            raise ModelError(f"impossible inertia: {problems[0]}", path=source.urdf)
    name = str(name_or_path) if not looks_like_path(name_or_path) else source.urdf.stem
    return Robot.from_model(
        model,
        name=name,
        urdf_path=source.urdf,
        srdf_path=source.srdf,
        passive_joints=_validate_passive(model, passive, source.srdf),
    )


def build_model(urdf: Path, *, free_flyer: bool = False, mimic: bool = False) -> pin.Model:
    """Parse ``urdf`` into a Pinocchio model (no geometry)."""
    try:
        if free_flyer:
            return pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer(), mimic=mimic)
        return pin.buildModelFromUrdf(str(urdf), mimic=mimic)
    except (RuntimeError, ValueError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ModelError(f"Pinocchio cannot parse this URDF: {first}", path=urdf) from None


def _load_rotor_parameters(model: pin.Model, srdf: Path) -> None:
    try:
        pin.loadRotorParameters(model, str(srdf), False)
    except (RuntimeError, ValueError) as exc:
        raise ModelError(f"bad <rotor_params>: {str(exc).strip().splitlines()[0]}", path=srdf) from None


def _validate_passive(model: pin.Model, names: Iterable[str], srdf: Path | None) -> tuple[str, ...]:
    known = list(model.names)[1:]
    for name in names:
        if name not in known:
            raise ModelError(
                f"<passive_joint name={name!r}> names no joint of the model; joints are: {', '.join(known)}",
                path=srdf,
            )
    return tuple(names)


def load_geometry(robot: Robot, *, kind: str = "visual") -> pin.GeometryModel:
    """Load the visual or collision geometry of ``robot`` (parses meshes; slow on big robots)."""
    if kind not in ("visual", "collision"):
        raise InputError(f"geometry kind must be 'visual' or 'collision', got {kind!r}")
    geometry_type = pin.GeometryType.VISUAL if kind == "visual" else pin.GeometryType.COLLISION
    from robodyn import robot_library

    package_dirs = [str(d) for d in robot_library.package_dirs(robot.urdf_path)]
    try:
        return pin.buildGeomFromUrdf(robot.model, str(robot.urdf_path), geometry_type, package_dirs=package_dirs)
    except (RuntimeError, ValueError) as exc:
        raise ModelError(f"cannot load {kind} geometry: {str(exc).strip().splitlines()[0]}", path=robot.urdf_path) from None


def default_configuration(robot: Robot) -> np.ndarray:
    """Pinocchio's neutral configuration of ``robot``, shape (nq,)."""
    from robodyn import dynamics

    return dynamics.neutral(robot.model)
