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

__version__ = "0.1.0"

if TYPE_CHECKING:
    from robodyn.check import CheckReport, check
    from robodyn.models import load
    from robodyn.robot import Robot

# Public name -> module that defines it; imported on first access (PEP 562).
_LAZY = {
    "load": "robodyn.models",
    "Robot": "robodyn.robot",
    "check": "robodyn.check",
    "CheckReport": "robodyn.check",
    "extract_params": "robodyn.params",
    "formulas": "robodyn.formulas",
    "simulate": "robodyn.simulate",
    "Trajectory": "robodyn.trajectory",
    "integrators": "robodyn.integrators",
    "viewer": "robodyn.viewer",
}


def __getattr__(name: str) -> Any:
    module_name = _LAZY.get(name)
    if module_name is None:
        raise AttributeError(f"module 'robodyn' has no attribute {name!r}")
    module = importlib.import_module(module_name)
    value = module if module_name.endswith("." + name) else getattr(module, name)
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
    "Robot",
    "RobodynError",
    "Trajectory",
    "UnavailableError",
    "UnknownNameError",
    "__version__",
    "check",
    "extract_params",
    "formulas",
    "integrators",
    "load",
    "simulate",
    "viewer",
]
