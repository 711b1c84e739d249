"""Scene files: validation messages, example scenes, and robodyn run."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robodyn.cli import main
from robodyn.errors import EXIT_BAD_INPUT
from robodyn.scene import SceneError, read_scene

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

GOOD = """
[model]
name = "pendubot"
lock = { joint1 = 0.5 }

[initial]
q = { joint2 = 1.0 }

[simulate]
duration = 0.2
dt = 1e-3
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "scene.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[model]\nname = 'pendubot'\n[simulat]\n", r"\[simulat\]: unknown table; expected one of: model"),
        ("[model]\nname = 'pendubot'\ncolour = 1\n", r"\[model\] colour: unknown key; expected one of: name"),
        ("[initial]\nq = [1]\n", r"\[model\]: missing"),
        ("[model]\nname = 'a'\nurdf = 'b.urdf'\n", "exactly one of name"),
        ("[model]\nurdf = 'nothere.urdf'\n", r"\[model\] urdf: no such file"),
        ("[model]\nname = 'pendubot'\n[simulate]\ndt = 0.01\n", r"\[simulate\] duration: missing"),
        (
            "[model]\nname = 'pendubot'\n[simulate]\nduration = 1\ndt = -0.01\n",
            r"\[simulate\] dt: expected a number > 0",
        ),
        ("[model]\nname = 'pendubot'\n[simulate]\nduration = 0.1\ndt = 1\n", "longer than the duration"),
        (
            "[model]\nname = 'pendubot'\n[simulate]\nduration = 1\ndt = 0.1\nintegrator = 'rk5'\n",
            "unknown integrator 'rk5'",
        ),
        ("[model]\nname = 'pendubot'\nkeep = 'joint1'\n", r"\[model\] keep: expected a non-empty list"),
        ("[model]\nname = 'pendubot'\n[control]\nkind = 'lqr'\n", "unknown controller 'lqr'"),
        ("[model]\nname = 'pendubot'\n[control]\nkind = 'constant'\n", r"\[control\] torque: missing"),
        ("[model]\nname = 'pendubot'\n[control]\nkp = 1.0\n", 'only kind = "pd" takes gains'),
        ("[model]\nname = 'pendubot'\n[initial]\nq = ['a']\n", r"\[initial\] q: expected a number"),
        ("[model]\nname = 'pendubot'\n[check]\nexactness = true\n", "needs a reduced model"),
        ("[model]\nname = 'pendubot'\n[check]\nsamples = 0\n", r"\[check\] samples: expected a number > 0"),
        ("[model]\nname = 'pendubot'\n[view]\nopen = true\n", r"\[view\]: needs \[simulate\]"),
        ("[model\nname = 'pendubot'\n", "not valid TOML"),
    ],
)
def test_validation_errors_name_file_table_and_key(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(SceneError, match=message) as info:
        read_scene(path)
    assert str(path) in str(info.value)
    assert "\n" not in str(info.value)


def test_missing_scene_file(tmp_path):
    with pytest.raises(SceneError, match="no such scene file"):
        read_scene(tmp_path / "nope.toml")


def test_joint_names_are_checked_against_the_minimal_model(tmp_path):
    scene = read_scene(write(tmp_path, GOOD.replace("joint2 = 1.0", "joint1 = 1.0")))
    robot, reduction = scene.build()
    with pytest.raises(SceneError, match="no joint 'joint1' in the scene's model; joints: joint2"):
        scene.initial_state(robot, reduction)


def test_initial_state_defaults_to_the_reference(tmp_path):
    text = "[model]\nname = 'panda'\nkeep = ['panda_joint4']\nreference = 'default'\n"
    scene = read_scene(write(tmp_path, text))
    robot, reduction = scene.build()
    q0, v0 = scene.initial_state(robot, reduction)
    np.testing.assert_allclose(q0, [-2.35619])
    np.testing.assert_array_equal(v0, [0.0])


def test_pd_controller_drives_to_target(tmp_path):
    text = GOOD + "[control]\nkind = 'pd'\nkp = 2.0\nkd = 0.5\ntarget = { joint2 = 0.0 }\n"
    scene = read_scene(write(tmp_path, text.replace("lock = { joint1 = 0.5 }", "keep = ['joint1', 'joint2']")))
    robot, _ = scene.build()
    tau = scene.torque(robot)
    out = tau(0.0, np.array([0.1, 1.0]), np.array([1.0, 0.0]))
    # joint1 actuated: 2 (0 - 0.1) - 0.5 * 1 = -0.7 (target of joint1 is its initial 0.0); joint2 passive: 0
    np.testing.assert_allclose(out, [-0.7, 0.0])


def test_run_writes_summary_and_trajectory(tmp_path):
    path = write(tmp_path, GOOD + "[check]\nsamples = 3\nexactness = true\n[bench]\nrepeat = 5\n")
    out = tmp_path / "out"
    code = main(["run", str(path), "--out", str(out)])
    summary = json.loads((out / "summary.json").read_text())
    assert summary["nv"] == 1 and summary["full_nv"] == 2
    assert summary["exactness"]["passed"]
    assert (out / "scene.npz").is_file()
    assert code in (0, 1)  # 1 only if a structural check row fails (see summary["check"])
    assert code == (0 if summary["check"]["passed"] else 1)


def test_run_view_html_writes_the_replay_page(tmp_path):
    path = write(tmp_path, GOOD + "[view]\nhtml = 'replay.html'\n")
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out)]) == 0
    page = (tmp_path / "replay.html").read_text()  # relative to the scene file's folder
    assert page.startswith("<!DOCTYPE html>") and "<title>robodyn: pendubot</title>" in page
    assert "handle_command_bytearray" in page  # meshcat's player is inlined: the page replays offline
    summary = json.loads((out / "summary.json").read_text())
    assert summary["view"] == {"html": str(tmp_path / "replay.html")}


def test_run_bad_scene_exit_code(tmp_path, capsys):
    path = write(tmp_path, "[model]\nname = 'pendubot'\n[simulate]\nduration = -1\ndt = 0.1\n")
    assert main(["run", str(path)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "[simulate] duration" in err and "Traceback" not in err


@pytest.mark.parametrize("name", ["panda_arm", "geared_arm", "cart_pole", "pendubot"])
def test_example_scenes_validate_and_build(name):
    scene = read_scene(EXAMPLES / f"{name}.toml")
    robot, reduction = scene.build()
    q0, v0 = scene.initial_state(robot, reduction)
    assert q0.shape == (robot.nq,) and v0.shape == (robot.nv,)
    if name == "panda_arm":
        assert robot.nv == 3 and reduction is not None and reduction.full.nv == 9


def test_panda_arm_scene_runs_in_a_subprocess(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "robodyn", "run", str(EXAMPLES / "panda_arm.toml"), "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    assert "9 -> 3 DoF" in result.stdout and "exactness: passed" in result.stdout
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["exactness"]["q_error"] < 1e-10
