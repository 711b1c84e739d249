"""Names written in the 3D view: points labelled as a textbook figure labels them, and joint angles as arcs.

A label is a text (``"A"``) on a frame of the model (``"joint_a"``): the page writes it beside
the frame's position at every moment of the playback. An angle mark is a text (``"θ"``) on a
revolute joint: a dashed reference ray along the direction the joint's child points at zero
angle, an arc from that ray to where the child points now (radius :data:`ARC_RADIUS_FRACTION`
of the framed size), and the text at the arc's middle. The child's direction is the way to its
first child joint (for the linkage's joint at A, up bar AB to B), else to its centre of mass.

Positions are computed here, in the model's world frame [m], one per rendered frame; the page
(``assets/replay.js``) projects them through meshcat's camera and the drawing's shift (follow
mode included) and draws them over the 3D pane.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.errors import InputError, UnknownNameError
from robodyn.viewer.springs import revolute_axis

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

ARC_POINTS = 24
"""Points of each angle's arc: smooth at the sizes a label is read at."""
ARC_RADIUS_FRACTION = 0.12
"""Radius of an angle's arc, as a fraction of the framed size."""
RAY_FRACTION = 1.6
"""Length of the reference ray, in arc radii: it reaches past the arc, so that the angle reads from it."""
TEXT_FRACTION = 1.35
"""The angle's text sits at this many arc radii from the joint, on the arc's bisector."""
MAX_LABEL_CHARS = 12
"""A label names a point or an angle: a few characters."""


@dataclass(frozen=True, eq=False)
class PointLabel:
    """A text on a frame: its world positions at the rendered frames [m], shape (k, 3)."""

    text: str
    frame: str
    points: Array


@dataclass(frozen=True, eq=False)
class AngleMark:
    """A joint angle drawn as an arc, at the rendered frames (world, [m]).

    Attributes:
        text: the angle's name, e.g. "θ".
        joint: the revolute joint whose angle it is.
        angles: the joint's angle at the rendered frames [rad], shape (k,).
        arcs: the arc from the reference ray to the child's direction, shape (k, ARC_POINTS, 3).
        rays: the reference ray's two ends (the joint, and RAY_FRACTION radii along it), shape (k, 2, 3).
        anchors: where the text sits, shape (k, 3).
    """

    text: str
    joint: str
    angles: Array
    arcs: Array
    rays: Array
    anchors: Array


def _check_text(text: str, what: str) -> str:
    if not isinstance(text, str) or not text.strip() or len(text) > MAX_LABEL_CHARS:
        raise InputError(f"{what}: a label is 1 to {MAX_LABEL_CHARS} characters, got {text!r}")
    return text


def point_labels(robot: Robot, labels: Mapping[str, str] | None, frames: dict[str, Array]) -> list[PointLabel]:
    """One :class:`PointLabel` per ``text -> frame`` of ``labels``, from the rendered frames' positions ``frames``.

    Raises:
        InputError: an empty or overlong text.
        UnknownNameError: a frame the model does not have.
    """
    out: list[PointLabel] = []
    for text, frame in (labels or {}).items():
        _check_text(text, "labels")
        if frame not in frames:
            raise UnknownNameError(f"frame of {robot.name} (label {text!r})", frame, frames)
        out.append(PointLabel(text, frame, np.array(frames[frame], dtype=np.float64)))
    return out


def _rotation(axis: Array, angle: Array) -> Array:
    """Rotations (n, 3, 3) about the unit ``axis`` by each of ``angle`` (n,) [rad] (Rodrigues)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def child_direction(robot: Robot, joint_id: int, axis: Array) -> Array:
    """Unit direction, in the joint's frame and normal to its axis, in which its child points at zero angle."""
    model = robot.model
    children = [
        np.asarray(model.jointPlacements[j].translation)
        for j in range(1, model.njoints)
        if model.parents[j] == joint_id
    ]
    candidates = [*children, np.asarray(model.inertias[joint_id].lever)]
    for c in candidates:
        normal = c - (c @ axis) * axis
        if np.linalg.norm(normal) > 1e-9:
            return normal / np.linalg.norm(normal)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    normal = np.cross(axis, helper)
    return normal / np.linalg.norm(normal)


def angle_marks(robot: Robot, angles: Mapping[str, str] | None, configurations: Array, size: float) -> list[AngleMark]:
    """One :class:`AngleMark` per ``text -> revolute joint`` of ``angles``, at each configuration (k, nq).

    Raises:
        InputError: an empty or overlong text, or a joint that is not revolute.
        UnknownNameError: a joint the model does not have.
    """
    model = robot.model
    names = [str(n) for n in model.names][1:]
    frame_names = [str(f.name) for f in model.frames]
    out: list[AngleMark] = []
    radius = ARC_RADIUS_FRACTION * size
    for text, joint in (angles or {}).items():
        _check_text(text, "angles")
        if joint not in names:
            raise UnknownNameError(f"joint of {robot.name} (angle {text!r})", joint, names)
        joint_id = int(model.getJointId(joint))
        joint_model = model.joints[joint_id]
        axis = revolute_axis(joint_model)
        if axis is None or joint not in frame_names:
            raise InputError(
                f"angles: {text!r} marks joint {joint!r}, a {joint_model.shortname()}; "
                "an angle is drawn on a revolute joint"
            )
        i = int(joint_model.idx_q)
        if int(joint_model.nq) == 2:  # continuous: (cos, sin)
            q = np.arctan2(configurations[:, i + 1], configurations[:, i])
        else:
            q = np.array(configurations[:, i], dtype=np.float64)
        index = frame_names.index(joint)
        placements = np.array(
            [dynamics.frame_placements(model, robot.data, qk)[index] for qk in configurations], dtype=np.float64
        )
        origin, rotation = placements[:, :3, 3], placements[:, :3, :3]
        zero = rotation @ _rotation(axis, -q)  # the joint's frame at zero angle, (k, 3, 3)
        d = child_direction(robot, joint_id, axis)
        s = np.linspace(0.0, 1.0, ARC_POINTS)
        arcs = np.empty((len(q), ARC_POINTS, 3))
        for n, fraction in enumerate(s):
            arcs[:, n] = origin + radius * ((zero @ _rotation(axis, fraction * q)) @ d)
        ray_end = origin + RAY_FRACTION * radius * (zero @ d)
        middle = zero @ _rotation(axis, 0.5 * q) @ d
        anchors = origin + TEXT_FRACTION * radius * middle
        out.append(AngleMark(text, joint, q, arcs, np.stack([origin, ray_end], axis=1), anchors))
    return out


def labels_info(labels: tuple[PointLabel, ...], marks: tuple[AngleMark, ...]) -> dict[str, list[dict[str, object]]]:
    """What the page draws: each label's points and each angle's arc, ray and text position (world, [m])."""

    def rounded(a: Array) -> list[object]:
        return np.round(a, 6).tolist()  # type: ignore[no-any-return]

    return {
        "points": [{"text": lab.text, "frame": lab.frame, "xyz": rounded(lab.points)} for lab in labels],
        "angles": [
            {"text": m.text, "joint": m.joint, "arc": rounded(m.arcs), "ray": rounded(m.rays), "at": rounded(m.anchors)}
            for m in marks
        ],
    }
