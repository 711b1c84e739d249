"""robodyn check on a closed chain: a KIND = "constrained" formula against Pinocchio's constrained dynamics.

The subject is Example 19.3's linkage (examples/textbook/linkage). Its reduced formula
(reduced_formula.py, re-derived by sympy in test_textbook.py) must pass to round-off; every
derivation error planted here in a copy of it -- the issue's own half M, a spring of the wrong
sign, a C that is not 1/2 dM/dtheta omega, an on_the_loop off the loop -- must fail on the row
that names it, and a file that breaks the contract is one line, exit 2.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.cli import main
from robodyn.errors import FormulaError, InputError, UnknownNameError
from robodyn.scene import read_scene

ROOT = Path(__file__).resolve().parents[1]
LINKAGE = ROOT / "examples" / "textbook" / "linkage"
SCENE = LINKAGE / "linkage.toml"
FORMULA = LINKAGE / "reduced_formula.py"
AS_PRINTED = ROOT / "tests" / "fixtures" / "linkage_as_printed.py"
ROUND_OFF = 1e-12  # the right formula against Pinocchio on the loop: M, G, V exact; the bias through constraintDynamics
SAMPLES = 40

FORMULA_ROWS = {
    "M": "M (reduced: S^T M S)",
    "bias": "C omega (reduced bias: S^T (M dS/dt omega + C v))",
    "G": "G (reduced: S^T (G + springs))",
    "a": "a (forward dynamics: constraintDynamics)",
    "V": "V - V(q0) (gravity + springs)",
    "residual": "on_the_loop q: loop residual",
    "independent": "on_the_loop q: independent entries = q",
    "v": "on_the_loop v = S omega",
    "skew": "N = dM/dt - 2C skew (formula)",
    "dV": "G = dV/dq (formula)",
}

TEMPLATE = """
import importlib.util
import numpy as np

KIND = "constrained"
INDEPENDENT = {independent}
_spec = importlib.util.spec_from_file_location("linkage_cf", {closed!r})
cf = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(cf)


def parameters(scene):
    {parameters}


def mass_matrix(q, p):
    return np.array([[{M}]])


def coriolis_matrix(q, v, p):
    return np.array([[{C}]])


def gravity(q, p):
    return np.array([{G}])


def potential_energy(q, p):
    return float({V})


def on_the_loop(q, v, p):
    {loop}
"""
RIGHT = {
    "independent": '("joint_a",)',
    "parameters": "return cf.parameters(scene)",
    "M": "cf.reduced_mass(q[0], p)",
    "C": "0.5 * cf.reduced_mass_slope(q[0], p) * v[0]",
    "G": "cf.generalized_gravity(q[0], p)",
    "V": "cf.potential_energy(q[0], p)",
    "loop": "return cf.on_the_loop(q[0], v[0], p)",
}


def formula_file(tmp_path: Path, name: str = "formula.py", **changes: str) -> Path:
    """The linkage's reduced formula with ``changes`` planted (the keys of RIGHT)."""
    path = tmp_path / name
    path.write_text(TEMPLATE.format(closed=str(LINKAGE / "closed_form.py"), **{**RIGHT, **changes}))
    return path


def run_check(formula: Path | str, **options):
    scene = read_scene(SCENE)
    robot, _ = scene.build()
    options = {"loops": scene.constraints.loops, "springs": scene.constraints.springs, "scene": SCENE, **options}
    return robodyn.check(robot, str(formula), samples=SAMPLES, seed=3, **options)


def failed(report) -> set[str]:
    names = {v: k for k, v in FORMULA_ROWS.items()}
    return {names.get(r.quantity, r.quantity) for r in report.failures}


def test_the_linkage_reduced_formula_matches_pinocchios_constrained_dynamics():
    report = run_check(FORMULA)
    assert report.passed and report.kind == "constrained"
    for key in ("M", "bias", "G", "a", "V", "v"):
        assert report.row(FORMULA_ROWS[key]).max_rel_error < ROUND_OFF, key
    assert report.row(FORMULA_ROWS["residual"]).max_abs_error < ROUND_OFF  # [m]
    assert report.params["k"] == 20.0 and report.params["l"] == 0.6  # parameters(scene) read the scene and URDF
    # The samples cover the loop on both sides of theta = 0, inside joint_a's limits (+-1.5 rad).
    assert "sampled in [-1.5, 1.5]" in report.notes[0]


def test_the_issues_printed_m_is_half_and_the_check_names_it(capsys):
    report = run_check(AS_PRINTED)
    assert not report.passed
    assert {"M", "bias", "a"} <= failed(report) and not {"G", "V", "residual", "v"} & failed(report)
    m = report.row(FORMULA_ROWS["M"])
    assert m.got == pytest.approx(m.expected / 2, rel=2e-3)  # half, up to the rods' thickness (slender bars)
    code = main(["check", str(SCENE), "--formula", str(AS_PRINTED), "--samples", str(SAMPLES)])
    out = capsys.readouterr().out
    assert code == 1
    assert "MISMATCH M[0,0] (M (reduced: S^T M S)): formula" in out and "FAIL: 3 mismatches" in out


@pytest.mark.parametrize(
    ("changes", "expected"),
    [
        # the spring pushing the wrong way: G and dV/dtheta disagree with Pinocchio + spring
        ({"G": "-cf.weight_moment(p) * np.sin(q[0]) - p['k'] * (q[0] - p['rest'])"}, {"G", "a", "dV"}),
        # V without the spring's k theta^2 / 2
        ({"V": "cf.weight_moment(p) * np.cos(q[0])"}, {"V", "dV"}),
        # C = dM/dtheta omega (not the Christoffel 1/2 dM/dtheta omega)
        ({"C": "cf.reduced_mass_slope(q[0], p) * v[0]"}, {"bias", "a", "skew"}),
        # forgetting the velocity terms altogether
        ({"C": "0.0"}, {"bias", "a", "skew"}),
        # the collar at l cos(theta) instead of 2 l cos(theta): off the loop
        (
            {"loop": "qq, vv = cf.on_the_loop(q[0], v[0], p); qq['guide'] = p['l'] * np.cos(q[0]); return qq, vv"},
            {"residual"},
        ),
        # bar BC turning at -omega relative to AB instead of -2 omega
        ({"loop": "qq, vv = cf.on_the_loop(q[0], v[0], p); vv['joint_b'] = -v[0]; return qq, vv"}, {"v"}),
    ],
    ids=["spring-sign", "V-without-spring", "C-twice", "C-zero", "collar-off-loop", "v-off-loop"],
)
def test_a_planted_derivation_error_fails_on_its_own_row(tmp_path, changes, expected):
    report = run_check(formula_file(tmp_path, **changes))
    assert failed(report) >= expected
    assert not failed(report) & ({"M"} | ({"G", "bias"} - expected))  # the right terms still agree


def test_python_api_takes_loops_and_springs_as_plain_values_and_given_params():
    robot = robodyn.load(LINKAGE / "linkage.urdf")
    params = json.loads(json.dumps(run_check(FORMULA).params))
    report = robodyn.check(
        robot,
        str(FORMULA),
        loops=[{"frame_a": "bc_tip", "frame_b": "collar"}],
        springs={"joint_a": {"stiffness": 20.0, "rest": 0.0}},
        params=params,
        samples=10,
    )
    assert report.passed and report.params_given
    # Without the spring the tree's G lacks k theta: the formula (which has it) must disagree.
    report = robodyn.check(robot, str(FORMULA), loops=[{"frame_a": "bc_tip", "frame_b": "collar"}], params=params)
    assert {"G", "a", "V"} <= failed(report)


def test_bad_calls_are_one_error_naming_what():
    robot = robodyn.load(LINKAGE / "linkage.urdf")
    loops = [{"frame_a": "bc_tip", "frame_b": "collar"}]
    with pytest.raises(InputError, match="give loops"):
        robodyn.check(robot, str(FORMULA))
    with pytest.raises(InputError, match=r"parameters\(scene\) reads the scene"):
        robodyn.check(robot, str(FORMULA), loops=loops)
    with pytest.raises(UnknownNameError, match="unknown frame"):
        robodyn.check(robot, str(FORMULA), loops=[{"frame_a": "bc_tipp", "frame_b": "collar"}], scene=SCENE)
    with pytest.raises(InputError, match="stiffness >= 0"):
        robodyn.check(robot, str(FORMULA), loops=loops, springs={"joint_a": (-1.0, 0.0)}, scene=SCENE)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"independent": '("joint_z",)'}, "unknown independent joint (INDEPENDENT of "),
        ({"independent": '"joint_a"'}, "INDEPENDENT = 'joint_a'; expected a tuple"),
        ({"loop": "qq, vv = cf.on_the_loop(q[0], v[0], p); del qq['guide'], vv['guide']; return qq, vv"},
         "on_the_loop leaves out joint(s) guide"),
        ({"loop": "return {'joint_a': q[0]}"}, "on_the_loop returned dict; expected"),
        ({"loop": "import sys; sys.exit(0)"}, "on_the_loop called sys.exit(0)"),
        ({"parameters": "return {'m': 'heavy'}"}, "parameters()['m'] is str; expected a number"),
        ({"parameters": "return {}['m']"}, "parameters raised KeyError"),
    ],
    ids=["unknown-joint", "not-a-tuple", "joint-left-out", "not-a-pair", "sys-exit", "not-a-number", "raises"],
)  # fmt: skip
def test_a_file_that_breaks_the_contract_is_one_line_exit_2(tmp_path, capsys, changes, message):
    path = formula_file(tmp_path, **changes)
    assert main(["check", str(SCENE), "--formula", str(path), "--samples", "5"]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1 and "Traceback" not in err


def test_constrained_formula_on_a_bare_urdf_is_one_line_exit_2(capsys):
    assert main(["check", str(LINKAGE / "linkage.urdf"), "--formula", str(FORMULA)]) == 2
    err = capsys.readouterr().err.strip()
    assert "give loops" in err and len(err.splitlines()) == 1


def test_the_scenes_own_formula_is_used_and_robodyn_run_checks_it(tmp_path, capsys):
    assert main(["check", str(SCENE), "--samples", "10"]) == 0  # [check] formula = "reduced_formula.py"
    assert "formula: " + str(FORMULA) in capsys.readouterr().out
    # The scene with the issue's printed formula: robodyn run says which term and exits 1.
    text = SCENE.read_text().replace('"reduced_formula.py"', json.dumps(str(AS_PRINTED)))
    for name in ("linkage.urdf", "closed_form.py"):
        text = text.replace(f'"{name}"', json.dumps(str(LINKAGE / name)))
    text = re.sub(r"^duration = .*$", "duration = 0.05", text, flags=re.M)
    scene = tmp_path / "linkage.toml"
    scene.write_text(text)
    assert main(["run", str(scene), "--out", str(tmp_path / "out"), "--no-view"]) == 1
    out = capsys.readouterr().out
    assert "check: FAILED" in out and "MISMATCH M[0,0] (M (reduced: S^T M S))" in out
    record = json.loads((tmp_path / "out" / "summary.json").read_text())["check"]
    assert not record["passed"] and "M (reduced: S^T M S)" in record["failed"]
    assert record["worst_relative_error"]["M (reduced: S^T M S)"] == pytest.approx(0.5, rel=2e-3)


def test_real_subprocess_exit_codes():
    base = [sys.executable, "-m", "robodyn", "check", str(SCENE), "--samples", "5", "--formula"]
    ok = subprocess.run([*base, str(FORMULA)], capture_output=True, text=True, check=False)
    assert ok.returncode == 0 and "PASS" in ok.stdout
    bad = subprocess.run([*base, str(AS_PRINTED)], capture_output=True, text=True, check=False)
    assert bad.returncode == 1 and "MISMATCH M[0,0]" in bad.stdout


def test_loaded_formula_reports_its_independent_coordinates(tmp_path):
    from robodyn.checker.user_formula import load_user_formula

    with load_user_formula(str(FORMULA)) as formula:
        assert formula.kind == "constrained" and formula.independent == ("joint_a",) and formula.dof == 1
        p = formula.parameters(str(SCENE))
        states = formula.loop_states(np.array([[0.3]]), np.array([[1.0]]), p)
        assert states.joints == ("joint_a", "joint_b", "guide")
        assert states.q[0] == pytest.approx([0.3, -0.6, 2 * 0.6 * np.cos(0.3)], rel=1e-15)
    with pytest.raises(FormulaError, match="KIND = 'nope' is not a known kind; expected one of .*'constrained'"):
        load_user_formula(str(formula_file(tmp_path).write_text('KIND = "nope"') and tmp_path / "formula.py"))
