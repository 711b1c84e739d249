"""What a formula file may be: C v alone, a C that is not Christoffel's, the textbook's earlier names, a NaN.

Each file is the repository's own example formula with one change, so what passes or fails is that change;
the check runs through ``main([...])`` as a user runs it (seeded: ``--seed 0``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from robodyn import kinds, load
from robodyn.checker.compare import check
from robodyn.checker.rows import EQUATIONS_AGREE, FAIL, PASS
from robodyn.checker.user_formula import load_user_formula
from robodyn.cli import main
from robodyn.errors import FormulaError
from robodyn.kinds.formula import Formula

ROOT = Path(__file__).resolve().parents[1]
PENDUBOT = (ROOT / "examples/formulas/pendubot_mine.py").read_text()
CHRISTOFFEL = "    return np.array([[-t3 * s2 * v[1], -t3 * s2 * (v[0] + v[1])], [t3 * s2 * v[0], 0.0]])\n"
SAMPLES = ["--samples", "20", "--seed", "0"]
PENDUBOT_PARAMS = {"m1": 1.3, "m2": 0.5, "l1": 0.15, "lc1": 0.1, "lc2": 0.126, "I1": 0.006, "I2": 0.0027, "g": 9.81}


def _pendubot(tmp_path: Path, name: str, coriolis: str, *, as_vector: bool = False) -> Path:
    """pendubot_mine.py with its C's return line replaced by ``coriolis`` (and renamed coriolis_vector)."""
    assert CHRISTOFFEL in PENDUBOT
    text = PENDUBOT.replace(CHRISTOFFEL, coriolis)
    if as_vector:
        text = text.replace("def coriolis_matrix(q, v, p):", "def coriolis_vector(q, v, p):")
    path = tmp_path / name
    path.write_text(text)
    return path


def _check(path: Path, capsys: pytest.CaptureFixture[str], *extra: str) -> tuple[int, str, str]:
    code = main(["check", "pendubot", "--formula", str(path), *SAMPLES, *extra])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


# ------------------------------------------------------------------ coriolis_vector: C v alone
C_V = "    return np.array([-t3 * s2 * (2 * v[0] * v[1] + v[1] ** 2), t3 * s2 * v[0] ** 2])\n"


def test_coriolis_vector_checks_c_v_and_says_c_was_not_checked(tmp_path, capsys):
    code, out, _ = _check(_pendubot(tmp_path, "cv.py", C_V, as_vector=True), capsys)
    assert code == 0, out
    assert "PASS: everything agrees within tolerance" in out
    assert "note: C and dM/dt - 2C skew not checked: " in out and "gives C v (coriolis_vector), not C" in out
    rows = [line.split("  ")[0] for line in out.splitlines()]
    assert "C" not in rows and "N = dM/dt - 2C skew (formula)" not in rows
    assert {"nle = C v + G", "tau (inverse dynamics)", "a (forward dynamics)"} <= set(rows)


def test_a_wrong_coriolis_vector_fails_in_c_v_tau_and_a(tmp_path, capsys):
    wrong = C_V.replace("2 * v[0] * v[1]", "v[0] * v[1]")  # the cross term's factor 2 dropped
    code, out, _ = _check(_pendubot(tmp_path, "cv_wrong.py", wrong, as_vector=True), capsys, "--json")
    report = json.loads(out)
    assert code == 1 and report["verdict"] == FAIL
    failed = {r["quantity"] for r in report["rows"] if r["status"] == "FAIL"}
    assert failed == {"nle = C v + G", "tau (inverse dynamics)", "a (forward dynamics)"}


def test_a_file_with_neither_c_nor_c_v_is_refused_naming_both(tmp_path, capsys):
    path = tmp_path / "none.py"
    path.write_text(PENDUBOT.replace("def coriolis_matrix(q, v, p):", "def coriolis(q, v, p):"))
    assert main(["check", "pendubot", "--formula", str(path), *SAMPLES]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "missing function(s) coriolis_matrix or coriolis_vector" in err
    assert "coriolis_matrix(q, v, p) (the matrix C) or coriolis_vector(q, v, p) (the vector C v)" in err


def test_a_file_with_both_is_refused(tmp_path):
    path = _pendubot(tmp_path, "both.py", CHRISTOFFEL)
    path.write_text(path.read_text() + "\n\ndef coriolis_vector(q, v, p):\n    return 0 * v\n")
    with pytest.raises(FormulaError, match="defines both coriolis_matrix and coriolis_vector; keep one"):
        load_user_formula(path).close()


def test_the_stand_in_of_c_v_gives_the_files_momentum_rate():
    """dp/dt of a C-v-only formula (by dM/dt v + tau - C v - G) is the built-in Christoffel one's (tau + C^T v - G)."""
    pendubot, p = kinds.get("pendubot"), PENDUBOT_PARAMS

    def cv(q, v, p):
        return pendubot.coriolis_matrix(q, v, p) @ v

    from robodyn.checker.velocity_terms import stand_in

    only_cv = Formula("pendubot", "cv", pendubot.param_names, pendubot.mass_matrix, stand_in(cv, "cv"),
                      pendubot.gravity, None, 2, "vector")  # fmt: skip
    rng = np.random.default_rng(3)
    for _ in range(10):
        q, v, tau = rng.uniform(-2, 2, 2), rng.uniform(-2, 2, 2), rng.uniform(-1, 1, 2)
        np.testing.assert_allclose(only_cv.nle(q, v, p), pendubot.nle(q, v, p), rtol=1e-13, atol=1e-15)
        # central difference of step 1e-6 on M: truncation ~1e-12, round-off ~1e-10 of |M|
        np.testing.assert_allclose(
            only_cv.momentum_rate(q, v, tau, p), pendubot.momentum_rate(q, v, tau, p), rtol=0, atol=1e-8
        )


# ------------------------------------------------------------------ a C that is not Christoffel's
SPONG_C = "    return np.array([[-2 * t3 * s2 * v[1], -t3 * s2 * v[1]], [t3 * s2 * v[0], 0.0]])\n"  # same C v


def test_a_right_c_v_in_a_non_christoffel_c_is_headed_equations_agree_exit_0(tmp_path, capsys):
    code, out, _ = _check(_pendubot(tmp_path, "spong.py", SPONG_C), capsys)
    assert code == 0, out
    headline = out.strip().splitlines()[-1]
    assert headline.startswith("PASS (equations of motion): M, C v + G, tau and a agree; note: the formula's C is "
                               "not the Christoffel C (dM/dt - 2C is not skew)")  # fmt: skip
    assert "MISMATCH C[0,0] (C)" in out
    code, out, _ = _check(_pendubot(tmp_path, "spong.py", SPONG_C), capsys, "--json")
    report = json.loads(out)
    assert report["verdict"] == EQUATIONS_AGREE and report["passed"] is False
    failed = {r["quantity"] for r in report["rows"] if r["status"] == "FAIL"}
    assert failed == {"C", "N = dM/dt - 2C skew (formula)"}


def test_a_c_whose_c_v_is_wrong_is_a_fail_exit_1(tmp_path, capsys):
    wrong = SPONG_C.replace("[t3 * s2 * v[0], 0.0]", "[-t3 * s2 * v[0], 0.0]")  # C[1,0]'s sign
    code, out, _ = _check(_pendubot(tmp_path, "wrong.py", wrong), capsys)
    assert code == 1 and out.strip().splitlines()[-1].startswith("FAIL: ")


def test_the_verdict_of_a_right_formula_is_pass(tmp_path, capsys):
    code, out, _ = _check(_pendubot(tmp_path, "right.py", CHRISTOFFEL), capsys, "--json")
    assert code == 0 and json.loads(out)["verdict"] == PASS


# ------------------------------------------------------------------ the textbook's earlier names
def _before_the_rename(name: str) -> str:
    """The example file as it was before M became m_cart (cart-pole) and m (geared arm)."""
    text = (ROOT / f"examples/formulas/{name}").read_text()
    if name == "cart_pole_seed.py":  # its C21 misprint corrected: a file that passes
        text = text.replace("[-m * l * s * v[1], 0.0]])", "[0.0, 0.0]])")
        return text.replace('m_cart, m, l = p["m_cart"]', 'M, m, l = p["M"]').replace("[m_cart + m,", "[M + m,")
    text = text.replace('p["m"]', 'p["M"]')  # geared_arm_seed.py: its 1 / n^2 misprint corrected
    return text.replace('p["J_m"] + p["J_l"] / p["n"]', 'p["J_m"] + p["J_l"] / p["n"] ** 2')


@pytest.mark.parametrize(
    ("kind", "model", "name", "meaning", "new"),
    [
        ("cart_pole", "examples/urdf/cart_pole_point_bob.urdf", "cart_pole_seed.py", "the cart's mass", "m_cart"),
        ("geared_arm", "geared_arm", "geared_arm_seed.py", "the link's mass", "m"),
    ],
)
def test_a_file_in_the_textbooks_names_passes_with_a_one_line_note(tmp_path, capsys, kind, model, name, meaning, new):
    path = tmp_path / f"{kind}.py"
    path.write_text(_before_the_rename(name))
    assert 'p["M"]' in path.read_text()
    model_arg = str(ROOT / model) if model.endswith(".urdf") else model
    code = main(["check", model_arg, "--formula", str(path), *SAMPLES])
    captured = capsys.readouterr()
    assert code == 0, captured.out + captured.err
    assert captured.err.strip() == (f"note: {kind}.py uses the textbook's M for {meaning} (robodyn calls it {new})")
    parameters = next(line for line in captured.out.splitlines() if line.startswith("parameters"))
    assert f"{new} = " in parameters and " M = " not in parameters  # robodyn's own output: M is the mass matrix


def test_a_file_in_robodyns_names_gets_no_note(capsys):
    assert main(["check", "pendubot", "--formula", str(ROOT / "examples/formulas/pendubot_mine.py"), *SAMPLES]) == 0
    assert capsys.readouterr().err == ""


def test_an_unknown_name_is_still_a_key_error_listing_the_current_names(tmp_path):
    path = tmp_path / "typo.py"
    path.write_text(_before_the_rename("cart_pole_seed.py").replace('p["M"]', 'p["M_cart"]'))
    with load_user_formula(path) as formula, pytest.raises(FormulaError) as err:
        formula.mass_matrix(np.zeros(2), {"m_cart": 1.0, "m": 0.1, "l": 0.5, "I": 0.0, "g": 9.81})
    assert "KeyError: 'M_cart' (line 21); the parameters are m_cart, m, l, I, g" in str(err.value)


# ------------------------------------------------------------------ a NaN, and an M asymmetric by round-off
def test_a_nan_names_the_function_entry_state_and_line(tmp_path):
    path = _pendubot(tmp_path, "nan.py", CHRISTOFFEL.replace("0.0]])", "np.log(v[0] - 5)]])"))
    with load_user_formula(path) as formula, pytest.raises(FormulaError) as err:
        formula.coriolis_matrix(np.array([0.5, 1.0]), np.array([0.25, -1.0]), PENDUBOT_PARAMS)
    assert str(err.value) == (
        f"{path}: coriolis_matrix returned NaN in C[1,1] at q = [0.5, 1], v = [0.25, -1] (line 27)"
    )


def test_an_m_asymmetric_by_round_off_lists_one_entry_of_the_pair():
    pendubot = kinds.get("pendubot")

    def mass(q, p):  # M[0,1] off by 1e-3 relative; M[1,0] computed another way, a few eps from M[0,1]
        M = pendubot.mass_matrix(q, p)
        M[0, 1] *= 1.001
        M[1, 0] = (M[0, 1] * 3.0) / 3.0 + 1e-16 * M[0, 1] * np.cos(q[0])
        return M

    wrong = Formula("pendubot", "asym", pendubot.param_names, mass, pendubot.coriolis_matrix, pendubot.gravity)
    row = check(load("pendubot"), wrong, samples=20, seed=0).row("M")
    assert row.status == "FAIL"
    assert [m.entry for m in row.mismatches] == [(0, 1)]


def test_a_kind_any_file_may_give_c_v_alone(tmp_path, capsys):
    text = (ROOT / "examples/formulas/double_pendulum.py").read_text()
    christoffel = "    return np.array([[h * v[1], h * (v[0] + v[1])], [-h * v[0], 0.0]])\n"
    assert christoffel in text
    path = tmp_path / "any_cv.py"
    path.write_text(
        text.replace("def coriolis_matrix(q, v, p):", "def coriolis_vector(q, v, p):").replace(
            christoffel, "    return np.array([h * (2 * v[0] * v[1] + v[1] ** 2), -h * v[0] ** 2])\n"
        )
    )
    code = main(["check", str(ROOT / "examples/urdf/double_pendulum.urdf"), "--formula", str(path), *SAMPLES])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "gives C v (coriolis_vector), not C" in out and "PASS: everything agrees" in out
