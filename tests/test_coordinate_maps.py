"""COORDINATES as a linear map q_formula = A q_urdf + b (robodyn.model.coordinate_map) in check and derive.

The documented example is a 3-link arm in a vertical plane derived by hand in absolute angles
(examples/formulas/three_link_absolute.py, non-round parameters): theta = A q_urdf with
A = [[1, 0, 0], [1, 1, 0], [1, 1, 1]]. It passes as written; a wrong term fails; Pinocchio's M, C,
G, RNEA and ABA map exactly as A^-T M A^-1 (etc.) against a direct transform; derive honours the
matrix and agrees with check; named constants read alike in both.
"""

import math
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.checker.compare import check
from robodyn.checker.reference import Reference
from robodyn.cli import main
from robodyn.errors import FormulaError, InputError
from robodyn.lagrange.coordinates import read_coordinates
from robodyn.model.coordinate_map import coordinate_map

ROOT = Path(__file__).resolve().parents[1]
ARM = ROOT / "examples" / "urdf" / "three_link_arm.urdf"
ABSOLUTE = ROOT / "examples" / "formulas" / "three_link_absolute.py"
PENDULUM = ROOT / "examples" / "urdf" / "double_pendulum.urdf"
PENDULUM_FORMULA = ROOT / "examples" / "formulas" / "double_pendulum.py"
SAMPLES = 20  # states per check: a wrong term shows at any one of them
# A^-T M A^-1 computed two ways (a solve against an explicit inverse): both round-off, a few eps of |M| cond(A)
MAP_RTOL = 1e-12


def _planted(tmp_path: Path, source: Path, old: str, new: str, name: str = "planted.py") -> str:
    text = source.read_text()
    assert old in text, old
    out = tmp_path / name
    out.write_text(text.replace(old, new))
    return str(out)


def test_three_link_arm_in_absolute_angles_passes_as_written():
    report = check(robodyn.load(ARM), str(ABSOLUTE), samples=SAMPLES)
    assert report.passed, [r.quantity for r in report.failures]
    assert report.row("M").max_rel_error < 1e-13  # round-off only: the map is exact
    assert report.notes[0] == (
        "coordinates: q1 = joint1, q2 = joint1 + joint2, q3 = joint1 + joint2 + joint3 "
        "(the q, v of a mismatch are the formula's)"
    )
    assert report.hints == ()


def test_a_wrong_term_in_absolute_angles_fails(tmp_path):
    wrong = _planted(tmp_path, ABSOLUTE, "a13 * np.cos(t1 - t3)", "a13 * np.cos(t1 - t2)")
    report = check(robodyn.load(ARM), wrong, samples=SAMPLES)
    assert not report.passed
    assert report.row("M").status == "FAIL" and report.row("M").entry in ((0, 2), (2, 0))


def test_the_same_arm_in_relative_angles_fails_against_the_absolute_formula(tmp_path):
    relative = _planted(tmp_path, ABSOLUTE, "COORDINATES = [[1, 0, 0], [1, 1, 0], [1, 1, 1]]", "")
    assert not check(robodyn.load(ARM), relative, samples=SAMPLES).passed


def test_mapped_pinocchio_is_the_direct_transform():
    """M_f = A^-T M A^-1, C_f = A^-T C A^-1, G_f = A^-T G, tau_f = A^-T tau, a_f = A a, against robot.M etc."""
    robot = robodyn.load(ARM)
    rng = np.random.default_rng(7)
    A = np.array([[1.0, 0.4, 0.0], [-0.3, 1.2, 0.5], [0.7, 0.1, 0.9]])  # not symmetric: A^-1 M A^-T differs
    b = np.array([0.2, -1.1, 0.6])
    ref = Reference.mapped(robot, ["joint1", "joint2", "joint3"], A, b)
    A_inv = np.linalg.inv(A)
    for _ in range(5):
        q, v = robot.random_state(rng)
        a, tau = rng.uniform(-2, 2, 3), rng.uniform(-1, 1, 3)
        qf, vf, af = A @ q + b, A @ v, A @ a
        np.testing.assert_allclose(ref.formula_q(q), qf, rtol=MAP_RTOL, atol=1e-15)
        np.testing.assert_allclose(ref.formula_v(v), vf, rtol=MAP_RTOL)
        np.testing.assert_allclose(ref.urdf_q(qf), q, rtol=MAP_RTOL, atol=1e-14)
        np.testing.assert_allclose(ref.mass_matrix(qf), A_inv.T @ robot.M(q) @ A_inv, rtol=MAP_RTOL)
        np.testing.assert_allclose(ref.coriolis_matrix(qf, vf), A_inv.T @ robot.C(q, v) @ A_inv, rtol=MAP_RTOL)
        np.testing.assert_allclose(ref.gravity(qf), A_inv.T @ robot.G(q), rtol=MAP_RTOL)
        np.testing.assert_allclose(ref.formula_tau(tau), A_inv.T @ tau, rtol=MAP_RTOL)
        tau_urdf = robot.M(q) @ a + robot.C(q, v) @ v + robot.G(q)
        np.testing.assert_allclose(ref.rnea(qf, vf, af), A_inv.T @ tau_urdf, rtol=MAP_RTOL, atol=1e-13)
        # a formula torque tau_f does the work of A^T tau_f: the accelerations it gives map as a_f = A a
        a_urdf = np.linalg.solve(robot.M(q), A.T @ tau - robot.C(q, v) @ v - robot.G(q))
        np.testing.assert_allclose(ref.aba(qf, vf, tau), A @ a_urdf, rtol=1e-10)


@pytest.mark.parametrize(
    ("coordinates", "line"),
    [
        ('{"shoulder": (-1, 0.3), "elbow": (1, -0.5)}', "q1 = -shoulder + 0.3 rad, q2 = elbow - 0.5 rad"),
        ("[[1, 0], [1, -1]]\nOFFSETS = [-0.25, 1.5]", "q1 = shoulder - 0.25 rad, q2 = shoulder - elbow + 1.5 rad"),
    ],
)
def test_the_coordinates_note_states_the_map_with_the_offsets_signs(tmp_path, coordinates, line):
    old = 'COORDINATES = {"shoulder": (1.0, math.pi / 2), "elbow": (-1.0, 0.0)}'
    f = _planted(tmp_path, PENDULUM_FORMULA, old, f"COORDINATES = {coordinates}")
    report = check(robodyn.load(PENDULUM), f, samples=2)
    said = line.replace("q1 =", "theta1 =").replace("q2 =", "theta2 =")  # the file's NAMES
    assert report.notes[0] == f"coordinates: {said} (the q, v of a mismatch are the formula's)"


@pytest.mark.parametrize(
    ("coordinates", "says"),
    [
        ("[[1, 0], [2, 0]]", "COORDINATES = [[1, 0], [2, 0]] is singular"),
        ('[[1, 0], [0, float("nan")]]', "expected 2 finite numbers"),
        ("[[1, 0, 0], [0, 1, 0]]", "expected {joint: (sign, offset)} or a 2x2 matrix over JOINTS"),
        ("[[1, 0], [0, 1]]\nOFFSETS = [0.1]", "OFFSETS = [0.1]; expected a list of 2 finite numbers"),
        ('{"elbow": (-1, 0)}\nOFFSETS = [0, 0]', "OFFSETS goes with a COORDINATES matrix"),
    ],
)
def test_bad_maps_are_refused_in_one_line(tmp_path, coordinates, says):
    old = 'COORDINATES = {"shoulder": (1.0, math.pi / 2), "elbow": (-1.0, 0.0)}'
    f = _planted(tmp_path, PENDULUM_FORMULA, old, f"COORDINATES = {coordinates}")
    with pytest.raises(FormulaError, match="COORDINATES|OFFSETS") as caught:
        check(robodyn.load(PENDULUM), f, samples=2)
    assert says in str(caught.value) and "\n" not in str(caught.value)


def test_a_row_mixing_a_slide_and_a_hinge_is_refused(tmp_path, capsys):
    f = tmp_path / "mixed.py"
    f.write_text(
        (ROOT / "examples/formulas/arm_rpr.py").read_text()
        + '\nJOINTS = ["shoulder", "slide", "wrist"]\nCOORDINATES = [[1, 0, 0], [0, 1, 1], [0, 0, 1]]\n'
    )
    urdf = str(ROOT / "examples/urdf/arm_rpr.urdf")
    with pytest.raises(FormulaError, match="row 2 of COORDINATES adds the slide slide .m. to the hinge wrist"):
        check(robodyn.load(urdf), str(f), samples=2)
    assert main(["derive", urdf, "--coordinates", str(f)]) == 2
    assert "row 2 of COORDINATES adds the slide" in capsys.readouterr().err


def test_derive_with_the_matrix_agrees_with_check(tmp_path, capsys):
    assert main(["derive", str(ARM), "--coordinates", str(ABSOLUTE), "--samples", "5"]) == 0
    out = capsys.readouterr().out
    assert "coordinates: q1 = joint1 [rad], q2 = joint1 + joint2 [rad], q3 = joint1 + joint2 + joint3 [rad]" in out
    assert "M[0,2] = M[2,0] = l1*lc3*m3*cos(q1 - q3)" in out  # the absolute-angle coupling, as by hand
    derived = tmp_path / "derived.py"
    assert main(["derive", str(ARM), "--coordinates", str(ABSOLUTE), "--format", "python", "--out", str(derived)]) == 0
    assert "COORDINATES = [[1, 0, 0], [1, 1, 0], [1, 1, 1]]" in derived.read_text()
    report = check(robodyn.load(ARM), str(derived), samples=SAMPLES)
    assert report.passed and report.notes == check(robodyn.load(ARM), str(ABSOLUTE), samples=2).notes


def test_derive_refuses_a_matrix_whose_inverse_halves_an_angle(tmp_path, capsys):
    f = tmp_path / "half.py"
    f.write_text('JOINTS = ["shoulder", "elbow"]\nCOORDINATES = [[2, 0], [0, 1]]\n')
    assert main(["derive", str(PENDULUM), "--coordinates", str(f)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "needs whole numbers" in err and "robodyn check takes any" in err


NAMED = """import math
import numpy as np
KIND = "any"
UP = math.pi
QUARTER = math.radians(90)
JOINTS = ["shoulder", "elbow"]
COORDINATES = {"shoulder": (1.0, UP / 2), "elbow": (-1, UP - UP)}
"""
NAMED_MATRIX = """import math
import numpy as np
KIND = "any"
UP = math.pi
JOINTS = ["shoulder", "elbow"]
COORDINATES = [[1, 0], [0, -1]]
OFFSETS = [np.deg2rad(90), -UP + UP]
"""


@pytest.mark.parametrize("block", [NAMED, NAMED_MATRIX], ids=["pairs", "matrix"])
def test_named_constants_read_alike_in_check_and_derive(tmp_path, capsys, block):
    text = PENDULUM_FORMULA.read_text()
    start = text.index("import math")
    end = text.index("\n", text.index("COORDINATES = "))
    f = tmp_path / "named.py"
    f.write_text(text[:start] + block + text[end:])
    assert check(robodyn.load(PENDULUM), str(f), samples=SAMPLES).passed
    joints, cmap, _ = read_coordinates(f)
    assert joints == ["shoulder", "elbow"]
    np.testing.assert_array_equal(cmap.A, [[1, 0], [0, -1]])
    assert cmap.b.tolist() == [math.pi / 2, 0.0]
    assert main(["derive", str(PENDULUM), "--coordinates", str(f), "--samples", "5"]) == 0
    assert "coordinates: q1 = shoulder + pi / 2 [rad], q2 = -elbow [rad]" in capsys.readouterr().out


def test_derive_prints_each_offset_with_its_sign(tmp_path, capsys):
    """Issue 39: the printed coordinates line gave the offsets the opposite sign and no test saw it."""
    f = tmp_path / "c.py"
    f.write_text(
        'import math\nJOINTS = ["joint1", "joint2"]\nCOORDINATES = {"joint1": (-1, 0.3), "joint2": (1, -math.pi / 2)}\n'
    )
    assert main(["derive", "pendubot", "--coordinates", str(f), "--samples", "3"]) == 0
    assert "coordinates: q1 = -joint1 + 0.3 [rad], q2 = joint2 - pi / 2 [rad]; v = dq/dt" in capsys.readouterr().out


def test_constants_that_are_not_constants_are_refused(tmp_path):
    f = tmp_path / "c.py"
    f.write_text('import os\nX = os.getpid()\nJOINTS = ["a"]\nCOORDINATES = {"a": (1, X)}\n')
    with pytest.raises(InputError, match="line 4: COORDINATES must be written with constants"):
        read_coordinates(f)
    f.write_text('JOINTS = ["a"]\nCOORDINATES = {"a": (1, 10 ** 10 ** 10)}\n')
    with pytest.raises(InputError, match="must be written with constants"):
        read_coordinates(f)


def test_the_sign_form_is_the_diagonal_map():
    cmap = coordinate_map({"b": (-1, 0.5)}, None, ["a", "b"], "f.py")
    np.testing.assert_array_equal(cmap.A, np.diag([1.0, -1.0]))
    assert cmap.b.tolist() == [0.0, 0.5] and cmap.diagonal


def test_derive_takes_a_fractional_matrix_whose_inverse_is_whole(tmp_path):
    """q1 = shoulder, q2 = (shoulder + elbow) / 3: the joints are q1 and 3 q2 - q1, whole combinations."""
    f = tmp_path / "third.py"
    f.write_text('JOINTS = ["shoulder", "elbow"]\nCOORDINATES = [[1, 0], [1 / 3, 1 / 3]]\nOFFSETS = [0.25, 0]\n')
    out = tmp_path / "derived.py"
    assert main(["derive", str(PENDULUM), "--coordinates", str(f), "--format", "python", "--out", str(out)]) == 0
    text = out.read_text()
    assert (
        "COORDINATES = [[1, 0], [0.3333333333333333, 0.3333333333333333]]" in text and "OFFSETS = [0.25, 0.0]" in text
    )
    assert check(robodyn.load(PENDULUM), str(out), samples=SAMPLES).passed
