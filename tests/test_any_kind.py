"""KIND = "any" formula files (robodyn.kinds.any_file, any_check, reference) and ``check --explain`` (kinds.explain).

Four systems that are none of robodyn's built-in kinds, each with a URDF and a formula derived by hand
in its own coordinates (examples/urdf, examples/formulas): a hanging double pendulum (angles from the
vertical, an offset and a sign flip), a revolute-prismatic-revolute arm, a cart with a double
pendulum (joints reordered, the rail's sign flipped) and a spatial 3-DoF arm. Each derivation passes;
each single-term mistake planted in it fails, and --explain names the term and its coefficient.
"""

from pathlib import Path

import pytest

import robodyn
from robodyn.kinds.check import check

ROOT = Path(__file__).resolve().parents[1]
SYSTEMS = {
    "double_pendulum": "double_pendulum",
    "arm_rpr": "arm_rpr",
    "cart_double_pendulum": "cart_double_pendulum",
    "spatial_arm": "spatial_arm",
}
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
    # the hanging double pendulum
    ("double_pendulum", "dropped term", "m12 = m2 * (lc2**2 + l1 * lc2 * c2) + I2", "m12 = m2 * lc2**2 + I2",
     ["M[0,1]: formula - Pinocchio = -m2*l1*lc2*cos(q2)   (coefficient -0.109, = -m2*l1*lc2 to"]),
    ("double_pendulum", "factor 2", "m22 = m2 * lc2**2 + I2", "m22 = 2 * m2 * lc2**2 + I2",
     ["M[1,1]: formula - Pinocchio = m2*lc2**2   (coefficient 0.0673, = m2*lc2**2 to"]),
    ("double_pendulum", "wrong sign", "[-h * v[0], 0.0]", "[h * v[0], 0.0]",
     ["C[1,0]: formula - Pinocchio = -2*m2*l1*lc2*sin(q2)*v1   (coefficient -0.217, = -2*m2*l1*lc2 to"]),
    ("double_pendulum", "sine for cosine", "(m1 * lc1 + m2 * l1) * g * np.sin(q[0])",
     "(m1 * lc1 + m2 * l1) * g * np.cos(q[0])",
     ["G[0]: formula - Pinocchio = (m1*lc1*g + m2*l1*g)*cos(q1) - (m1*lc1*g + m2*l1*g)*sin(q1)",
      "    the formula has (m1*lc1*g + m2*l1*g)*cos(q1) where Pinocchio has (m1*lc1*g + m2*l1*g)*sin(q1): "
      "a sine and a cosine swapped"]),
    ("double_pendulum", "lc for l", "m2 * (l1**2 + lc2**2", "m2 * (lc1**2 + lc2**2",
     ["M[0,0]: formula - Pinocchio = m2*lc1**2 - m2*l1**2   (coefficient -0.141, = m2*lc1**2 - m2*l1**2 to"]),
    # the revolute-prismatic-revolute arm
    ("arm_rpr", "dropped term", "[A * dd - B * w3, A * w1", "[A * dd, A * w1",
     ["C[0,0]: formula - Pinocchio = m3*lc3*q2*sin(q3)*v3 + m3*l2*lc3*sin(q3)*v3"]),
    ("arm_rpr", "factor 2", 'g * (p["m2"] + m3) * np.sin(t1)', '2 * g * (p["m2"] + m3) * np.sin(t1)',
     ["G[1]: formula - Pinocchio = (m2*g + m3*g)*sin(q1)   (coefficient 12.3, = m2*g + m3*g to"]),
    ("arm_rpr", "wrong sign", "m12 = -m3 * lc3 * np.sin(t3)", "m12 = m3 * lc3 * np.sin(t3)",
     ["M[0,1]: formula - Pinocchio = 2*m3*lc3*sin(q3)   (coefficient 0.126, = 2*m3*lc3 to",
      "M[1,2]: formula - Pinocchio = 2*m3*lc3*sin(q3)   (coefficient 0.126, = 2*m3*lc3 to"]),
    ("arm_rpr", "sine for cosine", "g3 = g * m3 * lc3 * np.cos(t1 + t3)", "g3 = g * m3 * lc3 * np.sin(t1 + t3)",
     ["G[2]: formula - Pinocchio = m3*lc3*g*sin(q1 + q3) - m3*lc3*g*cos(q1 + q3)"]),
    ("arm_rpr", "lc for l", 's, r2 = d + p["l2"], d + p["lc2"]\n    g, m3', 's, r2 = d + p["lc2"], d + p["lc2"]\n    g, m3',
     ["G[0]: formula - Pinocchio = (m3*lc2*g - m3*l2*g)*cos(q1)   (coefficient -1.02, = m3*lc2*g - m3*l2*g to"]),
    # the cart with a double pendulum
    ("cart_double_pendulum", "dropped term", "m13 = (m1 * lc1 + m2 * l1) * np.cos(t1) + m2 * lc2 * np.cos(t1 + t2)",
     "m13 = (m1 * lc1 + m2 * l1) * np.cos(t1)",
     ["M[0,2]: formula - Pinocchio = -m2*lc2*cos(q1 + q2)   (coefficient -0.07, = -m2*lc2 to"]),
    ("cart_double_pendulum", "factor 2", "[-P * w1 - Q * w2,", "[-2 * P * w1 - Q * w2,",
     ["C[2,0]: formula - Pinocchio = -(m1*lc1 + m2*l1)*sin(q1)*v1 - m2*lc2*sin(q1 + q2)*v1"]),
    ("cart_double_pendulum", "wrong sign", "g2 = g * m2 * lc2 * np.sin(t1 + t2)", "g2 = -g * m2 * lc2 * np.sin(t1 + t2)",
     ["G[0]: formula - Pinocchio = -2*m2*lc2*g*sin(q1 + q2)   (coefficient -1.37, = -2*m2*lc2*g to",
      "G[1]: formula - Pinocchio = -2*m2*lc2*g*sin(q1 + q2)   (coefficient -1.37, = -2*m2*lc2*g to"]),
    ("cart_double_pendulum", "sine for cosine", "m23 = m2 * lc2 * np.cos(t1 + t2)", "m23 = m2 * lc2 * np.sin(t1 + t2)",
     ["M[1,2]: formula - Pinocchio = m2*lc2*sin(q1 + q2) - m2*lc2*cos(q1 + q2)"]),
    ("cart_double_pendulum", "lc for l", "2 * l1 * lc2 * np.cos(t2)", "2 * lc1 * lc2 * np.cos(t2)",
     ["M[0,0]: formula - Pinocchio = 2*(m2*lc1*lc2 - m2*l1*lc2)*cos(q2)"]),
    # the spatial arm
    ("spatial_arm", "dropped term", 'p["I3x"] * s23**2 + p["I3z"]', 'p["I3z"]',
     ["M[0,0]: formula - Pinocchio = -I3x*sin(q2 + q3)**2   (coefficient -0.0007, = -I3x to"]),
    ("spatial_arm", "factor 2", "m33 = I3y + m3 * lc3**2", "m33 = I3y + 2 * m3 * lc3**2",
     ["M[2,2]: formula - Pinocchio = m3*lc3**2   (coefficient 0.0173, = m3*lc3**2 to"]),
    ("spatial_arm", "wrong sign", 'b = -p["m3"]', 'b = p["m3"]',
     ["C[1,1]: formula - Pinocchio = 2*m3*l2*lc3*sin(q3)*v3   (coefficient 0.0857, = 2*m3*l2*lc3 to"]),
    ("spatial_arm", "sine for cosine", "g3 = g * m3 * lc3 * np.cos(t2 + t3)", "g3 = g * m3 * lc3 * np.sin(t2 + t3)",
     ["G[2]: formula - Pinocchio = m3*lc3*g*sin(q2 + q3) - m3*lc3*g*cos(q2 + q3)"]),
    ("spatial_arm", "lc for l", 'm3 * p["l2"]) * np.cos(t2)', 'm3 * p["lc2"]) * np.cos(t2)',
     ["G[1]: formula - Pinocchio = (m3*lc2*g - m3*l2*g)*cos(q2)   (coefficient -1.29, = m3*lc2*g - m3*l2*g to"]),
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
