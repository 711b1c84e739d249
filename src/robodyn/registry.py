"""One registry type through which every user-supplied name resolves."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

from robodyn.errors import UnknownNameError

T = TypeVar("T")


class Registry(Generic[T]):
    """Map names to objects; a miss raises :class:`UnknownNameError` naming what exists."""

    def __init__(self, what: str) -> None:
        self.what = what
        self._items: dict[str, T] = {}

    def register(self, name: str, item: T) -> T:
        """Add ``item`` under ``name``; a duplicate name is a programming error."""
        if name in self._items:
            raise ValueError(f"{self.what} {name!r} is registered twice")
        self._items[name] = item
        return item

    def decorator(self, name: str) -> Callable[[T], T]:
        """Return a decorator that registers its target under ``name``."""

        def wrap(item: T) -> T:
            return self.register(name, item)

        return wrap

    def get(self, name: str) -> T:
        """Return the item called ``name``."""
        try:
            return self._items[name]
        except KeyError:
            raise UnknownNameError(self.what, name, self._items) from None

    def names(self) -> tuple[str, ...]:
        """Registered names, sorted."""
        return tuple(sorted(self._items))

    def __contains__(self, name: object) -> bool:
        return name in self._items

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())


# The forward-dynamics backends, by name: the one list that robot, simulate and the CLI read.
BACKENDS: Registry[str] = Registry("forward-dynamics backend")
BACKENDS.register("aba", "Pinocchio's articulated-body algorithm, O(n)")
BACKENDS.register("crba", "Pinocchio's CRBA + Cholesky solve, O(n^3); serves mimic joints")
BACKENDS.register("formula", "the hand-derived closed form of a built-in kind (NumPy)")
BACKENDS.register(
    "numba",
    "ABA, RNEA and CRBA compiled by numba over the model's arrays (checked against Pinocchio); "
    "whole runs in one compiled loop where they apply",
)
