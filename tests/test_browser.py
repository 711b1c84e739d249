"""End to end in a real browser: headless Chromium renders the replay with WebGL (SwiftShader).

Pages are loaded from the self-contained HTML files written by ``robodyn view --html`` and
from the live page of the meshcat server started by ``robodyn view``, each photographed at
two animation times; the screenshots are kept in ``test-artifacts/browser/`` (the README's
``docs/figures/replay_*.png`` are copies of two of them).

In the HTML file the time is set exactly (``#t=...`` in the URL), so the test projects
points through the scene's camera (the 3D pane is the left ``WIDTH - PANEL_WIDTH_PX`` pixels)
and checks the colours there: each link's centre, the trace's tip, each run's ghost; the
robot's pixels fill a stated fraction of the pane in fit and follow modes; the chart
panel's magenta cursor sits at the x of the animation's time. The live page starts playing
on its own; it is photographed after two different virtual-time budgets and must show the
links' colours and differ between the two shots where the robot is.

Chromium comes from Debian's ``chromium`` package (found on PATH). Without it these tests skip, except in CI
(``CI`` set, e.g. ``CI=true``), where they fail: CI must install it.
"""

from __future__ import annotations

import colorsys
import dataclasses
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import robodyn
import robodyn.control
from robodyn import viewer
from robodyn.cli import main
from robodyn.sim.trajectory import Trajectory
from robodyn.viewer import camera as _camera  # noqa: F401  (loads viewer.camera for box_corners)
from robodyn.viewer.html_export import BACKGROUND_BOTTOM, BACKGROUND_TOP
from robodyn.viewer.palette import BLACK, BLUE, ORANGE, SKY_BLUE, YELLOW

from ._viewer_helpers import HEADLESS_FLAGS, SLIDER_URDF, DevTools, interrupt, travel_trajectory, view_process

pytestmark = pytest.mark.browser

PANE = 700  # the 3D pane is square: the aspect robodyn frames for (viewer.PANE_ASPECT = 1)
WIDTH, HEIGHT = PANE + viewer.PANEL_WIDTH_PX, PANE
ARTIFACTS = Path(__file__).resolve().parents[1] / "test-artifacts" / "browser"
HUE_TOLERANCE = 0.04  # of a full turn (~14 degrees): Lambert shading changes brightness, barely the hue
MIN_SATURATION = 0.35  # the sky-blue background and the grey base are less saturated or far in hue
SEARCH_RADIUS_PX = 4  # around a projected link centre: antialiasing and rounding of the projection
MIN_MOVE_PX = 25.0  # how far (in the image) a link centre must travel between the two shots
MIN_LINK_PIXELS = 150  # pixels of each link colour in a live-page shot (a link covers several hundred)
MIN_CHANGED_PIXELS = 300  # pixels that change between the two live shots (moving links and marker)
MIN_FILL = 0.5  # of FRAME_FRACTION: the robot's silhouette spans at least half of its framed box's projection
BOX_MARGIN_PX = 6  # the silhouette stays inside the projected box, up to antialiasing
CURSOR_MIN_PIXELS = 60  # magenta pixels in the cursor's column (a 2 px line through four ~60 px plots)
CURSOR_STRAY_PIXELS = 6  # antialiased edges of the purple E curve come close to the cursor's hue
OVERLAY_BOX = (10, 10, 470, 130)  # left, top, right, bottom [px]: the text overlay's lines, above the robot
MIN_TEXT_PIXELS = 20  # saturated pixels of one bold 14 px line of coloured text (a few hundred when drawn)
FADE_COLOR_ATOL = 0.02  # float32 vertex colours, and the first point lies up to one sample (2 ms) inside the window
CURSOR_WINDOW_PX = 3  # the cursor's x is rounded to a pixel and drawn 2 px wide


CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome")


def in_ci() -> bool:
    """True when the environment variable CI is set (to anything but an empty, 0, false or no value)."""
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def find_chromium() -> str:
    """The first of CHROMIUM_NAMES on PATH; without one, FAIL in CI and skip elsewhere.

    Called in the test body (not in a fixture) so that a missing browser in CI is a test
    failure, not a setup error.
    """
    for name in CHROMIUM_NAMES:
        path = shutil.which(name)
        if path:
            return path
    if in_ci():
        pytest.fail(
            f"CI={os.environ['CI']!r} and no browser on PATH (looked for {', '.join(CHROMIUM_NAMES)}): "
            "CI must run the browser tests; install it with: apt-get install -y chromium",
            pytrace=False,
        )
    pytest.skip("chromium is not installed (apt-get install chromium); CI runs these tests")


@pytest.fixture(scope="module")
def artifacts() -> Path:
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    return ARTIFACTS


@pytest.fixture(scope="module")
def swing(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The Pendubot released from rest with both links 0.5 rad above the horizontal, 3 s."""
    robot = robodyn.load("pendubot")
    trajectory = robodyn.simulate(robot, [0.5, 0.0], [0.0, 0.0], duration=3.0, dt=0.002)
    return trajectory.save(tmp_path_factory.mktemp("swing") / "pendubot.npz")


def screenshot(chromium: str, url: str, out: Path, *, budget_ms: int, profile: Path) -> np.ndarray:
    """Load ``url`` in headless Chromium, let ``budget_ms`` of virtual time pass, save a PNG; return RGB."""
    from PIL import Image

    command = [
        chromium,
        *HEADLESS_FLAGS,
        f"--user-data-dir={profile}",
        f"--window-size={WIDTH},{HEIGHT}",
        f"--virtual-time-budget={budget_ms}",
        f"--screenshot={out}",
        url,
    ]
    if out.exists():
        out.unlink()
    result = subprocess.run(command, capture_output=True, text=True, timeout=180)
    assert out.is_file(), f"chromium wrote no screenshot (exit {result.returncode}): {result.stderr[-2000:]}"
    image = np.asarray(Image.open(out).convert("RGB"))
    assert image.shape == (HEIGHT, WIDTH, 3)
    return image


def project(playback: viewer.Playback, point: np.ndarray, frame: int = 0) -> np.ndarray:
    """Pixel (x, y) of a world point [m] at a rendered frame, through meshcat's camera in the 3D pane."""
    eye = playback.camera_position
    forward = -eye / np.linalg.norm(eye)  # the camera looks at the origin
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.asarray(point) + playback.offsets[frame] - eye
    depth = d @ forward
    tan_half = np.tan(np.radians(viewer.CAMERA_FOV_DEG / 2))
    x_ndc = (d @ right) / (depth * tan_half * PANE / HEIGHT)
    y_ndc = (d @ up) / (depth * tan_half)
    return np.array([(x_ndc + 1) / 2 * PANE, (1 - y_ndc) / 2 * HEIGHT])


def near(mask: np.ndarray, pixel: np.ndarray, radius: int = SEARCH_RADIUS_PX) -> bool:
    """Whether ``mask`` holds any pixel within ``radius`` of ``pixel`` (x, y)."""
    x, y = np.round(pixel).astype(int)
    assert 0 <= x < WIDTH and 0 <= y < HEIGHT, pixel
    return bool(mask[max(y - radius, 0) : y + radius + 1, max(x - radius, 0) : x + radius + 1].any())


def hue_mask(image: np.ndarray, color: int) -> np.ndarray:
    """Pixels whose hue is that of ``color`` (shading aside), as a boolean (H, W) array."""
    target = colorsys.rgb_to_hsv(((color >> 16) & 255) / 255, ((color >> 8) & 255) / 255, (color & 255) / 255)[0]
    rgb = image.astype(np.float64) / 255.0
    top, bottom = rgb.max(axis=2), rgb.min(axis=2)
    chroma = top - bottom
    saturation = np.where(top > 0, chroma / np.maximum(top, 1e-12), 0.0)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    safe = np.maximum(chroma, 1e-12)
    hue = np.where(top == r, ((g - b) / safe) % 6, np.where(top == g, (b - r) / safe + 2, (r - g) / safe + 4)) / 6
    distance = np.abs(hue - target)
    distance = np.minimum(distance, 1 - distance)
    return (distance < HUE_TOLERANCE) & (saturation > MIN_SATURATION) & (chroma > 0.15)


def cursor_x(playback: viewer.Playback, frame: int) -> float:
    """Pixel x of the chart cursor at a rendered frame: the panel's plotting area maps playback time linearly."""
    margins = viewer.PLOT_MARGINS_PX
    left = PANE + margins["left"]
    right = PANE + viewer.PANEL_WIDTH_PX - 1 - margins["right"]  # the canvases are one pixel narrower (border)
    return left + playback.playback_times[frame] / playback.duration * (right - left)


def cursor_column(image: np.ndarray, playback: viewer.Playback, frame: int) -> int:
    """Magenta pixels in the panel's column at the cursor's x for ``frame`` (CURSOR_WINDOW_PX either side)."""
    x = round(cursor_x(playback, frame))
    return int(hue_mask(image, viewer.CURSOR_COLOR)[:, x - CURSOR_WINDOW_PX : x + CURSOR_WINDOW_PX + 1].sum())


def link_centres(playback: viewer.Playback, frame: int) -> dict[str, tuple[np.ndarray, int]]:
    """Pixel position of the centre of each moving link's box, and its colour, at a rendered frame."""
    out = {}
    for obj in playback.objects:
        name = obj.path[-1]
        if name in ("link1_0", "link2_0"):
            centre = obj.placements[frame] @ np.append(obj.corners.mean(axis=0), 1.0)
            joint = 1 if name == "link1_0" else 2
            out[name] = (project(playback, centre[:3], frame), viewer.LINK_COLORS[joint - 1])
    return out


def test_exported_html_shows_the_pendubot_swinging(artifacts: Path, swing: Path, tmp_path: Path) -> None:
    chromium = find_chromium()
    page = artifacts / "pendubot_replay.html"  # fit mode, with the chart panel: docs/figures/replay_fit_pendubot.png
    assert main(["view", "pendubot", str(swing), "--html", str(page)]) == 0
    robot = robodyn.load("pendubot")
    playback = viewer.build(robot, robodyn.Trajectory.load(swing))
    shots = {}
    for when in (0.6, 2.2):
        frame = int(np.argmin(np.abs(playback.times - when)))
        t = float(playback.times[frame])
        image = screenshot(
            chromium,
            f"{page.resolve().as_uri()}#t={t!r}",
            artifacts / f"html_t{when:.1f}.png",
            budget_ms=1500,
            profile=tmp_path / f"profile_{when}",
        )
        centres = link_centres(playback, frame)
        for name, (pixel, color) in centres.items():
            x, y = np.round(pixel).astype(int)
            assert 0 <= x < WIDTH and 0 <= y < HEIGHT, (name, pixel)
            window = hue_mask(image, color)[
                y - SEARCH_RADIUS_PX : y + SEARCH_RADIUS_PX + 1, x - SEARCH_RADIUS_PX : x + SEARCH_RADIUS_PX + 1
            ]
            assert window.any(), f"t = {t}: no {name} colour near pixel ({x}, {y}); see {artifacts}"
        assert cursor_column(image, playback, frame) >= CURSOR_MIN_PIXELS, f"t = {t}: no cursor; see {artifacts}"
        tip = np.round(project(playback, playback.trace[frame], frame)).astype(int)
        assert hue_mask(image, viewer.TRACE_COLOR)[tip[1] - 6 : tip[1] + 7, tip[0] - 6 : tip[0] + 7].any()
        shots[when] = (image, centres)
    (first, a), (_, b) = shots[0.6], shots[2.2]
    for name in a:
        assert np.linalg.norm(a[name][0] - b[name][0]) > MIN_MOVE_PX, name  # the camera did not move: the link did
    trace_pixels = hue_mask(first, viewer.TRACE_COLOR).sum()
    assert trace_pixels > 500  # the tip's path is drawn (a line and a dot per frame)


def test_live_server_page_plays_the_animation(artifacts: Path, swing: Path, tmp_path: Path) -> None:
    chromium = find_chromium()
    port = viewer.free_port()
    with view_process(swing, port) as (process, url):
        images = [
            screenshot(
                chromium, url, artifacts / f"live_{budget}ms.png", budget_ms=budget, profile=tmp_path / str(budget)
            )
            for budget in (300, 2300)
        ]
        err = interrupt(process)
    assert process.returncode == 0, err
    for image in images:
        for color in viewer.LINK_COLORS[:2]:
            assert hue_mask(image, color).sum() > MIN_LINK_PIXELS, f"link colour {color:06x} missing on the live page"
    robot_colours = hue_mask(images[0], viewer.LINK_COLORS[0]) | hue_mask(images[0], viewer.LINK_COLORS[1])
    robot_colours |= hue_mask(images[1], viewer.LINK_COLORS[0]) | hue_mask(images[1], viewer.LINK_COLORS[1])
    changed = np.abs(images[0].astype(int) - images[1].astype(int)).sum(axis=2) > 60
    assert (changed & robot_colours).sum() > MIN_CHANGED_PIXELS, "the robot did not move between the two shots"


ROBOT_COLORS = tuple(c for c in viewer.LINK_COLORS if c not in (BLUE, SKY_BLUE, YELLOW, ORANGE, BLACK))
"""Link colours far in hue from the sky-blue background (blue, sky blue) and the yellow trace (yellow, orange); black has none."""


def robot_mask(image: np.ndarray) -> np.ndarray:
    """Pixels of the 3D pane in any link colour (the panel at the right is blanked)."""
    mask = np.zeros(image.shape[:2], dtype=bool)
    for color in ROBOT_COLORS:
        mask |= hue_mask(image, color)
    mask[:, PANE:] = False
    return mask


def framed_box_pixels(playback: viewer.Playback, frame: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel bounding box (low x, y), (high x, y) of the box the camera frames at ``frame``."""
    framing = playback.framing
    corners = framing.centres[frame] + viewer.camera.box_corners(framing.half)
    pixels = np.array([project(playback, c, frame) for c in corners])
    return pixels.min(axis=0), pixels.max(axis=0)


@pytest.fixture(scope="module")
def slider(tmp_path_factory: pytest.TempPathFactory) -> tuple[robodyn.Robot, Path]:
    """The box on a rail, pushed 100 m in 2 s (a 0.5 m robot that travels 200 times its size)."""
    folder = tmp_path_factory.mktemp("slider")
    urdf = folder / "slider.urdf"
    urdf.write_text(SLIDER_URDF)
    robot = robodyn.load(str(urdf))
    return robot, travel_trajectory(robot).save(folder / "travel.npz")


@pytest.fixture(scope="module")
def panda_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The Panda released from its neutral pose without torque, 1 s (robodyn simulate panda, shortened)."""
    out = tmp_path_factory.mktemp("panda") / "panda.npz"
    assert main(["simulate", "panda", "--duration", "1", "--out", str(out)]) == 0
    return out


@pytest.mark.parametrize("case", ["panda_fit", "slider_follow"])
def test_the_camera_frames_the_robot_not_its_travel(
    case: str,
    artifacts: Path,
    tmp_path: Path,
    panda_run: Path,
    slider: tuple[robodyn.Robot, Path],
    request: pytest.FixtureRequest,
) -> None:
    chromium = find_chromium()
    if case == "panda_fit":
        robot, file, mode, model = robodyn.load("panda"), panda_run, "fit", "panda"
    else:
        (robot, file), mode = slider, "follow"
        model = str(robot.urdf_path)
    page = tmp_path / f"{case}.html"
    assert main(["view", model, str(file), "--html", str(page)]) == 0  # the default camera picks the mode
    playback = viewer.build(robot, robodyn.Trajectory.load(file))
    assert playback.camera_mode == mode
    silhouettes = []
    for when in (0.25, 0.9):
        frame = round(when * (playback.n_frames - 1))
        t = float(playback.times[frame])
        image = screenshot(
            chromium,
            f"{page.resolve().as_uri()}#t={t!r}",
            artifacts / f"camera_{case}_{when}.png",
            budget_ms=3000,
            profile=tmp_path / f"profile_{when}",
        )
        ys, xs = np.nonzero(robot_mask(image))
        assert len(xs) > MIN_LINK_PIXELS, f"t = {t}: the robot is not in view; see {artifacts}"
        low, high = framed_box_pixels(playback, frame)
        # the framed box spans FRAME_FRACTION of the pane (the larger of its width and height)
        span = max((high[0] - low[0]) / PANE, (high[1] - low[1]) / HEIGHT)
        assert abs(span - viewer.FRAME_FRACTION) < 0.01, span
        assert xs.min() >= low[0] - BOX_MARGIN_PX and xs.max() <= high[0] + BOX_MARGIN_PX, (
            xs.min(),
            xs.max(),
            low,
            high,
        )
        assert ys.min() >= low[1] - BOX_MARGIN_PX and ys.max() <= high[1] + BOX_MARGIN_PX, (
            ys.min(),
            ys.max(),
            low,
            high,
        )
        silhouettes.append((xs.min(), ys.min(), xs.max(), ys.max()))
    boxes = np.array(silhouettes)
    if mode == "fit":  # the motion's silhouette (both shots) fills the framed box
        boxes = np.array([[*boxes[:, :2].min(axis=0), *boxes[:, 2:].max(axis=0)]])
    for x0, y0, x1, y1 in boxes:
        fill = max((x1 - x0) / PANE, (y1 - y0) / HEIGHT)
        assert fill >= MIN_FILL * viewer.FRAME_FRACTION, f"the robot spans {fill:.2f} of the pane; see {artifacts}"


def test_the_chart_cursor_sits_at_the_animation_time_after_a_seek(artifacts: Path, swing: Path, tmp_path: Path) -> None:
    chromium = find_chromium()
    page = tmp_path / "cursor.html"
    assert main(["view", "pendubot", str(swing), "--html", str(page)]) == 0
    playback = viewer.build(robodyn.load("pendubot"), robodyn.Trajectory.load(swing))
    frames = [round(f * (playback.n_frames - 1)) for f in (0.2, 0.75)]
    for frame, other in (frames, frames[::-1]):
        t = float(playback.times[frame])
        image = screenshot(
            chromium,
            f"{page.resolve().as_uri()}#t={t!r}",
            artifacts / f"cursor_t{t:.2f}.png",
            budget_ms=1500,
            profile=tmp_path / f"profile_{frame}",
        )
        assert cursor_column(image, playback, frame) >= CURSOR_MIN_PIXELS, f"t = {t}: no cursor at its x"
        assert cursor_column(image, playback, other) <= CURSOR_STRAY_PIXELS, f"t = {t}: a cursor at another time's x"


def test_two_runs_play_as_ghosts_at_their_own_poses(artifacts: Path, tmp_path: Path) -> None:
    chromium = find_chromium()
    robot = robodyn.load("pendubot")
    rk4 = robodyn.simulate(robot, [0.5, 0.0], [0.0, 0.0], duration=3.0, dt=0.002)
    euler = robodyn.simulate(robot, [0.5, 0.0], [0.0, 0.0], duration=3.0, dt=0.005, integrator="euler")
    files = [rk4.save(tmp_path / "rk4.npz"), euler.save(tmp_path / "euler.npz")]
    page = artifacts / "two_runs.html"  # Euler beside RK4: docs/figures/replay_two_runs.png
    assert main(["view", "pendubot", str(files[1]), str(files[0]), "--html", str(page)]) == 0
    playback = viewer.build(robot, [euler, rk4], names=["euler", "rk4"])
    assert [run.name for run in playback.runs] == ["euler", "rk4"]
    for when in (1.5, 2.6):
        frame = int(np.argmin(np.abs(playback.times - when)))
        t = float(playback.times[frame])
        image = screenshot(
            chromium,
            f"{page.resolve().as_uri()}#t={t!r}",
            artifacts / f"two_runs_t{when:.1f}.png",
            budget_ms=1500,
            profile=tmp_path / f"profile_{when}",
        )
        overlay = image[OVERLAY_BOX[1] : OVERLAY_BOX[3], OVERLAY_BOX[0] : OVERLAY_BOX[2]]
        for run in playback.runs:  # each run's own "E = ... J  name" line, in its colour
            assert hue_mask(overlay, run.color).sum() >= MIN_TEXT_PIXELS, f"t = {t}: no {run.name} energy line"
        tips = [project(playback, run_trace[frame], frame) for run_trace in playback.traces]
        assert np.linalg.norm(tips[0] - tips[1]) > MIN_MOVE_PX, "the runs sit at the same pose: a weak test time"
        for run, objects in zip(playback.runs, playback.ghosts, strict=True):
            mask = hue_mask(image, run.color)
            for obj in objects:
                if obj.path[-1] in ("link1_0", "link2_0"):
                    centre = (obj.placements[frame] @ np.append(obj.corners.mean(axis=0), 1.0))[:3]
                    pixel = project(playback, centre, frame)
                    assert near(mask, pixel), f"t = {t}: no {run.name} ghost at {obj.path[-1]} {pixel}; see {artifacts}"


SEEK_FRACTIONS = (0.3, 0.8)  # where along the time axis the chart is clicked: two times far apart


def test_clicking_a_chart_seeks_the_animation_and_moves_the_cursor(
    artifacts: Path, swing: Path, tmp_path: Path
) -> None:
    """A real click (DevTools Input.dispatchMouseEvent) on the energy chart at the x of a known time."""
    chromium = find_chromium()
    page = tmp_path / "seek.html"
    assert main(["view", "pendubot", str(swing), "--html", str(page)]) == 0
    playback = viewer.build(robodyn.load("pendubot"), robodyn.Trajectory.load(swing))
    one_sample = 1.0 / playback.fps  # playback time between two rendered frames [s]
    margins = viewer.PLOT_MARGINS_PX
    with DevTools(chromium, width=WIDTH, height=HEIGHT, profile=tmp_path / "profile") as browser:
        browser.open(page.resolve().as_uri())
        rect = browser.evaluate(
            "(function () { var r = document.querySelector('[data-chart=energy] canvas:last-child')"
            ".getBoundingClientRect(); return [r.left, r.top, r.width, r.height]; })()"
        )
        left, top, width, height = rect  # type: ignore[misc]
        clicked: list[float] = []
        for f in SEEK_FRACTIONS:
            x = left + margins["left"] + f * (width - margins["left"] - margins["right"])
            wanted = f * playback.duration  # the playback time under the click [s]
            browser.click(x, top + height / 2)
            browser.wait_for("Math.abs(document.body.getAttribute('data-cursor-tau') - viewer.animator.time) < 1e-9")
            shown = float(browser.evaluate("viewer.animator.time"))  # type: ignore[arg-type]
            assert abs(shown - wanted) <= one_sample, (f, shown, wanted)
            cursor = float(browser.evaluate("document.body.getAttribute('data-cursor-tau')"))  # type: ignore[arg-type]
            assert abs(cursor - wanted) <= one_sample, (f, cursor, wanted)
            hud = str(browser.evaluate("document.getElementById('robodyn-overlay').textContent"))
            t_hud = float(hud.split("t = ")[1].split(" s")[0])
            assert abs(t_hud - (playback.times[0] + wanted * playback.speed)) <= one_sample * playback.speed, hud
            image = browser.screenshot(artifacts / f"seek_{f:.1f}.png")
            column = hue_mask(image, viewer.CURSOR_COLOR)
            here = round(x)
            assert column[:, here - CURSOR_WINDOW_PX : here + CURSOR_WINDOW_PX + 1].sum() >= CURSOR_MIN_PIXELS, f
            for before in clicked:  # the cursor left the x of the earlier click
                old = round(before)
                assert column[:, old - CURSOR_WINDOW_PX : old + CURSOR_WINDOW_PX + 1].sum() <= CURSOR_STRAY_PIXELS
            clicked.append(x)
            # the animation holds still after the seek: a later look finds the same time
            assert float(browser.evaluate("viewer.animator.time")) == shown  # type: ignore[arg-type]


DRIFT_DECADES = (-12, -9)  # a solver-held loop: drift from 1e-12 m to 1e-9 m
DRIFT_PIXEL_TOLERANCE = 4  # the curve is 1.6 px wide and antialiased; the axis maps exactly


def test_constraint_drift_is_charted_in_metres_on_a_log_axis(artifacts: Path, tmp_path: Path) -> None:
    """Drift growing log-linearly from 1e-12 m to 1e-9 m: decade ticks in m, the mid time at mid height."""
    chromium = find_chromium()
    robot = robodyn.load("pendubot")
    motion = robodyn.simulate(robot, [0.5, 0.0], [0.0, 0.0], duration=2.0, dt=0.01)
    low, high = DRIFT_DECADES
    drift = 10.0 ** (low + (high - low) * motion.t / motion.t[-1])
    drift[0] = 0.0  # the loop closes exactly at the start: a zero sits on the axis floor
    playback = viewer.build(robot, dataclasses.replace(motion, constraint_drift=drift))
    page = tmp_path / "drift.html"
    page.write_text(viewer.to_html(playback), encoding="utf-8")
    with DevTools(chromium, width=WIDTH, height=HEIGHT, profile=tmp_path / "profile") as browser:
        browser.open(f"{page.resolve().as_uri()}#t=0")
        box = "document.querySelector('[data-chart=drift]')"
        assert browser.evaluate(f"{box}.getAttribute('data-scale')") == "log"
        ticks = str(browser.evaluate(f"{box}.getAttribute('data-ticks')")).split("|")
        assert ticks == [f"1e{e} m" for e in range(low, high + 1)]
        assert "Constraint drift [m], log scale" == str(
            browser.evaluate(f"{box}.querySelector('.robodyn-title').textContent")
        )
        browser.evaluate(f"{box}.scrollIntoView()")  # the panel scrolls when its charts outgrow the window
        rect = browser.evaluate(
            f"(function () {{ var r = {box}.querySelector('canvas').getBoundingClientRect();"
            " return [r.left, r.top, r.width, r.height]; })()"
        )
        image = browser.screenshot(artifacts / "drift_log_axis.png")
    left, top, width, height = (round(v) for v in rect)  # type: ignore[union-attr]
    margins = viewer.PLOT_MARGINS_PX
    plot_top, plot_bottom = top + margins["top"], top + height - margins["bottom"]
    x = round(left + margins["left"] + 0.5 * (width - margins["left"] - margins["right"]))  # t = 1 s: 10^-10.5 m
    curve = hue_mask(image, viewer.panel.DRIFT_COLOR)[plot_top : plot_bottom + 1, x - 1 : x + 2]
    ys = np.nonzero(curve)[0] + plot_top
    assert len(ys), f"no drift curve at the mid time; see {artifacts}"
    middle = (plot_top + plot_bottom) / 2  # log10 of 10^-10.5 is halfway between -12 and -9
    assert abs(ys.mean() - middle) <= DRIFT_PIXEL_TOLERANCE, (ys.mean(), middle)


def test_the_trace_keeps_only_its_window_behind_the_cursor_and_fades(swing: Path, tmp_path: Path) -> None:
    """At t = 2 s with a 0.5 s window, the line draws the points of 1.5 s to 2 s: yellow at 2 s, and at 1.5 s the
    background's colour where that point is on the screen (meshcat's vertical gradient), not white."""
    chromium = find_chromium()
    robot = robodyn.load("pendubot")
    motion = Trajectory.load(swing)
    window, now = 0.5, 2.0  # [s]
    playback = viewer.build(robot, motion, trace_window=window)
    page = tmp_path / "fade.html"
    page.write_text(viewer.to_html(playback), encoding="utf-8")
    tau = playback.trace_times[0]
    first = int(np.searchsorted(tau, now - window, side="left"))
    end = int(np.searchsorted(tau, now + 1e-9, side="left"))
    with DevTools(chromium, width=WIDTH, height=HEIGHT, profile=tmp_path / "profile") as browser:
        browser.open(f"{page.resolve().as_uri()}#t={now}")
        browser.wait_for("document.body.getAttribute('data-trace-ranges')")
        assert browser.evaluate("document.body.getAttribute('data-trace-ranges')") == f"{first}:{end - first}"
        line = "viewer.scene_tree.find(['meshcat', 'robodyn', 'trace', 'path', '<object>']).object.geometry"
        drawn = browser.evaluate(f"[{line}.drawRange.start, {line}.drawRange.count]")
        assert drawn == [first, end - first]
        colors = browser.evaluate(
            f"(function () {{ var a = {line}.getAttribute('color').array;"
            f" return [a[3 * {first}], a[3 * {first} + 1], a[3 * {first} + 2],"
            f" a[3 * {end - 1}], a[3 * {end - 1} + 1], a[3 * {end - 1} + 2]]; }})()"
        )
        oldest_xyz = browser.evaluate(
            f"Array.from({line}.getAttribute('position').array.slice(3 * {first}, 3 * {first} + 3))"
        )
    frame = int(np.argmin(np.abs(playback.times - (now - window))))  # fit mode: every frame has the same shift
    height_share = 1 - project(playback, np.array(oldest_xyz), frame)[1] / HEIGHT  # 0 at the bottom, 1 at the top
    behind = np.array(BACKGROUND_BOTTOM) + height_share * (np.array(BACKGROUND_TOP) - np.array(BACKGROUND_BOTTOM))
    yellow = np.array([(viewer.TRACE_COLOR >> s) & 255 for s in (16, 8, 0)]) / 255.0
    oldest, newest = np.array(colors[:3]), np.array(colors[3:])  # type: ignore[index]
    np.testing.assert_allclose(newest, yellow, atol=FADE_COLOR_ATOL)
    np.testing.assert_allclose(oldest, behind, atol=FADE_COLOR_ATOL)  # faded into the background behind it


LABEL_PX = 2.0  # the page's pixel of a label (rounded) against this test's own projection of its point
MIN_LABEL_INK = 15  # near-black pixels of a bold 20 px letter beside its point (a few dozen when drawn)


def test_labels_are_written_where_their_points_project(artifacts: Path, swing: Path, tmp_path: Path) -> None:
    """A, B and θ on the Pendubot at t = 1.2 s: each text sits at its point's pixel, in black ink there."""
    chromium = find_chromium()
    robot = robodyn.load("pendubot")
    playback = viewer.build(
        robot, Trajectory.load(swing), labels={"A": "joint1", "B": "joint2"}, angles={"θ": "joint1"}
    )
    page = tmp_path / "labels.html"
    page.write_text(viewer.to_html(playback), encoding="utf-8")
    frame = round(0.4 * (playback.n_frames - 1))
    t = float(playback.times[frame])
    expected = {lab.text: project(playback, lab.points[frame], frame) for lab in playback.labels}
    expected["θ"] = project(playback, playback.angles[0].anchors[frame], frame)
    with DevTools(chromium, width=WIDTH, height=HEIGHT, profile=tmp_path / "profile") as browser:
        browser.open(f"{page.resolve().as_uri()}#t={t!r}")
        browser.wait_for("document.body.getAttribute('data-labels')")
        listed = str(browser.evaluate("document.body.getAttribute('data-labels')"))
    shown = {
        text: np.array([float(c) for c in xy.split(",")]) for text, xy in (e.rsplit(":", 1) for e in listed.split("|"))
    }
    assert sorted(shown) == sorted(expected)
    for text, pixel in expected.items():
        assert np.abs(shown[text] - pixel).max() <= LABEL_PX + 0.5, f"{text}: at {shown[text]}, projects to {pixel}"
    image = screenshot(
        chromium,
        f"{page.resolve().as_uri()}#t={t!r}",
        artifacts / "labels.png",
        budget_ms=1500,
        profile=tmp_path / "p2",
    )
    ink = image.max(axis=2) < 60  # the letters are near-black with a white halo; nothing else in the pane is
    for text, (x, y) in expected.items():
        x0, y0 = (int(x) + 8, int(y) - 12) if text != "θ" else (int(x), int(y))  # where the page writes the letter
        box = ink[max(0, y0 - 12) : y0 + 12, max(0, x0 - 4) : x0 + 16]
        assert int(box.sum()) >= MIN_LABEL_INK, f"no letter {text} drawn near ({x0}, {y0}); see {artifacts}"


ARROW_INK_PX = 12  # dark pixels of the arrow's head (a ~13 x 14 px black triangle) within SEARCH_RADIUS_PX + 4
TARGET_DASH_SHARE = 0.3  # of the plot's width: the dashed target line (5 px on, 4 off) covers ~55 % of its row


def test_the_carts_push_arrow_and_the_regulated_energys_target_are_drawn(artifacts: Path, tmp_path: Path) -> None:
    """The cart-pole's swing-up: the push drawn as an arrow whose head is at the pixel the page states and
    dark there; the swing-up's energy target (0 J) dashed across its chart in the regulated energy's colour."""
    chromium = find_chromium()
    robot = robodyn.load("cart_pole")
    controller = robodyn.control.make("swing_up", robot)
    run = robodyn.simulate(robot, [0.0, 3.14159], [0.0, 0.0], duration=1.0, dt=0.002, torque=controller)
    run = dataclasses.replace(
        run, meta={**run.meta, "controller": {"name": "swing_up", **controller.record(run.q, run.v)}}
    )
    playback = viewer.build(robot, run)
    (arrow,) = playback.arrows
    frame = int(np.argmax(np.abs(arrow.values)))  # the strongest push: the longest arrow
    t = float(playback.times[frame])
    page = tmp_path / "push.html"
    page.write_text(viewer.to_html(playback), encoding="utf-8")
    box = "document.querySelector('[data-chart=regulated]')"
    with DevTools(chromium, width=WIDTH, height=HEIGHT, profile=tmp_path / "profile") as browser:
        browser.open(f"{page.resolve().as_uri()}#t={t!r}")
        browser.wait_for("document.body.getAttribute('data-arrows')")
        heads = str(browser.evaluate("document.body.getAttribute('data-arrows')"))
        mode = browser.evaluate("document.body.getAttribute('data-mode')")
        limits = str(browser.evaluate(f"{box}.getAttribute('data-limits')"))
        browser.evaluate(f"{box}.scrollIntoView()")
        rect = browser.evaluate(
            f"(function () {{ var r = {box}.querySelector('canvas').getBoundingClientRect();"
            " return [r.left, r.top, r.width, r.height]; })()"
        )
        image = browser.screenshot(artifacts / "push_and_target.png")
    joint, xy = heads.split(":")
    head = np.array([float(c) for c in xy.split(",")])
    assert joint == "slider" and mode == "mode: swing-up"
    tip = project(playback, arrow.points[frame, -1], frame)
    direction = np.sign(arrow.values[frame]) * np.array([1.0, 0.0])  # the rail is along x: right on the screen
    assert np.dot(head - tip, direction) > 0  # the head points the way the cart is pushed
    dark = image.max(axis=2) < 60  # the black head (white halo); the sky, the links and the rail are lighter
    assert (
        near(dark, head, SEARCH_RADIUS_PX + 4)
        and dark[int(head[1]) - 8 : int(head[1]) + 9, int(head[0]) - 8 : int(head[0]) + 9].sum() >= ARROW_INK_PX
    ), f"no arrow head at {head}; see {artifacts}"
    label, value, row = limits.split(":")
    assert (label, float(value)) == ("target 0 J", 0.0)
    left, top, width, _ = (round(v) for v in rect)  # type: ignore[union-attr]
    margins = viewer.PLOT_MARGINS_PX
    y = top + int(row)
    line = hue_mask(image, viewer.panel.REGULATED_COLOR)[
        y - 1 : y + 2, left + margins["left"] : left + width - margins["right"]
    ]
    assert line.any(axis=0).mean() >= TARGET_DASH_SHARE, f"no dashed target at y = {y}; see {artifacts}"
