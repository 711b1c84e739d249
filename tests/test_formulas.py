"""The hand formulas against an independent symbolic Lagrangian derivation (sympy).

sympy starts from positions of the centres of mass, builds T and V, and applies Lagrange's
equations; M is the Hessian of T in the velocities, C the Christoffel symbols of M, G the
gradient of V. The NumPy formulas must agree at seeded random states.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from robodyn import kinds as formulas
from robodyn.checker.user_formula import load_user_formula
from robodyn.errors import FormulaError, UnknownNameError

RTOL = 1e-12  # same expressions evaluated two ways: round-off only
N_STATES = 20


def _christoffel(M: sp.Matrix, q: list, v: list) -> sp.Matrix:
    n = len(q)
    C = sp.zeros(n, n)
    for k in range(n):
        for j in range(n):
            C[k, j] = sum(
                sp.Rational(1, 2) * (sp.diff(M[k, j], q[i]) + sp.diff(M[k, i], q[j]) - sp.diff(M[i, j], q[k])) * v[i]
                for i in range(n)
            )
    return C.applyfunc(sp.simplify)


def _lagrange(T, V, q, v):
    M = sp.Matrix([[sp.diff(T, vi, vj) for vj in v] for vi in v]).applyfunc(sp.simplify)
    return M, _christoffel(M, q, v), sp.Matrix([sp.diff(V, qi) for qi in q])


def _symbolic(kind: str):
    g = sp.Symbol("g")
    if kind == "pendubot":
        q1, q2, v1, v2 = sp.symbols("q1 q2 v1 v2")
        m1, m2, l1, lc1, lc2, I1, I2 = sp.symbols("m1 m2 l1 lc1 lc2 I1 I2")
        t = sp.Symbol("t")
        Q1, Q2 = sp.Function("Q1")(t), sp.Function("Q2")(t)
        r1 = sp.Matrix([lc1 * sp.cos(Q1), lc1 * sp.sin(Q1)])
        r2 = sp.Matrix([l1 * sp.cos(Q1) + lc2 * sp.cos(Q1 + Q2), l1 * sp.sin(Q1) + lc2 * sp.sin(Q1 + Q2)])
        sub = {sp.Derivative(Q1, t): v1, sp.Derivative(Q2, t): v2}
        d1, d2 = r1.diff(t).subs(sub), r2.diff(t).subs(sub)
        T = sp.Rational(1, 2) * (m1 * d1.dot(d1) + m2 * d2.dot(d2) + I1 * v1**2 + I2 * (v1 + v2) ** 2)
        T = T.subs({Q1: q1, Q2: q2})
        V = g * (m1 * r1[1] + m2 * r2[1]).subs({Q1: q1, Q2: q2})
        syms = dict(m1=m1, m2=m2, l1=l1, lc1=lc1, lc2=lc2, I1=I1, I2=I2, g=g)
        return [q1, q2], [v1, v2], T, V, syms
    if kind == "cart_pole":
        y, th, vy, vth = sp.symbols("y th vy vth")
        m_cart, m, l, I = sp.symbols("m_cart m l I")
        zb = l * sp.cos(th)  # the pole's centre of mass is at (y + l sin th, l cos th)
        xd = vy + l * sp.cos(th) * vth
        zd = -l * sp.sin(th) * vth
        T = sp.Rational(1, 2) * (m_cart * vy**2 + m * (xd**2 + zd**2) + I * vth**2)
        V = m * g * zb
        return [y, th], [vy, vth], T, V, dict(m_cart=m_cart, m=m, l=l, I=I, g=g)
    th, w = sp.symbols("th w")
    J_m, J_l, n, m, l = sp.symbols("J_m J_l n m l")
    T = sp.Rational(1, 2) * (J_m * (n * w) ** 2 + J_l * w**2)  # motor turns n times faster
    V = m * g * l * (1 - sp.cos(th))
    return [th], [w], T, V, dict(J_m=J_m, J_l=J_l, n=n, m=m, l=l, g=g)


PARAMS = {
    "pendubot": dict(m1=1.3, m2=0.45, l1=0.17, lc1=0.09, lc2=0.12, I1=0.006, I2=0.0027, g=9.81),
    "cart_pole": dict(m_cart=1.2, m=0.15, l=0.45, I=0.004, g=9.81),
    "geared_arm": dict(J_m=1.1e-6, J_l=7.3e-3, n=50.0, m=0.25, l=0.15, g=9.81),
}


@pytest.mark.parametrize("kind", sorted(PARAMS))
def test_formula_matches_symbolic_lagrangian(kind):
    q, v, T, V, syms = _symbolic(kind)
    M, C, G = _lagrange(T, V, q, v)
    values = {syms[k]: val for k, val in PARAMS[kind].items()}
    f_M = sp.lambdify([q], M.subs(values), "numpy")
    f_C = sp.lambdify([q, v], C.subs(values), "numpy")
    f_G = sp.lambdify([q], G.subs(values), "numpy")
    f_V = sp.lambdify([q], V.subs(values), "numpy")
    formula = formulas.get(kind)
    p = PARAMS[kind]
    rng = np.random.default_rng(7)
    q0 = np.zeros(len(q))
    for _ in range(N_STATES):
        qs, vs = rng.uniform(-3, 3, len(q)), rng.uniform(-2, 2, len(q))
        np.testing.assert_allclose(formula.mass_matrix(qs, p), np.array(f_M(qs), dtype=float), rtol=RTOL, atol=1e-15)
        np.testing.assert_allclose(
            formula.coriolis_matrix(qs, vs, p), np.array(f_C(qs, vs), dtype=float), rtol=RTOL, atol=1e-15
        )
        np.testing.assert_allclose(
            formula.gravity(qs, p), np.array(f_G(qs), dtype=float).ravel(), rtol=RTOL, atol=1e-15
        )
        dV = formula.potential_energy(qs, p) - formula.potential_energy(q0, p)
        np.testing.assert_allclose(dV, float(f_V(qs)) - float(f_V(q0)), rtol=RTOL, atol=1e-14)


@pytest.mark.parametrize("kind", sorted(PARAMS))
def test_christoffel_form_makes_mdot_minus_2c_skew(kind):
    formula, p = formulas.get(kind), PARAMS[kind]
    rng = np.random.default_rng(3)
    h = 1e-6  # central difference: error ~ h^2
    for _ in range(10):
        q, v = rng.uniform(-3, 3, formula.dof), rng.uniform(-2, 2, formula.dof)
        Mdot = (formula.mass_matrix(q + h * v, p) - formula.mass_matrix(q - h * v, p)) / (2 * h)
        N = Mdot - 2 * formula.coriolis_matrix(q, v, p)
        np.testing.assert_allclose(N + N.T, 0.0, atol=1e-8)


def test_geared_arm_motor_coordinate_forms_match_the_motor_lagrangian():
    """The motor-coordinate forms (the link closed form carried through theta_m = n theta_l) against
    sympy's Lagrangian written directly in theta_m, and the round trip motor -> link -> motor."""
    from robodyn.kinds import geared_arm as ga

    th, w = sp.symbols("th_m w_m")
    J_m, J_l, n, m, l, g = sp.symbols("J_m J_l n m l g")
    T = sp.Rational(1, 2) * (J_m * w**2 + J_l * (w / n) ** 2)  # the link turns n times slower
    V = m * g * l * (1 - sp.cos(th / n))
    M, C, G = _lagrange(T, V, [th], [w])
    p = PARAMS["geared_arm"]
    values = {J_m: p["J_m"], J_l: p["J_l"], n: p["n"], m: p["m"], l: p["l"], g: p["g"]}
    f_M = sp.lambdify([[th]], M.subs(values), "numpy")
    f_G = sp.lambdify([[th]], G.subs(values), "numpy")
    f_V = sp.lambdify([[th]], V.subs(values), "numpy")
    link = formulas.get("geared_arm")
    back = ga.from_motor_coordinates(
        ga.mass_matrix_motor, ga.coriolis_matrix_motor, ga.gravity_motor, ga.potential_energy_motor
    )
    rng = np.random.default_rng(11)
    for _ in range(10):
        q, v = rng.uniform(-3, 3, 1), rng.uniform(-2, 2, 1)
        theta_m, omega_m = ga.link_to_motor(q, v, p)
        np.testing.assert_allclose(ga.mass_matrix_motor(theta_m, p), np.array(f_M(theta_m), float), rtol=RTOL)
        assert C == sp.zeros(1, 1)  # constant inertia: no Coriolis term
        np.testing.assert_allclose(ga.coriolis_matrix_motor(theta_m, omega_m, p), 0.0, atol=0.0)
        np.testing.assert_allclose(ga.gravity_motor(theta_m, p), np.array(f_G(theta_m), float).ravel(), rtol=RTOL)
        np.testing.assert_allclose(ga.potential_energy_motor(theta_m, p), float(f_V(theta_m)), rtol=RTOL, atol=1e-15)
        for f_link, f_back, args in (
            (link.mass_matrix, back[0], (q, p)),
            (link.coriolis_matrix, back[1], (q, v, p)),
            (link.gravity, back[2], (q, p)),
        ):
            np.testing.assert_allclose(f_back(*args), f_link(*args), rtol=RTOL, atol=1e-15)


def test_unknown_kind_lists_the_kinds():
    with pytest.raises(UnknownNameError, match="cart_pole, geared_arm, pendubot"):
        formulas.get("double_pendulum")


def test_user_formula_errors_are_one_line(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text(
        "KIND = 'pendubot'\ndef mass_matrix(q, p):\n  return [[1, 2, 3]]\n"
        "def coriolis_matrix(q, v, p):\n  return [[0, 0], [0, 0]]\ndef gravity(q, p):\n  return [0, 0]\n"
    )
    f = load_user_formula(bad)
    with pytest.raises(FormulaError, match=r"mass_matrix returned shape \(1, 3\), expected \(2, 2\)"):
        f.mass_matrix(np.zeros(2), PARAMS["pendubot"])
    syntax = tmp_path / "syntax.py"
    syntax.write_text("KIND = 'pendubot'\ndef mass_matrix(q, p)\n  pass\n")
    with pytest.raises(FormulaError, match="syntax.py:2: the formula file has a syntax error"):
        load_user_formula(syntax)
    nokind = tmp_path / "nokind.py"
    nokind.write_text("def mass_matrix(q, p):\n  return 1\n")
    with pytest.raises(FormulaError, match="define KIND"):
        load_user_formula(nokind)
    missing = tmp_path / "missing.py"
    missing.write_text("KIND = 'cart_pole'\ndef mass_matrix(q, p):\n  return 1\n")
    with pytest.raises(FormulaError, match="missing function.*coriolis_matrix or coriolis_vector, gravity"):
        load_user_formula(missing)
    with pytest.raises(FormulaError, match="no such formula file"):
        load_user_formula(tmp_path / "absent.py")
    failing = tmp_path / "failing.py"
    failing.write_text("KIND = 'pendubot'\n1 / 0\n")
    with pytest.raises(FormulaError, match=r"failed to import: ZeroDivisionError: division by zero \(line 2\)"):
        load_user_formula(failing)
    raising = tmp_path / "raising.py"
    raising.write_text(
        "KIND = 'geared_arm'\ndef mass_matrix(q, p):\n  return p['mass']\n"
        "def coriolis_matrix(q, v, p):\n  return [[0]]\ndef gravity(q, p):\n  return [0]\n"
    )
    with pytest.raises(FormulaError, match=r"mass_matrix raised KeyError: 'mass' \(line 3\)"):
        load_user_formula(raising).mass_matrix(np.zeros(1), PARAMS["geared_arm"])


def test_user_formula_non_finite_and_key_errors_name_the_fix(tmp_path):
    f = tmp_path / "nan.py"
    f.write_text(
        "import numpy as np\nKIND = 'pendubot'\n"
        "def mass_matrix(q, p):\n    return np.eye(2) * p['mass1']\n"
        "def coriolis_matrix(q, v, p):\n    return np.zeros((2, 2))\n"
        "def gravity(q, p):\n    return np.array([np.nan, 0.0])\n"
    )
    formula = load_user_formula(f)
    with pytest.raises(FormulaError, match=r"KeyError: 'mass1' \(line 4\); the parameters are m1, m2, l1"):
        formula.mass_matrix(np.zeros(2), PARAMS["pendubot"])
    with pytest.raises(FormulaError, match=r"gravity returned NaN in G\[0\] at q = \[0, 0\] \(line 8\)$"):
        formula.gravity(np.zeros(2), PARAMS["pendubot"])
