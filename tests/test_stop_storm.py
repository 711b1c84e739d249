"""Talos in free fall on its stops: what holds, what lets go, and what locating a release costs.

Talos's neutral pose sits on several joint stops. Floating and falling from rest, every
joint's stop force is zero up to round-off, and without losses nothing lets go: the joints
that start on a stop settle onto it at round-off speed within the first steps and stay held. With the URDF's losses on, the smoothed
Coulomb friction of the arms (1 N m, tanh(v / 1e-3 rad/s), on ~1e-3 kg m^2) is far too stiff
for RK4 at 1 ms: it amplifies round-off velocities, and the stop forces it makes (up to
~1e-3 N m) really pull, so held joints are let go and struck again every few steps. Those
releases are located by regula falsi on the stop force; the locator stops once the force is
past zero by less than its own round-off (FORCE_NOISE_RTOL of sum_i |M_ji a_i|), instead of
chasing 1e-13 of its end value through the noise (~44 trial steps a release before, ~12 now).
"""

from __future__ import annotations

import numpy as np
import pytest

import robodyn
from robodyn.sim import events
from robodyn.sim.simulation import simulate

DT = 1e-3  # [s]
DURATION = 0.02  # [s], 20 RK4 steps
# Free fall: the books close to RK4's error on a ~1e3 J energy scale (measured ~1e-13 J).
LEDGER_TOL = 1e-9  # [J]
# Joints starting on a stop reach it at round-off speed [rad/s] (measured <= 2e-18).
ROUND_OFF_SPEED = 1e-15
# A held joint sits exactly on its bound.
VIOLATION_TOL = 1e-12  # [rad]
# Dynamics evaluations per stop event (impact or release), the 4 x 20 of the steps included:
# ~70 when each release was chased through the noise of its stop force, ~30 now.
EVALUATIONS_PER_EVENT = 45
# Stopping at the noise of the stop force instead of at 1e-13 of its end value moves the run
# by round-off only (measured 6e-17 rad, 6e-13 rad/s over the 20 steps).
SAME_Q_TOL = 1e-12  # [rad | m]
SAME_V_TOL = 1e-10  # [rad/s | m/s]


@pytest.fixture(scope="module")
def talos() -> robodyn.Robot:
    return robodyn.load("talos", free_flyer=True)


def fall(robot: robodyn.Robot, *, losses: bool, backend: str | None = None, **kw: float) -> robodyn.Trajectory:
    options = {"duration": DURATION, "dt": DT} | kw
    return simulate(robot, robot.neutral(), np.zeros(robot.nv), losses=losses, backend=backend, **options)


def test_without_losses_the_stops_of_a_falling_talos_hold_from_the_start(talos: robodyn.Robot) -> None:
    traj = fall(talos, losses=False)
    log = traj.meta["impact_log"]
    assert traj.meta["releases"] == 0, "a stop whose force is zero up to round-off was let go"
    assert traj.meta["impacts"] == len(log) >= 1
    # the joints that start on a stop settle onto it at round-off speed, with nothing to lose
    assert all(abs(r["speed_before"]) <= ROUND_OFF_SPEED for r in log), [r["speed_before"] for r in log]
    assert all(r["energy_change"] == 0.0 for r in log)
    assert sorted(traj.meta["held_at_end"]) == sorted({r["joint"] for r in log})
    assert abs(traj.meta["work_limits"]) <= LEDGER_TOL
    assert traj.max_ledger_residual <= LEDGER_TOL
    assert traj.meta["limit_violation"] <= VIOLATION_TOL
    # only the floating base falls: g t^2 / 2 down, every joint still [rad]
    base_z = traj.q[-1, 2] - traj.q[0, 2]
    assert base_z == pytest.approx(-0.5 * 9.81 * DURATION**2, rel=1e-9)
    assert float(np.max(np.abs(traj.v[:, 6:]))) <= 1e-12


def test_friction_driven_releases_are_located_at_the_noise_of_the_stop_force(
    talos: robodyn.Robot, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the event stepper's locator, in the Python pipeline alone: at dt = 1 ms the friction is unstable, so
    # the compiled loop's round-off (another order of the same sums) grows into another storm of events
    traj = fall(talos, losses=True, backend="aba")
    n_events = traj.meta["impacts"] + traj.meta["releases"]
    assert traj.meta["releases"] >= 10  # the friction instability at dt = 1 ms really pulls
    assert traj.max_ledger_residual <= LEDGER_TOL
    assert traj.meta["limit_violation"] <= VIOLATION_TOL
    assert traj.evaluations / n_events <= EVALUATIONS_PER_EVENT, (traj.evaluations, n_events)

    monkeypatch.setattr(events, "FORCE_NOISE_RTOL", 0.0)  # chase every release to 1e-13 of its end value
    exact = fall(talos, losses=True, backend="aba")
    assert exact.evaluations > traj.evaluations
    assert float(np.max(np.abs(traj.q - exact.q))) <= SAME_Q_TOL
    assert float(np.max(np.abs(traj.v - exact.v))) <= SAME_V_TOL


# Where the friction is stable for RK4 (dt below 3.4e-6 s, robodyn's stiffness warning), the compiled
# loop with its event steps and the Python pipeline agree to round-off (measured 2e-19 rad over 0.01 s).
STABLE_DT = 2e-6  # [s]
STABLE_Q_TOL = 1e-15  # [rad | m]


def test_with_stable_friction_the_compiled_loop_and_the_python_pipeline_agree(talos: robodyn.Robot) -> None:
    got = fall(talos, losses=True, duration=0.002, dt=STABLE_DT)
    ref = fall(talos, losses=True, duration=0.002, dt=STABLE_DT, backend="aba")
    assert got.meta["loop"] == "compiled" and ref.meta["loop"] == "python"
    assert got.meta["impacts"] == ref.meta["impacts"] >= 1
    assert float(np.max(np.abs(got.q - ref.q))) <= STABLE_Q_TOL
    assert got.max_ledger_residual <= LEDGER_TOL and ref.max_ledger_residual <= LEDGER_TOL
