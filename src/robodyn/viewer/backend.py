"""The meshcat dependency: imported lazily, and the scene-tree paths robodyn draws under.

Every viewer module reaches meshcat through :func:`import_meshcat`, inside a function, so
``import robodyn.viewer`` stays light; a missing meshcat becomes one
:class:`~robodyn.errors.MissingDependencyError` that names the install command.
"""

from __future__ import annotations

from typing import Any

from robodyn.errors import MissingDependencyError

INSTALL_HINT = "pip install meshcat"
ROOT = ("meshcat", "robodyn")
"""Scene path under which everything robodyn draws lives (deleted before a new scene is sent)."""


def import_meshcat() -> Any:
    """Import meshcat, or raise :class:`MissingDependencyError` with the install command."""
    try:
        import meshcat
        import meshcat.animation
        import meshcat.commands
        import meshcat.geometry
        import meshcat.path
        import umsgpack  # noqa: F401  (meshcat's own dependency: the wire format)
    except ImportError as exc:
        raise MissingDependencyError(
            f"the viewer needs meshcat, which cannot be imported ({exc}); install it with: {INSTALL_HINT}"
        ) from None
    return meshcat


def scene_path(mc: Any, entries: tuple[str, ...]) -> Any:
    """The meshcat ``Path`` of ``entries`` (e.g. ``(*ROOT, "trace", "marker")``)."""
    return mc.path.Path(tuple(entries))
