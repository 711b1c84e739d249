"""Adaptive integrators bound their work: steps per output interval, steps per run, the smallest step.

Issue 11, class 7: dopri5 under 1e6 N m on the Pendubot ran on for 148,598 evaluations over
10 ms. Every adaptive method now stops such a run in one line naming the bound it hit, and
robodyn.simulate keeps the trajectory up to the failing interval (exit 3 from the CLI).
"""

from __future__ import annotations

import dataclasses
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn import integrators
from robodyn.cli import main
from robodyn.errors import DivergenceError, InputError, StepError
from robodyn.integrators import ArrayProblem, solve
from robodyn.integrators.base import MAX_STEPS_PER_INTERVAL, AdaptiveIntegrator

ADAPTIVE = integrators.names(adaptive=True)
EXPLICIT_ADAPTIVE = integrators.names(adaptive=True, implicit=False)
IMPLICIT_ADAPTIVE = integrators.names(adaptive=True, implicit=True)

# The issue's run: 1e6 N m on the Pendubot's first joint, 10 ms at 1 ms output intervals.
# Unbounded, dopri5 took 148,598 evaluations (2.7 s) and SciPy's methods 55,000 to 531,000.
HOSTILE_TORQUE = "1e6,0"
DURATION, DT = 0.01, 0.001
# dopri5 evaluates the dynamics 6 times an attempted step (7 stages, the first reused from
# the step before: FSAL), once more when a run starts, and simulate once per kept sample
# whose acceleration it fills in afterwards.
DOPRI5_EVALUATIONS_PER_STEP = 6
# The most one SciPy solver step() evaluated in these hostile runs, its internal retries
# included, was 26 (BDF); 40 leaves room and is still 100x below the unbounded runs.
SCIPY_EVALUATIONS_PER_STEP = 40
# A bound that every method meets within the first three intervals of the hostile run.
SMALL_BOUND = 200
# No method shrinks its step more than this at once (dopri5 and SciPy's methods: 5x).
LARGEST_SHRINK = 10.0
# Two accurate runs (rtol 1e-9) of the same damped motion agree far better than this.
AGREEMENT = 1e-6

BOUND_NAMED = re.compile(r"max_steps_per_interval = [\d,]+|made no progress .*min_relative_step|max_steps = [\d,]+")


def evaluations_per_step(name: str) -> int:
    return DOPRI5_EVALUATIONS_PER_STEP if name == "dopri5" else SCIPY_EVALUATIONS_PER_STEP


@pytest.fixture(scope="module")
def free_pendubot(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The Pendubot with no effort limit declared on its motor (effort 0), so 1e6 N m is applied as given."""
    source = Path(robodyn.load("pendubot").urdf_path)  # type: ignore[arg-type]
    text = source.read_text()
    assert text.count('effort="2.0"') == 1
    path = tmp_path_factory.mktemp("free") / "pendubot_free.urdf"
    path.write_text(text.replace('effort="2.0"', 'effort="0"'))
    return path


def hostile_run(urdf: Path, method: str | integrators.Integrator) -> DivergenceError:
    robot = robodyn.load(str(urdf))
    torque = [float(x) for x in HOSTILE_TORQUE.split(",")]
    with pytest.raises(DivergenceError) as info:
        robodyn.simulate(robot, [0.0, 0.0], [0.0, 0.0], duration=DURATION, dt=DT, integrator=method, torque=torque)
    return info.value


def check_partial(exc: DivergenceError) -> robodyn.Trajectory:
    """The kept trajectory: diverged, shorter than the run, finite, and up to the failing interval."""
    traj = exc.trajectory
    assert traj.status == "diverged" and 1 <= traj.t.size < round(DURATION / DT) + 1
    assert np.all(np.isfinite(traj.q)) and np.all(np.isfinite(traj.v))
    assert traj.t[-1] <= exc.time
    return traj


# ----------------------------------------------------------------------------- the issue's run
def test_dopri5_stops_the_issues_run_at_the_interval_bound(free_pendubot: Path) -> None:
    exc = hostile_run(free_pendubot, "dopri5")
    message = str(exc)
    assert "\n" not in message and f"max_steps_per_interval = {MAX_STEPS_PER_INTERVAL:,}" in message
    traj = check_partial(exc)
    # Every interval begun (the kept ones and the failing one) took at most the bound's steps.
    assert traj.evaluations <= traj.t.size * (DOPRI5_EVALUATIONS_PER_STEP * MAX_STEPS_PER_INTERVAL + 1) + 1


@pytest.mark.parametrize("name", ADAPTIVE)
def test_every_adaptive_method_stops_the_issues_run(name: str, free_pendubot: Path) -> None:
    method = dataclasses.replace(integrators.get(name), max_steps_per_interval=SMALL_BOUND)
    exc = hostile_run(free_pendubot, method)
    message = str(exc)
    # The count bound, not the minimum step: a cautious first step (LSODA's is ~4e-16 s here)
    # is no verdict on progress.
    assert "\n" not in message and f"max_steps_per_interval = {SMALL_BOUND}" in message, message
    traj = check_partial(exc)
    assert traj.evaluations <= traj.t.size * (evaluations_per_step(name) * SMALL_BOUND + 1) + 1


def test_the_cli_exits_3_in_one_line_and_writes_the_partial_run(free_pendubot: Path, tmp_path: Path) -> None:
    out = tmp_path / "run.npz"
    argv = ["simulate", str(free_pendubot), "--integrator", "dopri5", "--torque", HOSTILE_TORQUE]
    argv += ["--duration", str(DURATION), "--dt", str(DT), "--out", str(out)]
    # timeout: a guard so that a regression cannot hang the suite, not a timing assertion.
    proc = subprocess.run([sys.executable, "-m", "robodyn", *argv], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 3, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "max_steps_per_interval" in lines[0] and "Traceback" not in proc.stderr
    written = sorted(tmp_path.glob("*.npz"))
    assert len(written) == 1, written
    traj = robodyn.Trajectory.load(written[0])
    assert traj.status == "diverged" and 1 <= traj.t.size < round(DURATION / DT) + 1
    assert np.all(np.isfinite(traj.q))


# ----------------------------------------------------------------------------- robot-free blow-up
def blow_up() -> ArrayProblem:
    """v' = v^2 from v(0) = 1: v = 1 / (1 - t), infinite at t = 1."""
    return ArrayProblem(
        lambda t, q, v: v**2, 1, jacobian_fn=lambda t, q, v: (np.zeros((1, 1)), np.array([[2.0 * v[0]]]))
    )


@pytest.mark.parametrize("name", ADAPTIVE)
def test_a_finite_time_blow_up_stops_at_the_minimum_step(name: str) -> None:
    # The per-interval bound lifted: only the minimum step can stop the run, at the blow-up.
    method = dataclasses.replace(integrators.get(name), max_steps_per_interval=10**6)
    problem = blow_up()
    with pytest.raises(StepError) as info, np.errstate(all="ignore"):
        solve(problem, [0.0], [1.0], dt=0.25, n_steps=8, method=method)
    message = str(info.value)
    assert "\n" not in message and "made no progress" in message and "min_relative_step 1e-12" in message
    assert info.value.time == pytest.approx(1.0, abs=1e-6)
    # Stopped at the first step below the minimum, not after crawling on far below it.
    found = re.search(r"step (\S+) s below the minimum (\S+) s", message)
    assert found is not None
    step, smallest = float(found[1]), float(found[2])
    assert smallest / LARGEST_SHRINK <= step < smallest


@pytest.mark.parametrize("name", ADAPTIVE)
def test_a_finite_time_blow_up_stops_in_bounded_work(name: str) -> None:
    problem = blow_up()
    with pytest.raises(StepError) as info, np.errstate(all="ignore"):
        solve(problem, [0.0], [1.0], dt=0.25, n_steps=8, method=name)
    assert BOUND_NAMED.search(str(info.value))
    intervals = 4  # the blow-up is in the fourth interval, [0.75, 1]
    assert problem.evaluations <= intervals * evaluations_per_step(name) * MAX_STEPS_PER_INTERVAL + 1


@pytest.mark.parametrize("name", ["dopri5", "scipy_rk45", "scipy_radau"])
def test_the_run_bound_counts_every_step(name: str) -> None:
    # A quiet pendulum, 10 intervals of 0.3 s: the run bound alone stops it.
    method = dataclasses.replace(integrators.get(name), max_steps=20)
    problem = ArrayProblem(
        lambda t, q, v: -np.sin(q), 1, jacobian_fn=lambda t, q, v: (-np.cos(q)[None, :], np.zeros((1, 1)))
    )
    with pytest.raises(StepError, match="max_steps = 20 at t = ") as info:
        solve(problem, [2.0], [0.0], dt=0.3, n_steps=10, method=method, rtol=1e-10, atol=1e-12)
    assert 0 < info.value.time < 3.0
    if name == "dopri5":
        assert problem.evaluations <= 20 * DOPRI5_EVALUATIONS_PER_STEP + 1
    solve(ArrayProblem(lambda t, q, v: -np.sin(q), 1), [2.0], [0.0], dt=0.3, n_steps=10, method=name)  # default: fine


# ----------------------------------------------------------------------------- stiff but solvable
def very_stiff() -> ArrayProblem:
    """q'' = -k q - c v with eigenvalues -0.1 and -1e5 [1/s]: (s + 0.1)(s + 1e5) = s^2 + c s + k."""
    k, c = 1e4, 1e5 + 0.1
    return ArrayProblem(
        lambda t, q, v: -k * q - c * v, 1, jacobian_fn=lambda t, q, v: (np.array([[-k]]), np.array([[-c]]))
    )


def very_stiff_exact(t: float) -> float:
    """From q(0) = 1, v(0) = 0: q = A e^(-0.1 t) + B e^(-1e5 t) with A + B = 1, 0.1 A + 1e5 B = 0."""
    a = 1.0 / (1.0 - 1e-6)
    return float(a * np.exp(-0.1 * t) + (1.0 - a) * np.exp(-1e5 * t))


@pytest.mark.parametrize("name", IMPLICIT_ADAPTIVE)
def test_a_very_stiff_problem_is_solved_by_the_implicit_methods(name: str) -> None:
    sol = solve(very_stiff(), [1.0], [0.0], dt=0.1, n_steps=10, method=name)
    assert abs(sol.q[-1, 0] - very_stiff_exact(1.0)) < AGREEMENT


@pytest.mark.parametrize("name", EXPLICIT_ADAPTIVE)
def test_a_very_stiff_problem_stops_an_explicit_method_pointing_at_radau(name: str) -> None:
    # Stability caps an explicit step near 3 / 1e5 s: ~3,000 steps per 0.1 s interval.
    problem = very_stiff()
    with pytest.raises(StepError, match="max_steps_per_interval") as info:
        solve(problem, [1.0], [0.0], dt=0.1, n_steps=10, method=name)
    assert "try scipy_radau" in str(info.value)
    assert problem.evaluations <= evaluations_per_step(name) * MAX_STEPS_PER_INTERVAL + 1


@pytest.fixture(scope="module")
def stiff_arm() -> robodyn.Robot:
    """The geared arm with joint damping 10 N m s/rad: a 1 ms time constant."""
    return robodyn.load(str(robodyn.model.files.models_dir() / "variants" / "geared_arm_stiff.urdf"))


@pytest.mark.parametrize("name", ADAPTIVE)
def test_the_stiff_geared_arm_still_runs_with_every_adaptive_method(name: str, stiff_arm: robodyn.Robot) -> None:
    # 10 ms output intervals, each 10 time constants: the bounds leave this run alone.
    traj = robodyn.simulate(stiff_arm, [1.0], [0.0], duration=1.0, dt=0.01, integrator=name)
    ref = robodyn.simulate(stiff_arm, [1.0], [0.0], duration=1.0, dt=0.01, integrator="scipy_radau")
    assert traj.status == "ok" and np.max(np.abs(traj.q - ref.q)) < AGREEMENT


# ----------------------------------------------------------------------------- the options
@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("max_steps_per_interval", 0),
        ("max_steps_per_interval", 1.5),
        ("max_steps_per_interval", True),
        ("max_steps_per_interval", None),
        ("max_steps", 0),
        ("min_relative_step", 0.0),
        ("min_relative_step", 1e-17),
        ("min_relative_step", 1.0),
        ("min_relative_step", float("nan")),
    ],
)
def test_bad_bounds_are_refused_naming_the_option(option: str, value: object) -> None:
    with pytest.raises(InputError, match=option):
        dataclasses.replace(integrators.get("dopri5"), **{option: value})


def test_every_adaptive_method_declares_its_bounds() -> None:
    for name in ADAPTIVE:
        method = integrators.get(name)
        assert isinstance(method, AdaptiveIntegrator)
        assert method.summary()["max_steps_per_interval"] == MAX_STEPS_PER_INTERVAL
    for name in integrators.names(fixed_step=True):
        assert not isinstance(integrators.get(name), AdaptiveIntegrator)
    unbounded_run = dataclasses.replace(integrators.get("scipy_radau"), max_steps=None)
    assert unbounded_run.max_steps is None


def test_the_cli_lists_the_bounds(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "--integrator", "list", "--json"]) == 0
    rows = {row["name"]: row for row in json.loads(capsys.readouterr().out)}
    assert rows["dopri5"]["max_steps_per_interval"] == MAX_STEPS_PER_INTERVAL
    assert "max_steps_per_interval" not in rows["rk4"]
