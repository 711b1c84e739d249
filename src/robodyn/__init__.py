"""robodyn: rigid-body robot dynamics you can trust.

Load a URDF into Pinocchio, check M(q), C(q, v), G(q) against hand-derived Lagrangian
formulas, simulate with a choice of integrators while keeping the books on energy and
work, and play the motion back in the browser.

``import robodyn`` is light: Pinocchio loads on first use of a model, and matplotlib,
meshcat and sympy only when a chart, the viewer or a symbolic derivation is asked for.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from robodyn.errors import (
    AssumptionError,
    DivergenceError,
    EngineRefusedError,
    FormulaError,
    InputError,
    MissingDependencyError,
    ModelError,
    RobodynError,
    UnavailableError,
    UnknownNameError,
)

__version__ = "0.2.0"

if TYPE_CHECKING:
    from robodyn.checker.compare import CheckReport, check
    from robodyn.model.files import example
    from robodyn.model.load import load
    from robodyn.other_engines import AgainstReport, against
    from robodyn.robot import Robot


def __getattr__(name: str) -> Any:
    """The public names resolved on first use (PEP 562), so that ``import robodyn`` stays light.

    Plain imports, not ``importlib``: import-linter sees each edge.
    """
    value: Any
    if name == "load":
        from robodyn.model.load import load as value
    elif name == "Robot":
        from robodyn.robot import Robot

        value = Robot
    elif name == "against":
        from robodyn.other_engines import against as value
    elif name == "AgainstReport":
        from robodyn.other_engines import AgainstReport

        value = AgainstReport
    elif name == "check":
        from robodyn.checker.compare import check as value
    elif name == "CheckReport":
        from robodyn.checker.compare import CheckReport

        value = CheckReport
    elif name == "example":
        from robodyn.model.files import example as value
    elif name == "extract_params":
        from robodyn.kinds.params import extract as value
    elif name == "batch":
        import robodyn.sim.batch as value
    elif name == "control":
        import robodyn.control as value
    elif name == "formulas":
        import robodyn.kinds as value
    elif name == "simulate":
        from robodyn.sim.simulation import simulate as value
    elif name == "Trajectory":
        from robodyn.sim.trajectory import Trajectory

        value = Trajectory
    elif name == "inertia":
        import robodyn.inertia as value
    elif name == "integrators":
        import robodyn.integrators as value
    elif name == "viewer":
        import robodyn.viewer as value
    else:
        raise AttributeError(f"module 'robodyn' has no attribute {name!r}")
    globals()[name] = value
    return value


__all__ = [
    "AgainstReport",
    "AssumptionError",
    "CheckReport",
    "DivergenceError",
    "EngineRefusedError",
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
    "against",
    "batch",
    "check",
    "control",
    "example",
    "extract_params",
    "formulas",
    "inertia",
    "integrators",
    "load",
    "simulate",
    "viewer",
]
