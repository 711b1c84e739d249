"""``check --explain`` names a term only by what equals its coefficient at every parameter set (kinds.explain_sets).

Three robots none of robodyn's kinds, with non-round values and hand derivations in their own names
(tests/fixtures/explain): a gantry crane whose values make a coincidence (m1 lc2 = 0.8 * 0.25 = 0.5 * 0.4 =
m2 (l1 - lc1)), a 3-link arm in a vertical plane whose last centre of mass is behind its joint (lc3 < 0),
and a SCARA-like arm with lateral centres of mass (lcy2 < 0). A single slip is planted in each and the
name --explain gives is held to the truth, its sign and its symbols (NAMES) included.
"""

import json
from pathlib import Path

import numpy as np
import pytest
import sympy

import robodyn
from robodyn.checker.compare import check
from robodyn.checker.explain_names import Namer
from robodyn.cli import main
from robodyn.errors import FormulaError

ROOT = Path(__file__).resolve().parents[1]
HERE = ROOT / "tests" / "fixtures" / "explain"
SAMPLES = 60  # enough states to pin a sparse fit of a 3-joint formula (a fit is exact or not, not close)
NAME_CHECK_RTOL = 1e-8  # a name equals its fitted coefficient to round-off (the fit leaves ~1e-13 of the entry)
CRANE_PARAMETERS = {
    "mt": 1.37, "m1": 0.8, "lc1": 0.25, "l1": 0.65, "I1": 0.0317, "m2": 0.5, "lc2": 0.25, "I2": 0.0119, "g": 9.81,
}  # fmt: skip  # crane.urdf's values as a constant PARAMETERS dict: lc1 and lc2 are both 0.25


def _mutant(tmp_path: Path, name: str, old: str, new: str) -> Path:
    text = (HERE / f"{name}.py").read_text()
    assert text.count(old) == 1, f"the planted slip must replace exactly one place of {name}.py"
    path = tmp_path / f"{name}_slip.py"
    path.write_text(text.replace(old, new))
    return path


def _explain(name: str, formula: Path) -> object:
    report = check(robodyn.load(HERE / f"{name}.urdf"), str(formula), samples=SAMPLES, explain=True)
    assert not report.passed
    _names_are_their_coefficients(report)
    return report


def _names_are_their_coefficients(report) -> None:
    """Every name and candidate, evaluated at the check's parameters, is its term's coefficient (sign included)."""
    for entry in report.explain_terms:
        for term in entry["terms"]:
            for text in term["candidates"]:
                value = float(sympy.sympify(text).subs(report.params))
                assert value == pytest.approx(term["coefficient"], rel=NAME_CHECK_RTOL), (entry["label"], text)


def _entry(report, label: str) -> dict:
    return next(e for e in report.explain_terms if e["label"] == label)


def test_the_fixtures_pass_as_derived():
    for name in ("crane", "arm3", "scara2"):
        report = check(robodyn.load(HERE / f"{name}.urdf"), str(HERE / f"{name}.py"), samples=SAMPLES)
        assert report.passed, (name, [r.quantity for r in report.failures])


def test_crane_lc_for_l_is_named_across_parameter_sets_not_by_a_coincidence(tmp_path):
    # m1*lc2 = 0.2 = -m2*(lc1 - l1) at the crane's own values: one set cannot tell them apart, five can
    slip = _mutant(tmp_path, "crane", "(m1 * lc1 + m2 * l1) * np.cos(t1)", "(m1 * lc1 + m2 * lc1) * np.cos(t1)")
    report = _explain("crane", slip)
    entry = _entry(report, "M[0,2]")
    assert entry["status"] == "named", entry
    (term,) = entry["terms"]
    assert (term["basis"], term["name"]) == ("cos(phi1)", "m2*(lc1 - l1)")
    assert any(line.startswith("M[0,2]: formula - Pinocchio = m2*(lc1 - l1)*cos(phi1)") for line in report.explanation)
    assert not any("m1*lc2" in line for line in report.explanation)


def test_the_coincidence_is_there_at_one_parameter_set():
    # what the check's own values alone allow: several names, the wrong one among them
    found = [n.text for n in Namer(CRANE_PARAMETERS, 9.81).candidates(-0.2, (1, 1, 0))]
    assert "-m1*lc2" in found and "m2*(lc1 - l1)" in found


def test_equal_values_held_constant_give_candidates_and_say_why(tmp_path):
    # PARAMETERS: lc1 = lc2 = 0.25 each equal two per-link values (the two links' centres of mass), so neither
    # can be varied; m2*(lc1 - l1) and m2*(lc2 - l1) then agree at every set, and the output says so
    text = (HERE / "crane.py").read_text()
    start, end = text.index("def parameters(robot):"), text.index("def mass_matrix")
    text = text[:start] + f"PARAMETERS = {CRANE_PARAMETERS!r}\n\n\n" + text[end:]
    text = text.replace("(m1 * lc1 + m2 * l1) * np.cos(t1)", "(m1 * lc1 + m2 * lc1) * np.cos(t1)")
    slip = tmp_path / "crane_constants.py"
    slip.write_text(text)
    report = _explain("crane", slip)
    entry = _entry(report, "M[0,2]")
    assert entry["status"] == "candidates", entry
    (term,) = entry["terms"]
    assert term["name"] is None and "m2*(lc1 - l1)" in term["candidates"]
    assert "-m1*lc2" not in term["candidates"]
    assert entry["reason"].startswith("cannot tell ")
    assert "lc1 = 0.25 equals several per-link values" in entry["reason"]
    assert entry["reason"].endswith("define parameters(robot) in place of PARAMETERS")
    # which per-link value each constant followed, and which could not be varied
    assert report.explanation[1].startswith("  the constant parameters followed mt = rail_slide mass, m1 = hinge1 mass")
    assert "l1 = -hinge2 origin z" in report.explanation[1]
    assert report.explanation[2].startswith("  could not be varied: lc1 = 0.25 equals several per-link values")


def test_three_link_arm_lc_for_l_is_named_in_its_own_angles(tmp_path):
    slip = _mutant(tmp_path, "arm3", "m3 * l1 * l2, m3 * l2 * lc3", "m3 * l1 * lc2, m3 * l2 * lc3")
    report = _explain("arm3", slip)
    entry = _entry(report, "M[0,1]")
    assert entry["status"] == "named"
    assert [(t["basis"], t["name"]) for t in entry["terms"]] == [("cos(th2)", "m3*l1*(lc2 - l2)")]
    c10 = _entry(report, "C[1,0]")
    assert [(t["basis"], t["name"]) for t in c10["terms"]] == [("sin(th2)*th1_dot", "m3*l1*(lc2 - l2)")]


def test_a_dropped_term_in_a_run_of_three_angles_is_named_with_its_sign(tmp_path):
    # G[0] lacks m3 lc3 g cos(th1 + th2 + th3); lc3 < 0, so the coefficient -m3*lc3*g is positive
    slip = _mutant(tmp_path, "arm3", "* np.cos(t1) + g2, g2, g3])", "* np.cos(t1) + g2 - g3, g2, g3])")
    report = _explain("arm3", slip)
    entry = _entry(report, "G[0]")
    assert entry["status"] == "named"
    assert [(t["basis"], t["name"]) for t in entry["terms"]] == [("cos(th1 + th2 + th3)", "-m3*lc3*g")]
    assert entry["terms"][0]["coefficient"] > 0
    assert not any("swapped" in line for line in report.explanation)


def test_scara_lateral_centre_of_mass_sign_slip_is_named_with_a_negative_parameter(tmp_path):
    slip = _mutant(tmp_path, "scara2", '- p["lcy2"] * np.sin(q[1]))', '+ p["lcy2"] * np.sin(q[1]))')
    report = _explain("scara2", slip)
    assert report.params["lcy2"] < 0
    assert [(t["basis"], t["name"]) for t in _entry(report, "M[0,1]")["terms"]] == [("sin(q2)", "2*m2*a1*lcy2")]
    assert [(t["basis"], t["name"]) for t in _entry(report, "M[0,0]")["terms"]] == [("sin(q2)", "4*m2*a1*lcy2")]


def test_json_carries_the_terms_in_the_students_names(tmp_path, capsys):
    slip = _mutant(tmp_path, "crane", "m23 = m2 * lc2 * np.cos(t1 + t2)", "m23 = m2 * lc2 * np.sin(t1 + t2)")
    slip.write_text(slip.read_text().replace("[-h * w1, 0.0, 0.0]", "[h * w1, 0.0, 0.0]"))  # and a sign in C
    urdf = str(HERE / "crane.urdf")
    assert main(["check", urdf, "--formula", str(slip), "--samples", str(SAMPLES), "--explain", "--json"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert report["hints"] == []
    entry = next(e for e in report["explain_terms"] if e["label"] == "M[1,2]")
    assert set(entry) == {"quantity", "entry", "label", "status", "terms", "reason"}
    assert (entry["quantity"], entry["entry"], entry["status"], entry["reason"]) == ("M", [1, 2], "named", "")
    terms = {t["basis"]: t for t in entry["terms"]}
    assert set(terms) == {"sin(phi1 + phi2)", "cos(phi1 + phi2)"}
    assert terms["sin(phi1 + phi2)"]["name"] == "m2*lc2" and terms["cos(phi1 + phi2)"]["name"] == "-m2*lc2"
    assert terms["sin(phi1 + phi2)"]["candidates"] == ["m2*lc2"]
    assert terms["sin(phi1 + phi2)"]["coefficient"] == pytest.approx(0.5 * 0.25, rel=NAME_CHECK_RTOL)
    c = next(e for e in report["explain_terms"] if e["label"] == "C[1,0]")
    assert [(t["basis"], t["name"]) for t in c["terms"]] == [("sin(phi2)*phi1_dot", "-2*m2*l1*lc2")]
    assert any(
        line.startswith("C[1,0]: formula - Pinocchio = -2*m2*l1*lc2*sin(phi2)*phi1_dot")
        for line in report["explanation"]
    )


def test_a_difference_outside_the_basis_is_no_fit(tmp_path):
    slip = _mutant(tmp_path, "scara2", "return np.array([[m11, m12], [m12, I2 + m2 * r2]])",
                   "return np.array([[m11 + np.exp(q[1]), m12], [m12, I2 + m2 * r2]])")  # fmt: skip
    report = _explain("scara2", slip)
    entry = _entry(report, "M[0,0]")
    assert entry["status"] == "no_fit" and entry["terms"] == [] and "more than a term is wrong" in entry["reason"]


@pytest.mark.parametrize(
    ("names", "says"),
    [
        ('["phi1", "phi2"]', "NAMES has 2 name(s) for 3 joint(s) in JOINTS"),
        ('["phi1", "phi 2", "x"]', "NAMES has 'phi 2', which is not an identifier"),
        ('["phi1", "phi1", "x"]', "NAMES has 'phi1' twice"),
        ('"phi1 phi2 x"', "NAMES = 'phi1 phi2 x'; expected 3 distinct identifiers"),
    ],
)
def test_bad_names_are_one_line(tmp_path, names, says):
    slip = _mutant(tmp_path, "crane", 'NAMES = ["phi1", "phi2", "x"]', f"NAMES = {names}")
    with pytest.raises(FormulaError) as err:
        check(robodyn.load(HERE / "crane.urdf"), str(slip), samples=2)
    assert says in str(err.value) and "\n" not in str(err.value)


def test_a_name_must_fit_at_every_set():
    # two sets where m1*lc2 and m2*(l1 - lc1) agree at the first only: a name needs both
    first = {"m1": 0.8, "m2": 0.5, "l1": 0.65, "lc1": 0.25, "lc2": 0.25}
    second = {"m1": 0.91, "m2": 0.43, "l1": 0.71, "lc1": 0.22, "lc2": 0.31}
    truth = np.array([p["m2"] * (p["lc1"] - p["l1"]) for p in (first, second)])
    namer = Namer([first, second], [9.81, 9.81])
    assert [n.text for n in namer.candidates(truth, (1, 1, 0))] == ["m2*(lc1 - l1)"]
    assert namer.name(truth, (1, 1, 0)).text == "m2*(lc1 - l1)"


def test_a_signed_sum_of_three_angles_is_one_term():
    # one joint measured the other way round turns cos(q1 + q2 + q3) into cos(q1 - q2 + q3): one term, not six
    from robodyn.checker.explain_basis import fit, q_basis

    rng = np.random.default_rng(3)
    q = rng.uniform(-np.pi, np.pi, (SAMPLES, 3))
    d = 0.3719 * np.cos(q[:, 0] - q[:, 1] + q[:, 2])
    found = fit(d, q_basis(q, [False, False, False]), scale=1.0)
    assert found.exact and found.terms == ("cos(q1 - q2 + q3)",)
    assert found.coefficients[0] == pytest.approx(0.3719, rel=NAME_CHECK_RTOL)


def test_a_number_no_parameter_makes_is_unnamed(tmp_path):
    # a number typed into M: it does not change with the model, so no product of the parameters is it at every set
    slip = _mutant(tmp_path, "scara2", "[m12, I2 + m2 * r2]]", "[m12, I2 + m2 * r2 + 0.01234]]")
    report = _explain("scara2", slip)
    entry = _entry(report, "M[1,1]")
    assert entry["status"] == "unnamed", entry
    assert [(t["basis"], t["name"], t["candidates"]) for t in entry["terms"]] == [("1", None, [])]
    assert entry["terms"][0]["coefficient"] == pytest.approx(0.01234, rel=NAME_CHECK_RTOL)
    assert entry["reason"].startswith("no product of at most 3 parameters")
    assert any(
        line.startswith("M[1,1]: formula - Pinocchio = 0.0123   (coefficient 0.0123, unnamed)")
        for line in report.explanation
    )


def test_a_derived_constant_that_cannot_vary_leaves_candidates_at_the_checks_values(tmp_path):
    # PARAMETERS' I1 is about the hinge (I1c + m1 lc1^2 = 0.0817), which no per-link value is: it cannot follow the
    # model, so the formula - Pinocchio of M[0,0] changes form across the sets and nothing is named, only candidates
    text = (HERE / "crane.py").read_text()
    start, end = text.index("def parameters(robot):"), text.index("def mass_matrix")
    constants = {**CRANE_PARAMETERS, "I1": 0.0317 + 0.8 * 0.25**2}
    text = text[:start] + f"PARAMETERS = {constants!r}\n\n\n" + text[end:]
    old = "m11 = I1 + m1 * lc1**2 + I2 + m2 * (l1**2 + lc2**2 + 2 * l1 * lc2 * np.cos(t2))"
    assert text.count(old) == 1
    text = text.replace(old, "m11 = I1 + I2 + m2 * (l1**2 + lc2**2)")  # the slip: the cos(phi2) term dropped
    slip = tmp_path / "crane_derived.py"
    slip.write_text(text)
    report = _explain("crane", slip)
    entry = _entry(report, "M[0,0]")
    assert entry["status"] == "candidates", entry
    (term,) = entry["terms"]
    assert term["basis"] == "cos(phi2)" and term["name"] is None and "-2*m2*l1*lc2" in term["candidates"]
    assert "do not keep their form" in entry["reason"] and "I1 = 0.0817 equals no per-link value" in entry["reason"]
