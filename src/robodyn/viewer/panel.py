"""The chart panel beside the 3D view: which curves it shows, in which units, at the rendered frames.

The page (``assets/replay.js``) draws the charts on canvases in a panel of
:data:`PANEL_WIDTH_PX` pixels at the right of the 3D pane, with a cursor (a magenta line at
the animation's time) that moves with playback; clicking a chart seeks the animation there.
This module computes what they plot, from each run's trajectory at its rendered rows:

* energy: T, V and E = T + V [J]; with springs (the trajectory's ``meta["springs"]``), V is
  charted as its two parts, gravity's and the springs' ½ k (q - rest)^2;
* the ledger: the cumulative works W_input, W_damping, W_limits [J];
* the ledger's residual E - E(0) - W [J] on a chart of its own (1e-11 J is no tick of an axis of
  joules; the page writes a shared power of ten in the title);
* the energy a switched controller's swing-up regulates (``meta["controller"]["energy"]``), with
  its target dashed (``["energy_target"]``), titled with what that energy is;
* power: tau . v, the rate of the input work [W] (the trajectory's ``power`` when it has one);
* joint positions [rad, or m on a prismatic joint], with the model's position limits dashed and
  the impacts on the stops marked on the time axis (the samples where W_limits steps down);
* joint torques [N m, or N on a prismatic joint], with the model's effort limits dashed; a model
  that mixes both has its unit in each legend entry, and none on the ticks;
* the controller's mode, when a switched controller recorded it (``meta["controller"]["mode"]``:
  0 swing-up, 1 balance), as a step curve under the other charts, titled with the hand-over
  (:func:`handover`: its time and the angles still left to the upright);
* constraint drift [m], when the trajectory carries one sample by sample, on a log scale:
  a closed loop held by a solver drifts by 1e-12 m to 1e-9 m, decades a linear axis would
  flatten (a zero sits on the axis floor).

One run: one colour per curve, each joint's limits dashed in its colour. Several runs: the
run's colour, one dash pattern per curve; the limits dashed in grey (:data:`LIMIT_COLOR`) under
one legend entry, "effort limit" or "position limit".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robodyn.viewer.geometry import LINK_COLORS
from robodyn.viewer.palette import BLACK, BLUE, BLUISH_GREEN, ORANGE, REDDISH_PURPLE, VERMILLION

if TYPE_CHECKING:
    from robodyn.robot import Robot
    from robodyn.viewer.runs import Run

Array = NDArray[np.float64]

PANEL_WIDTH_PX = 420
"""Width of the chart panel at the right of the page [px]."""
PLOT_MARGINS_PX = {"left": 70, "right": 14, "top": 8, "bottom": 18}
"""Plotting area inside each chart's canvas [px]: room for the value ticks (left) and the time ticks, in s (below)."""
CURSOR_COLOR = 0xFF00FF
"""The time cursor: magenta, a hue no curve and no link has."""
ENERGY_COLORS = {"E": BLACK, "T": BLUE, "V": VERMILLION, "spring": BLUISH_GREEN}
"""Okabe–Ito (viewer.palette): E black, so that it never hides a potential; the spring's potential bluish green."""
SPRING = ENERGY_COLORS["spring"]
MODE_COLOR = REDDISH_PURPLE
REGULATED_COLOR = REDDISH_PURPLE
"""The swing-up law's own energy and (dashed) its target."""
WORK_COLORS = {"input": BLUISH_GREEN, "damping": ORANGE, "limits": BLUE, "residual": BLACK}
POWER_COLOR = ORANGE
DRIFT_COLOR = BLUE
LIMIT_DASH = (5, 4)
"""Dash pattern of the limit lines [px]."""
LIMIT_COLOR = 0x757575
"""Limit lines when several runs share a chart: grey, one legend entry ("effort limit"), since the curves wear
the runs' colours and a joint's colour would match nothing in the legend."""
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
    markers: tuple[float, ...] = ()  # playback-frame indices of events (impacts), drawn as ticks on the time axis
    tick_unit: bool = True  # False: the curves have different units, given in the legend


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
    spring_energy, spring_torque = _springs(robot, trajectory, n)
    if kinetic is not None and potential is not None:
        out["energy"] = [
            ("E = T + V", kinetic + potential, ENERGY_COLORS["E"]),
            ("T kinetic", kinetic, ENERGY_COLORS["T"]),
        ]
        if spring_energy is None:
            out["energy"].append(("V potential", potential, ENERGY_COLORS["V"]))
        else:
            out["energy"] += [
                ("V gravity", potential - spring_energy[index], ENERGY_COLORS["V"]),
                ("V spring", spring_energy[index], ENERGY_COLORS["spring"]),
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
        out["ledger"] = works
        residual = (energy_all - energy_all[0] - total)[index]  # its own chart: 1e-11 J is no tick of a J axis
        out["residual"] = [("E - E(0) - W", residual, WORK_COLORS["residual"])]
    power = _power(trajectory, n)
    if power is not None:
        out["power"] = [("tau . v", power[index], POWER_COLOR)]
    q = np.asarray(getattr(trajectory, "q", np.zeros((n, 0))), dtype=np.float64)
    if q.ndim == 2 and q.shape == (n, robot.nq) and robot.nq == robot.nv and np.all(np.isfinite(q)):
        names = _dof_names(robot)
        out["position"] = [
            (_with_unit(robot, names[j], j, "position"), q[index, j], LINK_COLORS[j % len(LINK_COLORS)])
            for j in range(robot.nq)
        ]
    tau = np.asarray(getattr(trajectory, "tau", np.zeros((n, 0))), dtype=np.float64)
    if tau.ndim == 2 and tau.shape[0] == n and tau.shape[1] == robot.nv and np.all(np.isfinite(tau)):
        names = _dof_names(robot)
        out["torque"] = [
            (_with_unit(robot, names[j], j, "torque"), tau[index, j], LINK_COLORS[j % len(LINK_COLORS)])
            for j in range(robot.nv)
        ]
        if spring_torque is not None:  # the springs' couples, beside the applied torques
            out["torque"] += [
                (f"spring at {_with_unit(robot, names[j], j, 'torque')}", spring_torque[index, j], SPRING)
                for j in range(robot.nv)
                if np.any(spring_torque[:, j] != 0)
            ]
    regulated = _regulated(trajectory, n)
    if regulated is not None:
        out["regulated"] = [("the swing-up law's E", regulated[0][index], REGULATED_COLOR)]
    mode = _modes(trajectory, n)
    if mode is not None:
        out["mode"] = [("mode: 0 swing-up, 1 LQR balance", mode[index], MODE_COLOR)]
    drift = _rows(getattr(trajectory, "constraint_drift", None), n, index)
    if drift is not None:
        out["drift"] = [("drift", drift, DRIFT_COLOR)]
    return out


def _springs(robot: Robot, trajectory: Any, n: int) -> tuple[Array | None, Array | None]:
    """The springs' potential ½ k (q - rest)^2 (n,) [J] and couples -k (q - rest) (n, nv), from ``meta["springs"]``."""
    springs = (getattr(trajectory, "meta", None) or {}).get("springs") or {}
    q = np.asarray(getattr(trajectory, "q", np.zeros((n, 0))), dtype=np.float64)
    if not isinstance(springs, dict) or not springs or q.shape != (n, robot.nq):
        return None, None
    energy, torque = np.zeros(n), np.zeros((n, robot.nv))
    names = set(robot.joint_names)
    for joint, spring in springs.items():
        if joint not in names or not isinstance(spring, dict):
            return None, None  # a spring on a joint this model does not have: chart V whole
        info = robot.joint(joint)
        k, rest = float(spring.get("stiffness", 0.0)), float(spring.get("rest", 0.0))
        if info.nq != 1 or not (np.isfinite(k) and np.isfinite(rest)):
            return None, None
        stretch = q[:, info.idx_q] - rest
        energy += 0.5 * k * stretch**2
        torque[:, info.idx_v] -= k * stretch
    if not np.any(energy) or not np.all(np.isfinite(energy)):
        return None, None
    return energy, torque


def _modes(trajectory: Any, n: int) -> Array | None:
    """The recorded controller mode per sample (0 swing-up, 1 balance) as floats (n,), or None."""
    controller = (getattr(trajectory, "meta", None) or {}).get("controller")
    mode = controller.get("mode") if isinstance(controller, dict) else None
    if not isinstance(mode, list) or len(mode) != n:
        return None
    values = np.asarray(mode, dtype=np.float64)
    return values if np.all(np.isin(values, (0.0, 1.0))) else None


def _controller(trajectory: Any) -> dict[str, Any]:
    controller = (getattr(trajectory, "meta", None) or {}).get("controller")
    return controller if isinstance(controller, dict) else {}


def _regulated(trajectory: Any, n: int) -> tuple[Array, float, str] | None:
    """The swing-up law's own energy per sample (n,) [J], its target [J] and its name, from the record."""
    controller = _controller(trajectory)
    energy, target = _rows(controller.get("energy"), n, np.arange(n)), controller.get("energy_target")
    if energy is None or not isinstance(target, (int, float)) or not np.isfinite(target):
        return None
    return energy, float(target), str(controller.get("energy_name", "the swing-up law's energy"))


def handover(robot: Robot, trajectory: Any) -> str:
    """Where the switched controller hands over to the LQR: "LQR from t = 2.588 s, hinge 57.8° from upright".

    The angles are the revolute coordinates' distances from the LQR's upright (the record's
    ``upright``), wrapped to [-180°, 180°), at the first sample in balance mode; "" when the
    run records no hand-over.
    """
    controller = _controller(trajectory)
    mode, upright, angular = controller.get("mode"), controller.get("upright"), controller.get("angular")
    n = len(trajectory.t)
    if not isinstance(mode, list) or len(mode) != n or 1 not in mode:
        return ""
    k = mode.index(1)
    text = f"LQR from t = {float(trajectory.t[k]):.3f} s"
    q = np.asarray(trajectory.q, dtype=np.float64)
    if isinstance(upright, list) and isinstance(angular, list) and len(upright) == len(angular) == q.shape[1]:
        names = _dof_names(robot) if robot.nq == robot.nv else [str(j) for j in range(q.shape[1])]
        error = np.degrees((q[k] - np.asarray(upright, dtype=np.float64) + np.pi) % (2 * np.pi) - np.pi)
        parts = [f"{names[j]} {abs(error[j]):.1f}° from upright" for j in range(q.shape[1]) if angular[j]]
        text += ", " + ", ".join(parts) if parts else ""
    return text


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


def _prismatic(robot: Robot) -> list[bool]:
    """One flag per velocity coordinate: True on a prismatic joint (PX, PY, PZ, PrismaticUnaligned)."""
    flags: list[bool] = []
    for j in range(1, robot.model.njoints):
        shortname = str(robot.model.joints[j].shortname()).removeprefix("JointModel")
        flags += [shortname.startswith("P")] * int(robot.model.joints[j].nv)
    return flags


_UNITS = {"position": ("rad", "m"), "torque": ("N m", "N")}


def _units(robot: Robot, quantity: str) -> list[str]:
    rotation, translation = _UNITS[quantity]
    return [translation if p else rotation for p in _prismatic(robot)]


def _unit(robot: Robot, quantity: str) -> str:
    """The chart's unit: the one every coordinate shares, or both (then each legend entry carries its own)."""
    units = sorted(set(_units(robot, quantity)), reverse=True)
    return units[0] if len(units) == 1 else " or ".join(units)


def _with_unit(robot: Robot, name: str, j: int, quantity: str) -> str:
    """``name``, with its unit in brackets when the model mixes revolute and prismatic coordinates."""
    units = _units(robot, quantity)
    return name if len(set(units)) <= 1 else f"{name} [{units[j]}]"


def _impact_frames(runs: Sequence[Run]) -> tuple[float, ...]:
    """Rendered-frame positions (fractional) of the impacts: where a run's W_limits steps down."""
    marks: list[float] = []
    for run in runs:
        work = getattr(run.trajectory, "work_limits", None)
        if work is None:
            continue
        w = np.asarray(work, dtype=np.float64)
        if w.ndim != 1 or not np.all(np.isfinite(w)):
            continue
        steps = np.flatnonzero(np.diff(w) < 0) + 1  # sample indices just after an impact
        marks += [float(np.searchsorted(run.index, k)) for k in steps]
    return tuple(sorted(set(marks)))


def panel_charts(robot: Robot, runs: Sequence[Run]) -> list[Chart]:
    """The panel's charts for ``runs``: one colour per curve for one run, the run's colour for several."""
    titles = {
        "energy": ("Energy", "J"),
        "ledger": ("Energy ledger: works", "J"),
        "residual": ("Ledger residual E - E(0) - W (round-off and the method's error)", "J"),
        "regulated": ("Energy the swing-up regulates", "J"),
        "power": ("Power", "W"),
        "position": ("Joint positions", _unit(robot, "position")),
        "torque": ("Joint torques", _unit(robot, "torque")),
        "mode": ("Controller mode", ""),
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
        if key == "position":
            names = _dof_names(robot)
            lower, upper = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
            for j in range(robot.nq):
                lo, hi = float(lower[j]), float(upper[j])
                if np.isfinite(lo) and np.isfinite(hi) and lo < hi and max(abs(lo), abs(hi)) < 1e3:
                    if len(runs) == 1:
                        color = LINK_COLORS[j % len(LINK_COLORS)]
                        limits += [(f"{names[j]} limits", lo, color), ("", hi, color)]
                    else:
                        limits += [("position limit", lo, LIMIT_COLOR), ("position limit", hi, LIMIT_COLOR)]
        if key == "torque":
            names = _dof_names(robot)
            effort = np.asarray(robot.model.effortLimit, dtype=np.float64)
            for j, value in enumerate(effort[: robot.nv]):
                if np.isfinite(value) and 0 < value < 1e6:
                    if len(runs) == 1:
                        color = LINK_COLORS[j % len(LINK_COLORS)]
                        limits += [(f"{names[j]} limit", float(value), color), ("", -float(value), color)]
                    else:
                        limits += [
                            ("effort limit", float(value), LIMIT_COLOR),
                            ("effort limit", -float(value), LIMIT_COLOR),
                        ]
        if key == "regulated":
            found = _regulated(runs[0].trajectory, len(runs[0].trajectory.t))
            if found is not None:
                limits.append((f"target {found[1]:.4g} J", found[1], REGULATED_COLOR))
                title = f"Energy the swing-up regulates: {found[2]}"
        if key == "mode":
            said = handover(robot, runs[0].trajectory)
            title = f"Controller mode: {said}" if said else title
        scale = "log" if key in LOG_SCALE and any(np.any(s.values > 0) for s in series) else "linear"
        markers = _impact_frames(runs) if key == "position" else ()
        tick_unit = bool(unit) and " or " not in unit
        charts.append(Chart(key, title, unit, tuple(series), tuple(limits), scale, markers, tick_unit))
    return charts


def panel_info(charts: Sequence[Chart], runs: Sequence[Run]) -> dict[str, Any]:
    """What the page needs to draw the panel: geometry, runs, charts (JSON-ready)."""
    return {
        "limitDash": list(LIMIT_DASH),
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
                "markers": list(chart.markers),
                "tickUnit": chart.tick_unit,
            }
            for chart in charts
        ],
    }
