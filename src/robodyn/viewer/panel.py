"""The chart panel beside the 3D view: which curves it shows, in which units, at the rendered frames.

The page (``assets/replay.js``) draws the charts on canvases in a panel of
:data:`PANEL_WIDTH_PX` pixels at the right of the 3D pane, with a cursor (a magenta line at
the animation's time) that moves with playback; clicking a chart seeks the animation there.
This module computes what they plot, from each run's trajectory at its rendered rows:

* energy: T, V and E = T + V [J];
* the ledger: the cumulative works W_input, W_damping, W_limits and what is left over,
  E - E(0) - W [J];
* power: tau . v, the rate of the input work [W] (the trajectory's ``power`` when it has one);
* joint torques [N m, or N on a prismatic joint], with the model's effort limits dashed;
* constraint drift [m], when the trajectory carries one sample by sample, on a log scale:
  a closed loop held by a solver drifts by 1e-12 m to 1e-9 m, decades a linear axis would
  flatten (a zero sits on the axis floor).

One run: one colour per curve. Several runs: the run's colour, one dash pattern per curve.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.viewer.geometry import LINK_COLORS

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.viewer.runs import Run

Array = NDArray[np.float64]

PANEL_WIDTH_PX = 420
"""Width of the chart panel at the right of the page [px]."""
PLOT_MARGINS_PX = {"left": 70, "right": 14, "top": 8, "bottom": 30}
"""Plotting area inside each chart's canvas [px]: room for the value ticks (left) and the time ticks (below)."""
CURSOR_COLOR = 0xFF00FF
"""The time cursor: magenta, a hue no curve and no link has."""
ENERGY_COLORS = {"E": 0x7B1FA2, "T": 0x1E88E5, "V": 0xD81B60}
WORK_COLORS = {"input": 0x2E7D32, "damping": 0x6D4C41, "limits": 0x455A64, "residual": 0x9E9E9E}
POWER_COLOR = 0xEF6C00
DRIFT_COLOR = 0x5E35B1
DASHES = ((), (7, 4), (2, 3), (9, 3, 2, 3), (4, 4), (1, 2), (12, 4), (6, 2, 2, 2))
"""Dash patterns [px] that tell the curves of one run apart when several runs share a chart."""


@dataclass(frozen=True)
class Series:
    """One curve: its legend label, run number, colour, dash pattern and values at the rendered frames."""

    label: str
    run: int
    color: int
    dash: tuple[int, ...]
    values: Array


@dataclass(frozen=True)
class Chart:
    """One chart of the panel: key, title, unit of its values, its curves, its dashed limit lines, its scale.

    ``scale`` is "linear", or "log" (decades of the positive values; the page falls back to
    linear when none is positive).
    """

    key: str
    title: str
    unit: str
    series: tuple[Series, ...]
    limits: tuple[tuple[str, float, int], ...] = ()  # (label, value, colour)
    scale: str = "linear"


LOG_SCALE = frozenset({"drift"})
"""Charts drawn on a log scale: constraint drift spans decades near zero."""


def _rows(values: Any, n: int, index: NDArray[np.int64]) -> Array | None:
    """``values`` at the rows ``index`` when it holds one finite number per sample (n,), else None."""
    if values is None:
        return None
    array = np.asarray(values, dtype=np.float64)
    if array.shape != (n,) or not np.all(np.isfinite(array)):
        return None
    return array[index]


def _run_quantities(robot: Robot, run: Run) -> dict[str, list[tuple[str, Array, int]]]:
    """Chart key -> (label, values at the rendered rows, one-run colour) for one run."""
    trajectory, index = run.trajectory, run.index
    n = len(trajectory.t)
    out: dict[str, list[tuple[str, Array, int]]] = {}
    kinetic = _rows(getattr(trajectory, "kinetic", None), n, index)
    potential = _rows(getattr(trajectory, "potential", None), n, index)
    if kinetic is not None and potential is not None:
        out["energy"] = [
            ("E = T + V", kinetic + potential, ENERGY_COLORS["E"]),
            ("T kinetic", kinetic, ENERGY_COLORS["T"]),
            ("V potential", potential, ENERGY_COLORS["V"]),
        ]
        energy_all = np.asarray(trajectory.kinetic, dtype=np.float64) + np.asarray(trajectory.potential)
        works = []
        total = np.zeros(n)
        for key, label in (("input", "W input"), ("damping", "W damping"), ("limits", "W limits")):
            values = _rows(getattr(trajectory, f"work_{key}", None), n, np.arange(n))
            if values is not None:
                total = total + values
                if key != "limits" or np.any(values != 0):
                    works.append((label, values[index], WORK_COLORS[key]))
        works.append(("E - E(0) - W", (energy_all - energy_all[0] - total)[index], WORK_COLORS["residual"]))
        out["ledger"] = works
    power = _power(trajectory, n)
    if power is not None:
        out["power"] = [("tau . v", power[index], POWER_COLOR)]
    tau = np.asarray(getattr(trajectory, "tau", np.zeros((n, 0))), dtype=np.float64)
    if tau.ndim == 2 and tau.shape[0] == n and tau.shape[1] == robot.nv and np.all(np.isfinite(tau)):
        names = _dof_names(robot)
        out["torque"] = [(names[j], tau[index, j], LINK_COLORS[j % len(LINK_COLORS)]) for j in range(robot.nv)]
    drift = _rows(getattr(trajectory, "constraint_drift", None), n, index)
    if drift is not None:
        out["drift"] = [("drift", drift, DRIFT_COLOR)]
    return out


def _power(trajectory: Any, n: int) -> Array | None:
    """Total input power tau . v [W], shape (n,): the trajectory's own, else computed from tau and v."""
    own = getattr(trajectory, "power", None)
    if own is not None:
        array = np.asarray(own, dtype=np.float64)
        if array.ndim == 2 and array.shape[0] == n:
            array = array.sum(axis=1)
        if array.shape == (n,) and np.all(np.isfinite(array)):
            return array
    tau = np.asarray(getattr(trajectory, "tau", None), dtype=np.float64)
    v = np.asarray(getattr(trajectory, "v", None), dtype=np.float64)
    if tau.ndim == 2 and tau.shape == v.shape and tau.shape[0] == n:
        with np.errstate(over="ignore", invalid="ignore"):
            power = np.einsum("ni,ni->n", tau, v)
        return power if np.all(np.isfinite(power)) else None  # an overflowing tau * v has no curve to draw
    return None


def _dof_names(robot: Robot) -> list[str]:
    """One name per velocity coordinate: the joint's name (numbered when a joint has several)."""
    names: list[str] = []
    for j in range(1, robot.model.njoints):
        nv = int(robot.model.joints[j].nv)
        joint = str(robot.model.names[j])
        names += [joint] if nv == 1 else [f"{joint}[{i}]" for i in range(nv)]
    return names


def _torque_unit(robot: Robot) -> str:
    """N m for rotations, N for translations; both when the model has both."""
    kinds = set()
    for j in range(1, robot.model.njoints):
        shortname = str(robot.model.joints[j].shortname()).removeprefix("JointModel")
        kinds.add("N" if shortname.startswith("P") else "N m")  # PX, PY, PZ, PrismaticUnaligned
    return " | ".join(sorted(kinds, reverse=True)) if kinds else "N m"


def panel_charts(robot: Robot, runs: Sequence[Run]) -> list[Chart]:
    """The panel's charts for ``runs``: one colour per curve for one run, the run's colour for several."""
    titles = {
        "energy": ("Energy", "J"),
        "ledger": ("Energy ledger: works", "J"),
        "power": ("Power", "W"),
        "torque": ("Joint torques", _torque_unit(robot)),
        "drift": ("Constraint drift", "m"),
    }
    per_run = [_run_quantities(robot, run) for run in runs]
    charts: list[Chart] = []
    for key, (title, unit) in titles.items():
        series: list[Series] = []
        for r, (run, quantities) in enumerate(zip(runs, per_run, strict=True)):
            for s, (label, values, color) in enumerate(quantities.get(key, [])):
                if len(runs) == 1:
                    series.append(Series(label, r, color, (), values))
                else:
                    series.append(Series(label, r, run.color, DASHES[s % len(DASHES)], values))
        if not series:
            continue
        limits: list[tuple[str, float, int]] = []
        if key == "torque":
            names = _dof_names(robot)
            effort = np.asarray(robot.model.effortLimit, dtype=np.float64)
            for j, value in enumerate(effort[: robot.nv]):
                if np.isfinite(value) and 0 < value < 1e6:
                    color = LINK_COLORS[j % len(LINK_COLORS)]
                    limits += [(f"{names[j]} limit", float(value), color), ("", -float(value), color)]
        scale = "log" if key in LOG_SCALE and any(np.any(s.values > 0) for s in series) else "linear"
        charts.append(Chart(key, title, unit, tuple(series), tuple(limits), scale))
    return charts


def panel_info(charts: Sequence[Chart], runs: Sequence[Run]) -> dict[str, Any]:
    """What the page needs to draw the panel: geometry, runs, charts (JSON-ready)."""
    return {
        "width": PANEL_WIDTH_PX,
        "margins": dict(PLOT_MARGINS_PX),
        "cursor": f"#{CURSOR_COLOR:06x}",
        "runs": [{"name": run.name, "color": f"#{run.color:06x}"} for run in runs],
        "charts": [
            {
                "key": chart.key,
                "title": chart.title,
                "unit": chart.unit,
                "scale": chart.scale,
                "series": [
                    {
                        "label": s.label,
                        "run": s.run,
                        "color": f"#{s.color:06x}",
                        "dash": list(s.dash),
                        "values": [float(f"{x:.6g}") for x in s.values],
                    }
                    for s in chart.series
                ],
                "limits": [{"label": lb, "value": v, "color": f"#{c:06x}"} for lb, v, c in chart.limits],
            }
            for chart in charts
        ],
    }
