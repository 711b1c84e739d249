"""Convention hints (robodyn.checker.hints): a failing formula that is right under another convention says so first.

Each slip is planted in a correct hand derivation (the hanging double pendulum in the
{joint: (sign, offset)} form, the 3-link arm in absolute angles in the matrix form, the built-in
Pendubot) and must get exactly its hint, naming the COORDINATES entry that makes it agree; a correct
file, and a wrong term that is no convention, get none.
"""

from pathlib import Path

import pytest

import robodyn
from robodyn.checker.compare import check
from robodyn.cli import main

ROOT = Path(__file__).resolve().parents[1]
PENDULUM = ROOT / "examples" / "urdf" / "double_pendulum.urdf"
PENDULUM_FORMULA = ROOT / "examples" / "formulas" / "double_pendulum.py"
ARM = ROOT / "examples" / "urdf" / "three_link_arm.urdf"
ABSOLUTE = ROOT / "examples" / "formulas" / "three_link_absolute.py"
SAMPLES = 12  # the hints compare the first 8 states (HINT_SAMPLES); a few more for the rows
PAIRS = 'COORDINATES = {"shoulder": (1.0, math.pi / 2), "elbow": (-1.0, 0.0)}'
MATRIX = "COORDINATES = [[1, 0, 0], [1, 1, 0], [1, 1, 1]]"

GRAVITY = (
    "hint: the mismatch vanishes with gravity's sign reversed: your G (and V) has the opposite sign; "
    "V = m g h grows with the height h against gravity, and G = +dV/dq"
)
TRANSPOSED = (
    "hint: the mismatch vanishes with C transposed: your C[i,j] is the Christoffel C[j,i] "
    "(C[i,j] = sum_k Gamma_ijk v_k, Gamma_ijk = 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i))"
)
HALF_TURN = "(the URDF's zero may hang down where yours stands up)"


def _hints(tmp_path: Path, urdf: Path, source: Path, *edits: tuple[str, str]) -> tuple[str, ...]:
    text = source.read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    f = tmp_path / "slip.py"
    f.write_text(text)
    report = check(robodyn.load(urdf), str(f), samples=SAMPLES)
    assert report.passed == (not edits)
    return report.hints


def test_a_correct_file_gets_no_hint(tmp_path):
    assert _hints(tmp_path, PENDULUM, PENDULUM_FORMULA) == ()
    assert _hints(tmp_path, ARM, ABSOLUTE) == ()


SLIPS = {  # the double pendulum's file says NAMES = ["theta1", "theta2"]: the hints say them too
    "missing offset": (
        [(PAIRS, 'COORDINATES = {"elbow": (-1.0, 0.0)}')],
        [
            'hint: the mismatch vanishes with COORDINATES["shoulder"] = (1, math.pi / 2): theta1 is measured from a zero '
            "a quarter turn from the one COORDINATES gives"
        ],
    ),
    "offset half a turn off": (  # a planar pendulum half a turn round is the same under reversed gravity
        [(PAIRS, PAIRS.replace("math.pi / 2", "-math.pi / 2"))],
        [
            'hint: the mismatch vanishes with COORDINATES["shoulder"] = (1, math.pi / 2): theta1 is measured from a zero '
            f"half a turn from the one COORDINATES gives {HALF_TURN}",
            GRAVITY,
        ],
    ),
    "missing sign flip": (
        [(PAIRS, PAIRS.replace("(-1.0, 0.0)", "(1.0, 0.0)"))],
        [
            'hint: the mismatch vanishes with COORDINATES["elbow"] = (-1, 0): theta2 turns the other way round '
            "(against the URDF axis of elbow)"
        ],
    ),
    "swapped joints": (
        [('JOINTS = ["shoulder", "elbow"]', 'JOINTS = ["elbow", "shoulder"]')],
        [
            'hint: the mismatch vanishes with JOINTS = ["shoulder", "elbow"]: your theta1 and theta2 are the other way round'
        ],
    ),
    "transposed C": (
        [("[[h * v[1], h * (v[0] + v[1])], [-h * v[0], 0.0]]", "[[h * v[1], -h * v[0]], [h * (v[0] + v[1]), 0.0]]")],
        [TRANSPOSED],
    ),
}


@pytest.mark.parametrize("slip", sorted(SLIPS))
def test_each_convention_slip_gets_exactly_its_hint(tmp_path, slip):
    edits, expected = SLIPS[slip]
    assert list(_hints(tmp_path, PENDULUM, PENDULUM_FORMULA, *edits)) == expected


def test_gravity_sign_gets_its_hint_and_its_twin(tmp_path):
    """A planar pendulum turned half a turn is the same pendulum under reversed gravity: both fixes are true."""
    edits = [
        ("g2 = m2 * g * lc2", "g2 = -m2 * g * lc2"),
        ("[(m1 * lc1 + m2 * l1) * g * np.sin(q[0]) + g2", "[-(m1 * lc1 + m2 * l1) * g * np.sin(q[0]) + g2"),
        ("return -m1 * g * lc1 * np.cos(q[0]) - m2 * g", "return m1 * g * lc1 * np.cos(q[0]) + m2 * g"),
    ]
    hints = _hints(tmp_path, PENDULUM, PENDULUM_FORMULA, *edits)
    assert GRAVITY in hints
    assert hints == (
        'hint: the mismatch vanishes with COORDINATES["shoulder"] = (1, -math.pi / 2): theta1 is measured from a zero '
        f"half a turn from the one COORDINATES gives {HALF_TURN}",
        GRAVITY,
    )


MATRIX_SLIPS = {
    "sign of one row": (
        MATRIX.replace("[1, 1, 1]]", "[-1, -1, -1]]"),
        "hint: the mismatch vanishes with COORDINATES[2] = [1, 1, 1]: q3 turns the other way round",
    ),
    "rows swapped": (
        "COORDINATES = [[1, 0, 0], [1, 1, 1], [1, 1, 0]]",
        "hint: the mismatch vanishes with COORDINATES[1] and COORDINATES[2] swapped (and OFFSETS[1] and OFFSETS[2]): "
        "your q2 and q3 are the other way round",
    ),
    "offset half a turn off": (
        MATRIX + "\nOFFSETS = [0, 0, math.pi]",
        "hint: the mismatch vanishes with OFFSETS = [0, 0, 0]: q3 is measured from a zero half a turn from the one "
        f"OFFSETS gives {HALF_TURN}",
    ),
}


@pytest.mark.parametrize("slip", sorted(MATRIX_SLIPS))
def test_matrix_slips_name_the_row_or_offsets(tmp_path, slip):
    coordinates, expected = MATRIX_SLIPS[slip]
    hints = _hints(
        tmp_path, ARM, ABSOLUTE, (MATRIX, coordinates), ("import numpy as np", "import math\nimport numpy as np")
    )
    assert hints == (expected,)


@pytest.mark.parametrize(
    ("old", "new"),
    [
        ("a13 * np.cos(t1 - t3)", "a13 * np.cos(t1 - t2)"),  # a wrong index
        ('d3 = p["I3"] + m3 * lc3**2', 'd3 = p["I3"] + m3 * p["l2"] ** 2'),  # l for lc
        ("b1 * np.cos(q[0]), b2", "b1 * np.sin(q[0]), b2"),  # sin for cos in one entry
    ],
    ids=["index", "l for lc", "sin for cos"],
)
def test_a_wrong_term_that_is_no_convention_gets_no_hint(tmp_path, old, new):
    assert _hints(tmp_path, ARM, ABSOLUTE, (old, new)) == ()


def test_a_built_in_kind_gets_the_equation_and_the_any_file_entry(tmp_path):
    """A Pendubot file whose q1 is measured from the vertical (cos -> sin): the built-in kind takes the URDF's angles."""
    text = (ROOT / "examples/formulas/pendubot_mine.py").read_text()
    text = text.replace("np.cos(q[0] + q[1])", "COS12").replace("np.cos(q[0])", "COS1")
    text = text.replace("np.sin(q[0] + q[1])", "(-np.cos(q[0] + q[1]))").replace("np.sin(q[0])", "(-np.cos(q[0]))")
    f = tmp_path / "vertical.py"
    f.write_text(text.replace("COS12", "np.sin(q[0] + q[1])").replace("COS1", "np.sin(q[0])"))
    report = check(robodyn.load("pendubot"), str(f), samples=SAMPLES)
    assert report.hints == (
        "hint: the mismatch vanishes with q1 = joint1 + pi / 2 rad: q1 is measured from a zero a quarter turn from "
        "the URDF's; the pendubot kind takes every angle as the URDF measures it, so write the formula in those or as "
        'KIND = "any" with COORDINATES = {"joint1": (1, math.pi / 2)}',
    )


def test_the_hint_prints_under_the_verdict_and_before_the_terms_and_in_json(tmp_path, capsys):
    text = PENDULUM_FORMULA.read_text().replace(PAIRS, 'COORDINATES = {"elbow": (-1.0, 0.0)}')
    f = tmp_path / "slip.py"
    f.write_text(text)
    args = ["check", str(PENDULUM), "--formula", str(f), "--samples", str(SAMPLES)]
    assert main(args) == 1
    lines = capsys.readouterr().out.splitlines()
    assert lines[-2].startswith("FAIL: ") and lines[-1].startswith(
        'hint: the mismatch vanishes with COORDINATES["shoulder"]'
    )
    assert main([*args, "--explain"]) == 1
    lines = capsys.readouterr().out.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("hint: "))
    assert lines[first - 1] == "" and lines[first + 1].startswith("explain: ")  # the terms follow it
    assert sum(line.startswith("hint: ") for line in lines) == 1
    assert main([*args, "--json"]) == 1
    import json

    assert json.loads(capsys.readouterr().out)["hints"] == [lines[first]]


@pytest.mark.parametrize(
    ("edit", "hint"),
    [
        (("return np.array([(m1", "return -np.array([(m1"), "hint: the mismatch vanishes with G's sign reversed"),
        (("return -m1 * g * lc1", "return -(-m1 * g * lc1"), "hint: the mismatch vanishes with V's sign reversed"),
    ],
    ids=["G alone", "V alone"],
)
def test_the_sign_of_G_alone_or_of_V_alone_gets_its_hint(tmp_path, edit, hint):
    """G written with the wrong sign but V right: G = dV/dq fails too, and the hint says which of the two is off."""
    old, new = edit
    edits = [(old, new)] if "V's" not in hint else [(old, new), ("np.cos(q[0] + q[1]))\n", "np.cos(q[0] + q[1])))\n")]
    hints = _hints(tmp_path, PENDULUM, PENDULUM_FORMULA, *edits)
    assert len(hints) == 1 and hints[0].startswith(hint), hints
