"""robodyn: rigid-body robot dynamics you can trust.

Load a URDF into Pinocchio, check M(q), C(q, v), G(q) against hand-derived Lagrangian
formulas, simulate with a choice of integrators while keeping the books on energy and
work, and play the motion back in the browser.

``import robodyn`` is light: Pinocchio loads on first use of a model, and matplotlib,
meshcat and sympy only when a chart, the viewer or a symbolic derivation is asked for.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from robodyn import _compat
from robodyn.errors import (
    AssumptionError,
    DivergenceError,
    FormulaError,
    InputError,
    MissingDependencyError,
    ModelError,
    RobodynError,
    UnavailableError,
    UnknownNameError,
)

__version__ = "0.2.0"

_compat.install()

if TYPE_CHECKING:
    from robodyn.kinds.check import CheckReport, check
    from robodyn.model.load import load
    from robodyn.robot import Robot

# Public name -> (module, attribute); attribute None means the module itself.
# Imported on first access (PEP 562) so that ``import robodyn`` stays light.
_LAZY: dict[str, tuple[str, str | None]] = {
    "load": ("robodyn.model.load", "load"),
    "Robot": ("robodyn.robot", "Robot"),
    "check": ("robodyn.kinds.check", "check"),
    "CheckReport": ("robodyn.kinds.check", "CheckReport"),
    "extract_params": ("robodyn.kinds.params", "extract"),
    "control": ("robodyn.control", None),
    "formulas": ("robodyn.kinds", None),
    "simulate": ("robodyn.sim.simulation", "simulate"),
    "Trajectory": ("robodyn.sim.trajectory", "Trajectory"),
    "inertia": ("robodyn.inertia", None),
    "integrators": ("robodyn.integrators", None),
    "viewer": ("robodyn.viewer", None),
}


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 'robodyn' has no attribute {name!r}")
    module_name, attribute = _LAZY[name]
    module = importlib.import_module(module_name)
    value = module if attribute is None else getattr(module, attribute)
    globals()[name] = value
    return value


__all__ = [
    "AssumptionError",
    "CheckReport",
    "DivergenceError",
    "FormulaError",
    "InputError",
    "MissingDependencyError",
    "ModelError",
    "RobodynError",
    "Robot",
    "Trajectory",
    "UnavailableError",
    "UnknownNameError",
    "__version__",
    "check",
    "control",
    "extract_params",
    "formulas",
    "inertia",
    "integrators",
    "load",
    "simulate",
    "viewer",
]
