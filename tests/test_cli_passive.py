"""``--passive JOINT[,JOINT]`` on simulate, check, run and sweep; ``passive`` in scenes and sweep files; the q0 note.

A URDF written elsewhere has no SRDF, so every joint counts as actuated: ``--passive`` declares the
unactuated ones through the one mechanism the SRDF's ``<passive_joint>`` goes through
(:func:`robodyn.model.load.load`). Every misspelt joint is one line naming the valid joints, exit 2.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robodyn
import robodyn.sweep as sweep
from robodyn.cli import main
from robodyn.errors import EXIT_BAD_INPUT, InputError, SceneError, UnknownNameError
from robodyn.scene import read_scene
from robodyn.sweep import chunk as chunk_module
from robodyn.sweep.plan import Chunk
from robodyn.sweep.source import ModelFile

FIXTURES = Path(__file__).resolve().parent / "fixtures"
OTHER = FIXTURES / "pendubot_other.urdf"  # the Spong-Block Pendubot as another lab wrote it: no SRDF

# The LQR from 0.05 rad off upright: the slowest closed-loop pole is ~ -1.3 /s, so after 2 s the error
# is ~0.05 e^-2.6 ~ 4e-3 rad; 0.01 rad says "balanced" with room, and 0.05 would be "did nothing".
LQR_SETTLED = 0.01  # [rad]


def one_error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    return err


# ------------------------------------------------------------------------------------------- load()
def test_load_adds_the_given_passive_joints_to_the_srdfs():
    assert robodyn.load(str(OTHER)).passive_joints == ()
    assert robodyn.load(str(OTHER), passive=["joint2"]).passive_joints == ("joint2",)
    assert list(robodyn.load(str(OTHER), passive="joint2").actuated) == [True, False]  # one name, not its letters
    assert robodyn.load("pendubot", passive=["joint2"]).passive_joints == ("joint2",)  # the SRDF says so too: once
    assert robodyn.load("pendubot", passive=["joint1"]).passive_joints == ("joint1", "joint2")  # the union


def test_load_refuses_a_passive_joint_the_model_lacks():
    with pytest.raises(UnknownNameError, match=r"unknown passive joint 'joint3'.*expected one of: joint1, joint2"):
        robodyn.load(str(OTHER), passive=["joint3"])


# ------------------------------------------------------------------------------------------- simulate
def test_simulate_passive_makes_one_torque_per_remaining_actuator(tmp_path, capsys):
    """With joint2 passive, one torque entry is the shoulder's; without it, one entry is too few."""
    out = tmp_path / "run.npz"
    args = ["simulate", str(OTHER), "--torque", "0.5", "--duration", "0.01", "--out", str(out)]
    assert main([*args, "--passive", "joint2"]) == 0
    trajectory = robodyn.Trajectory.load(out)
    assert np.all(trajectory.tau[:, 0] == 0.5) and np.all(trajectory.tau[:, 1] == 0.0)
    capsys.readouterr()
    assert main(args) == EXIT_BAD_INPUT
    assert "torque" in one_error_line(capsys)


@pytest.mark.parametrize(
    "command",
    [
        ["simulate", str(OTHER), "--duration", "0.01"],
        ["check", str(OTHER), "--samples", "2"],
    ],
    ids=["simulate", "check"],
)
def test_an_unknown_passive_joint_is_one_line_naming_the_valid_ones(command, capsys):
    assert main([*command, "--passive", "joint2,elbow"]) == EXIT_BAD_INPUT
    err = one_error_line(capsys)
    assert "--passive joint2,elbow: unknown passive joint 'elbow'" in err
    assert "expected one of: joint1, joint2" in err


def test_an_empty_passive_name_is_refused_by_the_parser(capsys):
    with pytest.raises(SystemExit) as info:
        main(["simulate", str(OTHER), "--passive", "joint2,"])
    assert info.value.code == EXIT_BAD_INPUT
    assert "expected joint names separated by commas" in capsys.readouterr().err


def test_check_takes_passive(capsys):
    assert main(["check", str(OTHER), "--passive", "joint2", "--samples", "2"]) == 0


# ------------------------------------------------------------------------------------------- scenes
SCENE = """
[model]
urdf = "{urdf}"
{passive}

[initial]
q = [1.0, 0.0]

[control]
torque = [0.25, {elbow}]

[simulate]
duration = 0.01
"""


def write_scene(tmp_path: Path, passive: str = "", elbow: float = 0.0) -> Path:
    path = tmp_path / "other.toml"
    path.write_text(SCENE.format(urdf=OTHER.as_posix(), passive=passive, elbow=elbow))
    return path


def test_a_scene_declares_passive_joints(tmp_path):
    scene = read_scene(write_scene(tmp_path, 'passive = ["joint2"]'))
    robot, _ = scene.build()
    assert robot.passive_joints == ("joint2",)
    assert list(robot.actuated) == [True, False]


def test_run_passive_adds_to_the_scene(tmp_path, capsys):
    """A torque on the elbow runs while the elbow is actuated, and is refused once --passive declares it passive."""
    path = write_scene(tmp_path, elbow=0.1)
    assert main(["run", str(path), "--out", str(tmp_path / "a")]) == 0
    capsys.readouterr()
    assert main(["run", str(path), "--out", str(tmp_path / "b"), "--passive", "joint2"]) == EXIT_BAD_INPUT
    assert "passive" in one_error_line(capsys)
    assert main(["run", str(write_scene(tmp_path)), "--out", str(tmp_path / "c"), "--passive", "joint2"]) == 0


def test_a_scene_with_an_unknown_passive_joint_names_the_key(tmp_path):
    scene = read_scene(write_scene(tmp_path, 'passive = ["elbow"]'))
    with pytest.raises(SceneError, match=r"\[model\] passive: unknown passive joint 'elbow'.*joint1, joint2"):
        scene.build()


def test_a_scene_passive_that_is_not_a_list_of_names_is_refused(tmp_path):
    with pytest.raises(SceneError, match=r"\[model\] passive: expected a list of joint names"):
        read_scene(write_scene(tmp_path, 'passive = "joint2"'))


# ------------------------------------------------------------------------------------------- sweeps
def sweep_of(**changes: object) -> dict[str, object]:
    spec: dict[str, object] = {
        "model": str(OTHER),
        "duration": 2.0,
        "controller": "lqr",
        "measure": ["final_state"],
        "q0": {"joint1": [np.pi / 2 + 0.05], "joint2": 0.0},
    }
    spec.update(changes)
    return spec


def test_a_sweep_file_declares_passive_joints_and_its_runs_use_them(tmp_path):
    prepared = sweep.prepare(sweep_of(passive=["joint2"]), tmp_path / "out")
    (c,) = prepared.plan.chunks
    assert c.model == ModelFile(str(OTHER), ("joint2",))
    robot = chunk_module.robot_of(c.model)
    assert robot.passive_joints == ("joint2",)
    controller = chunk_module.controller_of(c.model, "lqr", prepared.job.gains)
    assert controller.B.shape == (4, 1)  # one input: the shoulder
    rows = chunk_module.execute(Chunk(c.id, c.index, c.setting, c.model, c.runs, c.q0, c.v0), prepared.job)
    q1 = np.asarray(rows["q.joint1"], dtype=float)
    assert np.all(np.abs(q1 - np.pi / 2) < LQR_SETTLED)


def test_the_passive_set_changes_a_sweeps_digest(tmp_path):
    plain = sweep.prepare(sweep_of(), tmp_path / "a").spec.digest
    passive = sweep.prepare(sweep_of(passive=["joint2"]), tmp_path / "b").spec.digest
    assert plain != passive  # results computed with another actuation are never resumed as these


def test_an_edited_model_file_changes_a_passive_sweeps_digest(tmp_path):
    """The model's bytes are in the digest whatever wraps its name (here its passive set)."""
    urdf = tmp_path / "other.urdf"
    urdf.write_text(OTHER.read_text())
    before = sweep.prepare(sweep_of(model=str(urdf), passive=["joint2"]), tmp_path / "a").spec.digest
    urdf.write_text(OTHER.read_text().replace('<mass value="0.4"/>', '<mass value="0.41"/>'))
    after = sweep.prepare(sweep_of(model=str(urdf), passive=["joint2"]), tmp_path / "b").spec.digest
    assert before != after


def test_a_sweep_with_an_unknown_passive_joint_is_refused(tmp_path):
    with pytest.raises(InputError, match=r"passive: unknown passive joint 'elbow'.*joint1, joint2"):
        sweep.prepare(sweep_of(passive=["elbow"]), tmp_path / "out")


def test_sweep_cli_passive_reaches_the_runs(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(f'model = "{OTHER.as_posix()}"\ncontroller = "swing_up"\nduration = 0.1\n')
    assert main(["sweep", str(path), "--out", str(tmp_path / "o"), "--passive", "elbow"]) == EXIT_BAD_INPUT
    assert "unknown passive joint 'elbow'" in one_error_line(capsys)
    # swing_up refuses a robot with both joints actuated: --passive joint2 is what lets prepare build it
    assert main(["sweep", str(path), "--out", str(tmp_path / "o")]) == EXIT_BAD_INPUT
    assert "declare it passive (--passive joint2" in one_error_line(capsys)


# ------------------------------------------------------------------------------------------- q0 note
def test_a_q0_moved_onto_a_limit_is_said_in_one_note(capsys):
    assert main(["simulate", "cart_pole", "--q0", "3,0.1", "--duration", "0.01"]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if "note:" in line]
    assert notes == [
        "robodyn simulate: note: q0: slider = 3 m is outside its limits, moved onto its upper limit 2.4 m "
        "(the run starts there)"
    ]


def test_a_q0_inside_the_limits_gives_no_note(capsys):
    assert main(["simulate", "cart_pole", "--q0", "2.4,0.1", "--duration", "0.01"]) == 0
    assert "note:" not in capsys.readouterr().err


def test_run_says_it_too(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text('[model]\nname = "cart_pole"\n[initial]\nq = [-2.5, 0.1]\n[simulate]\nduration = 0.01\n')
    assert main(["run", str(path), "--out", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    assert "robodyn run: note: q0: slider = -2.5 m is outside its limits, moved onto its lower limit -2.4 m" in err
