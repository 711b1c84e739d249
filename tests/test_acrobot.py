"""Issue 34: the Acrobot (a Pendubot with the shoulder passive and the elbow driven) swings up and balances.

The Spong-Block machine (tests/fixtures/spong_pendubot.urdf with ``passive=["joint1"]``) and the
built-in Pendubot's parameters with the elbow driven balance from the hanging rest at zero velocity
through ``control.make("swing_up", robot)`` (:mod:`robodyn.control.acrobot`), from Python and the CLI;
the gains scale with the model; a swing too weak to reach the upright gets its one-line reason.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn import control
from robodyn.cli import main
from robodyn.control import acrobot, outcome, region
from robodyn.control.acrobot import AcrobotEnergy
from robodyn.control.switch import BALANCE
from robodyn.errors import UnknownNameError

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import bench_swing_up  # the benchmark's Pendubot template and bases

SPONG = Path(__file__).parent / "fixtures" / "spong_pendubot.urdf"
# Measured from hanging at rest (dt = 1e-3, RK4): both balance from t = 8.39 s; 10 s leaves room.
BALANCE_BY_S = 10.0
DURATION_S = BALANCE_BY_S + outcome.HOLD
WEAK_AMPLITUDE = 0.02  # [rad] an elbow swing that pumps link 1 to a few hundredths of a rad in 5 s
WEAK_DURATION_S = 5.0
SCALE = 3.0  # every mass scaled by this: the same Acrobot in time, W scaled by it
REL_TOL = 1e-9  # gains that must scale exactly (floating-point only)


def _acrobot(path: Path) -> robodyn.Robot:
    return robodyn.load(str(path), passive=["joint1"])


def _built_in(folder: Path, mass_scale: float = 1.0) -> robodyn.Robot:
    """The built-in Pendubot's parameters (the benchmark's base) with the elbow driven (1000 N m)."""
    p = dict(bench_swing_up.BASES["pendubot (built-in)"][1])
    for name in ("m1", "m2", "I1", "I2"):
        p[name] *= mass_scale
    text = bench_swing_up.PENDUBOT.format(effort="0", **{k: repr(v) for k, v in p.items()})
    head, _, tail = text.rpartition('effort="0"')  # the elbow's limit, the template's last
    path = folder / f"acrobot_{mass_scale:g}.urdf"
    path.write_text(head + 'effort="1000"' + tail)
    return _acrobot(path)


def _swing(robot: robodyn.Robot, duration: float, **gains: float) -> tuple[control.Switched, outcome.Outcome]:
    controller = control.make("swing_up", robot, **gains)
    hanging = controller.lqr.plant.hanging()
    trajectory = robodyn.simulate(robot, hanging, [0.0, 0.0], duration=duration, dt=1e-3, torque=controller)
    verdict = outcome.judge(controller, trajectory.t, trajectory.q, trajectory.v, trajectory.tau)
    modes = controller.modes(trajectory.q, trajectory.v)
    values = controller.lqr.value(trajectory.q, trajectory.v)
    assert np.all(values[modes == BALANCE] < controller.region.rho)  # the LQR only inside its region
    return controller, verdict


@pytest.mark.parametrize("which", ["spong-block", "built-in"])
def test_the_acrobot_balances_from_hanging_at_rest(which: str, tmp_path: Path) -> None:
    robot = _acrobot(SPONG) if which == "spong-block" else _built_in(tmp_path)
    controller, verdict = _swing(robot, DURATION_S)
    assert isinstance(controller.swing_up, AcrobotEnergy)
    assert controller.region.rho == region.estimate(controller.lqr).rho  # the estimate's own level, not enlarged
    assert verdict.balanced, verdict.line()
    assert verdict.time <= BALANCE_BY_S
    assert verdict.error < outcome.BALANCE_TOL


def test_the_acrobot_balances_on_the_command_line(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["simulate", str(SPONG), "--passive", "joint1", "--controller", "swing_up", "--q0=-1.5707963268,0"]
    code = main([*argv, "--duration", str(DURATION_S)])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "outcome: balanced from t = " in out


def test_the_acrobot_gains_scale_with_the_model(tmp_path: Path) -> None:
    """Masses times SCALE: the same motion (w, kappa, the PD, the amplitude), W and the energy gain's 1/W scaled."""
    base = control.make("swing_up", _built_in(tmp_path)).swing_up
    heavy = control.make("swing_up", _built_in(tmp_path, SCALE)).swing_up
    assert isinstance(base, AcrobotEnergy) and isinstance(heavy, AcrobotEnergy)
    for name in ("omega", "k_p", "k_d", "amplitude", "kick", "sign"):
        assert getattr(heavy, name) == pytest.approx(getattr(base, name), rel=REL_TOL), name
    assert heavy.hold_torque == pytest.approx(SCALE * base.hold_torque, rel=REL_TOL)
    assert heavy.k_energy == pytest.approx(base.k_energy / SCALE, rel=REL_TOL)
    assert heavy.energy_up - heavy.energy_hanging == pytest.approx(2.0 * heavy.hold_torque, rel=1e-6)


def test_the_acrobot_lqr_weights_come_from_the_model() -> None:
    robot = _acrobot(SPONG)
    controller = control.make("swing_up", robot)
    Q, R = acrobot.lqr_weights(controller.lqr.plant)
    expected = robodyn.control.lqr.design(robot, Q=Q, R=R)
    np.testing.assert_allclose(controller.lqr.K, expected.K, rtol=REL_TOL)
    given = control.make("swing_up", robot, Q=10.0, R=1.0)  # the user's weights replace them
    assert not np.allclose(given.lqr.K, controller.lqr.K)


def test_a_swing_too_weak_to_reach_the_upright_says_so() -> None:
    _, verdict = _swing(_acrobot(SPONG), WEAK_DURATION_S, amplitude=WEAK_AMPLITUDE)
    assert not verdict.balanced
    assert verdict.reason is not None
    assert verdict.reason.startswith("the swing never reached the upright's energy"), verdict.reason
    assert "kappa = 0.101" in verdict.reason


def test_the_acrobot_refuses_the_pendubot_gains_it_has_no_use_for() -> None:
    with pytest.raises(UnknownNameError, match="accel_max"):
        control.make("swing_up", _acrobot(SPONG), accel_max=1.0)
