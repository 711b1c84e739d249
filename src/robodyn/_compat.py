"""The import paths of robodyn 0.1 that moved in 0.2: they still work for one release, with a warning.

``import robodyn.models`` (or ``from robodyn.simulation import simulate``) finds an alias module
here: importing it warns with a :class:`DeprecationWarning` that names the new home, and each
attribute is looked up in the new modules, in order. Nothing is imported until an old path is
used, so ``import robodyn`` stays light; robodyn's own code never uses these paths (import-linter
has no edge to see, and ``tests/test_package.py`` checks that every old name still resolves).
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from types import ModuleType
from typing import Any

REMOVED_IN = "0.3"

# Old module -> the modules (new paths) whose attributes it offered, searched in order.
MOVED: dict[str, tuple[str, ...]] = {
    "robodyn.models": (
        "robodyn.model.load",
        "robodyn.model.files",
        "robodyn.model.sources",
        "robodyn.robot",
        "robodyn.errors",
    ),
    "robodyn.robot_library": ("robodyn.model.sources", "robodyn.model.files"),
    "robodyn.urdf_check": ("robodyn.model.urdf",),
    "robodyn.consistency": ("robodyn.model.consistency",),
    "robodyn.reduce": ("robodyn.model.reduce", "robodyn.studies.exactness"),
    "robodyn.summary": ("robodyn.model.summary",),
    "robodyn.formulas": ("robodyn.kinds",),
    "robodyn.formulas.pendubot": ("robodyn.kinds.pendubot",),
    "robodyn.formulas.cart_pole": ("robodyn.kinds.cart_pole",),
    "robodyn.formulas.geared_arm": ("robodyn.kinds.geared_arm",),
    "robodyn.params": ("robodyn.kinds.params",),
    "robodyn.crosscheck": ("robodyn.kinds.check",),
    "robodyn.system": ("robodyn.sim.system",),
    "robodyn.energy": ("robodyn.sim.energy",),
    "robodyn.simulation": ("robodyn.sim.simulation", "robodyn.sim.run", "robodyn.errors"),
    "robodyn.trajectory": ("robodyn.sim.trajectory",),
    "robodyn.batch": ("robodyn.sim.batch",),
    "robodyn.fast": ("robodyn.sim.fast",),
    "robodyn.bench": ("robodyn.studies.bench",),
    "robodyn.stability": ("robodyn.studies.stability",),
}

# Names that were renamed on the way: (old module, old name) -> new name.
RENAMED: dict[tuple[str, str], str] = {}


class _Alias(ModuleType):
    """A module that forwards attribute look-ups to the modules that now hold them."""

    __targets__: tuple[str, ...]

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        wanted = RENAMED.get((self.__name__, name), name)
        for target in self.__targets__:
            module = importlib.import_module(target)
            if hasattr(module, wanted):
                return getattr(module, wanted)
        raise AttributeError(
            f"module {self.__name__!r} (moved to {', '.join(self.__targets__)}) has no attribute {name!r}"
        )


class _Finder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds the old module names of :data:`MOVED` and builds their alias modules."""

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> importlib.machinery.ModuleSpec | None:
        if fullname not in MOVED:
            return None
        is_package = any(name.startswith(fullname + ".") for name in MOVED)
        return importlib.machinery.ModuleSpec(fullname, self, is_package=is_package)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        module = _Alias(spec.name)
        module.__targets__ = MOVED[spec.name]
        return module

    def exec_module(self, module: ModuleType) -> None:
        targets = MOVED[module.__name__]
        warnings.warn(
            f"{module.__name__} moved to {' and '.join(targets)} in robodyn 0.2; "
            f"the old path will be removed in robodyn {REMOVED_IN}",
            DeprecationWarning,
            stacklevel=_caller_level(),
        )


def _caller_level() -> int:
    """The stack level of the first frame outside importlib, so that the warning points at the user's import."""
    frame = sys._getframe(1)
    level = 1
    while frame is not None and (
        frame.f_code.co_filename.startswith("<frozen importlib") or frame.f_code.co_filename == __file__
    ):
        frame = frame.f_back  # type: ignore[assignment]
        level += 1
    return level


FINDER = _Finder()


def install() -> None:
    """Put the finder first on ``sys.meta_path``, once (called by ``import robodyn``).

    First, because an installed wheel has a data folder ``robodyn/models`` (the built-in URDFs)
    that the path finder would otherwise import as a namespace package for ``robodyn.models``.
    The finder answers only the names of :data:`MOVED`, so it costs other imports nothing.
    """
    if FINDER not in sys.meta_path:
        sys.meta_path.insert(0, FINDER)
