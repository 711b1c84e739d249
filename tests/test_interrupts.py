"""Interrupted at the worst moment: nothing lost, nothing left running, one line (issue 27).

Each test runs the real ``robodyn`` program in a session of its own, paused at a window by
``ROBODYN_TEST_PAUSE_AT=WINDOW:FILE`` (:func:`robodyn.fileio.pause_for_test`): the command
creates ``FILE.waiting`` there and waits for ``FILE``. The test sends its signal inside the
window, to the whole process group as a terminal's Ctrl-C does, then lets the command go on.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import psutil
import pytest

from robodyn.sim.trajectory import Trajectory

ROOT = Path(__file__).resolve().parents[1]
# Seconds [s] a paused command may take to reach its window (imports, numba's cache, a cluster's start).
REACH_WINDOW_S = 240.0
# Seconds [s] the processes of a command get to be gone after it ended: the kernel kills at once;
# this only bounds the wait on a loaded machine.
GONE_WITHIN_S = 30.0
# A sweep whose chunks keep the workers busy when the signal comes: 6 runs of 8 s balanced by LQR
# (a torque callback from the compiled loop at every stage: seconds of wall time each), chunks of 1,
# 2 workers. Paused after chunk 1 is written, the workers are inside chunks 3 and 4.
SWEEP = """model = "pendubot"
duration = 8.0
dt = 1e-3
integrator = "rk4"
controller = "lqr"
measure = ["final_state"]
chunk = 1

[q0]
joint1 = [1.53, 1.55, 1.57, 1.59, 1.61, 1.63]
"""


class Paused:
    """A robodyn command started in its own session, paused at ``window``."""

    def __init__(self, tmp_path: Path, window: str, *args: str) -> None:
        self.go = tmp_path / f"go-{window}"
        self.stderr_path = tmp_path / f"stderr-{window}.txt"
        env = {**os.environ, "ROBODYN_TEST_PAUSE_AT": f"{window}:{self.go}"}
        env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")])
        with self.stderr_path.open("wb") as err:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "robodyn", *args],
                cwd=tmp_path,
                env=env,
                stdout=subprocess.DEVNULL,
                stderr=err,
                start_new_session=True,  # a process group of its own: a "terminal" to send Ctrl-C to
                preexec_fn=_default_sigint,
            )
        self.children: list[psutil.Process] = []

    def wait_for_window(self) -> None:
        """Block until the command sits in its window; note its child processes then."""
        waiting = Path(f"{self.go}.waiting")
        deadline = time.monotonic() + REACH_WINDOW_S
        while not waiting.exists():
            if self.process.poll() is not None:
                pytest.fail(f"the command ended ({self.process.returncode}) before its window: {self.stderr()}")
            if time.monotonic() > deadline:
                self.process.kill()
                pytest.fail("the command never reached its window")
            time.sleep(0.02)
        self.children = psutil.Process(self.process.pid).children(recursive=True)

    def signal_group(self, signum: int) -> None:
        """Send ``signum`` to the command's whole process group (as a terminal sends Ctrl-C)."""
        os.killpg(self.process.pid, signum)

    def release(self) -> int:
        """Let the command leave its window; return its exit code."""
        self.go.touch()
        return self.process.wait(timeout=REACH_WINDOW_S)

    def stderr(self) -> str:
        """The command's stderr, each progress bar redraw on a line of its own."""
        return self.stderr_path.read_text(errors="replace").replace("\r", "\n")

    def left_alive(self) -> list[psutil.Process]:
        """The command's processes (noted in the window) still running after it ended."""
        _, alive = psutil.wait_procs(self.children, timeout=GONE_WITHIN_S)
        return [p for p in alive if p.status() != psutil.STATUS_ZOMBIE]


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)  # a background pytest may ignore it; a user's shell does not


def _lines(text: str, *, drop: str = "") -> list[str]:
    """The non-empty lines of ``text``, less the progress bar's (those starting with ``drop``)."""
    return [line for line in text.splitlines() if line.strip() and not (drop and line.startswith(drop))]


def test_ctrl_c_while_simulate_writes_its_finished_run_keeps_it(tmp_path: Path) -> None:
    out, csv = tmp_path / "x.npz", tmp_path / "x.csv"
    command = Paused(
        tmp_path, "write", "simulate", "pendubot", "--duration", "0.2", "--out", str(out), "--csv", str(csv)
    )
    command.wait_for_window()  # the .npz is written under its temporary name, not yet renamed
    assert list(tmp_path.glob(".x.npz.*.part")), "the window is the .npz's temporary file"
    command.signal_group(signal.SIGINT)
    code = command.release()
    assert code == 130
    assert _lines(command.stderr()) == [
        f"robodyn simulate: interrupted after the run had finished; its trajectory is written to {out} and {csv}"
    ]
    whole = Trajectory.load(out)
    assert whole.t[-1] == pytest.approx(0.2)
    assert np.loadtxt(csv, delimiter=",", skiprows=1).shape[0] == whole.t.size
    assert not list(tmp_path.glob("*.part")), "no temporary file left"


def test_a_second_ctrl_c_abandons_the_write_and_says_so(tmp_path: Path) -> None:
    out = tmp_path / "x.npz"
    command = Paused(tmp_path, "write", "simulate", "pendubot", "--duration", "0.2", "--out", str(out))
    command.wait_for_window()
    command.signal_group(signal.SIGINT)
    time.sleep(0.2)  # two presses, not one: the first is noted before the second comes
    command.signal_group(signal.SIGINT)
    code = command.release()
    assert code == 130
    assert _lines(command.stderr()) == [
        "robodyn simulate: interrupted twice while the finished run was being written; the writes were abandoned "
        "(nothing written)"
    ]
    assert not out.exists() and not list(tmp_path.glob("*.part"))


def test_ctrl_c_while_the_command_line_loads_is_one_line(tmp_path: Path) -> None:
    """Before main() runs, a Ctrl-C ends the program with robodyn's line and 130, not an import traceback."""
    command = Paused(tmp_path, "loading", "info", "pendubot")
    command.wait_for_window()
    command.signal_group(signal.SIGINT)
    assert command.release() == 130
    assert _lines(command.stderr()) == ["robodyn: interrupted"]


def test_ctrl_c_once_the_command_has_returned_changes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "x.npz"
    command = Paused(tmp_path, "exit", "simulate", "pendubot", "--duration", "0.1", "--out", str(out))
    command.wait_for_window()  # main() has returned 0: the interpreter is about to exit
    command.signal_group(signal.SIGINT)
    assert command.release() == 0
    assert command.stderr() == ""  # no traceback, no "Exception ignored"
    assert Trajectory.load(out).t[-1] == pytest.approx(0.1)


def test_ctrl_c_while_run_writes_the_scene_trajectory_keeps_it(tmp_path: Path) -> None:
    scene = tmp_path / "s.toml"
    scene.write_text('[model]\nname = "pendubot"\n\n[simulate]\nduration = 0.2\ndt = 1e-3\n')
    command = Paused(tmp_path, "write", "run", str(scene), "--no-view", "--out", str(tmp_path / "out"))
    command.wait_for_window()
    command.signal_group(signal.SIGINT)
    code = command.release()
    assert code == 130
    path = tmp_path / "out" / "s.npz"
    assert _lines(command.stderr()) == [
        f"robodyn run: interrupted after the simulation had finished; its trajectory is written to {path}"
    ]
    assert Trajectory.load(path).t[-1] == pytest.approx(0.2)


@pytest.mark.timeout(600)
def test_ctrl_c_in_a_sweep_kills_its_cluster_and_says_how_to_resume(tmp_path: Path) -> None:
    (tmp_path / "s.toml").write_text(SWEEP)
    command = Paused(tmp_path, "chunk", "sweep", "s.toml", "--out", "out", "--workers", "2")
    command.wait_for_window()  # chunk 1 is written; the workers go on with the others
    assert len(command.children) >= 2, "a scheduler's workers run in processes of their own"
    command.signal_group(signal.SIGINT)
    code = command.release()
    assert code == 130
    lines = _lines(command.stderr(), drop="sweep [")
    assert len(lines) == 1, command.stderr()
    assert lines[0].startswith("robodyn sweep: interrupted; ")
    assert lines[0].endswith(" of 6 chunks are written in out/results; run the same command again to resume from them")
    assert command.left_alive() == []


@pytest.mark.timeout(600)
def test_a_killed_sweep_leaves_no_process_and_no_leaked_semaphore_warning(tmp_path: Path) -> None:
    (tmp_path / "s.toml").write_text(SWEEP)
    command = Paused(tmp_path, "chunk", "sweep", "s.toml", "--out", "out", "--workers", "2")
    command.wait_for_window()
    os.kill(command.process.pid, signal.SIGKILL)  # the sweep alone: its workers must follow
    assert command.process.wait(timeout=GONE_WITHIN_S) == -signal.SIGKILL
    assert command.left_alive() == []  # the resource tracker too, once the workers are gone
    assert "leaked" not in command.stderr()
    assert _lines(command.stderr(), drop="sweep [") == []


def test_the_workers_of_a_local_cluster_are_deaf_to_ctrl_c_and_die_with_their_parent() -> None:
    from robodyn.sweep.engine import client_for

    def parent_death_signal_and_blocked() -> tuple[int, bool]:
        import ctypes

        value = ctypes.c_int(0)
        ctypes.CDLL(None).prctl(2, ctypes.byref(value), 0, 0, 0)  # PR_GET_PDEATHSIG
        return value.value, signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, set())

    if not sys.platform.startswith("linux"):
        pytest.skip("prctl(PR_SET_PDEATHSIG) is Linux's")
    with client_for(scheduler=None, workers=1) as client:
        found = client.run(parent_death_signal_and_blocked)
    assert list(found.values()) == [(signal.SIGKILL, True)]
    assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, set()), "this process hears Ctrl-C again"


# --------------------------------------------------------------------------- robodyn bench
# A robot robodyn did not build (no built-in kind): a slider of range [0, 0.2] m (the bench's +0.5 m
# offset from neutral 0 would start it outside) carrying a double pendulum.
SLIDER_PENDULUM = """<?xml version="1.0"?>
<robot name="slider_pendulum">
  <link name="base"/>
  <link name="carriage">
    <inertial><origin xyz="0 0 0"/><mass value="1.0"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="arm">
    <inertial><origin xyz="0 0 -0.25"/><mass value="0.5"/><inertia ixx="0.003" iyy="0.003" izz="0.0005" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="slide" type="prismatic"><parent link="base"/><child link="carriage"/><origin xyz="0 0 0"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.2" effort="10" velocity="10"/></joint>
  <link name="forearm">
    <inertial><origin xyz="0 0 -0.2"/><mass value="0.3"/><inertia ixx="0.002" iyy="0.002" izz="0.0003" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="swing" type="revolute"><parent link="carriage"/><child link="arm"/><origin xyz="0 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
  <joint name="elbow" type="revolute"><parent link="arm"/><child link="forearm"/><origin xyz="0 0 -0.5"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
</robot>
"""
# A bench that is quick: rk4 at two steps on ABA and the compiled backend, over 0.4 s.
TINY_PLAN = dict(
    error_horizon=0.2,
    energy_horizon=0.4,
    sample_interval=0.02,
    dts=(0.01, 0.005),
    rtols=(),
    fixed=("rk4",),
    adaptive=(),
    backends=("aba", "formula", "fast"),
    all_backends_for=("rk4",),
)


@pytest.fixture
def slider(tmp_path: Path) -> Path:
    path = tmp_path / "slider_pendulum.urdf"
    path.write_text(SLIDER_PENDULUM)
    return path


def test_a_user_robot_starts_inside_its_joint_ranges(slider: Path) -> None:
    import robodyn
    from robodyn.studies.bench import INSIDE_RANGE, start_state

    q0, v0 = start_state(robodyn.load(slider))
    assert q0[0] == pytest.approx(0.2 - INSIDE_RANGE * 0.2)  # 0.5 m would pass the upper limit: 10 % of the range in
    assert list(q0[1:]) == [-0.3, -0.3]  # inside their ranges: the usual offset
    assert not v0.any()


def test_a_user_robot_runs_the_compiled_backend_simulate_runs(slider: Path) -> None:
    import robodyn
    from robodyn.studies import bench

    result = bench.sweep(robodyn.load(slider), plan=bench.SweepPlan(**TINY_PLAN))
    assert [s.split(":")[0] for s in result.skipped] == ["formula"]  # not a built-in kind: no closed form
    fast = [r for r in result.results if r.backend == "fast"]
    aba = {r.dt: r for r in result.results if r.backend == "aba"}
    assert [r.dt for r in fast] == [0.01, 0.005]
    for r in fast:  # the same RK4 steps: the compiled loop agrees with ABA to round-off
        assert not r.diverged and r.error == pytest.approx(aba[r.dt].error, rel=1e-3)


def test_a_report_about_a_user_robot_holds_no_built_in_study(
    slider: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import json

    from robodyn.cli import main
    from robodyn.studies import bench

    monkeypatch.setattr(bench, "default_plan", lambda *, quick=False: bench.SweepPlan(**TINY_PLAN))
    out = tmp_path / "out"
    assert main(["bench", str(slider), "--quick", "--no-progress", "--out", str(out)]) == 0
    stability = json.loads((out / "stability.json").read_text())
    assert {x["case"] for x in stability["limits"]} == {"slider_pendulum"}
    assert not {"stiff", "chaos", "near_singular"} & set(stability)
    report = (out / "report.md").read_text()
    for study in ("geared_arm_stiff", "Chaos (pendubot", "lyapunov.png", "pendubot_light"):
        assert study not in report
    assert not (out / "lyapunov.png").exists()


def test_ctrl_c_during_a_bench_sweep_keeps_its_runs_on_a_line_of_their_own(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import json

    from robodyn.cli import main
    from robodyn.errors import SimulationInterrupted
    from robodyn.studies import bench

    monkeypatch.setattr(bench, "default_plan", lambda *, quick=False: bench.SweepPlan(**TINY_PLAN))
    original, calls = bench.run_one, []

    def run_one_then_ctrl_c(*args: object, **kwargs: object) -> object:
        calls.append(1)
        if len(calls) == 3:  # as simulate answers a Ctrl-C during its third run
            raise SimulationInterrupted("simulation interrupted at t = 0.1 s", trajectory=None)
        return original(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(bench, "run_one", run_one_then_ctrl_c)
    out = tmp_path / "out"
    assert main(["bench", "pendubot", "--no-stability", "--out", str(out)]) == 130
    err = capsys.readouterr().err
    (stage,) = out.glob("bench.partial.*")
    line = f"robodyn bench: interrupted; the results so far are in {stage} ({out} is left as it was)\n"
    assert err.endswith("\n" + line)  # after the progress bar's line, not glued to it
    records = json.loads((stage / "bench.json").read_text())
    assert [(r["backend"], r["dt"]) for r in records] == [("aba", 0.01), ("aba", 0.005)]


def test_ctrl_c_while_bench_moves_its_results_in_leaves_out_as_it_was(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.md").write_text("# an earlier run\n")
    (out / "bench.json").write_text("[]\n")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    command = Paused(tmp_path, "publish", "bench", "cart_pole", "--quick", "--no-stability", "--out", str(out))
    command.wait_for_window()  # the first new file is in out
    command.signal_group(signal.SIGINT)
    code = command.release()
    assert code == 130
    (stage,) = out.glob("bench.partial.*")
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    lines = _lines(command.stderr())
    assert lines[-1] == (
        f"robodyn bench: interrupted while the results were being moved in; they are in {stage} "
        f"({out} is left as it was)"
    )
    assert "Exception ignored" not in command.stderr() and "Traceback" not in command.stderr()
    assert (stage / "report.md").is_file() and (stage / "bench.json").is_file()
