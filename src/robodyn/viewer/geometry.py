"""The robot's shapes: Pinocchio's visual geometry as meshcat objects, with their placements.

Each drawable geometry (box, sphere, ellipsoid, cylinder, capsule, or an STL/DAE/OBJ/glTF mesh on
disk; glTF sent as its triangles, through trimesh) becomes a :class:`SceneObject` holding its world
placement at every rendered frame; the others are named as skipped. Colours: the URDF's when it
gives one, else the static base in grey and one colour per moving joint.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.viewer.backend import ROOT, scene_path
from robodyn.viewer.palette import BLACK, BLUE, BLUISH_GREEN, ORANGE, REDDISH_PURPLE, SKY_BLUE, VERMILLION, YELLOW
from robodyn.viewer.transforms import rotation_x

if TYPE_CHECKING:
    import pinocchio as pin

    from robodyn.robot import Robot

Array = NDArray[np.float64]

# Colours: the static base in grey, then one colour per moving joint (URDF colours win).
BASE_COLOR = 0x5D6D7E
LINK_COLORS = (VERMILLION, BLUISH_GREEN, REDDISH_PURPLE, ORANGE, BLUE, SKY_BLUE, YELLOW, BLACK)
"""Okabe–Ito (viewer.palette), the first three far in hue from the sky-blue background and the yellow trace."""
_PINOCCHIO_DEFAULT_RGBA = (0.9, 0.9, 0.9, 1.0)

_MESH_FORMATS = {".stl": "stl", ".dae": "dae", ".obj": "obj", ".glb": "glb", ".gltf": "glb"}


@dataclass(frozen=True, eq=False)
class SceneObject:
    """One drawn object: its scene path, what it is, and its placements over the playback.

    ``placements`` has shape (k, 4, 4): the world (or parent-group) transform at each
    rendered sample; ``intrinsic`` (4, 4) is applied inside it (cylinder axis, mesh scale);
    ``corners`` (8, 3) are the corners of the shape's bounding box in its own frame [m].
    """

    path: tuple[str, ...]
    kind: str
    placements: Array
    intrinsic: Array
    corners: Array
    source: str = ""


def geometry_objects(
    robot: Robot, geometry: pin.GeometryModel | None, configurations: Array, *, group: str = "robot"
) -> tuple[list[SceneObject], list[Any], list[str]]:
    """Every drawable geometry with its world placements (k, 4, 4); the names of those skipped.

    Args:
        robot: the model.
        geometry: its visual ``GeometryModel``; None loads it from the URDF (meshes are parsed only now).
        configurations: the rendered configurations, shape (k, nq).
        group: the scene group the objects are drawn under (``ROOT/group/name``).

    Returns:
        The objects, the Pinocchio geometry object behind each, and the names of the geometries skipped.
    """
    if geometry is None:
        from robodyn.model.load import load_geometry

        geometry = load_geometry(robot, kind="visual")
    placements = np.array(
        [dynamics.geometry_placements(robot.model, robot.data, geometry, qk) for qk in configurations]
    ).reshape(len(configurations), len(geometry.geometryObjects), 4, 4)
    objects: list[SceneObject] = []
    geoms: list[Any] = []
    skipped: list[str] = []
    used: set[str] = set()
    for i, geom in enumerate(geometry.geometryObjects):
        kind, intrinsic = _shape(geom)
        if kind == "":
            skipped.append(str(geom.name))
            continue
        name = _unique(str(geom.name).replace("/", "_") or f"geometry_{i}", used)
        objects.append(
            SceneObject((*ROOT, group, name), kind, placements[:, i], intrinsic, _box_corners(geom), str(geom.meshPath))
        )
        geoms.append(geom)
    return objects, geoms, skipped


def object_commands(mc: Any, obj: SceneObject, geom: Any, *, tint: tuple[int, float] | None = None) -> list[Any]:
    """The meshcat commands that draw ``obj`` (its shape, colour and first placement).

    ``tint`` (colour, opacity) overrides the shape's own colour: a run's ghost in a replay of several.
    """
    color, opacity = _color(geom) if tint is None else tint
    material = mc.geometry.MeshLambertMaterial(color=color, opacity=opacity)
    path = scene_path(mc, obj.path)
    return [
        mc.commands.SetObject(_meshcat_geometry(mc, geom, obj.kind), material, path),
        mc.commands.SetTransform(obj.placements[0], path),
        mc.commands.SetTransform(obj.intrinsic, scene_path(mc, (*obj.path, "<object>"))),
    ]


def _unique(name: str, used: set[str]) -> str:
    candidate, n = name, 1
    while candidate in used:
        n += 1
        candidate = f"{name}_{n}"
    used.add(candidate)
    return candidate


def _shape(geom: Any) -> tuple[str, Array]:
    """(kind, intrinsic transform) of a Pinocchio geometry object; kind "" if it cannot be drawn."""
    shape = type(geom.geometry).__name__
    if shape in ("Box", "Sphere", "Ellipsoid"):
        return shape.lower(), np.eye(4)
    if shape in ("Cylinder", "Capsule"):
        # meshcat draws cylinders along y, URDF along z: turn by +90 degrees about x.
        return shape.lower(), rotation_x(np.pi / 2)
    suffix = Path(str(geom.meshPath)).suffix.lower()
    if suffix in _MESH_FORMATS and Path(str(geom.meshPath)).is_file():
        scale = np.ones(4)
        scale[:3] = np.asarray(geom.meshScale, dtype=np.float64)
        return "mesh", np.diag(scale)
    return "", np.eye(4)


def _meshcat_geometry(mc: Any, geom: Any, kind: str) -> Any:
    g = geom.geometry
    if kind == "box":
        return mc.geometry.Box(list(2.0 * np.asarray(g.halfSide, dtype=float)))
    if kind == "sphere":
        return mc.geometry.Sphere(float(g.radius))
    if kind == "ellipsoid":
        return mc.geometry.Ellipsoid(list(np.asarray(g.radii, dtype=float)))
    if kind == "cylinder":
        return mc.geometry.Cylinder(2.0 * float(g.halfLength), float(g.radius))
    if kind == "capsule":  # drawn as its cylindrical hull: meshcat 0.3 has no capsule
        return mc.geometry.Cylinder(2.0 * float(g.halfLength) + 2.0 * float(g.radius), float(g.radius))
    path = str(geom.meshPath)
    if _MESH_FORMATS[Path(path).suffix.lower()] == "glb":  # meshcat has no glTF loader: its triangles as an OBJ
        import trimesh

        return mc.geometry.MeshGeometry(trimesh.load(path, force="mesh").export(None, file_type="obj"), "obj")
    loader = {
        "stl": mc.geometry.StlMeshGeometry,
        "dae": mc.geometry.DaeMeshGeometry,
        "obj": mc.geometry.ObjMeshGeometry,
    }[_MESH_FORMATS[Path(path).suffix.lower()]]
    return loader.from_file(path)


def _color(geom: Any) -> tuple[int, float]:
    rgba = tuple(float(x) for x in np.asarray(geom.meshColor).ravel()[:4])
    if len(rgba) == 4 and not np.allclose(rgba, _PINOCCHIO_DEFAULT_RGBA):
        r, g, b = (round(255 * min(max(c, 0.0), 1.0)) for c in rgba[:3])
        return (r << 16) | (g << 8) | b, rgba[3]
    joint = int(geom.parentJoint)
    if joint == 0:
        return BASE_COLOR, 1.0
    return LINK_COLORS[(joint - 1) % len(LINK_COLORS)], 1.0


def _box_corners(geom: Any) -> Array:
    """Corners (8, 3) of the shape's axis-aligned bounding box in its own frame [m]."""
    g = geom.geometry
    try:
        g.computeLocalAABB()
        low, high = np.asarray(g.aabb_local.min_, dtype=float), np.asarray(g.aabb_local.max_, dtype=float)
    except (AttributeError, RuntimeError):
        low = high = np.zeros(3)
    return np.array(
        [[(low, high)[i][0], (low, high)[j][1], (low, high)[k][2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    )
