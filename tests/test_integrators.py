"""Integrators: checked tableaux, the registry, measured convergence orders (flat, on a manifold, with work), symplecticity."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.special import ellipj, ellipk

import robodyn
from robodyn import integrators
from robodyn.errors import InputError, UnknownNameError
from robodyn.integrators import (
    CLASSIC_RK4,
    DORMAND_PRINCE_54,
    ArrayProblem,
    ButcherTableau,
    ExplicitEuler,
    ExplicitRungeKutta,
    solve,
)
from robodyn.sim.system import robot_system

# Fitted orders must fall within this band of the declared order (asymptotic range, steps
# chosen so that round-off stays 3+ decades below the errors measured).
ORDER_BAND = 0.25
# Error-controlled implicit methods (variable step, and for BDF/LSODA variable order): the
# slope of error against work over a tolerance sweep scatters by about this much.
ADAPTIVE_ORDER_BAND = 1.5
# Identical arithmetic (ClassicRK4 vs the generic tableau loop) up to summation order.
SAME_ARITHMETIC = 1e-14
# A tolerance bounds each step's local error; over a 3 s non-stiff run sampled 30 times the
# global error stays within a decade of it (measured: 2x for dopri5, 9x for scipy_rk45).
GLOBAL_ERROR_PER_TOL = 20.0
# Kick-drift Euler conserves v^2 + w^2 q^2 - h w^2 q v exactly on q'' = -w^2 q: after 10^4
# steps only round-off (~1e-16 a step, random-walking) remains.
INVARIANT_RTOL = 1e-12
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


def rotate(q: np.ndarray, dq: np.ndarray) -> np.ndarray:
    """(cos, sin) of an angle, advanced by dq[0]: the retraction of a URDF continuous joint."""
    c, s = np.cos(dq[0]), np.sin(dq[0])
    return np.array([c * q[0] - s * q[1], s * q[0] + c * q[1]])


def circle_pendulum(nw: int = 0) -> ArrayProblem:
    """The same pendulum with q = (cos theta, sin theta) on SO(2) (nq = 2, nv = 1): not flat.

    With nw = 1 it also books the work of gravity, dw/dt = -sin(theta) v, in u = [v, w].
    """

    def rates(t: float, q: np.ndarray, u: np.ndarray) -> np.ndarray:
        a = -q[1]
        return np.array([a, a * u[0]][: 1 + nw])

    return ArrayProblem(
        rates, 2, 1, integrate_fn=rotate, nw=nw, jacobian_fn=lambda t, q, u: (np.array([[-q[0]]]), np.zeros((1, 1)))
    )


def working_pendulum() -> ArrayProblem:
    """The flat pendulum booking the work of gravity, dw/dt = -sin(q) v, as a running integral (nw = 1)."""
    return ArrayProblem(
        lambda t, q, u: np.array([-np.sin(q[0]), -np.sin(q[0]) * u[0]]),
        1,
        nw=1,
        jacobian_fn=lambda t, q, u: (np.array([[-np.cos(q[0])]]), np.zeros((1, 1))),
    )


def start(kind: str) -> tuple[ArrayProblem, np.ndarray, np.ndarray]:
    """(problem, q0, u0) of a kind of pendulum, from rest at AMPLITUDE."""
    if kind == "flat":
        return pendulum_problem(), np.array([AMPLITUDE]), np.array([0.0])
    if kind == "manifold":
        return circle_pendulum(), np.array([np.cos(AMPLITUDE), np.sin(AMPLITUDE)]), np.array([0.0])
    if kind == "work":
        return working_pendulum(), np.array([AMPLITUDE]), np.array([0.0, 0.0])
    if kind == "manifold+work":
        return circle_pendulum(nw=1), np.array([np.cos(AMPLITUDE), np.sin(AMPLITUDE)]), np.array([0.0, 0.0])
    raise KeyError(kind)


def state_error(kind: str, t: float, q: np.ndarray, u: np.ndarray) -> float:
    """|angle error| (wrapped) + |v error| (+ |w error|, the exact work being cos q(t) - cos q0)."""
    q_ref, v_ref = pendulum_exact(t)
    angle = float(np.arctan2(q[1], q[0])) if kind.startswith("manifold") else float(q[0])
    error = abs(float(np.angle(np.exp(1j * (angle - q_ref))))) + abs(u[0] - v_ref)
    if kind.endswith("work"):
        error += abs(u[1] - (np.cos(q_ref) - np.cos(AMPLITUDE)))
    return float(error)


def error_on(kind: str, method: integrators.Integrator, n: int, **options: float) -> float:
    """Error at T_END after n intervals of T_END / n, stepping the integrator's own stepper."""
    problem, q, u = start(kind)
    h = T_END / n
    advance = method.start(problem, 0.0, q, u, t_end=T_END, **options).advance
    for k in range(n):
        q, u, _ = advance(k * h, q, u, h)
    return state_error(kind, T_END, q, u)


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
        ExplicitRungeKutta(
            name="x", order=3, symplectic=False, adaptive=False, implicit=False, description="", tableau=CLASSIC_RK4
        )


# ----------------------------------------------------------------------------- registry
def test_every_integrator_declares_itself() -> None:
    assert integrators.names() == (
        "dopri5",
        "euler",
        "heun",
        "implicit_midpoint",
        "rk4",
        "scipy_bdf",
        "scipy_dop853",
        "scipy_lsoda",
        "scipy_radau",
        "scipy_rk45",
        "semi_implicit_euler",
        "symplectic_euler",
    )
    for name in integrators.names():
        m = integrators.get(name)
        assert m.name == name and m.order >= 1
        assert isinstance(m.symplectic, bool) and isinstance(m.adaptive, bool) and isinstance(m.implicit, bool)
        assert m.fixed_step == isinstance(m, integrators.FixedStepIntegrator) != m.adaptive
        assert m.summary()["fixed_step"] == m.fixed_step
    assert integrators.get("implicit_midpoint").symplectic and integrators.get("symplectic_euler").symplectic
    assert not integrators.get("semi_implicit_euler").symplectic


def test_names_filter_by_declared_property() -> None:
    fixed = integrators.names(fixed_step=True)
    assert set(fixed) == {"euler", "semi_implicit_euler", "symplectic_euler", "heun", "rk4", "implicit_midpoint"}
    assert integrators.names(adaptive=True) == tuple(n for n in integrators.names() if n not in fixed)
    assert integrators.names(fixed_step=True, implicit=True) == ("implicit_midpoint", "symplectic_euler")
    assert integrators.names(symplectic=True, adaptive=True) == ()


def test_an_integrator_cannot_contradict_its_class() -> None:
    with pytest.raises(ValueError, match="adaptive=True"):
        ExplicitEuler(
            name="bad",
            order=1,
            symplectic=False,
            adaptive=True,
            implicit=False,
            description="a fixed-step method declared adaptive",
        )
    with pytest.raises(ValueError, match="order must be >= 1"):
        ExplicitEuler(name="bad", order=0, symplectic=False, adaptive=False, implicit=False, description="")


def test_unknown_integrator_lists_the_choices() -> None:
    with pytest.raises(UnknownNameError, match="rk4"):
        integrators.get("rk5")


def test_solve_refuses_bad_steps() -> None:
    with pytest.raises(InputError, match="dt"):
        solve(lambda t, q, v: -q, [1.0], [0.0], dt=0.0, n_steps=3)
    with pytest.raises(InputError, match="n_steps"):
        solve(lambda t, q, v: -q, [1.0], [0.0], dt=0.1, n_steps=0)


# ----------------------------------------------------------------------------- orders
# Step counts per declared order: in the asymptotic range, with the smallest error still 3+
# decades above round-off.
STEPS_FOR_ORDER = {
    1: [200, 400, 800, 1600],
    2: [100, 200, 400, 800],
    4: [25, 50, 100, 200],
    5: [20, 40, 80, 160],
    8: [6, 8, 10, 12],
}
# Flat q with u = v; q on SO(2) (ClassicRK4's general branch, stages retracted by `integrate`);
# work booked in u = [v, w]; both at once.
KINDS = ("flat", "manifold", "work", "manifold+work")


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", integrators.names(fixed_step=True))
def test_fixed_step_order_matches_declared(name: str, kind: str) -> None:
    method = integrators.get(name)
    ns = STEPS_FOR_ORDER[method.order]
    errors = [error_on(kind, method, n) for n in ns]
    assert abs(fitted_order(errors, ns) - method.order) < ORDER_BAND, errors


@pytest.mark.parametrize("kind", KINDS)
def test_dormand_prince_solution_has_order_five(kind: str) -> None:
    method = integrators.get("dopri5")
    assert isinstance(method, integrators.EmbeddedRungeKutta)
    ns = STEPS_FOR_ORDER[method.order]
    errors = [error_on(kind, method.fixed(), n) for n in ns]
    assert abs(fitted_order(errors, ns) - method.order) < ORDER_BAND


def test_dormand_prince_error_follows_tolerance() -> None:
    method = integrators.get("dopri5")
    errors = [error_at_end(method, 6, rtol=tol, atol=tol)[0] for tol in (1e-6, 1e-8, 1e-10)]
    # Global error within a decade or two of the tolerance, and shrinking with it.
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 1e-8


@pytest.mark.parametrize("tol", [1e-8, 1e-10, 1e-12])
def test_dopri5_and_scipy_rk45_cross_check_on_a_manifold_with_work(tol: float) -> None:
    # Two independent Dormand-Prince 5(4) codes (robodyn's on the manifold, SciPy's in a chart)
    # agree with the exact solution, and so with each other, at every sample.
    n = 30
    h = T_END / n
    states = {}
    for name in ("dopri5", "scipy_rk45"):
        problem, q, u = start("manifold+work")
        advance = integrators.get(name).start(problem, 0.0, q, u, t_end=T_END, rtol=tol, atol=tol).advance
        samples = []
        for k in range(n):
            q, u, _ = advance(k * h, q, u, h)
            assert state_error("manifold+work", (k + 1) * h, q, u) < GLOBAL_ERROR_PER_TOL * tol, (name, k)
            samples.append(np.concatenate([q, u]))
        states[name] = np.array(samples)
    assert np.max(np.abs(states["dopri5"] - states["scipy_rk45"])) < GLOBAL_ERROR_PER_TOL * tol


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", ["scipy_rk45", "scipy_dop853"])
def test_scipy_explicit_methods_order_at_fixed_steps(name: str, kind: str) -> None:
    method = integrators.get(name)
    ns = STEPS_FOR_ORDER[method.order]
    errors = [error_on(kind, dataclasses.replace(method, forced_step=T_END / n), n) for n in ns]
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


def generic_rk4() -> ExplicitRungeKutta:
    """Classic RK4 through the generic tableau loop, to compare with the hand-written stages."""
    return ExplicitRungeKutta(
        name="rk4-generic",
        order=4,
        symplectic=False,
        adaptive=False,
        implicit=False,
        description="",
        tableau=CLASSIC_RK4,
    )


def test_classic_rk4_matches_generic_tableau_loop() -> None:
    generic = generic_rk4()
    fast = integrators.get("rk4")
    a = solve(pendulum_problem(), [AMPLITUDE], [0.3], dt=0.01, n_steps=300, method=generic)
    b = solve(pendulum_problem(), [AMPLITUDE], [0.3], dt=0.01, n_steps=300, method=fast)
    assert np.max(np.abs(a.q - b.q)) < SAME_ARITHMETIC and np.max(np.abs(a.v - b.v)) < SAME_ARITHMETIC
    assert a.evaluations == b.evaluations == 4 * 300


@pytest.mark.parametrize("kind", ["manifold", "work", "manifold+work"])
def test_classic_rk4_general_branch_matches_generic_tableau_loop(kind: str) -> None:
    # Off the bare-loop branch (q on a manifold, or work carried in u) the hand-written
    # stages still are the tableau's, step by step.
    generic = generic_rk4()
    fast = integrators.get("rk4")
    assert isinstance(fast, integrators.FixedStepIntegrator)
    problem, q, u = start(kind)
    qa, ua, qb, ub = q, u, q, u
    for k in range(300):
        qa, ua, _ = generic.step(problem, 0.01 * k, qa, ua, 0.01)
        qb, ub, _ = fast.step(problem, 0.01 * k, qb, ub, 0.01)
    assert np.max(np.abs(qa - qb)) < SAME_ARITHMETIC and np.max(np.abs(ua - ub)) < SAME_ARITHMETIC


# ----------------------------------------------------------------------------- kick-drift Euler
def oscillator(omega: float) -> ArrayProblem:
    return ArrayProblem(lambda t, q, v: -(omega**2) * q, 1)


def test_semi_implicit_euler_step_is_kick_then_drift() -> None:
    # One step by hand: the velocity is kicked with the OLD position, then the position
    # drifts with the NEW velocity. Same arithmetic, so exactly equal.
    omega, h = 3.0, 0.05
    q0, v0 = np.array([0.7]), np.array([-0.4])
    step = integrators.get("semi_implicit_euler").step  # type: ignore[attr-defined]
    q1, u1, k0 = step(oscillator(omega), 0.0, q0, v0, h)
    v1 = v0 + h * (-(omega**2) * q0)
    np.testing.assert_array_equal(k0, -(omega**2) * q0)
    np.testing.assert_array_equal(u1, v1)
    np.testing.assert_array_equal(q1, q0 + h * v1)


def test_semi_implicit_euler_keeps_oscillator_energy_bounded_where_explicit_euler_grows() -> None:
    # On q'' = -w^2 q kick-drift Euler conserves I = v^2 + w^2 q^2 - h w^2 q v exactly, so the
    # energy E = (v^2 + w^2 q^2) / 2 stays within I / (2 (1 +- h w / 2)) for ever; explicit
    # Euler multiplies E by 1 + (h w)^2 every step.
    omega, h, periods = 2.0, 0.05, 100
    n = round(periods * 2 * np.pi / omega / h)
    q0, v0 = [1.0], [0.5]

    def run(method: str) -> tuple[np.ndarray, np.ndarray]:
        sol = solve(oscillator(omega), q0, v0, dt=h, n_steps=n, method=method)
        return sol.q[:, 0], sol.v[:, 0]

    q, v = run("semi_implicit_euler")
    invariant = v**2 + omega**2 * q**2 - h * omega**2 * q * v
    np.testing.assert_allclose(invariant, invariant[0], rtol=INVARIANT_RTOL)
    energy = 0.5 * (v**2 + omega**2 * q**2)
    hw = h * omega
    assert np.all(energy >= invariant[0] / (2 * (1 + hw / 2)) * (1 - INVARIANT_RTOL))
    assert np.all(energy <= invariant[0] / (2 * (1 - hw / 2)) * (1 + INVARIANT_RTOL))
    q_e, v_e = run("euler")
    energy_e = 0.5 * (v_e**2 + omega**2 * q_e**2)
    assert energy_e[-1] / energy_e[0] == pytest.approx((1 + hw**2) ** n, rel=1e-9)


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


def test_integrators_are_declared_by_keyword_only() -> None:
    # Five positional booleans and numbers read as nothing: ExplicitEuler("euler", 1, False, False, False, ...)
    with pytest.raises(TypeError):
        ExplicitEuler("euler", 1, False, False, False, "explicit Euler")  # type: ignore[misc]
    euler = integrators.get("euler")
    assert (euler.order, euler.symplectic, euler.adaptive, euler.implicit) == (1, False, False, False)
