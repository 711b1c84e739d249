"""From a URDF (+ SRDF) on disk, or a name, to a :class:`robodyn.Robot`.

:func:`load` validates the file (:mod:`robodyn.model.urdf`), builds the Pinocchio model, reads
the SRDF's rotor parameters and passive joints, and refuses physically impossible inertials.
``load(..., lock=..., keep=...)`` returns the minimal model of a scene: the joints not kept are
locked through ``pinocchio.buildReducedModel`` (see :mod:`robodyn.model.reduce`).

Dynamics never parses meshes: geometry is loaded only by :func:`load_geometry`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from robodyn.errors import InputError, ModelError
from robodyn.model.consistency import impossible_inertials
from robodyn.model.files import _check_urdf_root, _parse_xml, looks_like_path, package_dirs, read_srdf
from robodyn.model.reduce import Reduction, reduce
from robodyn.model.sources import resolve
from robodyn.model.urdf import validate_urdf
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
    """As :func:`load` with ``lock``/``keep``, but return the whole :class:`robodyn.model.reduce.Reduction`.

    The full model is checked for impossible inertias except joints that move nothing (a
    joint that moves nothing makes M singular, unless it is locked); the reduced model must
    have none left.
    """
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
    try:
        return pin.buildGeomFromUrdf(robot.model, str(robot.urdf_path), geometry_type, package_dirs=dirs)
    except (RuntimeError, ValueError) as exc:
        raise ModelError(
            f"cannot load {kind} geometry: {str(exc).strip().splitlines()[0]}", path=robot.urdf_path
        ) from None
