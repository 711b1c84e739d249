"""Scene files: validation messages, example scenes, and robodyn run."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robodyn.cli import main
from robodyn.errors import EXIT_BAD_INPUT, SceneError
from robodyn.scene import read_scene

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
        ("[model]\nname = 'pendubot'\n[simulate]\ndt = -0.01\n", r"\[simulate\] dt: expected a number > 0, got -0.01"),
        ("[model]\nname = 'pendubot'\n[simulate]\nduration = 1e-4\n", r"\[simulate\] dt: the step 0.001 s .*default"),
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
        (
            "[model]\nname = 'pendubot'\n[control]\nkind = 'swing_upp'\n",
            r"\[control\] kind: unknown controller 'swing_upp'; did you mean 'swing_up'\?",
        ),
        ("[model]\nname = 'pendubot'\n[control]\nkind = 'constant'\n", r"\[control\] torque: missing"),
        ("[model]\nname = 'pendubot'\n[control]\nkp = 1.0\n", 'only kind = "pd" takes gains'),
        ("[model]\nname = 'pendubot'\n[initial]\nq = ['a']\n", r"\[initial\] q: expected a number"),
        ("[model]\nname = 'pendubot'\n[check]\nexactness = true\n", "needs a reduced model"),
        (
            "[model]\nname = 'pendubot'\n[check]\nsamples = 0\n",
            r"\[check\] samples: expected a whole number from 1 to 100000, got 0",
        ),
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


def test_simulate_defaults_are_those_of_robodyn_simulate(tmp_path):
    scene = read_scene(write(tmp_path, "[model]\nname = 'pendubot'\n[simulate]\n"))
    assert scene.simulate == {"duration": 2.0, "dt": 1e-3, "integrator": "rk4"}  # backend: simulate picks
    scene = read_scene(write(tmp_path, "[model]\nname = 'pendubot'\n[simulate]\ndt = 0.01\n"))
    assert scene.simulate is not None and scene.simulate["duration"] == 2.0 and scene.simulate["dt"] == 0.01


@pytest.mark.parametrize(
    ("model", "message"),
    [
        (
            "name = 'pendubot'\nkeep = ['nope']",
            r"\[model\] keep: unknown joint of pendubot to keep 'nope'; .*joint1, joint2",
        ),
        ("name = 'pendubot'\nlock = { nope = 0.1 }", r"\[model\] lock: unknown joint of pendubot to lock 'nope'"),
        ("name = 'panda'\nlock = { panda_joint1 = 99.0 }", r"\[model\] lock: lock value .* outside its limits"),
        ("name = 'panda'\nkeep = ['panda_joint2']\nreference = 'nope'", r"\[model\] reference: unknown reference"),
        ("name = 'pendubott'", r"\[model\] name: unknown model 'pendubott'"),
    ],
)
def test_model_errors_found_while_building_name_file_table_and_key(tmp_path, model, message):
    path = write(tmp_path, f"[model]\n{model}\n")
    with pytest.raises(SceneError, match=message) as info:
        read_scene(path).build()
    assert str(info.value).startswith(f"{path}: [model] ") and "\n" not in str(info.value)


def test_mimic_is_passed_to_the_model(tmp_path):
    # geared_arm_rotor: the rotor joint mimics the link joint (x 50); as a mimic joint it adds no DoF
    plain, _ = read_scene(write(tmp_path, "[model]\nname = 'geared_arm_rotor'\n")).build()
    coupled, _ = read_scene(write(tmp_path, "[model]\nname = 'geared_arm_rotor'\nmimic = true\n")).build()
    assert (plain.nv, coupled.nv) == (2, 1)


def test_run_with_mimic_runs_and_aba_refuses_in_one_line(tmp_path, capsys):
    text = "[model]\nname = 'geared_arm_rotor'\nmimic = true\n[simulate]\nduration = 0.05\n"
    assert main(["run", str(write(tmp_path, text)), "--out", str(tmp_path / "out")]) == 0  # simulate picks crba
    assert np.load(tmp_path / "out" / "scene.npz")["q"].shape[1] == 1  # the rotor mimics the link: nq = 1
    capsys.readouterr()
    path = write(tmp_path, text + "backend = 'aba'\n")
    assert main(["run", str(path), "--out", str(tmp_path / "out2")]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) == 1 and "crba" in err


def test_run_checks_the_output_folder_before_any_work(tmp_path, monkeypatch, capsys):
    from robodyn import scene as scene_module

    def no_build(self):
        raise AssertionError("the model was built before the output folder was checked")

    monkeypatch.setattr(scene_module.Scene, "build", no_build)
    path = write(tmp_path, GOOD + "[check]\nexactness = true\n")
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    for out, message in ((Path("/proc/zz"), "cannot write /proc/zz"), (a_file, "not a folder")):
        assert main(["run", str(path), "--out", str(out)]) == EXIT_BAD_INPUT
        err = capsys.readouterr().err
        assert message in err and len(err.splitlines()) == 1, err


def test_run_diverged_writes_the_summary_with_the_divergence(tmp_path, capsys):
    text = "[model]\nname = 'pendubot'\n[initial]\nq = [0.3, -0.2]\n[simulate]\nduration = 5.0\ndt = 0.05\nintegrator = 'euler'\n"
    out = tmp_path / "out"
    assert main(["run", str(write(tmp_path, text)), "--out", str(out)]) == 3
    assert "diverged" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["simulate"]["diverged"] is True and summary["simulate"]["step"] > 0
    assert "diverged" in summary["simulate"]["message"]
    # the partial run goes beside, never over, the NAME.npz of a complete run
    partial = out / "scene.partial.npz"
    assert summary["simulate"]["trajectory"] == str(partial) and partial.is_file()
    assert not (out / "scene.npz").exists()


def test_run_says_joint_for_one_and_joints_for_more(tmp_path, capsys):
    assert main(["run", str(write(tmp_path, GOOD)), "--out", str(tmp_path / "a")]) == 0
    assert "  locked 1 joint at joint1=0.5\n" in capsys.readouterr().out
    text = "[model]\nname = 'panda'\nkeep = ['panda_joint2']\nreference = 'default'\n"
    assert main(["run", str(write(tmp_path, text)), "--out", str(tmp_path / "b")]) == 0
    assert "  locked 8 joints at " in capsys.readouterr().out


def test_run_empty_view_serves_the_playback_and_prints_no_repr(tmp_path, monkeypatch, capsys):
    # [view] with no key: the documented default, a meshcat server playing the motion until Ctrl-C
    from robodyn.cli import view as view_cli

    served = []

    def fake_serve(playback, *, open_browser, zmq_url, port):
        served.append((playback.robot_name, playback.n_frames > 1, open_browser, zmq_url, port))
        return 0

    monkeypatch.setattr(view_cli, "serve_playback", fake_serve)
    out = tmp_path / "out"
    assert main(["run", str(write(tmp_path, GOOD + "[view]\n")), "--out", str(out)]) == 0
    assert served == [("pendubot", True, False, None, None)]
    stdout = capsys.readouterr().out
    assert "Replay(" not in stdout and len(stdout) < 2000
    assert json.loads((out / "summary.json").read_text())["view"] == {"server_port": None}


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
    assert summary["check"]["passed"] and summary["check"]["failed"] == []
    assert code == 0


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


@pytest.mark.parametrize("name", ["panda_arm", "geared_arm", "cart_pole", "pendubot", "cart_pole_swing_up"])
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


def test_run_gives_the_exactness_figures_their_units(tmp_path, capsys):
    """Every number of the exactness line has its unit: the lock drift's is the locked joints' (rad, m, or both)."""
    import re

    path = write(tmp_path, GOOD + "[check]\nsamples = 3\nexactness = true\n")
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("exactness:"))
    assert re.search(
        r"max \|dq\| = \S+ rad, max \|dv\| = \S+ rad/s, lock drift \S+ rad \(tolerance 1e-09 in each", line
    ), line
    slider = "[model]\nname = 'cart_pole'\nlock = { slider = 0.2 }\n[simulate]\nduration = 0.1\ndt = 1e-3\n"
    path = write(tmp_path, slider + "[check]\nsamples = 3\nexactness = true\n")
    assert main(["run", str(path), "--out", str(tmp_path / "out2")]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("exactness:"))
    assert re.search(r"max \|dq\| = \S+ rad, max \|dv\| = \S+ rad/s, lock drift \S+ m \(tolerance", line), line


# The Panda reduced to three joints under PD control, for 10 steps, with its exactness proof (kd to fill in).
PANDA_PD = """
[model]
name = "panda"
keep = ["panda_joint2", "panda_joint4", "panda_joint6"]
[control]
kind = "pd"
kp = 40.0
kd = {kd!r}
target = {{ panda_joint2 = -0.785398, panda_joint4 = -2.35619, panda_joint6 = 1.5707 }}
[simulate]
duration = 0.01
dt = 1e-3
[check]
samples = 2
exactness = true
"""


def test_exactness_starts_where_the_run_starts_inside_the_stops(tmp_path):
    """A q0 far outside a joint's limits is moved onto the limit for the run and for the exactness proof alike.

    Before: the proof integrated from q0 = -1e308 as given and failed with 'tau must be finite' (exit 2).
    """
    start = "[initial]\nq = { panda_joint2 = -1e308, panda_joint4 = -2.0, panda_joint6 = 1.2 }\n"
    path = write(tmp_path, start + PANDA_PD.format(kd=4.0))
    out = tmp_path / "out"
    assert main(["run", str(path), "--no-view", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["exactness"]["passed"]


def test_a_scene_formula_that_never_returns_stops_at_its_formula_timeout(tmp_path, capsys):
    """``formula_timeout`` in [check] bounds a formula file run from a scene, and the line names that key."""
    (tmp_path / "f.py").write_text("while True:\n    pass\n", encoding="utf-8")
    path = write(tmp_path, "[model]\nname = 'pendubot'\n[check]\nformula = 'f.py'\nsamples = 2\nformula_timeout = 1\n")
    assert main(["run", str(path), "--no-view", "--out", str(tmp_path / "out")]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert err.endswith("did not finish its import within 1 s ([check] formula_timeout); it was running line 1"), err
    assert "\n" not in err


def test_run_names_every_mismatching_entry_of_a_formula(tmp_path, capsys):
    """Two wrong entries of M (M[0,0] and M[0,1] = M[1,0]): run says each, as check does."""
    mine = (EXAMPLES / "formulas" / "pendubot_mine.py").read_text(encoding="utf-8")
    right = "return np.array([[t1 + t2 + 2 * t3 * c2, t2 + t3 * c2], [t2 + t3 * c2, t2]])"
    assert right in mine
    wrong = "return np.array([[2 * (t1 + t2 + 2 * t3 * c2), t2 + 2 * t3 * c2], [t2 + 2 * t3 * c2, t2]])"
    (tmp_path / "f.py").write_text(mine.replace(right, wrong), encoding="utf-8")
    path = write(tmp_path, "[model]\nname = 'pendubot'\n[check]\nformula = 'f.py'\nsamples = 3\n")
    assert main(["run", str(path), "--no-view", "--out", str(tmp_path / "out")]) == 1
    said = [line.split(" (")[0].strip() for line in capsys.readouterr().out.splitlines() if "MISMATCH M[" in line]
    assert sorted(said) == ["MISMATCH M[0,0]", "MISMATCH M[0,1]"], said  # M's row lists its upper triangle


def test_an_exactness_proof_that_blows_up_says_so_exit_3(tmp_path, capsys):
    """kd = 1e9 makes RK4 at 1 ms unstable: the proof's run diverges; the line says so (before: 'tau must be finite')."""
    path = write(tmp_path, PANDA_PD.format(kd=1e9))
    assert main(["run", str(path), "--no-view", "--out", str(tmp_path / "out")]) == 3
    err = capsys.readouterr().err.strip()
    assert "the exactness proof's run diverged by t = " in err and "\n" not in err, err


def test_run_passes_a_right_c_v_in_a_non_christoffel_c_as_check_does(tmp_path, capsys):
    """A scene's [check] gives the verdicts of robodyn check: the equations of motion agree, so exit 0."""
    grouped = EXAMPLES / "formulas" / "pendubot_grouped_c.py"
    (tmp_path / "f.py").write_text(grouped.read_text(encoding="utf-8"), encoding="utf-8")
    path = write(tmp_path, "[model]\nname = 'pendubot'\n[check]\nformula = 'f.py'\nsamples = 3\n")
    assert main(["run", str(path), "--no-view", "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "check: passed (equations of motion; C is not Christoffel's)" in out and "MISMATCH C[0,0]" in out
