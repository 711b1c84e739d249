"""robodyn grade's class report: one slip written in two coordinate conventions is one mistake; christoffel = false.

The double pendulum's solution (a frozen copy of the example) with two slips (G[0]'s m2*l1*g*sin(theta1) and
M[0,1]'s m2*l1*lc2*cos(theta2) dropped), written twice: in the textbook's angles (theta1 = q_shoulder + pi/2,
theta2 = -q_elbow), and in the URDF's own (the same functions, mapped). The students' own feedback names each slip
in their own coordinates (sin(q1) and cos(q1); -... and +... for the elbow's flipped sign); the class report names
it in the model's (cos(shoulder)) and counts it once.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from robodyn.grade import load_assignment
from robodyn.grade.grading import grade_file
from robodyn.grade.report import summarize

ROOT = Path(__file__).resolve().parents[1]
DOUBLE = (ROOT / "examples/grading/double_pendulum/solution.py").read_text()
PENDUBOT = (ROOT / "examples/formulas").joinpath
EXACT = 1e-9  # scores are sums of shares points / entries, rounded to 6 decimals: equal to far better than this
G0 = "(m1 * lc1 + m2 * l1) * g * np.sin(q[0])"
M12 = "m12 = m2 * (lc2**2 + l1 * lc2 * c2) + I2"
TEXTBOOK = 'COORDINATES = {"shoulder": (1.0, math.pi / 2), "elbow": (-1.0, 0.0)}  # q_formula = sign * q_urdf + offset'
FUNCTIONS = ("mass_matrix", "coriolis_matrix", "gravity", "potential_energy")
URDF = """
COORDINATES = {"shoulder": (1.0, 0.0), "elbow": (1.0, 0.0)}  # the URDF's own angles
D = np.diag([1.0, -1.0])  # the textbook's angles are D q + SHIFT
SHIFT = np.array([math.pi / 2, 0.0])


def mass_matrix(q, p):
    return D @ textbook_mass_matrix(D @ q + SHIFT, p) @ D


def coriolis_matrix(q, v, p):
    return D @ textbook_coriolis_matrix(D @ q + SHIFT, D @ v, p) @ D


def gravity(q, p):
    return D @ textbook_gravity(D @ q + SHIFT, p)


def potential_energy(q, p):
    return textbook_potential_energy(D @ q + SHIFT, p)
"""


def _replaced(text: str, old: str, new: str) -> str:
    if old not in text:
        raise ValueError(f"the planted change needs {old!r} in the file")  # the example changed: the test must too
    return text.replace(old, new)


def _in_urdf_angles(text: str) -> str:
    """The same answer in the URDF's angles: each function renamed textbook_..., mapped by D and SHIFT."""
    for name in FUNCTIONS:
        text = _replaced(text, f"def {name}(", f"def textbook_{name}(")
    return _replaced(text, TEXTBOOK, "") + URDF


@pytest.fixture(scope="module")
def assignment(tmp_path_factory: pytest.TempPathFactory) -> object:
    folder = tmp_path_factory.mktemp("conventions")
    (folder / "a.toml").write_text(
        f'model = "{ROOT / "examples/urdf/double_pendulum.urdf"}"\nsamples = 10\n[points]\nM = 3\nC = 4\nG = 2\n'
    )
    return load_assignment(folder / "a.toml")


def test_one_slip_in_two_conventions_is_one_mistake(assignment: object, tmp_path: Path) -> None:
    slip = _replaced(_replaced(DOUBLE, G0, "m1 * lc1 * g * np.sin(q[0])"), M12, "m12 = m2 * lc2**2 + I2")
    (tmp_path / "textbook.py").write_text(slip)
    (tmp_path / "urdf_angles.py").write_text(_in_urdf_angles(slip))
    (tmp_path / "right_urdf_angles.py").write_text(_in_urdf_angles(DOUBLE))
    results = [grade_file(assignment, tmp_path / f"{n}.py") for n in ("textbook", "urdf_angles", "right_urdf_angles")]
    assert [r.score for r in results] == pytest.approx([7.0, 7.0, 9.0], abs=EXACT), [r.feedback for r in results]
    textbook, urdf_angles, _ = results
    assert set(textbook.terms) == {  # each in its own coordinates
        "G[0]: formula - Pinocchio = -m2*l1*g*sin(q1)",
        "M[0,1]: formula - Pinocchio = -m2*l1*lc2*cos(q2)",
    }
    assert set(urdf_angles.terms) == {
        "G[0]: formula - Pinocchio = -m2*l1*g*cos(q1)",
        "M[0,1]: formula - Pinocchio = m2*l1*lc2*cos(q2)",
    }
    in_the_model = {
        "G[0]: formula - Pinocchio = -m2*l1*g*cos(shoulder)",
        "M[0,1]: formula - Pinocchio = m2*l1*lc2*cos(elbow)",
    }
    assert set(textbook.model_terms) == set(urdf_angles.model_terms) == in_the_model
    summary = summarize(results, assignment)
    assert dict(summary.terms) == dict.fromkeys(in_the_model, 2)
    assert dict(summary.entries) == {"G[0]": 2, "M[0,1]": 2}


def test_christoffel_false_gives_a_right_c_v_the_c_points(tmp_path: Path) -> None:
    # examples/formulas/pendubot_grouped_c.py: C v right, C[0,0] and C[0,1] not Christoffel's: with the
    # Christoffel form required, 2 of C's 4 entries lose their half point each.
    for christoffel, expected, wrong in ((False, 6.0, ()), (True, 5.0, ("C[0,0]", "C[0,1]"))):
        toml = tmp_path / f"{christoffel}.toml"
        toml.write_text(f'model = "pendubot"\nsamples = 10\nchristoffel = {str(christoffel).lower()}\n'
                        "[points]\nM = 2\nC = 2\nG = 2\n")  # fmt: skip
        result = grade_file(load_assignment(toml), PENDUBOT("pendubot_grouped_c.py"))
        assert result.score == pytest.approx(expected, abs=EXACT), (christoffel, result.feedback)
        (c,) = [q for q in result.quantities if q.name in ("C", "Cv")]
        assert (c.name, c.wrong) == ("Cv" if not christoffel else "C", wrong)
