"""End to end in a real browser: headless Chromium renders the replay with WebGL (SwiftShader).

Two pages are loaded: the self-contained HTML file written by ``robodyn view --html`` and
the live page of the meshcat server started by ``robodyn view``. Each is photographed at two
animation times; the screenshots are kept in ``test-artifacts/browser/``.

In the HTML file the time is set exactly (``#t=...`` in the URL), so the test projects the
centre of each link through the scene's camera and checks that the pixel there has the
link's colour, and that the links moved between the two times; the energy chart's legend
swatches are projected the same way and must show the colours of T, V and E. The live page starts playing
on its own; it is photographed after two different virtual-time budgets and must show the
links' colours and differ between the two shots where the robot is.

Chromium comes from Debian's ``chromium`` package (found on PATH). Without it these tests skip, except in CI
(``CI`` set, e.g. ``CI=true``), where they fail: CI must install it.
"""

from __future__ import annotations

import colorsys
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn import viewer
from robodyn.cli import main

from ._viewer_helpers import interrupt, view_process

pytestmark = pytest.mark.browser

WIDTH, HEIGHT = 800, 600
ARTIFACTS = Path(__file__).resolve().parents[1] / "test-artifacts" / "browser"
HUE_TOLERANCE = 0.04  # of a full turn (~14 degrees): Lambert shading changes brightness, barely the hue
MIN_SATURATION = 0.35  # the sky-blue background and the grey base are less saturated or far in hue
SEARCH_RADIUS_PX = 4  # around a projected link centre: antialiasing and rounding of the projection
MIN_MOVE_PX = 25.0  # how far (in the image) a link centre must travel between the two shots
MIN_LINK_PIXELS = 150  # pixels of each link colour in a live-page shot (a link covers several hundred)
MIN_CHANGED_PIXELS = 300  # pixels that change between the two live shots (moving links and marker)


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
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={profile}",
        "--enable-unsafe-swiftshader",
        "--use-angle=swiftshader",
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


def project(playback: viewer.Playback, point: np.ndarray) -> np.ndarray:
    """Pixel (x, y) of a world point [m] through meshcat's camera as robodyn places it."""
    eye = playback.camera_position
    forward = -eye / np.linalg.norm(eye)  # the camera looks at the origin
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.asarray(point) + playback.offset - eye
    depth = d @ forward
    tan_half = np.tan(np.radians(viewer.CAMERA_FOV_DEG / 2))
    x_ndc = (d @ right) / (depth * tan_half * WIDTH / HEIGHT)
    y_ndc = (d @ up) / (depth * tan_half)
    return np.array([(x_ndc + 1) / 2 * WIDTH, (1 - y_ndc) / 2 * HEIGHT])


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


def link_centres(playback: viewer.Playback, frame: int) -> dict[str, tuple[np.ndarray, int]]:
    """Pixel position of the centre of each moving link's box, and its colour, at a rendered frame."""
    out = {}
    for obj in playback.objects:
        name = obj.path[-1]
        if name in ("link1_0", "link2_0"):
            centre = obj.placements[frame] @ np.append(obj.corners.mean(axis=0), 1.0)
            joint = 1 if name == "link1_0" else 2
            out[name] = (project(playback, centre[:3]), viewer.LINK_COLORS[joint - 1])
    return out


def test_exported_html_shows_the_pendubot_swinging(artifacts: Path, swing: Path, tmp_path: Path) -> None:
    chromium = find_chromium()
    page = artifacts / "pendubot_replay.html"
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
        assert playback.chart is not None
        for key, swatch in playback.chart.swatches.items():  # the legend: each curve's colour beside its name
            x, y = np.round(project(playback, playback.chart.to_world(swatch))).astype(int)
            window = hue_mask(image, viewer.ENERGY_COLORS[key])[
                y - SEARCH_RADIUS_PX : y + SEARCH_RADIUS_PX + 1, x - SEARCH_RADIUS_PX : x + SEARCH_RADIUS_PX + 1
            ]
            assert window.any(), f"t = {t}: no legend swatch of {key} near pixel ({x}, {y}); see {artifacts}"
        tip = np.round(project(playback, playback.trace[frame])).astype(int)
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
