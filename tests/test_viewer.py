"""robodyn.viewer and ``robodyn view``: headless, no browser.

The animation is checked against Pinocchio directly (frame placements composed with the
geometry placements, a different route from the viewer's updateGeometryPlacements), the
servers are started for real on localhost, and bad input is checked for its exit code.
"""

from __future__ import annotations

import base64
import dataclasses
import json
import os
import re
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import robodyn
from robodyn import viewer
from robodyn.cli import main
from robodyn.errors import InputError, MissingDependencyError, UnavailableError, UnknownNameError
from robodyn.sim.trajectory import Trajectory

from ._viewer_helpers import SERVER_WAIT_S, interrupt, view_process

TRANSFORM_ATOL = 1e-12  # float64 matrix -> quaternion -> matrix round trip, nothing else in between
TIME_RTOL = 1e-12  # keyframe times are (t - t0) / speed * fps / fps: a few roundings
LEDGER_ATOL = 1e-12  # the panel's residual sums the same works in another order: roundings of ~1 J
FRACTION_RTOL = 1e-6  # the camera distance is bisected to far below this

ROOT = viewer.ROOT


def closed_form_trajectory(robot: robodyn.Robot, *, duration: float = 2.0, dt: float = 0.001) -> Trajectory:
    """A smooth motion through many poses, with the energies evaluated by the robot."""
    t = np.arange(0.0, duration + dt / 2, dt)
    phases = np.arange(1, robot.nq + 1)
    q = -np.pi / 2 + 1.1 * np.sin(np.outer(t, 1.7 * phases) + phases)
    v = 1.1 * 1.7 * phases * np.cos(np.outer(t, 1.7 * phases) + phases)
    kinetic = np.array([robot.kinetic_energy(qk, vk) for qk, vk in zip(q, v, strict=True)])
    potential = np.array([robot.potential_energy(qk) for qk in q])
    zeros = np.zeros_like(t)
    return Trajectory(
        t=t,
        q=q,
        v=v,
        a=np.zeros_like(v),
        tau=np.zeros_like(v),
        kinetic=kinetic,
        potential=potential,
        work_input=zeros,
        work_damping=zeros,
        meta={"model": robot.name, "joint_names": list(robot.joint_names)},
    )


@pytest.fixture(scope="module")
def pendubot() -> robodyn.Robot:
    return robodyn.load("pendubot")


@pytest.fixture(scope="module")
def motion(pendubot: robodyn.Robot) -> Trajectory:
    return closed_form_trajectory(pendubot)


@pytest.fixture(scope="module")
def motion_file(motion: Trajectory, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return motion.save(tmp_path_factory.mktemp("traj") / "pendubot.npz")


def oracle_geometry_placements(robot: robodyn.Robot, q: np.ndarray) -> list[np.ndarray]:
    """oMg = oMf[parent frame] * placement, by the frames' route (not updateGeometryPlacements)."""
    from robodyn.model.load import load_geometry

    geometry = load_geometry(robot)
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return [np.array((data.oMf[g.parentFrame] * g.placement).homogeneous) for g in geometry.geometryObjects]


# --------------------------------------------------------------------------- sampling
def test_one_rendered_sample_per_frame_at_real_time() -> None:
    t = np.linspace(0.0, 3.0, 3001)
    index = viewer.render_samples(t, speed=1.0, fps=30.0)
    assert len(index) == 91  # 3 s at 30 frames per second, both ends included
    np.testing.assert_allclose(t[index], np.arange(91) / 30.0, atol=0.5e-3)  # nearest of 1 ms samples
    assert index[-1] == len(t) - 1
    assert len(viewer.render_samples(t, speed=2.0, fps=30.0)) == 46
    assert len(viewer.render_samples(t, speed=0.5, fps=30.0)) == 181


def test_a_coarse_trajectory_keeps_every_sample_once() -> None:
    t = np.linspace(0.0, 2.0, 21)  # 10 samples per second, fewer than 30 frames per second
    index = viewer.render_samples(t, speed=1.0, fps=30.0)
    np.testing.assert_array_equal(index, np.arange(21))


# --------------------------------------------------------------------------- the animation
@pytest.mark.parametrize("speed", [1.0, 2.5])
def test_keyframes_are_pinocchio_placements_at_the_rendered_samples(
    pendubot: robodyn.Robot, motion: Trajectory, speed: float
) -> None:
    playback = viewer.build(pendubot, motion, speed=speed)
    index = viewer.render_samples(motion.t, speed=speed, fps=viewer.DEFAULT_FPS)
    np.testing.assert_array_equal(playback.sample_index, index)
    expected_times = (motion.t[index] - motion.t[0]) / speed
    oracle = [oracle_geometry_placements(pendubot, motion.q[i]) for i in index]
    assert len(playback.objects) == 4  # base cylinder, link1 box and cylinder, link2 box
    for g, obj in enumerate(playback.objects):
        times, transforms = viewer.keyframes(playback, obj.path)
        assert len(times) == len(index)  # one keyframe per rendered sample
        np.testing.assert_allclose(times, expected_times, rtol=TIME_RTOL, atol=1e-15)
        np.testing.assert_allclose(transforms, np.array([o[g] for o in oracle]), atol=TRANSFORM_ATOL)


def test_the_trace_marker_rides_on_the_tip_frame(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    playback = viewer.build(pendubot, motion)
    assert playback.trace_frame == "tip"  # the frame that travels farthest
    model, data = pendubot.model, pendubot.model.createData()
    tip = model.getFrameId("tip")
    expected = []
    for i in playback.sample_index:
        pin.framesForwardKinematics(model, data, motion.q[i])
        expected.append(np.array(data.oMf[tip].translation))
    _, transforms = viewer.keyframes(playback, (*ROOT, "trace", "marker"))
    np.testing.assert_allclose(transforms[:, :3, 3], np.array(expected), atol=TRANSFORM_ATOL)
    np.testing.assert_allclose(playback.trace, np.array(expected), atol=TRANSFORM_ATOL)


def test_the_panel_charts_energy_ledger_power_and_torques_with_units(
    pendubot: robodyn.Robot, motion: Trajectory
) -> None:
    playback = viewer.build(pendubot, motion)
    charts = {chart.key: chart for chart in playback.charts}
    # no drift: the trajectory has none; the ledger's residual on its own chart (its size is no tick of a J axis)
    assert list(charts) == ["energy", "ledger", "residual", "power", "position", "torque"]
    assert {key: chart.unit for key, chart in charts.items()} == {
        "energy": "J",
        "ledger": "J",
        "residual": "J",
        "power": "W",
        "position": "rad",
        "torque": "N m",
    }
    index = playback.sample_index
    energy = {s.label: s.values for s in charts["energy"].series}
    np.testing.assert_array_equal(energy["E = T + V"], motion.energy[index])
    np.testing.assert_array_equal(energy["T kinetic"], motion.kinetic[index])
    residual = {s.label: s.values for s in charts["residual"].series}
    np.testing.assert_allclose(residual["E - E(0) - W"], motion.ledger_residual[index], atol=LEDGER_ATOL)
    power = charts["power"].series[0].values
    np.testing.assert_allclose(power, np.einsum("ni,ni->n", motion.tau, motion.v)[index], atol=0.0)
    limits = sorted(value for _, value, _ in charts["torque"].limits)
    effort = np.asarray(pendubot.model.effortLimit)
    effort = effort[effort > 0]  # the Pendubot's elbow is passive (effort 0): no limit line for it
    np.testing.assert_array_equal(limits, sorted([*effort, *(-effort)]))
    info = json.loads(re.search(r'id="robodyn-info">(.*?)</script>', viewer.to_html(playback), re.S).group(1))
    assert [c["key"] for c in info["panel"]["charts"]] == list(charts) and info["camera"] == "fit"
    assert info["panel"]["width"] == viewer.PANEL_WIDTH_PX


def test_a_constraint_drift_is_charted_when_the_trajectory_has_one(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    drift = 1e-9 * np.arange(len(motion.t), dtype=np.float64)
    playback = viewer.build(pendubot, dataclasses.replace(motion, constraint_drift=drift))
    chart = {c.key: c for c in playback.charts}["drift"]
    assert (chart.unit, chart.scale) == ("m", "log")  # metres, decades: 1e-12 m is not a flat line at zero
    np.testing.assert_array_equal(chart.series[0].values, drift[playback.sample_index])
    info = json.loads(re.search(r'id="robodyn-info">(.*?)</script>', viewer.to_html(playback), re.S).group(1))
    scales = {c["key"]: c["scale"] for c in info["panel"]["charts"]}
    assert scales == {
        "energy": "linear", "ledger": "linear", "residual": "linear", "power": "linear", "position": "linear",
        "torque": "linear", "drift": "log",
    }  # fmt: skip
    still = viewer.build(pendubot, dataclasses.replace(motion, constraint_drift=np.zeros(len(motion.t))))
    assert {c.key: c.scale for c in still.charts}["drift"] == "linear"  # no decade to show: zeros on a plain axis


def test_the_linkage_run_carries_its_loop_drift_into_the_panel(tmp_path: Path) -> None:
    """robodyn run on the textbook's four-bar linkage: a real closed loop, its drift charted in metres."""
    example = Path(__file__).resolve().parents[1] / "examples" / "textbook" / "linkage"
    assert main(["run", str(example / "linkage.toml"), "--out", str(tmp_path)]) == 0
    run = Trajectory.load(tmp_path / "linkage.npz")
    assert run.constraint_drift is not None and np.max(run.constraint_drift) < 1e-9  # a solver-held loop
    playback = viewer.build(robodyn.load(str(example / "linkage.urdf")), run)
    chart = {c.key: c for c in playback.charts}["drift"]
    assert (chart.title, chart.unit, chart.scale) == ("Constraint drift", "m", "log")
    np.testing.assert_array_equal(chart.series[0].values, run.constraint_drift[playback.sample_index])


def test_the_animation_is_sent_once_and_nothing_else_moves(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    playback = viewer.build(pendubot, motion)
    packed = viewer.packed_commands(playback)
    kinds = [kind for kind, _, _ in packed]
    assert kinds.count("set_animation") == 1 and kinds[-1] == "set_animation"
    robot_paths = {"/" + "/".join(obj.path) for obj in playback.objects}
    transforms = [path for kind, path, _ in packed if kind == "set_transform" and path in robot_paths]
    assert sorted(transforms) == sorted(robot_paths)  # one initial pose each; the motion is the animation
    clips = playback.animation.lower()
    assert len(clips) == len(playback.objects) + 1  # + trace marker (fit mode: the camera stays put)
    for clip in clips:
        for track in clip["clip"]["tracks"]:
            assert len(track["keys"]) == playback.n_frames


def test_a_still_pose_has_no_animation(pendubot: robodyn.Robot) -> None:
    q = np.array([0.3, -0.7])
    playback = viewer.build(pendubot, q=q)
    assert playback.animation is None and playback.trace_frame is None
    oracle = oracle_geometry_placements(pendubot, q)
    for g, obj in enumerate(playback.objects):
        np.testing.assert_allclose(obj.placements[0], oracle[g], atol=TRANSFORM_ATOL)
    assert [kind for kind, _, _ in viewer.packed_commands(playback)].count("set_animation") == 0


def test_a_chosen_trace_frame_and_an_unknown_one(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    assert viewer.build(pendubot, motion, trace_frame="link1").trace_frame == "link1"
    assert viewer.build(pendubot, motion, trace=False).trace_frame is None
    with pytest.raises(UnknownNameError, match="unknown frame 'elbow'; expected one of: .*tip"):
        viewer.build(pendubot, motion, trace_frame="elbow")


def test_a_mesh_robot_ships_its_meshes() -> None:
    panda = robodyn.load("panda")
    playback = viewer.build(panda)
    assert {obj.kind for obj in playback.objects} == {"mesh"}
    packed = viewer.packed_commands(playback)
    mesh_bytes = sum(len(data) for kind, _, data in packed if kind == "set_object")
    assert mesh_bytes > 1_000_000  # the DAE files travel with the scene: nothing is fetched later


# --------------------------------------------------------------------------- bad input
def test_a_trajectory_of_another_model_is_refused(pendubot: robodyn.Robot) -> None:
    arm = robodyn.load("geared_arm")
    other = closed_form_trajectory(arm, duration=0.5)
    with pytest.raises(InputError, match=r"q has 1 columns but model 'pendubot' has nq = 2"):
        viewer.build(pendubot, other)


def test_cli_bad_input_exit_codes(motion_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    arm_file = closed_form_trajectory(robodyn.load("geared_arm"), duration=0.5).save(tmp_path / "arm.npz")
    cases = [
        (["view", "pendubot", str(arm_file), "--html", str(tmp_path / "x.html")], "has nq = 2"),
        (["view", "pendubot", str(tmp_path / "missing.npz")], "no such trajectory file"),
        (["view", "pendubot", "--q", "1,2,3"], "q must have 2 entries"),
        (["view", "pendubot", str(motion_file), "--q", "1,2"], "leave it out when playing"),
        (["view", "pendubot", "--html", str(tmp_path / "y.html"), "--port", "8000"], "starts no server"),
        (["view", "pendubot", str(motion_file), "--trace", "elbow", "--html", str(tmp_path / "z.html")], "frame"),
    ]
    for argv, message in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err, (argv, err)
    assert not (tmp_path / "x.html").exists()  # refused input leaves no file behind, not even an empty one


def test_cli_rejects_a_zero_speed(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["view", "pendubot", "--speed", "0"])
    assert exc.value.code == 2
    assert "expected a positive number" in capsys.readouterr().err


@pytest.mark.parametrize("port", ["99999", "0", "-1", "http"])
def test_cli_rejects_a_port_outside_1_to_65535(port: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["view", "pendubot", "--port", port])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "expected a port number from 1 to 65535" in err and "Traceback" not in err and len(err.splitlines()) == 1


def test_an_unwritable_html_path_fails_before_any_work(
    motion_file: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def no_baking(*args: object, **kwargs: object) -> None:
        raise AssertionError("the scene was built before the output path was checked")

    monkeypatch.setattr(viewer, "build", no_baking)
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    for html, message in (
        (Path("/proc/x.html"), "cannot write /proc/x.html"),  # root may write anywhere, yet /proc takes no files
        (tmp_path, "it is a folder"),
        (a_file / "x.html", "not a folder"),
    ):
        assert main(["view", "pendubot", str(motion_file), "--html", str(html)]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.splitlines()) == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]  # the check created nothing


def test_open_without_a_browser_says_what_to_open_by_hand(
    motion_file: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import webbrowser

    asked: list[str] = []

    def no_browser(url: str, *args: object, **kwargs: object) -> bool:
        asked.append(url)
        return False  # what webbrowser.open returns when no browser could be started

    monkeypatch.setattr(webbrowser, "open", no_browser)
    out = tmp_path / "replay.html"
    assert main(["view", "pendubot", str(motion_file), "--html", str(out), "--open"]) == 0
    err = capsys.readouterr().err
    assert asked == [out.resolve().as_uri()]
    assert "no web browser could be opened" in err and f"open {out} by hand" in err and len(err.splitlines()) == 1


def test_meshcat_missing_gives_the_install_hint(
    pendubot: robodyn.Robot, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "meshcat", None)  # import meshcat now raises ImportError
    with pytest.raises(MissingDependencyError, match="pip install meshcat"):
        viewer.build(pendubot)
    assert main(["view", "pendubot"]) == 4
    assert "pip install meshcat" in capsys.readouterr().err


def test_a_port_in_use_is_reported(capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        assert main(["view", "pendubot", "--port", str(port)]) == 5
    err = capsys.readouterr().err
    assert f"port {port} on 127.0.0.1 is in use" in err and "Traceback" not in err


def test_nobody_at_the_zmq_url(pendubot: robodyn.Robot, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("robodyn.viewer.server.CONNECT_TIMEOUT_MS", 300)  # read by serve() where it lives
    playback = viewer.build(pendubot)
    with pytest.raises(UnavailableError, match=r"no meshcat server answered at tcp://127.0.0.1:\d+"):
        viewer.serve(playback, zmq_url=f"tcp://127.0.0.1:{viewer.free_port()}")


# --------------------------------------------------------------------------- the HTML file
def test_the_html_replay_is_self_contained(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    playback = viewer.build(pendubot, motion)
    page = viewer.to_html(playback)
    assert page.count("<script") == page.count("</script>") == 4  # meshcat, commands, info, replay
    assert not re.search(r"<(script|link|img|iframe)[^>]+(src|href)=", page)  # nothing fetched
    assert "MeshCat" in page and "handle_command_bytearray" in page
    commands = json.loads(re.search(r'id="robodyn-commands">(.*?)</script>', page, re.S).group(1))
    assert [base64.b64decode(c) for c in commands] == [data for _, _, data in viewer.packed_commands(playback)]
    info = json.loads(re.search(r'id="robodyn-info">(.*?)</script>', page, re.S).group(1))
    assert len(info["tau"]) == len(info["energy"]) == playback.n_frames
    np.testing.assert_allclose(info["energy"], motion.energy[playback.sample_index])


def _page_commands(page: str) -> list[dict]:
    """The meshcat commands a written page carries, decoded as the browser decodes them."""
    import umsgpack

    found = re.search(r'id="robodyn-commands">(.*?)</script>', page, re.S)
    assert found, "the page holds no scene commands"
    return [umsgpack.unpackb(base64.b64decode(c)) for c in json.loads(found.group(1))]


def test_cli_writes_the_html_file(
    motion: Trajectory, motion_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "sub" / "replay.html"
    assert main(["view", "pendubot", str(motion_file), "--html", str(out), "--speed", "0.5"]) == 0
    assert out.stat().st_size > len(viewer.meshcat_javascript())  # meshcat's viewer is inlined, the scene on top
    text = out.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>") and '"speed": 0.5' in text
    commands = _page_commands(text)
    drawn = {c["path"] for c in commands if c["type"] == "set_object"}
    links = {f"/{'/'.join(ROOT)}/robot/{name}" for name in ("link1_0", "link2_0")}
    assert links <= drawn  # the pendubot's links are in the scene
    assert [c["type"] for c in commands].count("set_animation") == 1 and commands[-1]["type"] == "set_animation"
    clips = {entry["path"]: entry["clip"] for entry in commands[-1]["animations"]}
    assert links | {f"/{'/'.join(ROOT)}/trace/marker"} <= set(clips)
    frames = len(viewer.render_samples(motion.t, speed=0.5))  # the baked motion: one keyframe per rendered frame
    for path in links:
        keys = {track["name"]: track["keys"] for track in clips[path]["tracks"]}
        assert len(keys[".position"]) == len(keys[".quaternion"]) == frames, path
        last = keys[".position"][-1]["time"] / clips[path]["fps"]
        np.testing.assert_allclose(last, (motion.t[-1] - motion.t[0]) / 0.5, rtol=TIME_RTOL)
    assert f"wrote {out}" in capsys.readouterr().out


# --------------------------------------------------------------------------- notebooks
def test_show_renders_inline_without_a_server(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    replay = viewer.show(pendubot, motion)
    assert isinstance(replay, viewer.Replay) and replay.url is None
    html_cell = replay._repr_html_()
    assert html_cell.startswith("<div") and 'srcdoc="&lt;!DOCTYPE html&gt;' in html_cell
    assert replay.playback.n_frames == len(viewer.render_samples(motion.t))


def test_a_replay_prints_as_one_short_line_not_as_its_page(
    pendubot: robodyn.Robot, motion: Trajectory, tmp_path: Path
) -> None:
    """In a plain shell, robot.view(...) used to print the whole 1 MB page."""
    replay = viewer.show(pendubot, motion)
    text = repr(replay)
    assert "\n" not in text and len(text) < 300 and "<!DOCTYPE" not in text and "base64" not in text
    mb = len(replay.html.encode("utf-8")) / 1e6
    assert text == (
        f"<Replay pendubot: 1 run (run 1), {replay.playback.duration:.2f} s, {replay.playback.n_frames} frames; "
        f"HTML page {mb:.1f} MB in memory: .save(PATH) writes it, a notebook shows it inline>"
    )
    assert str(replay) == text
    two = viewer.show(pendubot, [motion, motion], names=["a", "b"])
    assert repr(two).startswith("<Replay pendubot: 2 runs (a, b (identical to a)), ")
    assert repr(viewer.show(pendubot)).startswith("<Replay pendubot: still pose, 0.00 s, 1 frame;")
    saved = replay.save(tmp_path / "r.html")
    assert saved.read_text(encoding="utf-8") == replay.html
    assert replay._repr_html_().startswith("<div")  # the notebook still gets the page inline


# --------------------------------------------------------------------------- live servers
def _port_open(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.settimeout(1.0)
        return s.connect_ex(("127.0.0.1", port)) == 0


def _web_port(url: str) -> int:
    match = re.match(r"http://127\.0\.0\.1:(\d+)/static/", url)
    assert match, url
    return int(match.group(1))


def test_serve_starts_and_stops_its_own_server(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    playback = viewer.build(pendubot, motion)
    with viewer.serve(playback) as server:
        assert server.owned
        page = urllib.request.urlopen(server.url, timeout=30).read().decode("utf-8")
        assert "MeshCat.Viewer" in page
        port = _web_port(server.url)
        # A second client finds the same server and replaces the scene: nothing piles up.
        with viewer.serve(playback, zmq_url=server.client.url) as again:
            assert not again.owned and again.url == server.url
    assert server.process is not None and server.process.poll() is not None
    assert not _port_open(port)


def test_robodyn_view_serves_until_ctrl_c(motion_file: Path) -> None:
    port = viewer.free_port()
    with view_process(motion_file, port) as (process, url):
        assert url == f"http://127.0.0.1:{port}/static/"
        assert "MeshCat" in urllib.request.urlopen(url, timeout=30).read().decode("utf-8")
        err = interrupt(process)
    assert process.returncode == 0, err
    assert "stopped the meshcat server" in err and "Traceback" not in err
    deadline = time.monotonic() + SERVER_WAIT_S
    while _port_open(port) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not _port_open(port)


# --------------------------------------------------------------------------- staying light
def test_dynamics_never_loads_geometry(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("geometry was loaded for dynamics-only work")

    monkeypatch.setattr(pin, "buildGeomFromUrdf", refuse)
    robot = robodyn.load("panda")
    q, v = robot.random_state(np.random.default_rng(5))
    robot.forward_dynamics(q, v, np.zeros(robot.nv))
    trajectory = robodyn.simulate(robot, q, v, duration=0.01, dt=0.005)
    assert trajectory.n_steps == 2


def test_importing_the_viewer_does_not_import_meshcat() -> None:
    code = "import sys, robodyn.viewer, robodyn.cli.view; print('meshcat' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=os.environ)
    assert result.stdout.strip() == "False"


# --------------------------------------------------------------------------- camera and runs (headless)
def test_fit_frames_the_robot_box_and_follow_moves_with_a_long_travel(pendubot: robodyn.Robot, tmp_path: Path) -> None:
    from robodyn.viewer.camera import box_corners, project_ndc

    from ._viewer_helpers import SLIDER_URDF, travel_trajectory

    urdf = tmp_path / "slider.urdf"
    urdf.write_text(SLIDER_URDF)
    slider = robodyn.load(str(urdf))
    travel = travel_trajectory(slider)
    follow = viewer.build(slider, travel)
    assert follow.camera_mode == "follow"  # 100 m against a 0.5 m box
    ndc = project_ndc(follow.camera_position, box_corners(follow.framing.half))
    span = max(np.ptp(ndc[:, 0]), np.ptp(ndc[:, 1])) / 2
    np.testing.assert_allclose(span, viewer.FRAME_FRACTION, rtol=FRACTION_RTOL)
    _, shifts = viewer.keyframes(follow, ROOT)  # the drawing's shift is animated: the box stays at the target
    box_x = np.array([obj.placements[:, 0, 3] for obj in follow.objects]).mean(axis=0)
    np.testing.assert_allclose(shifts[:, 0, 3] + box_x, 0.0, atol=TRANSFORM_ATOL)
    _, grid = viewer.keyframes(follow, ("Grid",))
    assert np.all(np.abs(grid[:, 0, 3]) <= viewer.camera.GRID_CELL / 2 + 1e-12)  # the ground scrolls cell by cell
    fixed = viewer.build(slider, travel, camera="fixed")
    assert fixed.framing.half[0] > 50.0 and not fixed.framing.animated  # robot and trace: 100 m wide
    fit = viewer.build(pendubot, closed_form_trajectory(pendubot, duration=0.5))
    assert fit.camera_mode == "fit" and not fit.framing.animated


def test_two_runs_on_different_grids_show_their_nearest_samples(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    coarse = closed_form_trajectory(pendubot, duration=2.5, dt=0.01)
    playback = viewer.build(pendubot, [motion, coarse], names=["fine", "coarse"])
    assert [r.name for r in playback.runs] == ["fine", "coarse"]
    np.testing.assert_allclose(playback.times[[0, -1]], [0.0, 2.5])  # the union of the two spans
    for run in playback.runs:
        t = run.trajectory.t
        nearest = np.abs(t[None, :] - playback.times[:, None]).min(axis=1)
        np.testing.assert_allclose(np.abs(t[run.index] - playback.times), nearest, atol=1e-15)
    ghost = playback.ghosts[1][1]
    assert ghost.path[:3] == (*ROOT, "ghost1")
    _, placements = viewer.keyframes(playback, ghost.path)
    np.testing.assert_allclose(placements, ghost.placements, atol=TRANSFORM_ATOL)
    assert {c.key: len(c.series) for c in playback.charts}["energy"] == 6  # T, V, E for each run


def test_cli_refuses_bad_runs_in_one_line(
    motion_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    renamed = closed_form_trajectory(robodyn.load("pendubot"), duration=0.5)
    renamed.meta["joint_names"] = ["shoulder", "elbow"]
    other = renamed.save(tmp_path / "other.npz")
    no_time = tmp_path / "no_time.npz"
    with np.load(motion_file) as npz:
        np.savez(no_time, **{k: npz[k] for k in npz.files if k != "t"})
    html = tmp_path / "out.html"
    cases = [
        ([str(motion_file), str(other)], "names joints shoulder, elbow but model 'pendubot' has joint1, joint2"),
        ([str(motion_file)] * 9, "at most 8 runs"),
        ([str(motion_file), str(no_time)], "no t in it"),
    ]
    for files, message in cases:
        assert main(["view", "pendubot", *files, "--html", str(html)]) == 2, files
        err = capsys.readouterr().err
        assert message in err and len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert not html.exists()


def test_joint_positions_show_their_limits_and_the_impacts_on_the_stops() -> None:
    """The cart runs into the rail's end: its position chart has the rail's limits and one mark per impact."""
    cart_pole = robodyn.load("cart_pole")
    motion = robodyn.simulate(cart_pole, [2.3, 0.0], [2.0, 0.0], duration=0.5, dt=1e-3, integrator="rk4")
    impacts = int(np.count_nonzero(np.diff(motion.work_limits) < 0))
    assert impacts >= 1
    playback = viewer.build(cart_pole, motion)
    charts = {chart.key: chart for chart in playback.charts}
    position = charts["position"]
    assert sorted(v for _, v, _ in position.limits if abs(v) < 100) == [
        -2.4,
        2.4,
    ]  # the rail; the hinge's +-1000 left out
    assert len(position.markers) == impacts
    first = int(np.flatnonzero(np.diff(motion.work_limits) < 0)[0]) + 1
    assert motion.t[playback.sample_index[int(np.ceil(position.markers[0]))]] >= motion.t[first] - 1e-12
    # a model mixing a slider and a hinge: each legend entry has its unit, the ticks none
    assert position.unit == "rad or m" and not position.tick_unit
    assert {s.label for s in position.series} == {"slider [m]", "hinge [rad]"}
    assert {s.label for s in charts["torque"].series} == {"slider [N]", "hinge [N m]"}
    info = json.loads(re.search(r'id="robodyn-info">(.*?)</script>', viewer.to_html(playback), re.S).group(1))
    chart = next(c for c in info["panel"]["charts"] if c["key"] == "position")
    assert chart["markers"] == list(position.markers) and chart["tickUnit"] is False


def test_springs_split_the_potential_and_their_couples_join_the_torques(
    pendubot: robodyn.Robot, motion: Trajectory
) -> None:
    """V gravity + V spring = V; the spring's curve is 1/2 k (q - rest)^2, its couple -k (q - rest)."""
    k, rest = 2.5, 0.1  # [N m/rad], [rad]
    sprung = dataclasses.replace(motion, meta={**motion.meta, "springs": {"joint2": {"stiffness": k, "rest": rest}}})
    playback = viewer.build(pendubot, sprung)
    charts = {chart.key: chart for chart in playback.charts}
    energy = {s.label: s.values for s in charts["energy"].series}
    index = playback.sample_index
    stretch = motion.q[index, 1] - rest
    np.testing.assert_allclose(energy["V spring"], 0.5 * k * stretch**2, rtol=1e-15)
    np.testing.assert_allclose(energy["V gravity"] + energy["V spring"], motion.potential[index], rtol=1e-12)
    assert "V potential" not in energy
    torque = {s.label: s.values for s in charts["torque"].series}
    np.testing.assert_allclose(torque["spring at joint2"], -k * stretch, rtol=1e-15)


def test_a_switched_controller_records_its_mode_and_the_replay_charts_it(tmp_path: Path) -> None:
    out = tmp_path / "swing.npz"
    argv = ["simulate", "cart_pole", "--q0", "0,3.14159", "--controller", "swing_up", "--duration", "5", "--out"]
    assert main([*argv, str(out)]) == 0
    motion = Trajectory.load(out)
    mode = motion.meta["controller"]["mode"]
    assert len(mode) == len(motion.t) and mode[0] == 0 and mode[-1] == 1  # pumping, then the LQR holds it
    handover = mode.index(1)
    controller = robodyn.control.make("swing_up", robodyn.load("cart_pole"))
    assert controller.mode(motion.q[handover], motion.v[handover]) == 1
    assert controller.mode(motion.q[handover - 1], motion.v[handover - 1]) == 0
    playback = viewer.build(robodyn.load("cart_pole"), motion)
    chart = next(c for c in playback.charts if c.key == "mode")
    np.testing.assert_array_equal(chart.series[0].values, np.asarray(mode, dtype=float)[playback.sample_index])


def test_the_ground_plane_lies_at_the_base_under_the_whole_motion(
    pendubot: robodyn.Robot, motion: Trajectory, motion_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--ground: a slab whose top face is the base's plane z = 0, under every link at every frame."""
    from robodyn.viewer.camera import robot_boxes

    playback = viewer.build(pendubot, motion, ground=True)
    slab = playback.ground
    assert slab is not None and slab.height == 0.0
    assert slab.centre[2] + 0.5 * slab.sides[2] == pytest.approx(0.0, abs=1e-15)  # the top face is the plane
    low, high = robot_boxes(list(playback.objects), playback.n_frames)
    assert np.all(slab.centre[:2] - 0.5 * slab.sides[:2] <= low[:, :2])
    assert np.all(slab.centre[:2] + 0.5 * slab.sides[:2] >= high[:, :2])
    assert viewer.build(pendubot, motion).ground is None  # only when asked
    out = tmp_path / "ground.html"
    assert main(["view", "pendubot", str(motion_file), "--ground", "--html", str(out)]) == 0
    commands = _page_commands(out.read_text(encoding="utf-8"))
    ground_path = "/" + "/".join((*ROOT, "ground"))
    drawn = [c for c in commands if c["type"] == "set_object" and c["path"] == ground_path]
    assert len(drawn) == 1
    placed = [c for c in commands if c["type"] == "set_transform" and c["path"] == ground_path]
    np.testing.assert_allclose(np.reshape(placed[-1]["matrix"], (4, 4)).T[:3, 3], slab.centre, atol=1e-6)
    capsys.readouterr()
    assert main(["simulate", "pendubot", "--duration", "0.1", "--ground"]) == 2
    assert "--ground draws a plane in the replay; add --view" in capsys.readouterr().err


def test_the_page_gets_the_trace_times_and_window_for_a_fading_trace(
    pendubot: robodyn.Robot, motion: Trajectory
) -> None:
    """The line's points carry their playback times, the window is in playback seconds; None: whole trace."""
    from robodyn.viewer.trace import dense_rows

    playback = viewer.build(pendubot, motion, speed=0.5, trace_window=0.75)
    info = json.loads(re.search(r'id="robodyn-info">(.*?)</script>', viewer.to_html(playback), re.S).group(1))
    assert info["traceWindow"] == pytest.approx(0.75 / 0.5, rel=1e-15)
    (trace,) = info["traces"]
    assert trace["line"] == [*ROOT, "trace", "path"] and trace["dots"] == [*ROOT, "trace", "dots"]
    rows = dense_rows(len(motion.t))
    np.testing.assert_allclose(trace["tau"], (motion.t[rows] - motion.t[0]) / 0.5, atol=1e-9)
    assert len(trace["tau"]) == len(viewer.trace.dense_path(pendubot, motion, "tip"))
    whole = viewer.build(pendubot, motion, trace_window=None)
    assert (
        json.loads(re.search(r'id="robodyn-info">(.*?)</script>', viewer.to_html(whole), re.S).group(1))["traceWindow"]
        is None
    )
    with pytest.raises(InputError, match="trace_window must be a positive number"):
        viewer.build(pendubot, motion, trace_window=0.0)


def test_two_identical_runs_say_so_in_the_legend(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    playback = viewer.build(pendubot, [motion, motion])
    assert [run.name for run in playback.runs] == ["run 1", "run 2 (identical to run 1)"]
    other = dataclasses.replace(motion, q=motion.q + 1e-9)
    assert [run.name for run in viewer.build(pendubot, [motion, other]).runs] == ["run 1", "run 2"]


def test_several_runs_draw_the_limits_grey_under_one_legend_entry(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    """One run: each joint's limit in its colour; several: grey, labelled "effort limit", matching no run's colour."""
    one = next(c for c in viewer.build(pendubot, motion).charts if c.key == "torque")
    assert {color for _, _, color in one.limits} <= set(viewer.LINK_COLORS)
    two = viewer.build(pendubot, [motion, dataclasses.replace(motion, q=motion.q + 1e-3)])
    torque = next(c for c in two.charts if c.key == "torque")
    assert torque.limits and {(label, color) for label, _, color in torque.limits} == {
        ("effort limit", viewer.panel.LIMIT_COLOR)
    }
    assert viewer.panel.LIMIT_COLOR not in {run.color for run in two.runs}


def test_several_runs_each_get_their_own_energy_in_the_overlay(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    euler = robodyn.simulate(pendubot, [0.5, 0.0], [0.0, 0.0], duration=2.0, dt=0.002, integrator="euler")
    playback = viewer.build(pendubot, [motion, euler], names=["rk4", "euler"])
    info = json.loads(re.search(r'id="robodyn-info">(.*?)</script>', viewer.to_html(playback), re.S).group(1))
    assert [(r["name"], r["color"]) for r in info["runEnergies"]] == [
        (run.name, f"#{run.color:06x}") for run in playback.runs
    ]
    for entry, run in zip(info["runEnergies"], playback.runs, strict=True):
        own = (run.trajectory.kinetic + run.trajectory.potential)[run.index]
        np.testing.assert_array_equal(entry["energy"], own)
    assert not np.allclose(info["runEnergies"][0]["energy"], info["runEnergies"][1]["energy"])  # Euler gains energy
    single = json.loads(
        re.search(r'id="robodyn-info">(.*?)</script>', viewer.to_html(viewer.build(pendubot, motion)), re.S).group(1)
    )
    assert single["runEnergies"] == []


def test_a_sprung_joint_is_drawn_as_a_coil_riding_on_its_frame(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    """The spring at joint2: a flat coil normal to the joint's axis, its keyframes the joint frame's placements."""
    from robodyn.viewer.springs import COIL_TURNS

    sprung = dataclasses.replace(motion, meta={**motion.meta, "springs": {"joint2": {"stiffness": 2.5, "rest": 0.1}}})
    playback = viewer.build(pendubot, sprung)
    (coil,) = playback.springs
    assert coil.joint == "joint2" and coil.path == (*ROOT, "springs", "joint2")
    axis = np.asarray(pendubot.model.joints[pendubot.model.getJointId("joint2")].extract().axis)
    np.testing.assert_allclose(coil.points @ axis, 0.0, atol=1e-15)  # in the plane normal to the axis
    turns = np.sum(np.abs(np.diff(np.unwrap(np.arctan2(coil.points[:, 2], coil.points[:, 0]))))) / (2 * np.pi)
    assert turns == pytest.approx(COIL_TURNS, rel=1e-9)
    frame = pendubot.model.getFrameId("joint2")
    for k, row in enumerate(playback.sample_index[:5]):
        pin.framesForwardKinematics(pendubot.model, pendubot.data, motion.q[row])
        _, placements = viewer.animation.read_keyframes(playback.animation, coil.path)
        np.testing.assert_allclose(placements[k], pendubot.data.oMf[frame].homogeneous, atol=TRANSFORM_ATOL)
    assert viewer.build(pendubot, motion).springs == ()  # no springs, no coil


FLOAT32_ROUNDING = 1e-7  # relative: a float32's half ulp is 6e-8

ONE_MESH = """<robot name="meshed">
  <link name="base"/>
  <link name="arm"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial><visual><geometry><mesh filename="MESH"/></geometry></visual></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="5"/></joint>
</robot>
"""


def _meshed(tmp_path: Path, mesh: str) -> robodyn.Robot:
    path = tmp_path / "meshed.urdf"
    path.write_text(ONE_MESH.replace("MESH", mesh))
    return robodyn.load(path)


def test_a_glb_mesh_is_drawn_as_its_triangles(tmp_path: Path) -> None:
    """issue 39 item 9: a .glb mesh was 'not drawn (unsupported shape)', leaving a nearly empty page."""
    import meshcat
    import meshcat.geometry
    import trimesh

    from robodyn.viewer.geometry import geometry_objects, object_commands

    (tmp_path / "box.glb").write_bytes(trimesh.creation.box(extents=(0.1, 0.2, 0.3)).export(file_type="glb"))
    objects, geoms, skipped = geometry_objects(_meshed(tmp_path, "box.glb"), None, np.zeros((1, 1)))
    assert skipped == [] and [o.kind for o in objects] == ["mesh"]
    sent = object_commands(meshcat, objects[0], geoms[0])[0].lower()["object"]["geometries"][0]
    assert sent["format"] == "obj"
    vertices = np.array([line.split()[1:] for line in sent["data"].splitlines() if line.startswith("v ")], dtype=float)
    # the box as written; glTF stores float32 vertices: 0.3 m comes back as 0.30000002 m
    np.testing.assert_allclose(np.ptp(vertices, axis=0), [0.1, 0.2, 0.3], rtol=FLOAT32_ROUNDING)


def test_an_unresolved_package_mesh_names_ros_package_path_which_resolves_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from robodyn.errors import ModelError
    from robodyn.model.load import load_geometry

    (tmp_path / "robot").mkdir()
    robot = _meshed(tmp_path / "robot", "package://nopkg/box.stl")
    with pytest.raises(ModelError, match=r"package://nopkg/box.stl could not be found.*ROS_PACKAGE_PATH"):
        load_geometry(robot)
    share = tmp_path / "share"
    (share / "nopkg").mkdir(parents=True)
    import trimesh

    (share / "nopkg" / "box.stl").write_bytes(trimesh.creation.box().export(file_type="stl"))
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(share))  # the advice, followed
    assert len(load_geometry(robot).geometryObjects) == 1
