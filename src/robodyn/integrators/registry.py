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


def _register(integrator: Integrator) -> None:
    INTEGRATORS.register(integrator.name, integrator)


_register(
    ExplicitEuler(
        name="euler",
        order=1,
        symplectic=False,
        adaptive=False,
        implicit=False,
        description="explicit Euler: q += h v, v += h a(q, v); energy grows",
    )
)
_register(
    SemiImplicitEuler(
        name="semi_implicit_euler",
        order=1,
        symplectic=False,
        adaptive=False,
        implicit=False,
        description="kick-drift Euler in (q, v): v += h a(q, v), then q += h v; symplectic only for constant M",
    )
)
_register(
    SymplecticEuler(
        name="symplectic_euler",
        order=1,
        symplectic=True,
        adaptive=False,
        implicit=True,
        description="symplectic Euler in (q, p = M v): p += h F(q, v*), q += h v*; fixed-point for v*",
    )
)
_register(
    ExplicitRungeKutta(
        name="heun",
        order=2,
        symplectic=False,
        adaptive=False,
        implicit=False,
        description="Heun's method (explicit RK2)",
        tableau=HEUN,
    )
)
_register(
    ClassicRK4(
        name="rk4",
        order=4,
        symplectic=False,
        adaptive=False,
        implicit=False,
        description="classic 4-stage Runge-Kutta",
        tableau=CLASSIC_RK4,
    )
)
_register(
    ImplicitMidpoint(
        name="implicit_midpoint",
        order=2,
        symplectic=True,
        adaptive=False,
        implicit=True,
        description="implicit midpoint in (q, p = M v), Newton with ABA derivatives",
    )
)
_register(
    EmbeddedRungeKutta(
        name="dopri5",
        order=5,
        symplectic=False,
        adaptive=True,
        implicit=False,
        description="Dormand-Prince 5(4), robodyn's own: stages on the manifold, work kept out of the error norm, "
        "lands on each sample; scipy_rk45 cross-checks it",
        tableau=DORMAND_PRINCE_54,
    )
)
for _method, (_order, _implicit, _text) in SCIPY_METHODS.items():
    _register(
        ScipyIntegrator(
            name=f"scipy_{_method.lower()}",
            order=_order,
            symplectic=False,
            adaptive=True,
            implicit=_implicit,
            description=_text,
            method=_method,
        )
    )


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
