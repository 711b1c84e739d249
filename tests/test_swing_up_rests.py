"""The upright and the hanging rest read from the model's potential energy, not from the kind's convention alone.

A cart-pole whose pole hangs below its hinge at q = 0 (its centre of mass at z = -0.37 m: l < 0 in the
kind's parameters) meets the cart-pole's assumptions, but its upright is theta = pi. Before the rests
were read from the model, such a file started "balanced from t = 0 s" while hanging, and exited 0.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numba
import numpy as np
import pytest

import robodyn
import robodyn.control
from robodyn.control.compiled import law_of
from robodyn.control.outcome import judge
from robodyn.control.plant import plant, wrap
from robodyn.engine import torque_laws as tl
from robodyn.kinds import params
from robodyn.sim.fast import FastDynamics
from robodyn.sweep.policy import batch_policy

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import bench_swing_up  # the swing-up benchmark's cart-pole template, its pole at z = l

POLE_BELOW = bench_swing_up.CART_POLE.format(m_cart=0.83, m=0.137, l=-0.37, I=6.1e-3, effort=12)
UPRIGHT_TOL = 0.05  # [rad] the swing-up's "upright" (robodyn.control.outcome.BALANCE_TOL)
DURATION_S = 8.0  # [s] it balances at 2.93 s from hanging (12 N on a 0.97 kg cart and pole)
# The controller's __call__ takes M, C v, G from Pinocchio, the compiled law from the closed form:
# round-off, a few ulps of the largest force (12 N), as tests/test_torque_laws.py.
POLICY_ATOL = 1e-12


@pytest.fixture()
def pole_below(tmp_path: Path) -> robodyn.Robot:
    path = tmp_path / "pole_below.urdf"
    path.write_text(POLE_BELOW, encoding="utf-8")
    return robodyn.load(path, passive=["hinge"])


def test_a_pole_below_its_hinge_has_its_upright_half_a_turn_away(pole_below: robodyn.Robot) -> None:
    assert params.extract(pole_below, "cart_pole")["l"] == pytest.approx(-0.37)
    p = plant(pole_below)
    assert abs(float(wrap(p.upright()[1] - np.pi))) < 1e-15
    np.testing.assert_array_equal(p.hanging(), [0.0, 0.0])
    assert pole_below.potential_energy(p.upright()) > pole_below.potential_energy(p.hanging())


@pytest.mark.parametrize(
    ("kind", "upright", "hanging"), [("cart_pole", (0, 0), (0, np.pi)), ("pendubot", (np.pi / 2, 0), (-np.pi / 2, 0))]
)
def test_the_built_in_kinds_keep_their_convention_to_the_bit(kind: str, upright: tuple, hanging: tuple) -> None:
    p = plant(robodyn.load(kind))
    np.testing.assert_array_equal(p.upright(), upright)
    np.testing.assert_array_equal(p.hanging(), hanging)


def test_a_pole_below_its_hinge_swings_up_from_hanging(pole_below: robodyn.Robot) -> None:
    controller = robodyn.control.make("swing_up", pole_below)
    run = robodyn.simulate(pole_below, [0.0, 0.0], [0.0, 0.0], duration=DURATION_S, dt=1e-3, torque=controller)
    verdict = judge(controller, run.t, run.q, run.v, run.tau)
    assert verdict.balanced, verdict.line()
    assert verdict.time > 1.0  # it starts hanging: not "balanced from t = 0"
    assert abs(float(wrap(run.q[-1, 1] - np.pi))) < UPRIGHT_TOL
    assert verdict.unit == "N"


def test_the_compiled_law_pumps_a_pole_below_its_hinge_as_the_controller_does(pole_below: robodyn.Robot) -> None:
    fast = FastDynamics.from_robot(pole_below)
    controller = robodyn.control.make("swing_up", pole_below)
    law, c = law_of(controller, fast)
    scalar = tl.law("cart_pole", law, numba.njit)
    rng = np.random.default_rng(5)
    q = np.column_stack([rng.uniform(-1.0, 1.0, 200), rng.uniform(-3.0, 3.0, 200)])
    v = rng.uniform(-3.0, 3.0, (200, 2))
    p, b = fast.param_vector, np.zeros(2)
    got = np.array([scalar(c, p, b, q[k, 0], q[k, 1], v[k, 0], v[k, 1]) for k in range(q.shape[0])])
    batch = batch_policy(controller, fast)(q, v)[:, 0]
    ref = np.array([controller(0.0, q[k], v[k])[0] for k in range(q.shape[0])])
    assert np.array_equal(got, batch)
    np.testing.assert_allclose(got, ref, rtol=0, atol=POLICY_ATOL * max(1.0, float(np.abs(ref).max())))
    assert np.any(controller.modes(q, v) == 0)  # the energy law gives some of those torques


def test_a_pendubot_whose_link_2_mass_sits_behind_its_elbow(tmp_path: Path) -> None:
    # link 2's centre of mass at x = -0.1262 m (lc2 < 0): its upright is the elbow folded, q2 = pi;
    # relabelled q2 - pi it is Spong and Block's machine, and its law is that machine's law
    spong = Path(__file__).parent / "fixtures" / "spong_pendubot.urdf"
    text = spong.read_text(encoding="utf-8").replace('<origin xyz="0.1262 0 0"', '<origin xyz="-0.1262 0 0"')
    path = tmp_path / "behind.urdf"
    path.write_text(text, encoding="utf-8")
    robot = robodyn.load(path, passive=["joint2"])
    p = plant(robot)
    np.testing.assert_allclose(wrap(p.upright() - [np.pi / 2, np.pi]), 0.0, atol=1e-15)
    np.testing.assert_allclose(wrap(p.hanging() - [-np.pi / 2, np.pi]), 0.0, atol=1e-15)
    controller = robodyn.control.make("swing_up", robot)
    run = robodyn.simulate(robot, p.hanging(), [0.0, 0.0], duration=0.5, dt=1e-3, torque=controller)
    assert not judge(controller, run.t, run.q, run.v, run.tau).balanced  # hanging is not upright
