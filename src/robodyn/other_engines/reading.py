"""What another engine holds after reading a URDF, in one shape for every engine.

Each engine's module (:mod:`robodyn.other_engines.mujoco_side`, ``pybullet_side``, ``drake_side``) reads the file
and returns an :class:`EngineReading`: per moving joint, the inertia of the bodies it moves (the joint's child
link with every link welded to it by fixed joints, as Pinocchio merges them), expressed in the child link's
frame; the joint's axis, limits, damping and armature; and a function evaluating M(q), C(q, v) v and G(q).

Units: mass [kg], centre of mass [m], rotational inertia about the centre of mass [kg m^2], q [rad | m].
"""

from __future__ import annotations

import functools
import os
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from robodyn.errors import MissingDependencyError

Array = NDArray[np.float64]
# (q, v) of the moving joints in the order of ``EngineReading.names`` -> (M, C v, G) in that order. With a free
# flyer, q and v begin with its 7 coordinates and 6 velocities in Pinocchio's convention, and so do M, C v, G
# (robodyn.other_engines.floating maps them).
Evaluate = Callable[[Array, Array], tuple[Array, Array, Array]]

ENGINES = ("mujoco", "pybullet", "drake")
DEFAULT, TRUSTED = "default", "trusted"


@dataclass(frozen=True)
class BodyInertia:
    """The inertia a moving joint carries: its child link and the links welded to it (``links``)."""

    links: tuple[str, ...]
    mass: float
    com: Array
    inertia: Array


@dataclass(frozen=True)
class JointReading:
    """One moving joint as the engine holds it; ``lower``/``upper`` are nan where it has no limit.

    ``effort`` [N m | N] and ``velocity`` [rad/s | m/s] limits: nan where the joint has none, None where the
    engine holds no such limit at all (MuJoCo has no velocity limit; Drake an effort limit only on an actuator,
    which a URDF ``<transmission>`` makes). ``friction`` [N m | N]: the joint's dry friction (URDF
    ``<dynamics friction>``; MuJoCo's ``frictionloss``).
    """

    axis: Array
    lower: float
    upper: float
    damping: float
    armature: float
    effort: float | None = None
    velocity: float | None = None
    friction: float = 0.0


@dataclass(frozen=True, eq=False)
class EngineReading:
    """One engine's reading of one file with one set of options (``reading``: default or trusted)."""

    engine: str
    version: str
    reading: str
    option: str
    names: tuple[str, ...]
    bodies: dict[str, BodyInertia]
    joints: dict[str, JointReading]
    evaluate: Evaluate


@dataclass(frozen=True)
class WorldBody:
    """One engine body at the reference pose: its link name, mass, centre of mass and inertia in world axes."""

    link: str
    mass: float
    com: Array
    inertia: Array


def group_inertia(parts: Sequence[WorldBody], rotation: Array, origin: Array) -> BodyInertia:
    """Sum ``parts`` (world axes) and express the total in the frame (``rotation``, ``origin``) of the joint's link."""
    mass = float(sum(p.mass for p in parts))
    com = sum((p.mass * p.com for p in parts), np.zeros(3)) / mass if mass > 0 else parts[0].com
    inertia = np.zeros((3, 3))
    for p in parts:
        d = p.com - com
        inertia += p.inertia + p.mass * (d @ d * np.eye(3) - np.outer(d, d))
    local = rotation.T @ inertia @ rotation
    return BodyInertia(tuple(p.link for p in parts), mass, rotation.T @ (com - origin), 0.5 * (local + local.T))


@functools.cache
def engine_version(distribution: str) -> str:
    """The installed version of an engine's PyPI distribution (``mujoco``, ``pybullet``, ``drake``)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(distribution)
    except PackageNotFoundError:
        return "(version unknown)"


def require(module: str, engine: str) -> None:
    """Raise :class:`MissingDependencyError` naming the extra when ``module`` cannot be imported."""
    import importlib.util

    if importlib.util.find_spec(module) is None:
        raise MissingDependencyError(f"--against {engine} needs {engine}: pip install 'robodyn[{engine}]'")


@contextmanager
def portable_copy(urdf: Path, package_dirs: Sequence[Path], extra: ET.Element | None = None) -> Iterator[Path]:
    """A temporary copy of ``urdf`` whose mesh filenames are absolute paths, with ``extra`` appended to <robot>.

    Engines resolve ``package://`` URIs and relative paths each their own way (or not at all); the copy makes
    every engine read the same mesh files as Pinocchio. Nothing physical in the file changes.
    """
    from robodyn.model.files import read_xml, resolve_resource

    root = read_xml(urdf, "URDF")  # as robodyn read it: a blank line before the XML declaration is no error
    tree = ET.ElementTree(root)
    for mesh in root.iter("mesh"):
        name = mesh.get("filename") or ""
        found = resolve_resource(name, package_dirs) if "://" in name else urdf.parent / name
        if found is not None:
            mesh.set("filename", os.fspath(Path(found).resolve()))
    if extra is not None:
        root.append(extra)
    with tempfile.TemporaryDirectory(prefix="robodyn-against-") as folder:
        path = Path(folder) / urdf.name
        tree.write(path, encoding="utf-8", xml_declaration=True)
        yield path


def rpy_matrix(rpy: Sequence[float]) -> Array:
    """URDF's fixed-axis roll, pitch, yaw as a rotation matrix: Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    cx, sx, cy, sy, cz, sz = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx],
            [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx],
            [-sy, cy * sx, cy * cx],
        ]
    )


def joint_origins(urdf: Path) -> dict[str, tuple[str, Array, Array]]:
    """Child link -> (parent link, rotation, translation) of its joint's <origin>, read from the file."""
    from robodyn.model.files import read_xml

    out = {}
    for joint in read_xml(urdf, "URDF").findall("joint"):
        origin = joint.find("origin")
        xyz = [float(x) for x in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()]
        rpy = [float(x) for x in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
        parent, child = joint.find("parent"), joint.find("child")
        if parent is not None and child is not None:
            out[str(child.get("link"))] = (str(parent.get("link")), rpy_matrix(rpy), np.array(xyz))
    return out


@contextmanager
def quiet_native_output() -> Iterator[None]:
    """Silence what native code prints on file descriptors 1 and 2 while inside.

    PyBullet prints a banner and its loader's warnings there; its errors still reach the caller as exceptions.
    """
    import ctypes
    import sys

    sys.stdout.flush()
    sys.stderr.flush()
    saved = {fd: os.dup(fd) for fd in (1, 2)}
    try:
        with open(os.devnull, "wb") as null:
            for fd in saved:
                os.dup2(null.fileno(), fd)
            yield
    finally:
        ctypes.CDLL(None).fflush(None)  # what C's stdio buffered goes to /dev/null, not to the next print
        for fd, copy in saved.items():
            os.dup2(copy, fd)
            os.close(copy)
