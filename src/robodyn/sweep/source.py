"""Where a sweep's runs get their robot: a model name or URDF, or the scene file the sweep names.

The scene package sits above the sweep in robodyn's layers, so nothing here imports it: the caller
(``robodyn sweep``, or :func:`robodyn.sweep.run` given ``read_scene=robodyn.scene.read_scene``)
reads the scene and hands the :class:`~robodyn.scene.Scene` down. The sweep only calls what
:class:`SceneLike` lists: ``build`` (the model, reduced to the joints the scene keeps),
``initial_state``, ``torque`` (the scene's [control]) and the ``simulate``, ``constraints`` and
``model`` tables.

A :class:`SceneSource` carries the scene to the workers inside each chunk (it pickles with it)
and is hashed by a key, the digest of the files that decide its numbers, so a worker builds
each scene's robot and controller once.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from robodyn.robot import Robot
from robodyn.sim.constraints import Constraints

Array = NDArray[np.float64]


class SceneLike(Protocol):
    """What the sweep uses of a :class:`robodyn.scene.Scene`."""

    @property
    def path(self) -> Path:
        """The scene file."""
        ...

    @property
    def model(self) -> dict[str, Any]:
        """The [model] table (paths resolved)."""
        ...

    @property
    def control(self) -> dict[str, Any]:
        """The [control] table."""
        ...

    @property
    def simulate(self) -> dict[str, Any] | None:
        """The [simulate] table with its defaults, or None."""
        ...

    @property
    def constraints(self) -> Constraints:
        """The [constraints] and [springs] tables."""
        ...

    def build(self) -> tuple[Robot, Any]:
        """The robot (reduced when joints are locked) and its reduction (or None)."""
        ...

    def initial_state(self, robot: Robot, reduction: Any = None) -> tuple[Array, Array]:
        """(q0 (nq,), v0 (nv,)) of the scene."""
        ...

    def torque(self, robot: Robot, reduction: Any = None) -> Any:
        """None, a constant torque (nv,), or a controller tau(t, q, v)."""
        ...


SceneReader = Callable[[Path], SceneLike]
"""A function that reads a scene file (``robodyn.scene.read_scene``)."""


@dataclass(frozen=True, eq=False)
class SceneSource:
    """The scene a sweep runs, possibly with its model file replaced (a parameter setting's URDF).

    ``key`` identifies it (equality and hash go by it); ``scene`` is the scene object.
    """

    key: str
    scene: Any

    def __hash__(self) -> int:
        return hash(self.key)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, SceneSource) and other.key == self.key

    def __repr__(self) -> str:
        return f"SceneSource({self.scene.path}, {self.key[:12]})"

    def build(self) -> tuple[Robot, Any]:
        """(robot, reduction or None) as the scene builds it."""
        robot, reduction = self.scene.build()
        return robot, reduction

    @property
    def constraints(self) -> Constraints:
        """The scene's [constraints] and [springs]."""
        constraints: Constraints = self.scene.constraints
        return constraints

    @property
    def backend(self) -> str | None:
        """The scene's [simulate] backend, or None (simulate picks)."""
        table = self.scene.simulate or {}
        backend = table.get("backend")
        return None if backend is None else str(backend)

    def with_urdf(self, urdf: Path) -> SceneSource:
        """This scene with its model read from ``urdf`` (same SRDF, joints kept or locked, reference)."""
        model = {k: v for k, v in self.scene.model.items() if k != "name"}
        model["urdf"] = Path(urdf)
        scene = dataclasses.replace(self.scene, model=model)
        return SceneSource(_digest(self.key, Path(urdf).read_bytes()), scene)

    def full(self) -> Robot:
        """The scene's model before any joint is locked (parameters are written to its URDF)."""
        model = {k: v for k, v in self.scene.model.items() if k not in ("keep", "lock", "reference")}
        robot, _ = dataclasses.replace(self.scene, model=model).build()
        return robot


@dataclass(frozen=True)
class AsWritten:
    """A model name or URDF path loaded with its file's numbers as written (a sweep's ``physics_check = false``)."""

    name: str

    def __str__(self) -> str:
        return self.name

    def __fspath__(self) -> str:
        return self.name

    def build(self) -> tuple[Robot, None]:
        """(robot, None): the model loaded without refusing physically impossible inertias."""
        from robodyn.model.load import load

        return load(self.name, check_physics=False), None


Model = str | SceneSource | AsWritten


def scene_source(scene: SceneLike) -> SceneSource:
    """The source of a scene just read: keyed by the bytes of the scene file and of the files it names."""
    parts = [Path(scene.path).read_bytes()]
    for value in (scene.model.get("urdf"), scene.model.get("srdf"), scene.control.get("path")):
        if value is not None and Path(value).is_file():
            parts.append(Path(value).read_bytes())
    return SceneSource(_digest(str(Path(scene.path).resolve()), *parts), scene)


def simulate_defaults(scene: SceneLike) -> Mapping[str, Any]:
    """The scene's [simulate] table (duration, dt, integrator), or nothing."""
    return dict(scene.simulate or {})


def has_control(scene: SceneLike) -> bool:
    """Whether the scene's [control] gives a torque or a controller (kind other than none)."""
    c = scene.control
    return c.get("kind", "constant" if "torque" in c else "none") != "none"


def _digest(*parts: str | bytes) -> str:
    h = hashlib.sha256()
    for part in parts:
        data = part.encode() if isinstance(part, str) else part
        h.update(hashlib.sha256(data).digest())
    return h.hexdigest()
