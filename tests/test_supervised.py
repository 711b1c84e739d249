"""A controller file runs in a watched child (robodyn.control.supervised): it cannot fake a run, hang it or corrupt it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robodyn.cli import main
from robodyn.control import supervised
from robodyn.sim.trajectory import Trajectory

ROOT = Path(__file__).resolve().parents[1]
HEAD = "import os\nimport sys\n\nimport numpy as np\n\n"


def controller(tmp_path: Path, body: str, name: str = "ctl.py") -> Path:
    path = tmp_path / name
    path.write_text(HEAD + body)
    return path


def robodyn_process(argv: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    """robodyn as a fresh process: an os._exit that escaped would end it, never this test run."""
    env = {"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin", "OPENBLAS_NUM_THREADS": "1"}
    return subprocess.run(
        [sys.executable, "-m", "robodyn", *argv], cwd=cwd, env=env, capture_output=True, text=True, timeout=300
    )


@pytest.mark.parametrize(
    "body",
    ["os._exit(0)\n", "def make(robot, **gains):\n    return lambda t, q, v: os._exit(0)\n"],
    ids=["at-import", "in-tau"],
)
def test_os_exit_in_a_controller_file_is_no_finished_run(tmp_path: Path, body: str) -> None:
    controller(tmp_path, body)
    done = robodyn_process(
        ["simulate", "pendubot", "--controller", "ctl.py", "--duration", "0.05", "--out", "x.npz"], tmp_path
    )
    assert done.returncode == 2, (done.stdout, done.stderr)
    assert done.stderr.splitlines() == [
        "robodyn simulate: error: ctl.py: the controller file ended the simulation's process "
        "(exit code 0: os._exit in the file, or a crash?); no run done"
    ]
    assert not (tmp_path / "x.npz").exists()


def test_os_exit_in_a_scenes_controller_file_is_no_finished_run(tmp_path: Path) -> None:
    controller(tmp_path, "def make(robot, **gains):\n    return lambda t, q, v: os._exit(0)\n")
    (tmp_path / "s.toml").write_text(
        '[model]\nname = "pendubot"\n[control]\nkind = "file"\npath = "ctl.py"\n'
        '[simulate]\nduration = 0.05\ndt = 0.001\nintegrator = "rk4"\n'
    )
    done = robodyn_process(["run", "s.toml", "--no-view", "--out", "out"], tmp_path)
    assert done.returncode == 2, (done.stdout, done.stderr)
    assert "the controller file ended the simulation's process" in done.stderr


LOOPS = "        while True:\n            pass\n"
# issue 39 item 10: a time limit that is a plain Exception is caught here, and the run ends 0 with the fall-back torque
LOOPS_INSIDE_A_TRY = (
    "        try:\n"
    + LOOPS.replace("        ", "            ")
    + ("        except Exception:\n            return np.zeros(1)\n")
)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("body", [LOOPS, LOOPS_INSIDE_A_TRY], ids=["loop", "loop_in_try_except_exception"])
def test_an_endless_loop_in_tau_ends_at_the_call_limit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, body: str
) -> None:
    monkeypatch.setattr("robodyn.control.user_controller.CALL_TIMEOUT", 0.5)  # the forked child inherits it
    path = controller(tmp_path, f"def make(robot, **gains):\n    def tau(t, q, v):\n{body}    return tau\n")
    assert main(["simulate", "pendubot", "--controller", str(path), "--duration", "0.05"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"robodyn simulate: error: {path}: the controller did not return within 0.5 s at t = 0 s (an endless loop?)"
    ]


@pytest.mark.parametrize(
    ("write", "backend"), [("q[1] = 0.0", []), ("v *= 2", ["--backend", "aba"]), ("np.copyto(q, 0.0)", [])]
)
def test_a_controller_cannot_write_into_the_state(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], write: str, backend: list[str]
) -> None:
    path = controller(
        tmp_path,
        f"def make(robot, **gains):\n    def tau(t, q, v):\n        {write}\n        return np.zeros(2)\n    return tau\n",
    )
    assert (
        main(["simulate", "pendubot", "--q0", "0.3,0.2", "--controller", str(path), "--duration", "0.05", *backend])
        == 2
    )
    err = capsys.readouterr().err
    assert f"{path}:8: the controller wrote into its argument q or v at t = 0 s; they are read-only" in err
    assert len(err.splitlines()) == 1


@pytest.mark.parametrize(
    ("returns", "message"),
    [
        ("np.zeros(2) * (1 + 1j)", "returned complex numbers at t = 0 s; expected real torques"),
        ("['1', '2']", "returned list of dtype <U1 at t = 0 s"),
        ("[2**70, 0]", "returned list of dtype object"),
        ("[1.0, [2.0, 3.0]]", "returned list at t = 0 s, not an array of numbers"),
    ],
)
def test_torques_that_are_not_real_numbers_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], returns: str, message: str
) -> None:
    path = controller(tmp_path, f"def make(robot, **gains):\n    return lambda t, q, v: {returns}\n")
    assert main(["simulate", "pendubot", "--controller", str(path), "--duration", "0.05"]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.splitlines()) == 1, err


def test_a_supervised_run_is_the_run_in_process(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # the trajectory crosses the pipe whole: the same numbers as the same controller run without the child
    path = controller(
        tmp_path, "def make(robot, **gains):\n    return lambda t, q, v: np.array([0.3 * np.sin(5 * t), 0.0])\n"
    )
    argv = [
        "simulate",
        "pendubot",
        "--q0",
        "0.3,0.2",
        "--controller",
        str(path),
        "--duration",
        "0.1",
        "--backend",
        "aba",
    ]
    assert main([*argv, "--out", str(tmp_path / "child.npz")]) == 0
    child = Trajectory.load(tmp_path / "child.npz")
    import robodyn
    from robodyn import control

    robot = robodyn.load("pendubot")
    here = robodyn.simulate(
        robot, [0.3, 0.2], [0.0, 0.0], duration=0.1, dt=1e-3, torque=control.make(str(path), robot), backend="aba"
    )
    for name in ("t", "q", "v", "tau", "kinetic", "potential", "work_input"):
        np.testing.assert_array_equal(getattr(child, name), getattr(here, name))  # identical arithmetic
    assert child.meta["controller"]["name"] == str(path)


def test_a_diverging_supervised_run_keeps_its_partial_trajectory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = controller(tmp_path, "def make(robot, **gains):\n    return lambda t, q, v: np.array([1e6, 0.0])\n")
    out = tmp_path / "x.npz"
    argv = ["simulate", "pendubot", "--controller", str(path), "--no-effort-limits", "--dt", "0.1", "--duration", "2"]
    assert main([*argv, "--out", str(out)]) == 3
    err = capsys.readouterr().err
    assert "diverged at step" in err and "partial trajectory written to" in err
    assert Trajectory.load(tmp_path / "x.partial.npz").status == "diverged"


def test_errors_come_back_with_their_exit_code() -> None:
    from robodyn.errors import MissingDependencyError, RobodynError

    def job() -> int:
        raise MissingDependencyError("meshcat is missing")

    with pytest.raises(RobodynError, match="meshcat is missing") as caught:
        supervised.run_supervised(job, source="x.py")
    assert caught.value.exit_code == 4
    assert supervised.run_supervised(lambda: 7, source="x.py") == 7
