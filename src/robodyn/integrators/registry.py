"""The integrator registry: every integrator reached by name (``get("rk4")``), and names by property.

Twelve integrators are registered, in this order: euler, semi_implicit_euler, symplectic_euler,
heun, rk4, implicit_midpoint, dopri5 and the five SciPy methods. Lists of names elsewhere
(the stability study's fixed-step methods, for one) are derived from the declared properties
through :func:`names` rather than written out, so that registering an integrator here is the
only edit needed to add one.
"""

from __future__ import annotations

from robodyn.integrators.adaptive import EmbeddedRungeKutta
from robodyn.integrators.base import Integrator
from robodyn.integrators.explicit import ClassicRK4, ExplicitEuler, ExplicitRungeKutta
from robodyn.integrators.scipy_methods import SCIPY_METHODS, ScipyIntegrator
from robodyn.integrators.symplectic import ImplicitMidpoint, SemiImplicitEuler, SymplecticEuler
from robodyn.integrators.tableau import CLASSIC_RK4, DORMAND_PRINCE_54, HEUN
from robodyn.registry import Registry

INTEGRATORS: Registry[Integrator] = Registry("integrator")
INTEGRATORS.register(
    "euler",
    ExplicitEuler("euler", 1, False, False, False, "explicit Euler: q += h v, v += h a(q, v); energy grows"),
)
INTEGRATORS.register(
    "semi_implicit_euler",
    SemiImplicitEuler(
        "semi_implicit_euler",
        1,
        False,
        False,
        False,
        "kick-drift Euler in (q, v): v += h a(q, v), then q += h v; symplectic only for constant M",
    ),
)
INTEGRATORS.register(
    "symplectic_euler",
    SymplecticEuler(
        "symplectic_euler",
        1,
        True,
        False,
        True,
        "symplectic Euler in (q, p = M v): p += h F(q, v*), q += h v*; fixed-point for v*",
    ),
)
INTEGRATORS.register("heun", ExplicitRungeKutta("heun", 2, False, False, False, "Heun's method (explicit RK2)", HEUN))
INTEGRATORS.register("rk4", ClassicRK4("rk4", 4, False, False, False, "classic 4-stage Runge-Kutta", CLASSIC_RK4))
INTEGRATORS.register(
    "implicit_midpoint",
    ImplicitMidpoint(
        "implicit_midpoint", 2, True, False, True, "implicit midpoint in (q, p = M v), Newton with ABA derivatives"
    ),
)
INTEGRATORS.register(
    "dopri5",
    EmbeddedRungeKutta(
        "dopri5",
        5,
        False,
        True,
        False,
        "Dormand-Prince 5(4), robodyn's own: stages on the manifold, work kept out of the error norm, "
        "lands on each sample; scipy_rk45 cross-checks it",
        DORMAND_PRINCE_54,
    ),
)
for _method, (_order, _implicit, _text) in SCIPY_METHODS.items():
    _name = f"scipy_{_method.lower()}"
    INTEGRATORS.register(_name, ScipyIntegrator(_name, _order, False, True, _implicit, _text, _method))


def get(name: str) -> Integrator:
    """The integrator called ``name``; :class:`UnknownNameError` lists what exists."""
    return INTEGRATORS.get(name)


def names(
    *,
    fixed_step: bool | None = None,
    symplectic: bool | None = None,
    adaptive: bool | None = None,
    implicit: bool | None = None,
) -> tuple[str, ...]:
    """Integrator names, sorted; each keyword given keeps only the integrators whose property matches.

    ``names()`` is every name; ``names(fixed_step=True)`` the methods that take one step of
    exactly the requested size (:class:`FixedStepIntegrator`, the ones with a stability limit
    in dt); ``names(implicit=True, fixed_step=True)`` combines filters.
    """
    wanted = {"fixed_step": fixed_step, "symplectic": symplectic, "adaptive": adaptive, "implicit": implicit}
    wanted = {key: value for key, value in wanted.items() if value is not None}
    return tuple(
        name
        for name in INTEGRATORS.names()
        if all(getattr(INTEGRATORS.get(name), key) == value for key, value in wanted.items())
    )
