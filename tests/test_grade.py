"""robodyn grade on a small generated class: right answers in several conventions, planted slips, hostile files.

The class is graded once (through ``main``) per module; each test reads what it wrote. Every right answer
must get full marks, every planted slip lose exactly the points of the entries it touches, and every
hostile file 0 with one line of why, the others unaffected.
"""

from __future__ import annotations

import csv
import importlib.util
import json
import math
from pathlib import Path

import pytest

from robodyn.cli import main
from robodyn.grade import load_assignment, notebook_check
from robodyn.grade.mutate import mutants

ROOT = Path(__file__).resolve().parents[1]
DOUBLE = (ROOT / "examples/grading/double_pendulum/solution.py").read_text()  # a copy of the example, frozen here
PENDUBOT = (ROOT / "examples/formulas/pendubot_mine.py").read_text()
EXACT = 1e-9  # scores are sums of shares points / entries, rounded to 6 decimals: equal to far better than this

M12 = "m12 = m2 * (lc2**2 + l1 * lc2 * c2) + I2"
G0 = "(m1 * lc1 + m2 * l1) * g * np.sin(q[0])"
H = 'h = -p["m2"]'
COORDS = 'COORDINATES = {"shoulder": (1.0, math.pi / 2), "elbow": (-1.0, 0.0)}  # q_formula = sign * q_urdf + offset'
MATRIX = "COORDINATES = [[1, 0], [0, -1]]\nOFFSETS = [math.pi / 2, 0.0]"


def _replaced(text: str, old: str, new: str) -> str:
    if old not in text:
        raise ValueError(f"the planted change needs {old!r} in the file")  # the example changed: the test must too
    return text.replace(old, new)


# student -> (file text, expected score of 10). M = 3 points over 3 entries, C = 4 over 4, G = 2 over 2, V = 1.
CLASS = {
    "right_dict": (DOUBLE, 10.0),
    "right_matrix": (_replaced(DOUBLE, COORDS, MATRIX), 10.0),
    "dropped_m12": (_replaced(DOUBLE, M12, "m12 = m2 * lc2**2 + I2"), 9.0),  # M[0,1]: 1 of M's 3
    "dropped_g0_term": (_replaced(DOUBLE, G0, "m1 * lc1 * g * np.sin(q[0])"), 9.0),  # G[0]: 1 of G's 2
    "c_sign": (_replaced(DOUBLE, H, 'h = p["m2"]'), 7.0),  # C[0,0], C[0,1], C[1,0]: 3 of C's 4 (C[1,1] = 0)
    "loops": (
        _replaced(DOUBLE, "def mass_matrix(q, p):", "def mass_matrix(q, p):\n    while True:\n        pass"),
        0.0,
    ),
    "exits": (_replaced(DOUBLE, "import math", "import math\nimport sys\nsys.exit(3)"), 0.0),
    "writes": (
        _replaced(DOUBLE, "def gravity(q, p):", "def gravity(q, p):\n    open('pwned.txt', 'w').write('x')"),
        0.0,
    ),
    "socket": (_replaced(DOUBLE, "import math", "import math\nimport socket"), 0.0),
    "memory": (_replaced(DOUBLE, "import numpy as np", "import numpy as np\n\nBIG = np.empty(2**31)"), 0.0),  # 16 GiB
    "nan": (_replaced(DOUBLE, "    return np.array([(m1", "    return np.nan * np.array([(m1"), 0.0),
}
HOSTILE = {
    "memory": "MemoryError",
    "loops": "within 3 s",
    "exits": "exit",
    "writes": "open",
    "socket": "socket",
    "nan": "NaN",
}
PLANTED = {"dropped_m12": ("M[0,1]",), "dropped_g0_term": ("G[0]",), "c_sign": ("C[0,0]", "C[0,1]", "C[1,0]")}
ASSIGNMENT = """
title = "Double pendulum"
model = "{urdf}"
samples = 10
time_limit = 3
memory_mb = 1024
feedback = "{feedback}"
[points]
M = 3
C = 4
G = 2
V = 1
"""


@pytest.fixture(scope="module")
def graded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """The class written, graded with two processes; (assignment, submissions, out)."""
    tmp = tmp_path_factory.mktemp("class")
    assignment = tmp / "assignment.toml"
    assignment.write_text(ASSIGNMENT.format(urdf=ROOT / "examples/urdf/double_pendulum.urdf", feedback="terms"))
    subs = tmp / "submissions"
    for student, (text, _) in CLASS.items():
        folder = subs / student  # Gradescope / nbgrader: one folder a student
        folder.mkdir(parents=True)
        (folder / "dynamics.py").write_text(text)
    out = tmp / "out"
    assert main(["grade", str(assignment), str(subs), "--out", str(out), "--jobs", "2"]) == 0
    return assignment, subs, out


def _result(out: Path, student: str) -> dict:
    return json.loads((out / "results" / f"{student}.json").read_text())


def test_each_student_gets_exactly_the_planted_score(graded: tuple[Path, Path, Path]) -> None:
    _, _, out = graded
    for student, (_, expected) in CLASS.items():
        r = _result(out, student)
        assert r["score"] == pytest.approx(expected, abs=EXACT), (student, r["feedback"])
        assert r["max_score"] == 10.0


def test_a_planted_slip_is_charged_to_the_entries_it_touches(graded: tuple[Path, Path, Path]) -> None:
    _, _, out = graded
    for student, entries in PLANTED.items():
        wrong = [w for q in _result(out, student)["quantities"] for w in q["wrong"]]
        assert sorted(wrong) == sorted(entries), student


def test_hostile_files_get_zero_with_one_line(graded: tuple[Path, Path, Path]) -> None:
    _, subs, out = graded
    for student, needle in HOSTILE.items():
        r = _result(out, student)
        assert r["score"] == 0.0 and r["verdict"] == "ERROR"
        assert "\n" not in r["error"] and needle in r["error"], (student, r["error"])
        assert "Traceback" not in r["feedback"]
    assert not list(subs.rglob("pwned.txt")) and not (Path.cwd() / "pwned.txt").exists()


def test_feedback_names_the_term_in_the_students_symbols(graded: tuple[Path, Path, Path]) -> None:
    _, _, out = graded
    text = (out / "feedback" / "dropped_m12.txt").read_text()
    assert "M: 2 / 3  (wrong: M[0,1])" in text
    assert "M[0,1]: formula - Pinocchio = -m2*l1*lc2*cos(q2)" in text


def test_gradebook_and_class_report_count_each_mistake(graded: tuple[Path, Path, Path]) -> None:
    _, _, out = graded
    with (out / "gradebook.csv").open() as f:
        rows = {r["student"]: r for r in csv.DictReader(f)}
    assert set(rows) == set(CLASS) and rows["c_sign"]["C"] == "1" and rows["dropped_m12"]["M"] == "2"
    summary = json.loads((out / "class.json").read_text())
    assert summary["entries"]["M[0,1]"] == 1 and summary["entries"]["C[0,1]"] == 1
    assert summary["terms"]["M[0,1]: formula - Pinocchio = m2*l1*lc2*cos(elbow)"] == 1  # the model's coordinates
    assert len(summary["errors"]) == len(HOSTILE) and summary["full_marks"] == 2
    assert (out / "scores.png").stat().st_size > 0 and "1 student: M[0,1]" in (out / "report.md").read_text()


def _validate_gradescope(d: dict) -> None:
    """Gradescope's documented results.json (gradescope-autograders.readthedocs.io/en/latest/specs/)."""
    known = {"score", "execution_time", "output", "output_format", "visibility", "stdout_visibility", "extra_data",
             "tests", "leaderboard"}  # fmt: skip
    assert set(d) <= known and isinstance(d["score"], float) and isinstance(d["execution_time"], int)
    assert d["visibility"] in ("hidden", "after_due_date", "after_published", "visible")
    assert d["output_format"] in ("text", "html", "simple_format", "md", "ansi")
    for t in d["tests"]:
        assert set(t) <= {"score", "max_score", "status", "name", "name_format", "number", "output", "output_format",
                          "tags", "visibility", "extra_data"}  # fmt: skip
        assert isinstance(t["score"], float) and isinstance(t["max_score"], float) and isinstance(t["name"], str)
        assert t["status"] in ("passed", "failed") and 0 <= t["score"] <= t["max_score"]
    assert math.isclose(sum(t["score"] for t in d["tests"]), d["score"], abs_tol=EXACT)


def test_gradescope_results_json_validates(graded: tuple[Path, Path, Path], tmp_path: Path) -> None:
    assignment, subs, _ = graded
    results = tmp_path / "results" / "results.json"
    assert main(["grade", str(assignment), str(subs / "c_sign"), "--gradescope", str(results)]) == 0
    d = json.loads(results.read_text())
    _validate_gradescope(d)
    assert d["score"] == pytest.approx(7.0, abs=EXACT)
    assert [t["name"] for t in d["tests"]] == ["M", "C", "G", "V"]


def test_notebook_helper_gives_the_clis_score(graded: tuple[Path, Path, Path], tmp_path: Path) -> None:
    assignment, subs, out = graded
    path = subs / "dropped_m12" / "dynamics.py"
    score, top, feedback = notebook_check(assignment, path, student="dropped_m12")
    assert (score, top, feedback) == (9.0, 10.0, _result(out, "dropped_m12")["feedback"])
    spec = importlib.util.spec_from_file_location("dropped_m12_nb", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert notebook_check(assignment, vars(module))[0] == 9.0  # a notebook's globals(): functions by their source


def test_rerun_resumes_and_regrades_only_what_changed(
    graded: tuple[Path, Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    assignment, subs, out = graded
    (subs / "dropped_m12" / "dynamics.py").write_text(DOUBLE)  # the student fixed it
    try:
        capsys.readouterr()
        assert main(["grade", str(assignment), str(subs), "--out", str(out)]) == 0
        lines = capsys.readouterr().out.splitlines()
        resumed = [line.split(":")[0] for line in lines if "(graded before: resumed)" in line]
        assert sorted(resumed) == sorted(set(CLASS) - {"dropped_m12"})  # hostile ones too: their 0 is final
        assert "dropped_m12: 10 / 10" in lines
    finally:
        (subs / "dropped_m12" / "dynamics.py").write_text(CLASS["dropped_m12"][0])


def test_teacher_coordinates_are_imposed(tmp_path: Path) -> None:
    toml = ASSIGNMENT.format(urdf=ROOT / "examples/urdf/double_pendulum.urdf", feedback="entries")
    toml += (
        '[coordinates]\njoints = ["shoulder", "elbow"]\nmap = [[1, 0], [0, -1]]\noffsets = [1.5707963267948966, 0]\n'
    )
    (tmp_path / "a.toml").write_text(toml)
    (tmp_path / "mine.py").write_text(_replaced(DOUBLE, COORDS, 'COORDINATES = {"shoulder": (1.0, 0.0)}'))
    score, top, feedback = notebook_check(tmp_path / "a.toml", tmp_path / "mine.py")
    assert (score, top) == (10.0, 10.0), feedback


def test_christoffel_not_required_grades_c_v(tmp_path: Path) -> None:
    (tmp_path / "a.toml").write_text(
        'model = "pendubot"\nsamples = 10\nchristoffel = false\n[points]\nM = 2\nC = 2\nG = 2\n'
    )
    for name, expected in (("pendubot_mine.py", 6.0), ("pendubot_cv.py", 6.0), ("pendubot_grouped_c.py", 6.0)):
        assert notebook_check(tmp_path / "a.toml", ROOT / "examples/formulas" / name)[0] == expected, name
    slip = tmp_path / "slip.py"  # G[1]'s term dropped: G[1] loses 1 of G's 2; C v is not charged for it
    slip.write_text(_replaced(PENDUBOT, "t5 * np.cos(q[0] + q[1])])", "0.0])"))
    score, _, feedback = notebook_check(tmp_path / "a.toml", slip)
    assert score == 5.0, feedback


def test_mutants_are_single_changes() -> None:
    found = mutants(DOUBLE, limit=1000)
    kinds = {m.description.split(": ")[1].split(" ")[0] for m in found}
    assert {"'+'", "'-'", "dropped", "cos", "sin"} <= kinds
    assert all(m.source != DOUBLE for m in found) and len({m.source for m in found}) == len(found)


def test_check_solution_catches_its_mutants(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assignment = ROOT / "examples/grading/double_pendulum/assignment.toml"
    solution = ROOT / "examples/grading/double_pendulum/solution.py"
    assert main(["grade", str(assignment), "--check-solution", str(solution), "--mutants", "4", "--jobs", "2"]) == 0
    assert "4 of 4 mutants lose points" in capsys.readouterr().out
    wrong = tmp_path / "wrong.py"
    wrong.write_text(_replaced(DOUBLE, M12, "m12 = m2 * lc2**2 + I2"))
    assert main(["grade", str(assignment), "--check-solution", str(wrong), "--mutants", "1"]) == 1


def test_bad_assignment_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "a.toml").write_text('model = "pendubot"\n[points]\nQ = 1\n')
    assert main(["grade", str(tmp_path / "a.toml"), str(tmp_path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "[points] names 'Q'" in err
    assert load_assignment(ROOT / "examples/grading/double_pendulum/assignment.toml").max_score == 10.0


def test_the_program_refuses_a_missing_submissions_folder_in_one_line(tmp_path: Path) -> None:
    import subprocess
    import sys

    assignment = ROOT / "examples/grading/double_pendulum/assignment.toml"
    run = subprocess.run(
        [sys.executable, "-m", "robodyn", "grade", str(assignment), str(tmp_path / "none"), "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert run.returncode == 2 and run.stderr.count("\n") == 1 and "SUBMISSIONS must be a folder" in run.stderr
