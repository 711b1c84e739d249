"""The built-in kinds' parameter units and earlier names, gathered from each :class:`~robodyn.kinds.kind.Kind`."""

from robodyn.kinds import catalog

UNITS = catalog.units()
"""The SI unit of every built-in kind's parameter ("1": a pure number, the gear ratio)."""

RENAMED = catalog.renamed()
"""(kind, earlier name) -> its name now: M is only ever the mass matrix, so a mass has a name of its own."""

RENAMED_MEANING = catalog.renamed_meaning()
"""What each earlier name stood for, as a note about a file that still uses it says it."""
