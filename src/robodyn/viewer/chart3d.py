"""The in-scene energy chart: T, V and E = T + V drawn on a panel beside the robot, with a cursor.

The panel stands in the scene (meshcat has no 2D overlay): a legend band at the top (a
colour swatch and a name per curve, at fixed places), the plotting area below it, the energy
ticks in joules left of the axis and the time ticks in seconds under it. The cursor rides on
the E curve; its placements are one animation track, so it moves with the animation.
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.viewer.backend import ROOT, scene_path
from robodyn.viewer.layout import Layout
from robodyn.viewer.transforms import rotation_x, translation, translations

Array = NDArray[np.float64]

# The chart's curves: hues apart from the first link colours, so neither can pass for the other.
ENERGY_COLORS = {"E": 0x7B1FA2, "T": 0x1E88E5, "V": 0xD81B60}
CURSOR_PATH = (*ROOT, "energy", "cursor")
"""Scene path of the cursor that rides on the E curve (animated)."""

# The chart's legend: (key, label), drawn left to right in the top band of the panel.
CHART_LEGEND = (("E", "E = T + V"), ("T", "T kinetic"), ("V", "V potential"))

# Average advance of a sans-serif character, in ems: the width estimate that places text
# beside a swatch or against an axis (Chromium's sans-serif measured 0.45 em on "V potential").
_EM_PER_CHAR = 0.5
_CANVAS_PX = 256  # meshcat draws text textures on a 256 x 256 canvas
_TEXT_FONT_PX = 32


class _PlaneGeometry:
    """three.js PlaneGeometry (meshcat 0.3 has none); lowered like meshcat's own geometries."""

    field = "geometries"

    def __init__(self, width: float, height: float) -> None:
        self.uuid = str(uuid.uuid1())
        self.width, self.height = width, height

    def intrinsic_transform(self) -> Array:
        return np.eye(4)

    def lower_in_object(self, object_data: dict[str, Any]) -> str:
        object_data.setdefault(self.field, []).append(
            {"uuid": self.uuid, "type": "PlaneGeometry", "width": self.width, "height": self.height}
        )
        return self.uuid


class _TextTexture:
    """meshcat's ``_text`` canvas texture: black text centred on a 256 x 256 canvas."""

    field = "textures"

    def __init__(self, text: str, font_size: int = 40) -> None:
        self.uuid = str(uuid.uuid1())
        self.text, self.font_size = text, font_size

    def lower_in_object(self, object_data: dict[str, Any]) -> str:
        object_data.setdefault(self.field, []).append(
            {
                "uuid": self.uuid,
                "type": "_text",
                "text": self.text,
                "font_size": self.font_size,
                "font_face": "sans-serif",
            }
        )
        return self.uuid


@dataclass(frozen=True)
class ChartLabel:
    """One text of the energy chart: what it says and the box it covers, chart frame [m].

    ``box`` is (x_min, y_min, x_max, y_max) in the panel's plane (origin at its lower-left
    corner, x along time, y along energy), from the text's estimated width and its em height.
    """

    key: str
    text: str
    box: tuple[float, float, float, float]


@dataclass(frozen=True)
class ChartLayout:
    """Where the energy chart put its parts (chart frame [m]), for tests and for the legend's colours.

    ``frame`` maps chart coordinates (x, y, 0) to robot coordinates (before ``Playback.offset``).
    """

    frame: Array
    width: float
    height: float
    plot: tuple[float, float, float, float]  # left, bottom, right, top of the plotting area
    labels: tuple[ChartLabel, ...]
    swatches: dict[str, tuple[float, float]]  # legend key -> centre of its colour swatch

    def to_world(self, xy: tuple[float, float]) -> Array:
        """Chart point (x, y) -> robot coordinates [m] (add ``Playback.offset`` for the drawing)."""
        return (self.frame @ np.array([xy[0], xy[1], 0.0, 1.0]))[:3]


def _text_box(key: str, text: str, centre: tuple[float, float], em: float) -> ChartLabel:
    half = 0.5 * _EM_PER_CHAR * em * len(text)
    x, y = centre
    return ChartLabel(key, text, (x - half, y - 0.5 * em, x + half, y + 0.5 * em))


def chart_commands(
    mc: Any, layout: Layout, tau: Array, kinetic: Array, potential: Array
) -> tuple[list[Any], Array, ChartLayout]:
    """The chart's commands, the cursor's placements (k, 4, 4) in the chart's frame, and where things went.

    The panel has a legend band at the top (a colour swatch and a name per curve, at fixed
    places: no label can land on another or on a curve), the plotting area below it, the
    energy ticks in joules left of the axis and the time ticks in seconds under it.

    Args:
        mc: the meshcat module.
        layout: the scene's layout; it must have a chart panel.
        tau: playback times of the rendered frames [s], shape (k,).
        kinetic: T at those frames [J], shape (k,), or empty (no curves).
        potential: V at those frames [J], shape (k,), or empty (no curves).
    """
    chart = layout.chart
    if chart is None:
        raise ValueError("the layout has no chart")
    w, h = chart.width, chart.height
    em = 0.07 * h  # text height [m]
    left, right, bottom, top = 0.22 * w, 0.95 * w, 0.2 * h, 0.76 * h
    lines = {"E": kinetic + potential, "T": kinetic, "V": potential} if len(kinetic) else {}
    values = np.concatenate(list(lines.values())) if lines else np.zeros(1)
    lo, hi = float(values.min()), float(values.max())
    pad = max(0.05 * (hi - lo), 1e-6 * max(abs(lo), abs(hi), 1.0))
    lo, hi = lo - pad, hi + pad
    span_t = float(tau[-1]) if tau[-1] > 0 else 1.0

    def to_xy(tk: Array, e: Array) -> Array:
        return np.column_stack([left + (right - left) * tk / span_t, bottom + (top - bottom) * (e - lo) / (hi - lo)])

    frame = rotation_x(np.pi / 2)  # chart x -> world x, chart y -> world z, chart normal -> world -y
    frame[:3, 3] = chart.origin
    base = (*ROOT, "energy")
    lift = 0.004 * layout.size
    panel = mc.geometry.Mesh(_PlaneGeometry(w, h), mc.geometry.MeshBasicMaterial(color=0xFFFFFF))
    commands: list[Any] = [
        mc.commands.SetTransform(frame, scene_path(mc, base)),
        mc.commands.SetObject(panel, path=scene_path(mc, (*base, "panel"))),
        mc.commands.SetTransform(translation([w / 2, h / 2, 0.0]), scene_path(mc, (*base, "panel"))),
    ]
    axes = np.array([[left, top, lift], [left, bottom, lift], [left, bottom, lift], [right, bottom, lift]])
    commands.append(_line(mc, (*base, "axes"), axes, 0x333333, segments=True))
    for name, series in lines.items():
        xy = to_xy(tau, series)
        commands.append(_line(mc, (*base, name), np.column_stack([xy, np.full(len(xy), lift)]), ENERGY_COLORS[name]))

    labels: list[ChartLabel] = []
    swatches: dict[str, tuple[float, float]] = {}
    # One fixed slot per entry, a third of the width each: a swatch, then its name.
    legend_y, swatch_w, swatch_h, gap = 0.88 * h, 0.05 * w, 0.6 * em, 0.015 * w
    for i, (key, text) in enumerate(CHART_LEGEND if lines else ()):
        slot = 0.03 * w + i * 0.32 * w
        centre = (slot + swatch_w / 2, legend_y)
        swatches[key] = centre
        swatch = mc.geometry.Mesh(
            _PlaneGeometry(swatch_w, swatch_h), mc.geometry.MeshBasicMaterial(color=ENERGY_COLORS[key])
        )
        commands += [
            mc.commands.SetObject(swatch, path=scene_path(mc, (*base, f"legend_{key}_swatch"))),
            mc.commands.SetTransform(translation([*centre, lift]), scene_path(mc, (*base, f"legend_{key}_swatch"))),
        ]
        text_w = _EM_PER_CHAR * em * len(text)
        labels.append(_text_box(f"legend_{key}", text, (slot + swatch_w + gap + text_w / 2, legend_y), em))
    tick_em = 0.9 * em
    for key, text, anchor in (
        ("e_max", f"{hi:.3g} J", top),
        ("e_min", f"{lo:.3g} J", bottom),
    ):
        text_w = _EM_PER_CHAR * tick_em * len(text)
        labels.append(_text_box(key, text, (left - 0.03 * w - text_w / 2, anchor), tick_em))
    labels.append(_text_box("t_min", "0 s", (left, bottom - 0.09 * h), tick_em))
    labels.append(_text_box("t_max", f"{span_t:.3g} s", (right - 0.04 * w, bottom - 0.09 * h), tick_em))
    labels.append(_text_box("t_axis", "t [s]", (0.5 * (left + right), bottom - 0.09 * h), tick_em))
    for label in labels:
        x0, y0, x1, y1 = label.box
        commands += _text(mc, (*base, label.key), label.text, [0.5 * (x0 + x1), 0.5 * (y0 + y1), lift], y1 - y0)
    cursor_xy = to_xy(tau, kinetic + potential) if lines else np.zeros((len(tau), 2))
    cursor = translations(np.column_stack([cursor_xy, np.full(len(tau), 2 * lift)]))
    sphere = mc.geometry.Mesh(mc.geometry.Sphere(0.03 * h), mc.geometry.MeshBasicMaterial(color=ENERGY_COLORS["E"]))
    commands += [
        mc.commands.SetObject(sphere, path=scene_path(mc, CURSOR_PATH)),
        mc.commands.SetTransform(cursor[0], scene_path(mc, CURSOR_PATH)),
    ]
    where = ChartLayout(frame, w, h, (left, bottom, right, top), tuple(labels), swatches)
    return commands, cursor, where


def _line(mc: Any, path: tuple[str, ...], xyz: Array, color: int, *, segments: bool = False) -> Any:
    kind = mc.geometry.LineSegments if segments else mc.geometry.Line
    geometry = mc.geometry.PointsGeometry(np.ascontiguousarray(xyz.T, dtype=np.float32))
    return mc.commands.SetObject(kind(geometry, mc.geometry.LineBasicMaterial(color=color)), path=scene_path(mc, path))


def _text(mc: Any, path: tuple[str, ...], text: str, centre: list[float], glyph: float) -> list[Any]:
    """A label ``glyph`` [m] high (its em), centred on ``centre`` (chart frame).

    meshcat draws the text on a 256 px canvas and shrinks the font when the text is wider;
    the font is chosen here so that it fits, and the plane scaled so the em stays ``glyph``.
    """
    font_px = max(8, min(_TEXT_FONT_PX, int(0.95 * _CANVAS_PX / (_EM_PER_CHAR * max(len(text), 1) * 1.1))))
    size = glyph * _CANVAS_PX / font_px
    # The canvas draws on its middle line (alphabetic baseline): lower the plane by a third of an em.
    x, y, z = centre
    material = mc.geometry.MeshBasicMaterial(
        color=0xFFFFFF, map=_TextTexture(text, font_px), transparent=True, depthWrite=False
    )
    return [
        mc.commands.SetObject(mc.geometry.Mesh(_PlaneGeometry(size, size), material), path=scene_path(mc, path)),
        mc.commands.SetTransform(translation([x, y - 0.35 * glyph, z]), scene_path(mc, path)),
    ]
