"""Charts of benchmark and stability results (the only module that imports matplotlib).

matplotlib is imported inside each function with the non-interactive Agg backend, so
``import robodyn`` stays light and charts render without a display. Every function takes
finished results (it never runs numerics), writes ``<stem>.png`` and ``<stem>.svg`` (each through
:func:`robodyn.fileio.write_atomically`: complete or not at all, never through a planted link), and
returns both paths.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from robodyn.errors import MissingDependencyError
from robodyn.fileio import write_atomically

if TYPE_CHECKING:
    from robodyn.control.basin import Basin
    from robodyn.studies.bench import BenchResult, EnergySeries
    from robodyn.studies.portrait import Portrait

# One colour per integrator, one marker per backend: the same run looks the same on every chart.
_COLOURS = {
    "euler": "#d62728",
    "semi_implicit_euler": "#ff7f0e",
    "symplectic_euler": "#bf5b17",
    "heun": "#8c564b",
    "rk4": "#1f77b4",
    "implicit_midpoint": "#2ca02c",
    "dopri5": "#9467bd",
    "scipy_rk45": "#e377c2",
    "scipy_dop853": "#17becf",
    "scipy_radau": "#7f7f7f",
    "scipy_bdf": "#bcbd22",
    "scipy_lsoda": "#000000",
}
_MARKERS = {"aba": "o", "crba": "s", "formula": "^", "fast": "*"}
_LINES = {"aba": "-", "crba": "--", "formula": ":", "fast": "-."}


def _pyplot() -> Any:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover - matplotlib is a declared dependency
        raise MissingDependencyError("charts need matplotlib: pip install matplotlib") from None
    return plt


def _save(fig: Any, stem: Path) -> tuple[Path, Path]:
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    png, svg = stem.with_suffix(".png"), stem.with_suffix(".svg")
    fig.tight_layout()
    try:  # atomically: never a half-written chart, never through a planted link
        write_atomically(png, lambda fh: fig.savefig(fh, format="png", dpi=110))
        write_atomically(svg, lambda fh: fig.savefig(fh, format="svg"))
    finally:
        _pyplot().close(fig)
    return png, svg


def _finish(
    fig: Any,
    ax: Any,
    stem: Path,
    xlabel: str,
    ylabel: str,
    title: str,
    *,
    legend_size: int,
    legend_columns: int = 1,
) -> tuple[Path, Path]:
    """Label a one-panel log chart, grid it, add the legend and save it (see :func:`_save`)."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=legend_size, ncol=legend_columns)
    return _save(fig, stem)


def _groups(results: Sequence[BenchResult]) -> dict[tuple[str, str], list[BenchResult]]:
    groups: dict[tuple[str, str], list[BenchResult]] = {}
    for r in results:
        groups.setdefault((r.integrator, r.backend), []).append(r)
    return groups


def _finite(results: Sequence[BenchResult]) -> list[BenchResult]:
    return [r for r in results if not r.diverged and np.isfinite(r.error) and r.error > 0]


def work_precision(results: Sequence[BenchResult], stem: Path, *, title: str = "") -> tuple[Path, Path]:
    """Error against wall time per simulated second, log--log (the work--precision diagram)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8.5, 6))
    for (name, backend), runs in sorted(_groups(_finite(results)).items()):
        runs = sorted(runs, key=lambda r: -(r.dt if r.dt is not None else r.rtol or 0.0))  # along the ladder
        ax.loglog(
            [r.wall_time_s for r in runs],
            [r.error for r in runs],
            marker=_MARKERS.get(backend, "x"),
            linestyle=_LINES.get(backend, "-"),
            color=_COLOURS.get(name, None),
            label=f"{name} / {backend}",
            markersize=7 if backend == "fast" else 5,
        )
    return _finish(
        fig,
        ax,
        stem,
        "wall time per simulated second [s/s]",
        "relative state error vs DOP853 reference",
        title or "work-precision: lower left is better",
        legend_size=7,
        legend_columns=2,
    )


def error_vs_dt(
    results: Sequence[BenchResult], stem: Path, *, orders: Mapping[str, float | None], title: str = ""
) -> tuple[Path, Path]:
    """Error against dt for the fixed-step methods (ABA backend), with reference slopes.

    ``orders`` maps integrator -> measured order (printed in the legend next to the declared one).
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 6))
    fixed = [r for r in _finite(results) if r.dt is not None and r.backend == "aba"]
    declared: dict[str, int] = {}
    for (name, _backend), runs in sorted(_groups(fixed).items()):
        runs = sorted(runs, key=lambda r: r.dt or 0.0)
        declared[name] = runs[0].order
        measured = orders.get(name)
        text = f"measured {measured:.2f}" if measured is not None else "no asymptotic points"
        ax.loglog(
            [r.dt for r in runs],
            [r.error for r in runs],
            marker="o",
            color=_COLOURS.get(name, None),
            label=f"{name}: declared {runs[0].order}, {text}",
        )
    if fixed:
        dts = np.array(sorted({r.dt for r in fixed if r.dt is not None}))
        anchor_err = float(np.median([r.error for r in fixed]))
        anchor_dt = float(np.exp(np.mean(np.log(dts))))
        for p in sorted(set(declared.values())):
            ax.loglog(dts, anchor_err * (dts / anchor_dt) ** p, color="0.6", linewidth=0.8, linestyle="--")
            ax.annotate(f"slope {p}", (dts[-1], anchor_err * (dts[-1] / anchor_dt) ** p), fontsize=8, color="0.4")
    return _finish(
        fig,
        ax,
        stem,
        "dt [s]",
        "relative state error vs DOP853 reference",
        title or "convergence: error against step",
        legend_size=8,
    )


def energy_error(series: Sequence[EnergySeries], stem: Path, *, title: str = "") -> tuple[Path, Path]:
    """|E - E0 - W| / scale against time, one line per integrator (semi-log)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 5))
    floor = 1e-17
    for s in series:
        ax.semilogy(
            s.t,
            np.maximum(np.abs(s.error), floor),
            color=_COLOURS.get(s.integrator, None),
            linewidth=0.9,
            label=f"{s.integrator} / {s.backend}, dt = {s.dt:g} s",
        )
    return _finish(
        fig, ax, stem, "t [s]", "|E - E0 - W| / energy scale", title or "energy error against time", legend_size=8
    )


def stability(
    cases: Sequence[Mapping[str, Any]],
    regions: Mapping[str, tuple[ArrayLike, ArrayLike, ArrayLike]],
    stem: Path,
) -> tuple[Path, Path]:
    """Left: stability regions |Phi| <= 1 in the h-lambda plane. Right: measured vs predicted dt_max.

    ``cases`` are the per-(case, integrator) records of ``stability.json`` (keys ``case``,
    ``integrator``, ``predicted_dt_max``, ``measured_dt_max``); ``regions`` maps integrator ->
    (re grid, im grid, spectral radius on the grid).
    """
    plt = _pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 5.5))
    for name, (re, im, rho) in regions.items():
        rho_arr = np.asarray(rho, dtype=float)
        left.contour(re, im, rho_arr, levels=[1.0], colors=[_COLOURS.get(name, "k")], linewidths=1.4)
        left.plot([], [], color=_COLOURS.get(name, "k"), label=name)  # legend entry for the contour
    left.axhline(0, color="0.7", linewidth=0.6)
    left.axvline(0, color="0.7", linewidth=0.6)
    left.set_xlabel("Re(h lambda)")
    left.set_ylabel("Im(h lambda)")
    left.set_title("stability regions (inside the curve: stable)")
    left.set_aspect("equal")
    left.legend(fontsize=8, loc="upper left")
    markers = ["o", "s", "^", "D", "v", "P"]
    case_names = sorted({str(c["case"]) for c in cases})
    lo, hi = np.inf, 0.0
    for c in cases:
        p, m = c.get("predicted_dt_max"), c.get("measured_dt_max")
        if not isinstance(p, float) or not isinstance(m, float) or not (p > 0 and m > 0):
            continue
        if not (np.isfinite(p) and np.isfinite(m)):
            continue
        lo, hi = min(lo, p, m), max(hi, p, m)
        right.loglog(
            p,
            m,
            marker=markers[case_names.index(str(c["case"])) % len(markers)],
            color=_COLOURS.get(str(c["integrator"]), "k"),
            linestyle="none",
            label=f"{c['case']}: {c['integrator']}",
        )
    if np.isfinite(lo):
        from robodyn.studies.report import LIMIT_RTOL, percent  # the report's agreement band

        x = np.array([lo / 2, hi * 2])
        right.loglog(x, x, color="0.5", linewidth=0.8)
        band = f"within {percent(LIMIT_RTOL)} (the report's agreement)"
        right.fill_between(x, (1 - LIMIT_RTOL) * x, (1 + LIMIT_RTOL) * x, color="0.85", label=band)
    right.set_xlabel("predicted largest stable dt [s] (linearisation)")
    right.set_ylabel("measured largest stable dt [s] (bisection)")
    right.set_title("where methods fail: theory against measurement")
    right.grid(True, which="both", alpha=0.3)
    right.legend(fontsize=7)
    return _save(fig, stem)


def lyapunov(t: ArrayLike, running: ArrayLike, gap_t: ArrayLike, gap: ArrayLike, stem: Path) -> tuple[Path, Path]:
    """Left: running Lyapunov estimate. Right: separation of two runs one ulp apart (semi-log)."""
    plt = _pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5))
    left.plot(t, running)
    left.set_xlabel("t [s]")
    left.set_ylabel("running estimate of lambda_max [1/s]")
    left.grid(True, alpha=0.3)
    right.semilogy(gap_t, np.maximum(np.asarray(gap, dtype=float), 1e-17))
    right.set_xlabel("t [s]")
    right.set_ylabel("max |q_a - q_b| [rad]")
    right.set_title("two runs whose starts differ by one ulp")
    right.grid(True, which="both", alpha=0.3)
    return _save(fig, stem)


def speed_bars(
    labels: Sequence[str], values: Sequence[float], stem: Path, *, unit: str, title: str
) -> tuple[Path, Path]:
    """Horizontal bars (log scale) of one cost per path, e.g. microseconds per step."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 0.6 * len(labels) + 1.5))
    y = np.arange(len(labels))
    ax.barh(y, values, color="#1f77b4")
    ax.set_yticks(y, labels)
    ax.set_xscale("log")
    for yi, v in zip(y, values, strict=True):
        ax.annotate(f"{v:.3g}", (v, yi), xytext=(3, -3), textcoords="offset points", fontsize=8)
    ax.set_xlabel(unit)
    ax.set_title(title)
    ax.grid(True, axis="x", which="both", alpha=0.3)
    return _save(fig, stem)


PORTRAIT_COLORS = {
    "runs": ("#D55E00", "#0072B2", "#E69F00", "#CC79A7", "#009E73", "#56B4E9"),
    "region": "#CC79A7",
    "basin": "#009E73",
}
"""Okabe–Ito colours of a portrait's runs, region and basin (the contours are viridis, also colour-blind safe)."""


def portrait(
    p: Portrait, stem: Path, *, title: str = "", levels: int = 24, basin: Basin | None = None
) -> tuple[Path, Path]:
    """A phase portrait (:mod:`robodyn.studies.portrait`): energy contours, flow, equilibria, separatrix, runs, region.

    The one-joint flow is drawn as grey streamlines with arrows; stable equilibria are filled
    circles, unstable ones open; the separatrix is the thick black level set; each trajectory is
    a line from a square (its start), named by its label; the LQR region is a dashed ellipse and
    a simulated ``basin`` (:func:`robodyn.control.basin.simulate`) its balanced starts as dots.
    Colours are Okabe–Ito (colour-blind safe); the axes and the energy are labelled in mathtext.
    """
    plt = _pyplot()
    symbol = r"\theta" if p.angular else "x"
    fig, ax = plt.subplots(figsize=(8.5, 6))
    filled = ax.contourf(p.q, p.v, p.energy, levels=levels, cmap="viridis", alpha=0.5)
    ax.contour(p.q, p.v, p.energy, levels=levels, colors="0.35", linewidths=0.4)
    fig.colorbar(filled, ax=ax, label=rf"$E = \frac{{1}}{{2}} M_{{jj}}\,\dot{{{symbol}}}^2 + V$ [J]")
    if p.acceleration is not None:  # the flow (q', v') = (v, a): streamlines along the contours, arrows on them
        ax.streamplot(
            p.q,
            p.v,
            np.broadcast_to(p.v[:, None], p.energy.shape),
            p.acceleration,
            color="0.25",
            linewidth=0.6,
            density=1.1,
            arrowsize=0.9,
            broken_streamlines=True,
        )
    if p.separatrix_energy is not None:
        ax.contour(p.q, p.v, p.energy, levels=[p.separatrix_energy], colors="black", linewidths=2.0)
        ax.plot([], [], color="black", lw=2.0, label=f"separatrix, E = {p.separatrix_energy:.4g} J")
    if basin is not None:
        bq, bv = np.meshgrid(basin.q, basin.v)
        ax.plot(
            bq[basin.balanced],
            bv[basin.balanced],
            ".",
            color=PORTRAIT_COLORS["basin"],
            markersize=4,
            label=f"LQR balances from here (simulated, {basin.duration:g} s)",
        )
    for kind in (True, False):
        points = [e for e in p.equilibria if e.stable is kind]
        if points:
            ax.plot(
                [e.q for e in points],
                [0.0] * len(points),
                "o",
                markersize=9,
                markerfacecolor="white" if not kind else "black",
                markeredgecolor="black",
                linestyle="none",
                label="stable equilibrium" if kind else "unstable equilibrium",
            )
    for r, (label, q, v) in enumerate(p.trajectories):
        color = PORTRAIT_COLORS["runs"][r % len(PORTRAIT_COLORS["runs"])]
        ax.plot(q, v, lw=1.4, color=color, label=label)
        ax.plot(q[:1], v[:1], "s", color=color, markersize=6)
    if p.region is not None:
        eq, ev = p.region.outline()
        ax.plot(
            eq,
            ev,
            "--",
            color=PORTRAIT_COLORS["region"],
            lw=1.8,
            label=rf"LQR region slice, $e^\top P e < {p.region.rho:.3g}$",
        )
    ax.set_xlim(p.q[0], p.q[-1])
    ax.set_ylim(p.v[0], p.v[-1])
    unit_q, unit_v = p.q_unit, p.v_unit
    ax.set_xlabel(rf"${symbol}$ ({p.joint}) [{unit_q}]")
    ax.set_ylabel(rf"$\dot{{{symbol}}}$ ({p.joint}) [{unit_v}]")
    held = f"\nother joints held at {p.held}" if p.held else ""
    ax.set_title(title or f"{p.model}: phase portrait of {p.joint}{held}")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper right", framealpha=0.9)
    return _save(fig, stem)
