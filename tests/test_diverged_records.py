"""A run that diverges reports only what happened up to its failure: impacts, holds, the compiled loop's hand-back.

The Python run steps a block of steps before it checks them, so a diverging run takes steps
past its failure; the compiled loop may run far past it before it hands the run back. The
events of those steps (impacts at the pendubot's stops once explicit Euler has blown up) and
the step where the compiled loop stopped must not reach the report of a run kept to step 7.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.errors import DivergenceError
from robodyn.sim.simulation import simulate
from tests.test_limits import PENDULUM_URDF

# Explicit Euler at dt = 0.05 s blows the Pendubot up: the energy bound is crossed at step 7
# (t = 0.35 s), and the blown-up motion strikes joint2's stops from ~2 s on.
BLOWUP = {"q0": [0.3, -0.2], "v0": [0.0, 0.0], "duration": 5.0, "dt": 0.05, "integrator": "euler"}
FAIL_STEP = 7


def _diverged(backend: str | None) -> robodyn.Trajectory:
    robot = robodyn.load("pendubot")
    with pytest.raises(DivergenceError) as info:
        simulate(robot, backend=backend, **BLOWUP)  # type: ignore[arg-type]
    assert info.value.step == FAIL_STEP
    return info.value.trajectory


@pytest.mark.parametrize("backend", [None, "aba"])
def test_a_diverged_run_reports_no_impact_after_its_failure(backend: str | None) -> None:
    traj = _diverged(backend)
    t_end = float(traj.t[-1])
    assert traj.n_steps == FAIL_STEP and t_end == pytest.approx(0.35, abs=1e-12)
    log = traj.meta["impact_log"]
    assert all(r["time"] <= t_end for r in log), [r["time"] for r in log]
    # The blow-up reaches no stop before step 7: the kept samples are clear of them.
    assert traj.meta["impacts"] == len(log) == 0
    assert traj.meta["releases"] == 0 and traj.meta["held_at_end"] == []
    assert traj.work_limits[-1] == 0.0


def test_the_compiled_loops_note_names_no_step_past_the_failure() -> None:
    traj = _diverged(None)
    note = traj.meta["compiled_loop"]
    assert traj.meta["loop"] == "python"
    steps = [int(s) for s in re.findall(r"at step (\d+)", note)]
    assert steps == [FAIL_STEP], note
    assert "energy error" in note
    assert traj.meta["compiled_loop_steps"] >= FAIL_STEP


def test_impacts_before_a_failure_are_kept(tmp_path: Path) -> None:
    # An elastic stop at 0.5 rad and explicit Euler at dt = 0.02 s: the bob strikes the stop
    # five times, then the energy Euler gains crosses the bound at step 142 (t = 2.84 s), and
    # the blown-up swing strikes it again in the steps of the same check block after that.
    path = tmp_path / "stopped_pendulum.urdf"
    path.write_text(PENDULUM_URDF.format(effort=5.0))
    robot = robodyn.load(path)
    with pytest.raises(DivergenceError) as info:
        simulate(robot, [1.0], [0.0], duration=20.0, dt=0.02, integrator="euler", backend="aba", restitution=1.0)
    traj = info.value.trajectory
    t_end = float(traj.t[-1])
    assert info.value.step == 142 and t_end == pytest.approx(2.84, abs=1e-12)
    log = traj.meta["impact_log"]
    assert traj.meta["impacts"] == len(log) == 5
    assert all(r["time"] <= t_end for r in log)
    # each elastic impact reverses the bob's speed at the stop: one sign change of v per impact
    v = traj.v[:, 0]
    assert int(np.count_nonzero(np.diff(np.sign(v[v != 0.0])) > 0)) == 5
