"""KIND = "any" formula files (robodyn.checker.any_kind, any_check, reference) and ``check --explain`` (kinds.explain).

Four systems that are none of robodyn's built-in kinds, each with a URDF and a formula derived by hand
in its own coordinates (examples/urdf, examples/formulas): a hanging double pendulum (angles from the
vertical, an offset and a sign flip), a revolute-prismatic-revolute arm, a cart with a double
pendulum (joints reordered, the rail's sign flipped) and a spatial 3-DoF arm. Each derivation passes;
each single-term mistake planted in it fails, and --explain names the term and its coefficient.
"""

from pathlib import Path

import numpy as np
import pytest
import sympy

import robodyn
from robodyn.checker.compare import check
from robodyn.errors import FormulaError

ROOT = Path(__file__).resolve().parents[1]
SYSTEMS = {
    "double_pendulum": "double_pendulum",
    "arm_rpr": "arm_rpr",
    "cart_double_pendulum": "cart_double_pendulum",
    "spatial_arm": "spatial_arm",
}
NAME_CHECK_RTOL = 1e-8  # a name equals its fitted coefficient to round-off (the fit leaves ~1e-13 of the entry)
SAMPLES = 60  # enough states to pin a sparse fit (the basis has at most ~700 terms; an exact fit is exact)


def _urdf(name: str) -> Path:
    return ROOT / "examples" / "urdf" / f"{name}.urdf"


def _formula(name: str) -> Path:
    return ROOT / "examples" / "formulas" / f"{name}.py"


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_the_hand_derivation_passes_in_its_own_coordinates(name):
    report = check(robodyn.load(_urdf(name)), str(_formula(name)), samples=SAMPLES)
    assert report.passed, [r.quantity for r in report.failures]
    assert report.kind == "any"
    assert report.row("M").max_rel_error < 1e-12  # round-off: the map to the formula's coordinates is exact


# (system, what is planted, text replaced, replacement, lines --explain must print)
MISTAKES = [
    # the hanging double pendulum, in its file's NAMES (theta1, theta2)
    ("double_pendulum", "dropped term", "m12 = m2 * (lc2**2 + l1 * lc2 * c2) + I2", "m12 = m2 * lc2**2 + I2",
     ["M[0,1]: formula - Pinocchio = -m2*l1*lc2*cos(theta2)   (coefficient -0.10"]),  # -0.1085: a tie at 3 digits
    ("double_pendulum", "factor 2", "m22 = m2 * lc2**2 + I2", "m22 = 2 * m2 * lc2**2 + I2",
     ["M[1,1]: formula - Pinocchio = m2*lc2**2   (coefficient 0.0673 = m2*lc2**2 at each of 5 parameter sets)"]),
    ("double_pendulum", "wrong sign", "[-h * v[0], 0.0]", "[h * v[0], 0.0]",
     ["C[1,0]: formula - Pinocchio = -2*m2*l1*lc2*sin(theta2)*theta1_dot   (coefficient -0.217 = -2*m2*l1*lc2 at each of 5 parameter sets)"]),
    ("double_pendulum", "sine for cosine", "(m1 * lc1 + m2 * l1) * g * np.sin(q[0])",
     "(m1 * lc1 + m2 * l1) * g * np.cos(q[0])",
     ["G[0]: formula - Pinocchio = (m1*lc1 + m2*l1)*g*cos(theta1) - (m1*lc1 + m2*l1)*g*sin(theta1)",
      "    the formula has (m1*lc1 + m2*l1)*g*cos(theta1) where Pinocchio has (m1*lc1 + m2*l1)*g*sin(theta1): "
      "a sine and a cosine swapped"]),
    ("double_pendulum", "lc for l", "m2 * (l1**2 + lc2**2", "m2 * (lc1**2 + lc2**2",
     ["M[0,0]: formula - Pinocchio = m2*(lc1**2 - l1**2)   (coefficient -0.141 = m2*(lc1**2 - l1**2) at each of 5"]),
    # the revolute-prismatic-revolute arm
    ("arm_rpr", "dropped term", "[A * dd - B * w3, A * w1", "[A * dd, A * w1",
     ["C[0,0]: formula - Pinocchio = m3*lc3*q2*sin(q3)*v3 + m3*l2*lc3*sin(q3)*v3"]),
    ("arm_rpr", "factor 2", 'g * (p["m2"] + m3) * np.sin(t1)', '2 * g * (p["m2"] + m3) * np.sin(t1)',
     ["G[1]: formula - Pinocchio = (m2 + m3)*g*sin(q1)   (coefficient 12.3 = (m2 + m3)*g at each of 5 parameter sets)"]),
    ("arm_rpr", "wrong sign", "m12 = -m3 * lc3 * np.sin(t3)", "m12 = m3 * lc3 * np.sin(t3)",
     ["M[0,1]: formula - Pinocchio = 2*m3*lc3*sin(q3)   (coefficient 0.126 = 2*m3*lc3 at each of 5 parameter sets)",
      "M[1,2]: formula - Pinocchio = 2*m3*lc3*sin(q3)   (coefficient 0.126 = 2*m3*lc3 at each of 5 parameter sets)"]),
    ("arm_rpr", "sine for cosine", "g3 = g * m3 * lc3 * np.cos(t1 + t3)", "g3 = g * m3 * lc3 * np.sin(t1 + t3)",
     ["G[2]: formula - Pinocchio = m3*lc3*g*sin(q1 + q3) - m3*lc3*g*cos(q1 + q3)"]),
    ("arm_rpr", "lc for l", 's, r2 = d + p["l2"], d + p["lc2"]\n    g, m3', 's, r2 = d + p["lc2"], d + p["lc2"]\n    g, m3',
     ["G[0]: formula - Pinocchio = m3*(lc2 - l2)*g*cos(q1)   (coefficient -1.02 = m3*(lc2 - l2)*g at each of 5"]),
    # the cart with a double pendulum
    ("cart_double_pendulum", "dropped term", "m13 = (m1 * lc1 + m2 * l1) * np.cos(t1) + m2 * lc2 * np.cos(t1 + t2)",
     "m13 = (m1 * lc1 + m2 * l1) * np.cos(t1)",
     ["M[0,2]: formula - Pinocchio = -m2*lc2*cos(q1 + q2)   (coefficient -0.07 = -m2*lc2 at each of 5 parameter sets)"]),
    ("cart_double_pendulum", "factor 2", "[-P * w1 - Q * w2,", "[-2 * P * w1 - Q * w2,",
     ["C[2,0]: formula - Pinocchio = -(m1*lc1 + m2*l1)*sin(q1)*v1 - m2*lc2*sin(q1 + q2)*v1"]),
    ("cart_double_pendulum", "wrong sign", "g2 = g * m2 * lc2 * np.sin(t1 + t2)", "g2 = -g * m2 * lc2 * np.sin(t1 + t2)",
     ["G[0]: formula - Pinocchio = -2*m2*lc2*g*sin(q1 + q2)   (coefficient -1.37 = -2*m2*lc2*g at each of 5 parameter sets)",
      "G[1]: formula - Pinocchio = -2*m2*lc2*g*sin(q1 + q2)   (coefficient -1.37 = -2*m2*lc2*g at each of 5 parameter sets)"]),
    ("cart_double_pendulum", "sine for cosine", "m23 = m2 * lc2 * np.cos(t1 + t2)", "m23 = m2 * lc2 * np.sin(t1 + t2)",
     ["M[1,2]: formula - Pinocchio = m2*lc2*sin(q1 + q2) - m2*lc2*cos(q1 + q2)"]),
    ("cart_double_pendulum", "lc for l", "2 * l1 * lc2 * np.cos(t2)", "2 * lc1 * lc2 * np.cos(t2)",
     ["M[0,0]: formula - Pinocchio = 2*m2*lc2*(lc1 - l1)*cos(q2)   (coefficient -0.0392 = 2*m2*lc2*(lc1 - l1) at"]),
    # the spatial arm
    ("spatial_arm", "dropped term", 'p["I3x"] * s23**2 + p["I3z"]', 'p["I3z"]',
     ["M[0,0]: formula - Pinocchio = -I3x*sin(q2 + q3)**2   (coefficient -0.0007 = -I3x at each of 5 parameter sets)"]),
    ("spatial_arm", "factor 2", "m33 = I3y + m3 * lc3**2", "m33 = I3y + 2 * m3 * lc3**2",
     ["M[2,2]: formula - Pinocchio = m3*lc3**2   (coefficient 0.0173 = m3*lc3**2 at each of 5 parameter sets)"]),
    ("spatial_arm", "wrong sign", 'b = -p["m3"]', 'b = p["m3"]',
     ["C[1,1]: formula - Pinocchio = 2*m3*l2*lc3*sin(q3)*v3   (coefficient 0.0857 = 2*m3*l2*lc3 at each of 5 parameter sets)"]),
    ("spatial_arm", "sine for cosine", "g3 = g * m3 * lc3 * np.cos(t2 + t3)", "g3 = g * m3 * lc3 * np.sin(t2 + t3)",
     ["G[2]: formula - Pinocchio = m3*lc3*g*sin(q2 + q3) - m3*lc3*g*cos(q2 + q3)"]),
    ("spatial_arm", "lc for l", 'm3 * p["l2"]) * np.cos(t2)', 'm3 * p["lc2"]) * np.cos(t2)',
     ["G[1]: formula - Pinocchio = m3*(lc2 - l2)*g*cos(q2)   (coefficient -1.29 = m3*(lc2 - l2)*g at each of 5"]),
]  # fmt: skip


@pytest.mark.parametrize(("name", "what", "old", "new", "expected"), MISTAKES, ids=[f"{m[0]}-{m[1]}" for m in MISTAKES])
def test_each_single_term_mistake_fails_and_explain_names_it(name, what, old, new, expected, tmp_path):
    text = _formula(name).read_text()
    assert text.count(old) == 1, f"the planted mistake ({what}) must replace exactly one place"
    mutant = tmp_path / f"{name}_mutant.py"
    mutant.write_text(text.replace(old, new))
    report = check(robodyn.load(_urdf(name)), str(mutant), samples=SAMPLES, explain=True)
    assert not report.passed
    for line in expected:
        assert any(got.startswith(line) for got in report.explanation), (line, report.explanation)
    for entry in report.explain_terms:  # every name is its coefficient, sign included, at the check's parameters
        for term in entry["terms"]:
            for text in term["candidates"]:
                value = float(sympy.sympify(text).subs(report.params))
                assert value == pytest.approx(term["coefficient"], rel=NAME_CHECK_RTOL), (entry["label"], text)


# ---------------------------------------------------------------------------------------- bad files
GOOD = (ROOT / "examples" / "formulas" / "double_pendulum.py").read_text()
BAD_FILES = {
    "unknown joint": (GOOD.replace('JOINTS = ["shoulder", "elbow"]', 'JOINTS = ["shoulder", "elbw"]')
                      .replace('"elbow": (-1.0, 0.0)', '"elbw": (-1.0, 0.0)'),
                      "JOINTS names 'elbw', which is not a moving joint of double_pendulum"),
    "sign not +-1": (GOOD.replace('"elbow": (-1.0, 0.0)', '"elbow": (2.0, 0.0)'),
                     "COORDINATES['elbow'] = (2.0, 0.0); expected (sign, offset) with sign +1 or -1"),
    "offset not finite": (GOOD.replace("(1.0, math.pi / 2)", "(1.0, math.inf)"),
                          "COORDINATES['shoulder'] = (1.0, inf); expected a finite offset"),
    "coordinates of a joint not in JOINTS": (GOOD.replace('"elbow": (-1.0, 0.0)}', '"elbow": (-1.0, 0.0), "hip": (1, 0)}'),
                                             "COORDINATES names 'hip', which is not in JOINTS"),
    "a parameter missing": (GOOD.replace('"lc2": lower.com[0],', ""),
                            "mass_matrix raised KeyError: 'lc2'"),
    "wrong shape": (GOOD.replace("return np.array([[m11, m12], [m12, m22]])", "return np.array([m11, m12])"),
                    "mass_matrix returned shape (2,), expected (2, 2)"),
    "no parameters": (GOOD.replace("def parameters(robot):", "def _parameters(robot):"),
                      "define PARAMETERS = {name: number} or def parameters(robot)"),
    "parameters not numbers": (GOOD.replace('"g": robot.g,', '"g": "9.81",'),
                               "parameters()['g'] is str; expected a number"),
    "JOINTS not a list of names": (GOOD.replace('JOINTS = ["shoulder", "elbow"]', 'JOINTS = "shoulder"'),
                                   "JOINTS = 'shoulder'; expected a list of the URDF joints"),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_a_bad_file_is_one_line_with_exit_2(case, tmp_path, capsys):
    from robodyn.cli import main

    text, expected = BAD_FILES[case]
    assert text != GOOD
    path = tmp_path / "bad.py"
    path.write_text(text)
    code = main(["check", str(_urdf("double_pendulum")), "--formula", str(path), "--samples", "5"])
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert expected in err, err


def test_a_named_free_flyer_is_refused_by_name(tmp_path):
    path = tmp_path / "ff.py"
    path.write_text(
        GOOD.replace('JOINTS = ["shoulder", "elbow"]', 'JOINTS = ["root_joint", "elbow"]').replace(
            '"shoulder": (1.0, math.pi / 2), ', ""
        )
    )
    with pytest.raises(FormulaError, match="JOINTS names 'root_joint', a JointModelFreeFlyer"):
        check(robodyn.load(_urdf("double_pendulum"), free_flyer=True), str(path), samples=3)


# ---------------------------------------------------------------------------------------- locked joints
LOCKED_ELBOW = """
import numpy as np

KIND = "any"
JOINTS = ["shoulder"]
COORDINATES = {"shoulder": (1.0, np.pi / 2)}
LOCKED = {"elbow": -0.4}  # the URDF's own coordinate: theta2 = -q_elbow = 0.4 rad
PARAMETERS = {"m1": 1.2, "m2": 0.7, "l1": 0.5, "lc1": 0.22, "lc2": 0.31, "I1": 0.0262, "I2": 0.0231, "g": 9.81}
PHI = 0.4


def mass_matrix(q, p):  # one rigid body: link 2's centre at |l1 + lc2 e(phi)| from the shoulder
    r2 = p["l1"] ** 2 + p["lc2"] ** 2 + 2 * p["l1"] * p["lc2"] * np.cos(PHI)
    return np.array([[p["I1"] + p["m1"] * p["lc1"] ** 2 + p["I2"] + p["m2"] * r2]])


def coriolis_matrix(q, v, p):
    return np.zeros((1, 1))


def gravity(q, p):
    g = p["g"]
    return np.array([g * (p["m1"] * p["lc1"] + p["m2"] * p["l1"]) * np.sin(q[0]) + g * p["m2"] * p["lc2"] * np.sin(q[0] + PHI)])
"""


def test_joints_left_out_are_locked_at_the_stated_value(tmp_path):
    path = tmp_path / "locked.py"
    path.write_text(LOCKED_ELBOW)
    report = check(robodyn.load(_urdf("double_pendulum")), str(path), samples=SAMPLES)
    assert report.passed, [r.quantity for r in report.failures]
    assert any("locked (welded to their parents): elbow at -0.4" in note for note in report.notes)
    path.write_text(LOCKED_ELBOW.replace('LOCKED = {"elbow": -0.4}', 'LOCKED = {"elbow": 0.4}'))
    assert not check(robodyn.load(_urdf("double_pendulum")), str(path), samples=SAMPLES).passed


# ---------------------------------------------------------------------------------------- every entry, symmetry
def test_every_mismatching_entry_is_reported_not_only_the_worst(tmp_path):
    text = (ROOT / "examples" / "formulas" / "pendubot_mine.py").read_text()
    both = text.replace("t2 + t3 * c2", "t2 + 2 * t3 * c2").replace("t1 + t2 + 2 * t3 * c2", "t1 + t2 + 3 * t3 * c2")
    assert both.count("t2 + 2 * t3 * c2") == 2 and "3 * t3 * c2" in both  # M[0,0], M[0,1] and M[1,0] wrong
    path = tmp_path / "both.py"
    path.write_text(both)
    report = check(robodyn.load("pendubot"), str(path), samples=SAMPLES, explain=True)
    row = report.row("M")
    assert {m.entry for m in row.mismatches} == {(0, 0), (0, 1)}
    assert report.row("M = M^T (formula)").passed  # still symmetric: M[1,0] is M[0,1]'s, not listed twice
    assert any(line.startswith("M[0,0]: formula - Pinocchio = m2*l1*lc2*cos(q2)") for line in report.explanation)


def test_an_asymmetric_formula_mass_matrix_is_said(tmp_path):
    text = (ROOT / "examples" / "formulas" / "pendubot_mine.py").read_text()
    lopsided = text.replace("[t2 + t3 * c2, t2]])", "[t2 + 2 * t3 * c2, t2]])")
    assert lopsided != text
    path = tmp_path / "lopsided.py"
    path.write_text(lopsided)
    report = check(robodyn.load("pendubot"), str(path), samples=SAMPLES, explain=True)
    assert not report.row("M = M^T (formula)").passed
    assert {m.entry for m in report.row("M").mismatches} == {(1, 0)}
    assert any(line.startswith("the formula's M is not symmetric: M[0,1] - M[1,0]") for line in report.explanation)


def test_a_non_christoffel_c_with_a_right_c_v_is_said(tmp_path):
    text = (ROOT / "examples" / "formulas" / "pendubot_mine.py").read_text()
    # C v is the same with row 1 of C written as (-t3 s2 (2 v1 + v2), 0) ... times v: the whole bias in column 0
    other = text.replace(
        "return np.array([[-t3 * s2 * v[1], -t3 * s2 * (v[0] + v[1])], [t3 * s2 * v[0], 0.0]])",
        "return np.array([[-t3 * s2 * (2 * v[0] + v[1]) * v[1] / v[0], 0.0], [t3 * s2 * v[0], 0.0]])",
    )
    assert other != text
    path = tmp_path / "other.py"
    path.write_text(other)
    report = check(robodyn.load("pendubot"), str(path), samples=SAMPLES, explain=True)
    assert report.row("nle = C v + G").passed and not report.row("N = dM/dt - 2C skew (formula)").passed
    assert any("a valid C v written in a non-Christoffel form" in line for line in report.explanation)


def test_explain_names_the_textbook_misprints():
    report = check(robodyn.load("pendubot"), str(ROOT / "examples/formulas/pendubot_seed.py"), explain=True)
    lines = report.explanation
    assert any(
        line.startswith("M[0,1]: formula - Pinocchio = m2*l1*lc2*cos(q2)   (coefficient 0.00945") for line in lines
    )
    assert any(
        line.startswith("C[1,0]: formula - Pinocchio = m2*l1*lc2*sin(q2)*v2 - m2*l1*lc2*sin(q2)*v1") for line in lines
    )
    assert "tau[1] (tau (inverse dynamics)) follows from M[0,1], C[1,0]" in lines


def test_coordinates_map_pinocchio_exactly():
    from robodyn.checker.reference import Reference

    robot = robodyn.load(_urdf("cart_double_pendulum"))
    ref = Reference.mapped(robot, ["hinge1", "hinge2", "cart"], [1.0, 1.0, -1.0], [0.0, 0.0, 0.3])
    rng = np.random.default_rng(0)
    q, v = robot.random_state(rng)
    qf, vf = ref.formula_q(q), ref.formula_v(v)
    np.testing.assert_array_equal(qf, [q[1], q[2], -q[0] + 0.3])
    S = ref.S
    np.testing.assert_allclose(ref.mass_matrix(qf), S.T @ robot.M(q) @ S, rtol=0, atol=0)
    np.testing.assert_allclose(ref.coriolis_matrix(qf, vf), S.T @ robot.C(q, v) @ S, rtol=0, atol=0)
    np.testing.assert_allclose(ref.gravity(qf), S.T @ robot.G(q), rtol=0, atol=0)
    np.testing.assert_allclose(ref.urdf_q(qf), q, rtol=0, atol=1e-15)


def test_a_coefficient_is_named_with_the_entrys_dimension():
    from robodyn.checker.explain_names import Namer

    namer = Namer({"m2": 1.0, "l1": 0.15, "lc2": 0.126}, 9.81)  # m2 = 1 kg: l1*lc2 has the same value
    c = 1.0 * 0.15 * 0.126
    assert namer.name(c, (1, 2, 0)).text == "m2*l1*lc2"  # an entry of M in kg m^2
    assert namer.name(c, (0, 2, 0)).text == "l1*lc2"
    assert namer.name(-0.126 * 9.81, (1, 2, -2)).text == "-m2*lc2*g"  # a torque of gravity [N m], not lc2*g
    assert namer.name(0.123456789, (1, 2, 0)) is None  # no product of these equals it
