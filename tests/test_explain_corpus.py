"""The explain corpus is honest (benchmarks/explain_corpus) and bench_explain's scorer calls a wrong name wrong.

Every planted edit applies exactly once and its written truth is the planted file minus the correct
one at seeded random parameters and states (NumPy and sympy, no Pinocchio); the file in absolute
angles equals arm3's through its COORDINATES matrix; two correct files pass ``robodyn check`` and a
planted one fails it. The scorer is tested on explanations written here, not on robodyn's output:
the benchmark, not a test, reports how well ``--explain`` does.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from robodyn.cli import main

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "benchmarks" / "explain_corpus"))

import _explain_score as score  # noqa: E402 - the benchmark's modules, beside it
import verify  # noqa: E402

ROBOTS = {robot.name: robot for robot in verify.load_corpus()}
CASES = [(robot, case) for robot in ROBOTS.values() for case in robot.cases]
CHECK_SAMPLES = "20"  # states of the robodyn check runs: a planted slip is off at every one


def test_the_corpus_has_what_the_issue_asks():
    assert len(ROBOTS) >= 6
    assert len(CASES) >= 40
    assert len({case.id for _, case in CASES}) == len(CASES)
    slips = {case.slip for _, case in CASES}
    for slip in ("lc for l", "dropped cross term", "forgotten parallel-axis term", "sin for cos", "wrong index"):
        assert slip in slips
    assert {"sign", "convention", "gravity sign", "transposed C"} <= slips


@pytest.mark.parametrize(("robot", "case"), CASES, ids=[case.id for _, case in CASES])
def test_each_edit_applies_once_and_its_truth_is_the_difference(robot, case):
    verify.verify_case(robot, case)


def test_a_wrong_truth_or_an_ambiguous_edit_is_caught():
    robot = ROBOTS["arm3"]
    case = next(c for c in robot.cases if c.id == "arm3-lc-for-l-k12")
    wrong = verify.Case(**{**case.__dict__, "truth": {**case.truth, "M[0,1]": "m3*l1*(lc2 - l1)*cos(th2)"}})
    with pytest.raises(verify.CorpusError, match="M\\[0,1\\]"):
        verify.verify_case(robot, wrong)
    twice = verify.Case(**{**case.__dict__, "old": "np.cos("})
    with pytest.raises(verify.CorpusError, match="occurs"):
        verify.verify_case(robot, twice)


def test_a_hint_whose_fix_does_not_fix_is_caught():
    robot = ROBOTS["cart_double_pendulum_up"]
    case = next(c for c in robot.cases if c.id == "cdp-offset-missing")
    assert case.hint is not None
    wrong = verify.Case(**{**case.__dict__, "hint": {**case.hint, "coordinates": [1.0, 0.0]}})
    with pytest.raises(verify.CorpusError, match="fix"):
        verify.verify_case(robot, wrong)


def test_the_absolute_angle_file_equals_arm3_through_its_coordinate_matrix():
    robot = ROBOTS["arm3_absolute"]
    assert robot.equivalent is not None
    verify.verify_equivalent(robot)


@pytest.mark.parametrize("name", ["scara", "crane_hoist"])  # parameters(robot), and a PARAMETERS dict
def test_a_correct_file_passes_check_and_a_planted_one_fails(name, tmp_path, capsys):
    robot = ROBOTS[name]
    assert main(["check", robot.model, "--formula", str(robot.formula), "--samples", CHECK_SAMPLES]) == 0
    planted = tmp_path / "planted.py"
    planted.write_text(verify.planted_text(robot, robot.cases[0]), encoding="utf-8")
    assert main(["check", robot.model, "--formula", str(planted), "--samples", CHECK_SAMPLES]) == 1
    capsys.readouterr()


# ------------------------------------------------------------------------------ the scorer
CRANE = ROBOTS["crane_hoist"]
DROPPED = next(c for c in CRANE.cases if c.id == "crane-dropped-rope-m12")  # truth: -m1*lc1*cos(theta)


def _line(name: str) -> dict:
    return {
        "explanation": [
            "explain: ...",
            f"M[0,1]: formula - Pinocchio = {name}*cos(q2)   (coefficient -0.2, = {name} to 1e-16)",
        ]
    }


def test_the_scorer_tells_the_truth_from_a_coincidence():
    # m1 lc1 = m2 lc2 = 0.2 in the crane: both names fit the coefficient, only one is the truth
    assert score.score_case(CRANE, DROPPED, _line("-m1*lc1"))["outcome"] == "named_right"
    assert score.score_case(CRANE, DROPPED, _line("-m2*lc2"))["outcome"] == "wrong_name"
    unnamed = {"explanation": ["explain: ...", "M[0,1]: formula - Pinocchio = -0.2*cos(q2)   (coefficient -0.2)"]}
    assert score.score_case(CRANE, DROPPED, unnamed)["outcome"] == "cannot_name"
    assert score.score_case(CRANE, DROPPED, {"explanation": []})["outcome"] == "missing"


def test_the_scorer_reads_the_schema_with_the_files_own_names():
    def report(candidates):
        term = {"basis": "cos(theta)", "coefficient": -0.2, "name": None, "candidates": candidates}
        item = {"quantity": "M", "entry": [0, 1], "label": "M[0,1]", "status": "candidates", "terms": [term]}
        return {"explain_terms": [item], "hints": []}

    assert score.score_case(CRANE, DROPPED, report(["-m2*lc2", "-m1*lc1"]))["outcome"] == "candidates"
    assert score.score_case(CRANE, DROPPED, report(["-m2*lc2", "-mt*lc2/2.5"]))["outcome"] == "wrong_name"


def test_the_scorer_cuts_a_printed_sum_into_its_terms():
    line = (
        "C[0,2]: formula - Pinocchio = 0.8*cos(q2)*v3 - (m2*lc1 - m1*lc1)*cos(q2)*v2   "
        "(coefficients 0.8; -0.12, = -(m2*lc1 - m1*lc1) to 1e-15)"
    )
    entry = score.parse_line(line)
    assert entry is not None and entry.status == "partial"
    assert [(t.basis, t.name) for t in entry.terms] == [("cos(q2)*v3", None), ("cos(q2)*v2", "-(m2*lc1 - m1*lc1)")]


def test_a_convention_hint_is_right_only_when_it_names_the_joint():
    robot = ROBOTS["rp_arm"]
    case = next(c for c in robot.cases if c.id == "rp-sign-slide")
    assert score.score_hint(case, ["slide: COORDINATES['slide'] = (-1, 0) makes it agree"]) == "right"
    assert score.score_hint(case, ["shoulder: COORDINATES['shoulder'] = (-1, 0) makes it agree"]) == "wrong"
    assert score.score_hint(case, []) == "missing"


def test_a_term_below_the_checks_own_tolerance_does_not_unname_a_slip(tmp_path, capsys):
    """UR5's rounded rpy tilt its parallel axes by ~1e-10: a term of 1e-9 of G[0] the check itself lets pass.

    The fit may leave it (explain_basis.BELOW_CHECK of the check's tolerance), so the dropped offset is named in
    G[0] as in G[1] and G[2]; fitted to round-off alone, G[0] came out as the slip plus 2.26e-10*sin(q1), unnamed.
    """
    robot = ROBOTS["ur5_planar"]
    case = next(c for c in robot.cases if c.id == "ur5-dropped-offset-g3")
    planted = tmp_path / "planted.py"
    planted.write_text(verify.planted_text(robot, case), encoding="utf-8")
    assert main(["check", robot.model, "--formula", str(planted), "--explain", "--samples", "40"]) == 1
    out = capsys.readouterr().out
    g0 = next(line for line in out.splitlines() if line.startswith("G[0]: formula - Pinocchio ="))
    assert g0.startswith("G[0]: formula - Pinocchio = -m3*h3*g*sin(th1 + th2 + th3)   (coefficient -0.174 = -m3*h3*g")


def test_c_entries_off_by_equal_and_opposite_amounts_are_each_listed(tmp_path, capsys):
    """C[1,2] and C[2,1] off by +e and -e: C is no symmetric quantity, so both are mismatches (and explained).

    Listing one entry of a pair whose |errors| agree is right for M alone; applied to C it hid C[2,1].
    """
    robot = ROBOTS["scara"]
    case = next(c for c in robot.cases if c.id == "scara-factor-two-dM3")
    planted = tmp_path / "planted.py"
    planted.write_text(verify.planted_text(robot, case), encoding="utf-8")
    assert main(["check", robot.model, "--formula", str(planted), "--explain", "--samples", "40"]) == 1
    explained = {line.split(":")[0] for line in capsys.readouterr().out.splitlines() if "formula - Pinocchio =" in line}
    assert explained == {"C[1,1]", "C[1,2]", "C[2,1]"}
