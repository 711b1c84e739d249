"""Integrators: checked tableaux, the registry, measured convergence orders, symplecticity."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.special import ellipj, ellipk

import robodyn
from robodyn import integrators
from robodyn.errors import InputError, UnknownNameError
from robodyn.integrators import CLASSIC_RK4, DORMAND_PRINCE_54, ArrayProblem, ButcherTableau, ExplicitRungeKutta, solve
from robodyn.sim.system import robot_system

# Fitted orders must fall within this band of the declared order (asymptotic range, steps
# chosen so that round-off stays 3+ decades below the errors measured).
ORDER_BAND = 0.25
# Error-controlled implicit methods (variable step, and for BDF/LSODA variable order): the
# slope of error against work over a tolerance sweep scatters by about this much.
ADAPTIVE_ORDER_BAND = 1.5
# Identical arithmetic (ClassicRK4 vs the generic tableau loop) up to summation order.
SAME_ARITHMETIC = 1e-14
# Symplecticity of a one-step map, J^T Omega J = Omega, by central differences (step 1e-6):
# the finite-difference error is ~1e-9.
SYMPLECTIC_TOL = 1e-7

# The nonlinear pendulum q'' = -sin q from rest at amplitude A has the exact solution
# sin(q/2) = k sn(K(k) - t; k), k = sin(A/2) (Jacobi elliptic functions).
AMPLITUDE = 2.0
T_END = 3.0


def pendulum_exact(t: float) -> tuple[float, float]:
    m = np.sin(AMPLITUDE / 2) ** 2
    k = np.sqrt(m)
    sn, cn, dn, _ = ellipj(ellipk(m) - t, m)
    q = 2 * np.arcsin(k * sn)
    v = -2 * k * cn * dn / np.sqrt(1 - (k * sn) ** 2)
    return float(q), float(v)


def pendulum_problem() -> ArrayProblem:
    return ArrayProblem(
        lambda t, q, v: -np.sin(q),
        1,
        jacobian_fn=lambda t, q, v: (np.array([[-np.cos(q[0])]]), np.zeros((1, 1))),
    )


def error_at_end(method: integrators.Integrator, n: int, **options: float) -> tuple[float, int]:
    problem = pendulum_problem()
    sol = solve(problem, [AMPLITUDE], [0.0], dt=T_END / n, n_steps=n, method=method, **options)
    q, v = pendulum_exact(T_END)
    return abs(sol.q[-1, 0] - q) + abs(sol.v[-1, 0] - v), sol.evaluations


def fitted_order(errors: list[float], ns: list[int]) -> float:
    slope, _ = np.polyfit(np.log(ns), np.log(errors), 1)
    return float(-slope)


# ----------------------------------------------------------------------------- tableaux
def test_builtin_tableaux_are_consistent() -> None:
    assert CLASSIC_RK4.stages == 4 and not CLASSIC_RK4.fsal
    assert DORMAND_PRINCE_54.stages == 7 and DORMAND_PRINCE_54.fsal
    assert DORMAND_PRINCE_54.order == 5 and DORMAND_PRINCE_54.error_order == 4


@pytest.mark.parametrize(
    ("a", "b", "c", "match"),
    [
        (((0, 0), (0.5, 0)), (0.5, 0.5), (0, 1), "row 1 of a sums to"),
        (((0, 0), (1, 0)), (0.6, 0.5), (0, 1), "sum to"),
        (((0, 1), (1, 0)), (0.5, 0.5), (0, 1), "strictly lower triangular"),
        (((0, 0), (1, 0)), (0.5, 0.5), (0, 1, 2), "must be 2x2"),
    ],
)
def test_bad_tableau_raises_value_error(a: tuple, b: tuple, c: tuple, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        ButcherTableau(name="bad", a=a, b=b, c=c, order=2)


def test_tableau_declared_order_must_match_integrator() -> None:
    with pytest.raises(ValueError, match="declares order 3"):
        ExplicitRungeKutta("x", 3, False, False, False, "", CLASSIC_RK4)


# ----------------------------------------------------------------------------- registry
def test_every_integrator_declares_itself() -> None:
    names = integrators.names()
    for expected in ("euler", "symplectic_euler", "rk4", "implicit_midpoint", "dopri5", "scipy_dop853"):
        assert expected in names
    for name in names:
        m = integrators.get(name)
        assert m.name == name and m.order >= 1
        assert isinstance(m.symplectic, bool) and isinstance(m.adaptive, bool) and isinstance(m.implicit, bool)
    assert integrators.get("implicit_midpoint").symplectic and integrators.get("symplectic_euler").symplectic
    assert not integrators.get("semi_implicit_euler").symplectic


def test_unknown_integrator_lists_the_choices() -> None:
    with pytest.raises(UnknownNameError, match="rk4"):
        integrators.get("rk5")


def test_solve_refuses_bad_steps() -> None:
    with pytest.raises(InputError, match="dt"):
        solve(lambda t, q, v: -q, [1.0], [0.0], dt=0.0, n_steps=3)
    with pytest.raises(InputError, match="n_steps"):
        solve(lambda t, q, v: -q, [1.0], [0.0], dt=0.1, n_steps=0)


# ----------------------------------------------------------------------------- orders
FIXED = {
    "euler": [200, 400, 800, 1600],
    "semi_implicit_euler": [200, 400, 800, 1600],
    "symplectic_euler": [200, 400, 800, 1600],
    "heun": [100, 200, 400, 800],
    "implicit_midpoint": [100, 200, 400, 800],
    "rk4": [25, 50, 100, 200],
}


@pytest.mark.parametrize("name", sorted(FIXED))
def test_fixed_step_order_matches_declared(name: str) -> None:
    method = integrators.get(name)
    ns = FIXED[name]
    errors = [error_at_end(method, n)[0] for n in ns]
    assert abs(fitted_order(errors, ns) - method.order) < ORDER_BAND


def test_dormand_prince_solution_has_order_five() -> None:
    method = integrators.get("dopri5")
    assert isinstance(method, integrators.EmbeddedRungeKutta)
    fixed = method.fixed()
    ns = [20, 40, 80, 160]
    errors = [error_at_end(fixed, n)[0] for n in ns]
    assert abs(fitted_order(errors, ns) - method.order) < ORDER_BAND


def test_dormand_prince_error_follows_tolerance() -> None:
    method = integrators.get("dopri5")
    errors = [error_at_end(method, 6, rtol=tol, atol=tol)[0] for tol in (1e-6, 1e-8, 1e-10)]
    # Global error within a decade or two of the tolerance, and shrinking with it.
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 1e-8


@pytest.mark.parametrize(("name", "ns"), [("scipy_rk45", [20, 40, 80, 160]), ("scipy_dop853", [6, 8, 10, 12])])
def test_scipy_explicit_methods_order_at_fixed_steps(name: str, ns: list[int]) -> None:
    method = integrators.get(name)
    errors = [error_at_end(dataclasses.replace(method, fixed_step=T_END / n), n)[0] for n in ns]
    assert abs(fitted_order(errors, ns) - method.order) < ORDER_BAND + 0.05 * method.order


@pytest.mark.parametrize("name", ["scipy_radau", "scipy_bdf", "scipy_lsoda"])
def test_scipy_implicit_methods_converge_with_tolerance(name: str) -> None:
    # Error-controlled only: the slope of error against work lies between 1 and the
    # declared (highest) order, and the error follows the tolerance down.
    method = integrators.get(name)
    runs = [error_at_end(method, 3, rtol=tol, atol=tol) for tol in (1e-5, 1e-7, 1e-9, 1e-11)]
    errors = [e for e, _ in runs]
    measured = fitted_order(errors, [n for _, n in runs])
    assert errors[0] > errors[-1] and errors[-1] < 1e-8
    assert 1.0 - ADAPTIVE_ORDER_BAND < measured < method.order + ADAPTIVE_ORDER_BAND


def test_classic_rk4_matches_generic_tableau_loop() -> None:
    generic = ExplicitRungeKutta("rk4-generic", 4, False, False, False, "", CLASSIC_RK4)
    fast = integrators.get("rk4")
    a = solve(pendulum_problem(), [AMPLITUDE], [0.3], dt=0.01, n_steps=300, method=generic)
    b = solve(pendulum_problem(), [AMPLITUDE], [0.3], dt=0.01, n_steps=300, method=fast)
    assert np.max(np.abs(a.q - b.q)) < SAME_ARITHMETIC and np.max(np.abs(a.v - b.v)) < SAME_ARITHMETIC
    assert a.evaluations == b.evaluations == 4 * 300


# ----------------------------------------------------------------------------- symplecticity
def _one_step_map(name: str, h: float, x: np.ndarray) -> np.ndarray:
    """(q0, p0) -> (q1, p1) of one step on the Pendubot, p = M(q) v."""
    robot = robodyn.load("pendubot")
    system = robot_system(robot)
    q0, p0 = x[:2], x[2:]
    v0 = np.linalg.solve(system.mass_matrix(q0), p0)
    step = integrators.get(name).step  # type: ignore[attr-defined]
    q1, u1, _ = step(system, 0.0, q0, v0, h)
    return np.concatenate([q1, system.mass_matrix(q1) @ u1[:2]])


def _symplectic_defect(name: str) -> float:
    rng = np.random.default_rng(7)
    x = np.concatenate([rng.uniform(-1, 1, 2), rng.uniform(-0.05, 0.05, 2)])
    eps = 1e-6
    J = np.empty((4, 4))
    for i in range(4):
        e = np.zeros(4)
        e[i] = eps
        J[:, i] = (_one_step_map(name, 0.05, x + e) - _one_step_map(name, 0.05, x - e)) / (2 * eps)
    omega = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.eye(2), np.zeros((2, 2))]])
    return float(np.max(np.abs(J.T @ omega @ J - omega)))


@pytest.mark.parametrize("name", ["symplectic_euler", "implicit_midpoint"])
def test_symplectic_methods_preserve_the_symplectic_form(name: str) -> None:
    assert _symplectic_defect(name) < SYMPLECTIC_TOL


def test_kick_drift_euler_is_not_symplectic_when_mass_varies() -> None:
    # The Pendubot's M depends on q2: kick-drift in (q, v) breaks J^T Omega J = Omega.
    assert _symplectic_defect("semi_implicit_euler") > 100 * SYMPLECTIC_TOL
