"""robodyn.viewer and ``robodyn view``: headless, no browser.

The animation is checked against Pinocchio directly (frame placements composed with the
geometry placements, a different route from the viewer's updateGeometryPlacements), the
servers are started for real on localhost, and bad input is checked for its exit code.
"""

from __future__ import annotations

import base64
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
CURSOR_ATOL = 1e-9  # the chart cursor is an affine map of (tau, E): exact up to roundings at chart scale

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


def test_the_energy_cursor_is_an_affine_image_of_time_and_energy(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    playback = viewer.build(pendubot, motion)
    _, cursor = viewer.keyframes(playback, (*ROOT, "energy", "cursor"))
    x, y = cursor[:, 0, 3], cursor[:, 1, 3]
    energy = motion.energy[playback.sample_index]
    for coordinate, source in ((x, playback.playback_times), (y, energy)):
        design = np.column_stack([source, np.ones_like(source)])
        slope, intercept = np.linalg.lstsq(design, coordinate, rcond=None)[0]
        assert slope > 0
        np.testing.assert_allclose(coordinate, slope * source + intercept, atol=CURSOR_ATOL)


def _drawn_texts(playback: viewer.Playback) -> set[str]:
    """Every text the scene draws (meshcat canvas textures)."""
    texts = set()
    for command in playback.commands:
        material = getattr(getattr(command, "object", None), "material", None)
        texture = getattr(material, "map", None)
        if texture is not None and hasattr(texture, "text"):
            texts.add(texture.text)
    return texts


def test_the_chart_has_a_legend_and_units_and_no_label_overlaps(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    playback = viewer.build(pendubot, motion)
    chart = playback.chart
    assert chart is not None
    labels = {label.key: label for label in chart.labels}
    # a legend names each curve (its colour is the swatch beside it), wherever the curves end
    assert [labels[f"legend_{key}"].text for key in "ETV"] == ["E = T + V", "T kinetic", "V potential"]
    assert set(chart.swatches) == {"E", "T", "V"}
    assert len(set(viewer.ENERGY_COLORS.values()) | set(viewer.LINK_COLORS[:2])) == 5  # curves never look like links
    # units on the ticks: joules on the energy axis, seconds on the time axis
    assert labels["e_max"].text.endswith(" J") and labels["e_min"].text.endswith(" J")
    assert labels["t_min"].text == "0 s" and labels["t_max"].text.endswith(" s") and labels["t_axis"].text == "t [s]"
    assert {label.text for label in chart.labels} <= _drawn_texts(playback)
    boxes = [label.box for label in chart.labels]
    for i, a in enumerate(boxes):
        assert 0 <= a[0] and a[2] <= chart.width and 0 <= a[1] and a[3] <= chart.height, chart.labels[i]
        for j in range(i + 1, len(boxes)):
            b = boxes[j]
            apart = a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]
            assert apart, (chart.labels[i], chart.labels[j])
    left, _bottom, _right, top = chart.plot
    for key in ("legend_E", "legend_T", "legend_V"):
        assert labels[key].box[1] > top  # the legend band lies above the curves: no curve runs through it
    # and with the energies of any motion: a tiny one and a huge one lay out the same way
    for scale in (1e-6, 1e6):
        scaled = Trajectory(
            **{**{f: getattr(motion, f) for f in ("t", "q", "v", "a", "tau", "work_input", "work_damping", "meta")}},
            kinetic=scale * motion.kinetic,
            potential=scale * motion.potential,
        )
        other = viewer.build(pendubot, scaled).chart
        assert other is not None and [lb.key for lb in other.labels] == [lb.key for lb in chart.labels]
        widest = max(lb.box[2] for lb in other.labels if lb.key.startswith("e_"))
        assert widest < left * other.width / chart.width and min(lb.box[0] for lb in other.labels) >= 0


def test_the_animation_is_sent_once_and_nothing_else_moves(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    playback = viewer.build(pendubot, motion)
    packed = viewer.packed_commands(playback)
    kinds = [kind for kind, _, _ in packed]
    assert kinds.count("set_animation") == 1 and kinds[-1] == "set_animation"
    robot_paths = {"/" + "/".join(obj.path) for obj in playback.objects}
    transforms = [path for kind, path, _ in packed if kind == "set_transform" and path in robot_paths]
    assert sorted(transforms) == sorted(robot_paths)  # one initial pose each; the motion is the animation
    clips = playback.animation.lower()
    assert len(clips) == len(playback.objects) + 2  # + trace marker + energy cursor
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
    assert links | {f"/{'/'.join(ROOT)}/trace/marker", f"/{'/'.join(ROOT)}/energy/cursor"} <= set(clips)
    frames = len(viewer.render_samples(motion.t, speed=0.5))  # the baked motion: one keyframe per rendered frame
    for path in links:
        keys = {track["name"]: track["keys"] for track in clips[path]["tracks"]}
        assert len(keys[".position"]) == len(keys[".quaternion"]) == frames, path
        last = keys[".position"][-1]["time"] / clips[path]["fps"]
        np.testing.assert_allclose(last, (motion.t[-1] - motion.t[0]) / 0.5, rtol=TIME_RTOL)
    assert f"wrote {out}" in capsys.readouterr().out


# --------------------------------------------------------------------------- notebooks
def test_show_renders_inline_without_a_server(pendubot: robodyn.Robot, motion: Trajectory) -> None:
    replay = pendubot.view(motion)
    assert isinstance(replay, viewer.Replay) and replay.url is None
    html_cell = replay._repr_html_()
    assert html_cell.startswith("<div") and 'srcdoc="&lt;!DOCTYPE html&gt;' in html_cell
    assert replay.playback.n_frames == len(viewer.render_samples(motion.t))


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
