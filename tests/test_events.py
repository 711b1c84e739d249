"""The event stepper's loop projection: after every step the loops are closed to the projection's threshold."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.sim.loops import PROJECT_ABOVE
from robodyn.sim.simulation import simulate

from .test_constraints import LOOP, closed, linkage_urdf

# A step whose residual has an entry above PROJECT_ABOVE (either sign) is projected back, so the
# drift recorded at every sample, the norm of a point loop's 3 residual rows, stays within
# sqrt(3) PROJECT_ABOVE (measured 1.0e-12 m on the linkage). Far below the 1e-9 m the loop tests
# ask for: a projection that only looked at positive residuals let it grow to 9.8e-10 m.
PROJECTED_DRIFT_TOL = np.sqrt(3) * PROJECT_ABOVE  # [m]


@pytest.mark.parametrize("theta0", [0.3, 1.1])
def test_every_sample_is_projected_back_onto_the_loop(tmp_path: Path, theta0: float) -> None:
    linkage = robodyn.load(linkage_urdf(tmp_path / "linkage.urdf"))
    traj = simulate(linkage, closed(theta0), [0, 0, 0], duration=2.0, dt=1e-3, loops=LOOP)
    drift = traj.constraint_drift
    assert drift is not None and np.ptp(traj.q[:, 1]) > 1.0  # it moved through the motion
    assert traj.meta["loop_drift"] <= PROJECTED_DRIFT_TOL, traj.meta["loop_drift"]
    assert np.max(drift) <= PROJECTED_DRIFT_TOL


def test_no_stage_is_swapped_at_run_time() -> None:
    """A run that hits, holds and releases stops keeps the class's own ``rates`` and ``advance``.

    The system's path is a fixed dispatch (``RobotSystem.rates``) and the stepper's stages are
    methods called in order: nothing is bound onto an instance, before or during the run.
    """
    from robodyn import integrators
    from robodyn.sim.run import Run
    from robodyn.sim.simulation import _time_grid
    from robodyn.sim.system import robot_system

    robot = robodyn.load("panda")
    system = robot_system(robot, backend="aba")
    q0 = system.stops.clamp(robot.neutral())[0]
    run = Run(robot, system, integrators.get("rk4"), _time_grid(0.5, 1e-3), q0, np.zeros(robot.nv),
              rtol=1e-9, atol=1e-12, max_energy_growth=None)  # fmt: skip
    assert "rates" not in vars(system) and "advance" not in vars(run.stepper)
    run.integrate()
    assert run.stepper.n_impacts > 0 and system.held, "the run must hit and hold a stop to exercise hold()"
    assert "rates" not in vars(system), "RobotSystem.rates was bound onto the instance during the run"
    assert "advance" not in vars(run.stepper), "EventStepper.advance was bound onto the instance"
