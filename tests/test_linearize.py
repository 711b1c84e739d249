"""Robot.linearize against central finite differences and against the closed forms differentiated by sympy."""

from __future__ import annotations

import numpy as np
import pytest

import robodyn
from robodyn.control import symbolic
from robodyn.errors import InputError
from robodyn.kinds import params
from tests import _urdf

# Central differences with step FD_STEP on x and u: truncation ~h^2 |f'''| ~1e-12 and round-off
# ~eps |f| / h ~1e-10 of the largest entry; 1e-6 leaves room for the stiffer Pendubot entries.
FD_STEP = 1e-6
FD_RTOL = 1e-6
# Pinocchio's analytic derivatives vs the sympy derivative of the hand-derived closed form: two
# exact derivations, round-off apart.
SYMPY_RTOL = 1e-9

UPRIGHT = {"cart_pole": [0.0, 0.0], "pendubot": [np.pi / 2, 0.0]}


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def finite_differences(robot, q, v, u, h=FD_STEP):
    """(A, B) of f(x, u) = [v, a(q, v, S u - D v)] by central differences: the oracle."""
    n, S = robot.nv, robot.input_matrix()

    def f(x, uu):
        return np.r_[x[n:], robot.forward_dynamics(x[:n], x[n:], S @ uu - robot.damping * x[n:])]

    x0 = np.r_[q, v]
    A = np.column_stack([(f(x0 + h * e, u) - f(x0 - h * e, u)) / (2 * h) for e in np.eye(2 * n)])
    B = np.column_stack([(f(x0, u + h * e) - f(x0, u - h * e)) / (2 * h) for e in np.eye(u.size)])
    return A, B


def damped_cart_pole(tmp_path):
    """The seed cart-pole with viscous damping on both joints (the seed has none)."""
    text = (robodyn.load("cart_pole").urdf_path).read_text()
    text = text.replace('damping="0" friction="0"', 'damping="0.4" friction="0"', 1)
    text = text.replace('damping="0" friction="0"', 'damping="0.02" friction="0"', 1)
    path = tmp_path / "damped_cart_pole.urdf"
    path.write_text(text)
    (tmp_path / "damped_cart_pole.srdf").write_text(robodyn.load("cart_pole").srdf_path.read_text())
    robot = robodyn.load(str(path))
    assert np.all(robot.damping > 0)
    return robot


@pytest.mark.parametrize("name", ["cart_pole", "pendubot"])
def test_upright_matches_finite_differences(name):
    robot = robodyn.load(name)
    q = np.array(UPRIGHT[name])
    A, B = robot.linearize(q, [0.0, 0.0], [0.0])
    Af, Bf = finite_differences(robot, q, np.zeros(2), np.zeros(1))
    assert _relative(A, Af) < FD_RTOL
    assert _relative(B, Bf) < FD_RTOL


@pytest.mark.parametrize("name", ["cart_pole", "pendubot"])
def test_upright_matches_sympy(name):
    robot = robodyn.load(name)
    q = np.array(UPRIGHT[name])
    A, B = robot.linearize(q, [0.0, 0.0], [0.0])
    As, Bs = symbolic.linearize(name, params.extract(robot, name), q, actuated=robot.actuated)
    assert _relative(A, As) < SYMPY_RTOL
    assert _relative(B, Bs) < SYMPY_RTOL


def test_state_ordering_and_one_column_per_actuated_joint():
    robot = robodyn.load("pendubot")
    A, B = robot.linearize([np.pi / 2, 0.0], [0.0, 0.0], [0.0, 0.0])  # nv entries, zero on the passive joint
    n = robot.nv
    assert A.shape == (2 * n, 2 * n) and B.shape == (2 * n, 1)
    assert np.array_equal(A[:n, :n], np.zeros((n, n))) and np.array_equal(A[:n, n:], np.eye(n))
    assert np.array_equal(B[:n], np.zeros((n, 1)))
    Minv = np.linalg.inv(robot.M([np.pi / 2, 0.0]))
    assert np.allclose(B[n:, 0], Minv[:, 0], rtol=SYMPY_RTOL, atol=0)  # joint1 is the actuated one


def test_damping_enters_A_as_simulate_applies_it(tmp_path):
    robot = damped_cart_pole(tmp_path)
    q = np.array([0.0, 0.0])
    A, B = robot.linearize(q, [0.0, 0.0], [0.0])
    Af, Bf = finite_differences(robot, q, np.zeros(2), np.zeros(1))
    assert _relative(A, Af) < FD_RTOL and _relative(B, Bf) < FD_RTOL
    As, _ = symbolic.linearize(
        "cart_pole", params.extract(robot, "cart_pole"), q, actuated=robot.actuated, damping=robot.damping
    )
    assert _relative(A, As) < SYMPY_RTOL
    undamped, _ = robot.linearize(q, [0.0, 0.0], [0.0], losses=False)
    assert _relative(undamped, As) > 1e-3  # the damping is visible in A


def test_equilibrium_held_by_a_torque():
    """Link 1 horizontal, link 2 hanging: the shoulder holds (m1 lc1 + m2 l1) g."""
    robot = robodyn.load("pendubot")
    p = params.extract(robot, "pendubot")
    q = np.array([0.0, -np.pi / 2])
    u = np.array([(p["m1"] * p["lc1"] + p["m2"] * p["l1"]) * p["g"]])
    A, B = robot.linearize(q, [0.0, 0.0], u)
    As, Bs = symbolic.linearize("pendubot", p, q, actuated=robot.actuated, u_eq=u)
    assert _relative(A, As) < SYMPY_RTOL and _relative(B, Bs) < SYMPY_RTOL


def test_anywhere_when_not_asked_for_an_equilibrium():
    robot = robodyn.load("pendubot")
    rng = np.random.default_rng(5)
    for _ in range(5):
        q, v = robot.random_state(rng)
        u = rng.uniform(-1, 1, 1)
        A, B = robot.linearize(q, v, u, equilibrium=False)
        Af, Bf = finite_differences(robot, q, v, u)
        assert _relative(A, Af) < FD_RTOL and _relative(B, Bf) < FD_RTOL


def test_a_state_that_is_no_equilibrium_reports_its_residual():
    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match=r"is not an equilibrium: residual nle\(q\) - B u = \[") as info:
        robot.linearize([0.3, 0.0], [0.0, 0.0], [0.0])
    assert "\n" not in str(info.value)
    with pytest.raises(InputError, match="the velocity must be 0"):
        robot.linearize([np.pi / 2, 0.0], [0.1, 0.0], [0.0])


def test_bad_torques_and_coordinates_are_refused(tmp_path):
    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match="passive joint"):
        robot.linearize([np.pi / 2, 0.0], [0.0, 0.0], [0.0, 1.0])
    with pytest.raises(InputError, match="tau must have 2 entries"):
        robot.linearize([np.pi / 2, 0.0], [0.0, 0.0], [0.0, 0.0, 0.0])
    continuous = robodyn.load(str(_urdf.pendubot(tmp_path / "c.urdf", continuous=True)))
    with pytest.raises(InputError, match=r"nq == nv"):
        continuous.linearize(continuous.neutral(), np.zeros(continuous.nv), np.zeros(continuous.nv))
