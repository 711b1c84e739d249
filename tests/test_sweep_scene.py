"""A sweep file that names a scene: the scene supplies model, state, timing, constraints, controller; axes override."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

import robodyn
import robodyn.sweep as sweep
from robodyn.cli import main
from robodyn.errors import InputError
from robodyn.scene import read_scene

from ._dask_helpers import two_workers

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
# The sweep's simulate path against robodyn.simulate on a model reduced by the scene, and on the
# same URDF reduced by robodyn.load(lock=...): the same model built twice, round-off over 2,000 steps.
SAME_MODEL_ATOL = 1e-10
# The swing-up's closed loop (closed form) against simulate with the scene's controller (Pinocchio):
# round-off (7e-15 measured over 0.4 s) grown over 8 s of a swing-up and balance; a wrong gain or
# law is off by > 1e-3.
SWING_UP_ATOL = 1e-7

# The Pendubot scene of examples/: shoulder locked at 0.5 rad, the elbow a 1-DoF pendulum, 2 s at 1 ms.
LOCKED_SCENE = EXAMPLES / "pendubot.toml"


@pytest.fixture(scope="module")
def client():
    with two_workers() as c:
        yield c


def layout(tmp_path: Path, sweep_text: str, scene_text: str | None = None) -> Path:
    """scenes/pendubot.toml (a copy, or ``scene_text``) and sweeps/sweep.toml naming it as ../scenes/pendubot.toml."""
    (tmp_path / "scenes").mkdir()
    (tmp_path / "sweeps").mkdir()
    scene = tmp_path / "scenes" / "pendubot.toml"
    if scene_text is None:
        shutil.copy(LOCKED_SCENE, scene)
    else:
        scene.write_text(scene_text)
    path = tmp_path / "sweeps" / "sweep.toml"
    path.write_text('scene = "../scenes/pendubot.toml"\n' + sweep_text)
    return path


def test_scene_supplies_model_state_and_timing_and_axes_override(tmp_path, monkeypatch):
    path = layout(tmp_path, 'measure = ["final_state"]\nchunk = 2\n[v0]\njoint2 = [0.0, 1.0, -2.0]\n')
    elsewhere = tmp_path / "a" / "b"
    elsewhere.mkdir(parents=True)
    monkeypatch.chdir(elsewhere)  # relative paths go by the sweep file's folder: ../scenes is not a/scenes
    result = sweep.run(path, out=tmp_path / "out", workers=1)  # the default reader: robodyn.scene.read_scene
    table = result.table().to_pydict()
    scene = read_scene(LOCKED_SCENE)
    robot, _ = scene.build()
    assert robot.joint_names == ("joint2",)  # the scene's minimal model: the shoulder is locked
    assert table["q0.joint2"] == [1.0, 1.0, 1.0]  # the scene's [initial] q where the sweep has no axis
    assert table["v0.joint2"] == [0.0, 1.0, -2.0]  # the sweep's axis
    # the elbow has URDF limits (+-1000 rad) that the batch path could not stop at: simulate runs it
    assert table["dt"] == [1e-3] * 3 and set(table["path"]) == {"simulate"}
    for k in range(3):  # 2 s, the scene's duration: the same call, the same bits
        ref = robodyn.simulate(robot, [1.0], [table["v0.joint2"][k]], duration=2.0, dt=1e-3, integrator="rk4")
        assert table["q.joint2"][k] == ref.q[-1, 0] and table["v.joint2"][k] == ref.v[-1, 0]


def test_sweep_keys_override_the_scenes_simulate_table(tmp_path):
    path = layout(tmp_path, 'duration = 0.5\ndt = 2e-3\nintegrator = "heun"\nmeasure = ["final_state"]\n')
    prepared = sweep.prepare(path, tmp_path / "out", read_scene=read_scene)
    assert prepared.spec.duration == 0.5 and prepared.spec.dts == (2e-3,) and prepared.spec.integrators == ("heun",)


def test_scene_constraints_reach_every_run(tmp_path):
    """A spring in the scene: the runs go through simulate with it, bit for bit as simulate alone."""
    text = LOCKED_SCENE.read_text() + "\n[springs]\njoint2 = { stiffness = 3.0, rest = 0.2 }\n"
    path = layout(tmp_path, 'measure = ["final_state", "energy_drift"]\n[q0]\njoint2 = [0.4, 1.2]\n', text)
    table = sweep.run(path, out=tmp_path / "out", workers=1, read_scene=read_scene).table().to_pydict()
    assert set(table["path"]) == {"simulate"}
    scene = read_scene(tmp_path / "scenes" / "pendubot.toml")
    robot, _ = scene.build()
    for k, q0 in enumerate((0.4, 1.2)):
        ref = robodyn.simulate(robot, [q0], [0.0], duration=2.0, dt=1e-3, constraints=scene.constraints)
        free = robodyn.simulate(robot, [q0], [0.0], duration=2.0, dt=1e-3)
        assert table["q.joint2"][k] == ref.q[-1, 0] != free.q[-1, 0]


def test_an_edited_scene_is_another_sweep(tmp_path):
    """The scene file's bytes are part of the sweep's digest: old results are refused, not reused."""
    path = layout(tmp_path, 'measure = ["final_state"]\n')
    sweep.run(path, out=tmp_path / "out", workers=1, read_scene=read_scene)
    scene = tmp_path / "scenes" / "pendubot.toml"
    scene.write_text(scene.read_text() + "\n[springs]\njoint2 = { stiffness = 3.0, rest = 0.2 }\n")
    with pytest.raises(InputError, match="another sweep"):
        sweep.run(path, out=tmp_path / "out", workers=1, read_scene=read_scene)


def test_params_axis_rewrites_the_scenes_model(tmp_path):
    path = layout(tmp_path, 'measure = ["final_state"]\n[params]\nm2 = [0.5, 0.65]\n')
    result = sweep.run(path, out=tmp_path / "out", workers=1, read_scene=read_scene)
    table = result.table().to_pydict()
    assert table["params.m2"] == [0.5, 0.65] and table["q0.joint2"] == [1.0, 1.0]
    urdfs = sorted((tmp_path / "out" / "models").glob("*.urdf"))
    assert len(urdfs) == 2
    for urdf in urdfs:
        robot = robodyn.load(urdf, lock={"joint1": 0.5})
        ref = robodyn.simulate(robot, [1.0], [0.0], duration=2.0, dt=1e-3)
        assert min(abs(x - ref.q[-1, 0]) for x in table["q.joint2"]) < SAME_MODEL_ATOL
    assert abs(table["q.joint2"][0] - table["q.joint2"][1]) > 1e-3  # the heavier elbow moves otherwise


def test_example_swing_up_sweep_over_a_scene(client, tmp_path):
    """examples/sweeps/cart_pole_swing_up.toml: the scene's swing-up, vectorised, balances every start."""
    example = EXAMPLES / "sweeps" / "cart_pole_swing_up.toml"
    result = sweep.run(example, out=tmp_path / "out", client=client, read_scene=read_scene)
    table = result.table().to_pydict()
    assert result.plan.n_runs == 27 and len(result.plan.chunks) == 2
    assert set(table["controller"]) == {"scene"} and set(table["path"]) == {"closed_loop"}
    assert all(0.0 < t < 8.0 for t in table["time_to_balance"])  # every start swung up and held
    scene = read_scene(EXAMPLES / "cart_pole_swing_up.toml")
    robot, _ = scene.build()
    controller = scene.torque(robot)
    for k in (0, 26):
        q0 = [table["q0.slider"][k], table["q0.hinge"][k]]
        ref = robodyn.simulate(robot, q0, [0.0, 0.0], duration=8.0, dt=1e-3, torque=controller)
        got = [table["q.slider"][k], table["q.hinge"][k]]
        np.testing.assert_allclose(got, ref.q[-1], rtol=0, atol=SWING_UP_ATOL)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ('scene = "../scenes/nowhere.toml"\n', r"nowhere.toml: no such scene file \(expected a .toml scene file\)"),
        ('scene = "../scenes/pendubot.toml"\n[q0]\njoint1 = [0.0, 1.0]\n', r"unknown joint in \[q0\] 'joint1'"),
        ('scene = "../scenes/pendubot.toml"\n[v0]\njoint9 = 1.0\n', r"unknown joint in \[v0\] 'joint9'"),
        ('scene = "../scenes/pendubot.toml"\nmodel = "pendubot"\n', "give exactly one of 'model'"),
        ('model = "pendubot"\ncontroller = "scene"\n', "controller 'scene' is the scene's \\[control\\]"),
        ('scene = "../scenes/pendubot.txt"\n', "scene must be a scene file NAME.toml"),
        ('scene = "../scenes/pendubot.toml"\ncontroller = "scene"\n[gains.scene]\nR = 1.0\n', r"\[gains.scene\]: the"),
    ],
)
def test_bad_scene_sweep_is_one_line_exit_2(text, expected, tmp_path, capsys):
    layout(tmp_path, "")
    path = tmp_path / "sweeps" / "bad.toml"
    path.write_text(text)
    code = main(["sweep", str(path), "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("robodyn sweep: error: "), err
    assert re.search(expected, err), err
    assert not (tmp_path / "out" / "results").exists()


def test_a_given_scene_reader_replaces_the_default(tmp_path):
    path = layout(tmp_path, "")
    seen = []

    def reader(p):
        seen.append(Path(p).name)
        return read_scene(p)

    default = sweep.prepare(path, tmp_path / "a")
    given = sweep.prepare(path, tmp_path / "b", read_scene=reader)
    assert seen == [LOCKED_SCENE.name]
    assert given.spec.digest == default.spec.digest  # the same scene, read either way
