"""Labels in the replay's 3D view: texts on frames (a figure's A, B, C) and joint angles drawn as arcs (θ).

Headless: the labelled points are checked against Pinocchio's frame placements, and each
angle's arc against the geometry it must show (it starts on a still reference ray, ends on
the child link's direction, and spans the joint's angle); the page carries them; bad names
are one line and exit code 2.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import robodyn
from robodyn import viewer
from robodyn.cli import main
from robodyn.errors import InputError, UnknownNameError
from robodyn.sim.trajectory import Trajectory
from robodyn.viewer.labels import ARC_RADIUS_FRACTION

POSITION_ATOL = 1e-12  # the same forward kinematics, computed again: roundings only
ANGLE_ATOL = 1e-9  # angles from arccos of unit vectors built by rotations: ~1e-12 near the ends, looser near 0 and pi

pytest.importorskip("meshcat")


def swinging(robot: robodyn.Robot, *, duration: float = 1.0, dt: float = 0.01) -> Trajectory:
    """Both Pendubot joints sweeping through large angles, both signs (no dynamics needed here)."""
    t = np.arange(0.0, duration + dt / 2, dt)
    q = np.column_stack([2.5 * np.sin(3.0 * t), 1.5 * np.cos(2.0 * t)])
    zeros = np.zeros_like(t)
    return Trajectory(
        t=t, q=q, v=np.zeros_like(q), a=np.zeros_like(q), tau=np.zeros_like(q), kinetic=zeros, potential=zeros,
        work_input=zeros, work_damping=zeros, meta={"integrator": "rk4"},
    )  # fmt: skip


@pytest.fixture(scope="module")
def pendubot() -> robodyn.Robot:
    return robodyn.load("pendubot")


@pytest.fixture(scope="module")
def playback(pendubot: robodyn.Robot) -> viewer.Playback:
    return viewer.build(
        pendubot, swinging(pendubot), labels={"A": "joint1", "B": "joint2", "P": "tip"}, angles={"θ": "joint1"}
    )


def frame_world(robot: robodyn.Robot, name: str, q: np.ndarray) -> np.ndarray:
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    return np.array(data.oMf[robot.model.getFrameId(name)].translation)


def test_labels_sit_on_their_frames(playback: viewer.Playback, pendubot: robodyn.Robot) -> None:
    q = swinging(pendubot).q[playback.sample_index]
    assert [(lab.text, lab.frame) for lab in playback.labels] == [("A", "joint1"), ("B", "joint2"), ("P", "tip")]
    for label in playback.labels:
        expected = np.array([frame_world(pendubot, label.frame, qk) for qk in q])
        np.testing.assert_allclose(label.points, expected, atol=POSITION_ATOL)


def test_the_angle_arc_runs_from_a_still_ray_to_the_link_through_the_joint_angle(
    playback: viewer.Playback, pendubot: robodyn.Robot
) -> None:
    (mark,) = playback.angles
    q = swinging(pendubot).q[playback.sample_index]
    np.testing.assert_array_equal(mark.angles, q[:, 0])
    radius = ARC_RADIUS_FRACTION * playback.framing.size
    origin = mark.rays[:, 0]
    np.testing.assert_allclose(origin, [frame_world(pendubot, "joint1", qk) for qk in q], atol=POSITION_ATOL)
    start, end = mark.arcs[:, 0] - origin, mark.arcs[:, -1] - origin
    np.testing.assert_allclose(np.linalg.norm(start, axis=1), radius, rtol=1e-12)
    # joint1 hangs from the fixed base: its zero direction, the reference ray, never moves
    ray = mark.rays[:, 1] - origin
    np.testing.assert_allclose(ray, np.tile(ray[0], (len(ray), 1)), atol=POSITION_ATOL)
    np.testing.assert_allclose(np.cross(start, ray), 0.0, atol=POSITION_ATOL)
    # the arc ends on link 1's direction (joint1 -> joint2, its normal part to the axis)
    link = np.array([frame_world(pendubot, "joint2", qk) for qk in q]) - origin
    link[:, 1] = 0.0  # joint1 turns about the world's y axis: its child's direction is in the x-z plane
    unit = link / np.linalg.norm(link, axis=1)[:, None]
    np.testing.assert_allclose(end, radius * unit, atol=1e-12)
    # and spans |q|: the angle between its ends, along the way (the middle point is at q / 2)
    cosine = np.clip(np.sum(start * end, axis=1) / radius**2, -1.0, 1.0)
    np.testing.assert_allclose(
        np.arccos(cosine), np.abs(np.remainder(q[:, 0] + np.pi, 2 * np.pi) - np.pi), atol=ANGLE_ATOL
    )


def test_the_page_carries_the_labels(playback: viewer.Playback) -> None:
    page = viewer.to_html(playback)
    info = json.loads(re.search(r'id="robodyn-info">(.*?)</script>', page, re.S).group(1))  # type: ignore[union-attr]
    assert [p["text"] for p in info["labels"]["points"]] == ["A", "B", "P"]
    assert len(info["labels"]["points"][0]["xyz"]) == playback.n_frames
    (angle,) = info["labels"]["angles"]
    assert angle["text"] == "θ" and len(angle["arc"]) == playback.n_frames
    assert 'id="robodyn-labels"' in page


def test_bad_labels_name_what_exists(pendubot: robodyn.Robot) -> None:
    with pytest.raises(UnknownNameError, match="expected one of: .*joint2"):
        viewer.build(pendubot, labels={"A": "elbow"})
    with pytest.raises(UnknownNameError, match="joint of pendubot"):
        viewer.build(pendubot, angles={"θ": "tip"})
    with pytest.raises(InputError, match="1 to 12 characters"):
        viewer.build(pendubot, labels={"": "joint1"})
    with pytest.raises(InputError, match="revolute"):
        viewer.build(robodyn.load("cart_pole"), angles={"x": "slider"})


def test_view_labels_on_the_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pendubot = robodyn.load("pendubot")
    file = tmp_path / "t.npz"
    swinging(pendubot).save(file)
    page = tmp_path / "t.html"
    args = ["view", "pendubot", str(file), "--label", "A=joint1", "--angle", "θ=joint1", "--html", str(page)]
    assert main(args) == 0
    assert '"text": "\\u03b8"' in page.read_text(encoding="utf-8")
    assert main(["view", "pendubot", str(file), "--label", "A=elbow", "--html", str(page)]) == 2
    assert "unknown frame of pendubot (label 'A') 'elbow'" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:
        main(["view", "pendubot", str(file), "--label", "A", "--html", str(page)])
    assert exit_.value.code == 2
    assert "expected TEXT=NAME" in capsys.readouterr().err
