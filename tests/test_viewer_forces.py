"""What acts on the robot in a replay (robodyn.viewer.forces) and what the replay says about the physics.

Arrows point the way their force or torque acts and scale with it; a hit on a stop is put on the
joint at its limit; the switched controller's record carries the energy its swing-up regulates
and the page charts it with its target; the hand-over names the pole's angle from upright; the
ground plane says what passes through it; meshcat's axes are hidden; the fit camera frames the
moving shapes, not a cart's long rail.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import robodyn
import robodyn.control
from robodyn import dynamics, viewer
from robodyn.sim.trajectory import Trajectory
from robodyn.viewer import camera, forces, ground, palette, panel

GEOMETRY_ATOL = 1e-12  # [m]: the arrow's points come from the same joint placement and one product
ANGLE_ATOL_DEG = 1e-9  # the sweep is MAX_SWEEP_DEG times a ratio of the same numbers: round-off only


@pytest.fixture(scope="module")
def cart_pole() -> robodyn.Robot:
    return robodyn.load("cart_pole")


def _pushed(robot: robodyn.Robot, column: int, amplitude: float) -> Trajectory:
    """A run whose actuated joint ``column`` is driven by amplitude * sin(2 pi t) for 1 s."""

    def torque(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        tau = np.zeros(robot.nv)
        tau[column] = amplitude * np.sin(2 * np.pi * t)
        return tau

    return robodyn.simulate(robot, robot.neutral(), np.zeros(robot.nv), duration=1.0, dt=0.01, torque=torque)


def test_the_carts_push_is_an_arrow_along_the_rail_the_way_it_pushes(cart_pole: robodyn.Robot) -> None:
    playback = viewer.build(cart_pole, _pushed(cart_pole, 0, 8.0))
    (arrow,) = playback.arrows  # the hinge is passive: no torque, no arrow
    assert (arrow.joint, arrow.kind) == ("slider", "force")
    largest = float(np.max(np.abs(playback.runs[0].trajectory.tau[:, 0])))
    length = arrow.points[:, -1] - arrow.points[:, 0]
    expected = (arrow.values / largest * forces.ARROW_FRACTION * playback.framing.size)[:, None] * [1.0, 0.0, 0.0]
    np.testing.assert_allclose(length, expected, atol=GEOMETRY_ATOL)  # along +x when F > 0, its size in scale
    pushing = int(np.argmax(arrow.values))
    assert arrow.values[pushing] > 0 and length[pushing, 0] > 0


def test_a_motor_torque_is_a_curved_arrow_sweeping_the_way_it_turns() -> None:
    pendubot = robodyn.load("pendubot")
    playback = viewer.build(pendubot, _pushed(pendubot, 0, 1.5))
    (arrow,) = playback.arrows
    assert (arrow.joint, arrow.kind) == ("joint1", "torque")
    largest = float(np.max(np.abs(playback.runs[0].trajectory.tau[:, 0])))
    placement, _, axis = dynamics.joint_frames(pendubot.model, pendubot.data, pendubot.neutral())[0]  # the shoulder
    origin = placement[:3, 3]  # fixed: the shoulder does not move; a positive torque turns about +axis
    for k in np.flatnonzero((np.abs(arrow.values) > 0.05 * largest) & (np.abs(arrow.values) < 0.5 * largest)):
        start, end = arrow.points[k, 0] - origin, arrow.points[k, -1] - origin
        turned = np.degrees(np.arctan2(np.dot(np.cross(start, end), axis), np.dot(start, end)))
        expected = forces.MAX_SWEEP_DEG * arrow.values[k] / largest  # under 150 degrees: atan2 is unambiguous
        assert turned == pytest.approx(expected, abs=ANGLE_ATOL_DEG), k


def test_a_hit_on_a_stop_is_put_on_the_joint_at_its_limit(cart_pole: robodyn.Robot) -> None:
    run = robodyn.simulate(cart_pole, [0.0, 0.3], [0.0, 0.0], duration=0.2, dt=0.01)
    n = len(run.t)
    q = np.array(run.q, dtype=np.float64)
    q[10:, 0] = cart_pole.model.upperPositionLimit[0]  # the cart reaches its stop at sample 10 ...
    work_limits = np.zeros(n)
    work_limits[10:] = -0.25  # ... and the stop takes 0.25 J there
    hit = dataclasses.replace(run, q=q, work_limits=work_limits)
    playback = viewer.build(cart_pole, hit, fps=1 / 0.01)  # one rendered frame per sample
    (impact,) = playback.impacts
    assert (impact.joint, impact.frame, impact.energy) == ("slider", 10.0, -0.25)
    placement = dynamics.joint_frames(cart_pole.model, cart_pole.data, q[10])[0][0]
    np.testing.assert_allclose(impact.xyz, placement[:3, 3], atol=GEOMETRY_ATOL)


def test_the_switched_controllers_record_is_charted_with_its_target_and_hand_over(cart_pole: robodyn.Robot) -> None:
    controller = robodyn.control.make("swing_up", cart_pole)
    run = robodyn.simulate(cart_pole, [0.0, 1.2], [0.0, 0.0], duration=0.3, dt=0.01, torque=controller)
    record = controller.record(run.q, run.v)
    k = 17  # the hand-over sample this test writes into the record
    record["mode"] = [0] * k + [1] * (len(run.t) - k)
    np.testing.assert_array_equal(
        record["energy"], [controller.swing_up.energy(q, v) for q, v in zip(run.q, run.v, strict=True)]
    )
    assert record["energy_target"] == controller.swing_up.energy_up == 0.0
    playback = viewer.build(cart_pole, dataclasses.replace(run, meta={**run.meta, "controller": record}))
    charts = {c.key: c for c in playback.charts}
    regulated = charts["regulated"]
    assert [value for _, value, _ in regulated.limits] == [0.0] and regulated.limits[0][0] == "target 0 J"
    np.testing.assert_array_equal(regulated.series[0].values, np.array(record["energy"])[playback.sample_index])
    angle = abs(np.degrees((run.q[k, 1] + np.pi) % (2 * np.pi) - np.pi))
    assert charts["mode"].title == f"Controller mode: LQR from t = {run.t[k]:.3f} s, hinge {angle:.1f}° from upright"
    assert playback.mode is not None and playback.mode["values"][0] == 0 and playback.mode["names"][1] == "LQR balance"


def test_what_goes_below_the_ground_plane_is_named_with_its_depth() -> None:
    frames = {"base": np.zeros((3, 3)), "hand_joint": np.array([[0, 0, 0.5], [0, 0, -0.43], [0, 0, 0.1]])}
    frames["hand"] = frames["hand_joint"].copy()  # as deep as its joint's frame: the body's name is said
    (sentence,) = ground.below_ground(frames)
    assert sentence.startswith("hand goes 0.43 m below the ground plane")
    assert ground.below_ground({"base": np.zeros((3, 3)), "tip": np.array([[0, 0, -1e-4]] * 3)}) == ()


def test_meshcats_axes_are_hidden_unless_asked_for(cart_pole: robodyn.Robot) -> None:
    def axes_visible(playback: viewer.Playback) -> list[bool]:
        sent = [c.lower() for c in playback.commands if type(c).__name__ == "SetProperty"]
        return [c["value"] for c in sent if c["path"] == "/Axes" and c["property"] == "visible"]

    assert axes_visible(viewer.build(cart_pole)) == [False]
    assert axes_visible(viewer.build(cart_pole, axes=True)) == [True]


def test_the_fit_camera_frames_the_moving_cart_and_pole_not_the_rail(cart_pole: robodyn.Robot) -> None:
    playback = viewer.build(cart_pole, _pushed(cart_pole, 0, 8.0))
    rail = float(cart_pole.model.upperPositionLimit[0])  # the rail's blocks stand beyond the cart's stops
    moving = [obj for obj in playback.objects if np.ptp(obj.placements, axis=0).max() > 0]
    low, high = camera.robot_boxes(moving, playback.n_frames)
    np.testing.assert_allclose(playback.framing.half[0], 0.5 * (high[:, 0].max() - low[:, 0].min()))
    assert playback.framing.half[0] < rail


def test_the_panels_colours_are_okabe_ito() -> None:
    okabe_ito = set(palette.OKABE_ITO.values())
    assert set(panel.ENERGY_COLORS.values()) <= okabe_ito and set(panel.WORK_COLORS.values()) <= okabe_ito
    assert (
        set(viewer.RUN_COLORS) <= okabe_ito and set(viewer.LINK_COLORS) <= okabe_ito and viewer.TRACE_COLOR in okabe_ito
    )
