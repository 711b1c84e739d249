"""Robots shipped by the ``example-robot-data`` package, reachable by name.

The PyPI wheel of example-robot-data carries URDF, SRDF and meshes under
``cmeel.prefix/share/example-robot-data/robots`` but no Python loader, so robodyn indexes
that folder itself: every URDF is reachable by its file stem, and a few short aliases
follow example-robot-data's own loader names (``talos``, ``ur5``, ``hyq``...).
"""

from __future__ import annotations

import importlib.metadata
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from robodyn.models import ModelSource

# Loader-style short names -> URDF stem (where the stem is not the obvious name).
ALIASES = {
    "talos": "talos_reduced",
    "talos_full": "talos_full_v2",
    "ur3": "ur3_robot",
    "ur5": "ur5_robot",
    "ur10": "ur10_robot",
    "hyq": "hyq_no_sensors",
    "romeo": "romeo_small",
    "tiago": "tiago",
    "quadrotor": "quadrotor_base",
    "alexander": "alexander_v1.lowerBodyOnly",
    "g1": "g1_29dof_rev_1_0",
    "anymal": "anymal_b",
}


@lru_cache(maxsize=1)
def robots_dir() -> Path | None:
    """The ``robots`` folder of the installed example-robot-data, or None if absent."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return None
    folder = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    return folder if folder.is_dir() else None


def _name_for(urdf: Path, stems: dict[str, int]) -> str:
    # Two packages ship an "anymal.urdf": disambiguate with the package folder.
    if stems[urdf.stem] > 1:
        package = urdf.parent.parent.name.removesuffix("_description").removesuffix("_simple")
        return package
    return urdf.stem


@lru_cache(maxsize=1)
def sources() -> dict[str, ModelSource]:
    """Name -> :class:`ModelSource` for every URDF in example-robot-data (empty if absent)."""
    from robodyn.models import ModelSource, find_srdf

    folder = robots_dir()
    if folder is None:
        return {}
    urdfs = sorted(folder.glob("*/*/*.urdf"))
    stems: dict[str, int] = {}
    for urdf in urdfs:
        stems[urdf.stem] = stems.get(urdf.stem, 0) + 1
    table: dict[str, ModelSource] = {}
    for urdf in urdfs:
        name = _name_for(urdf, stems)
        table[name] = ModelSource(urdf, find_srdf(urdf), f"example-robot-data {urdf.parent.parent.name}/{urdf.name}")
    for alias, target in ALIASES.items():
        if target in table and alias not in table:
            table[alias] = table[target]
    return table


def package_dirs(urdf: Path) -> list[Path]:
    """Folders in which ``package://name/...`` URIs of ``urdf`` are resolved."""
    dirs = [urdf.resolve().parent, urdf.resolve().parent.parent, urdf.resolve().parent.parent.parent]
    folder = robots_dir()
    if folder is not None:
        dirs.append(folder)
    return dirs
