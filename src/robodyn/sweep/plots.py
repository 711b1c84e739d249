"""Pictures of a sweep's results: basin and chaos maps as images, sensitivity as bar charts, the numbers beside.

Imported only when ``--plots`` is asked; matplotlib (Agg) is imported inside the functions.

* A *map* needs exactly two varying initial-state axes (``q0.joint1`` x ``q0.joint2``, say): one
  image per other setting and per mapped measure (``time_to_balance`` as a basin, ``lyapunov``
  as a chaos map, any other number as a colour map), written as ``map-<measure>[-<setting>].png``
  with the grid as ``.csv`` beside it (first row the x values, first column the y values).
* A *sensitivity* chart needs one or more ``params.*`` axes: for each measure, one bar per
  parameter value showing the measure's mean over the states (NaN runs left out), written as
  ``sensitivity-<measure>.png`` and ``.csv``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.fileio import write_text_atomically

SKIP = {"run", "path", "status", "integrator", "dt", "controller", "wall_time"}


def draw(table: Any, axes: dict[str, tuple[Any, ...]], folder: Path) -> list[Path]:
    """Every picture the axes allow, from the results ``table`` (pyarrow), into ``folder``; the paths written."""
    import matplotlib

    matplotlib.use("Agg")
    data = {name: table.column(name).to_numpy(zero_copy_only=False) for name in table.column_names}
    measures = [n for n in table.column_names if n not in SKIP and not n.startswith(("q0.", "v0.", "params."))]
    folder.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    state_axes = [a for a in axes if a.startswith(("q0.", "v0."))]
    if len(state_axes) == 2:
        for measure in measures:
            written += _maps(data, state_axes[1], state_axes[0], measure, axes, folder)
    params = [a for a in axes if a.startswith("params.")]
    if params:
        for measure in measures:
            written += _sensitivity(data, params, measure, folder)
    return written


def _maps(data: dict[str, Any], x: str, y: str, measure: str, axes: dict[str, Any], folder: Path) -> list[Path]:
    import matplotlib.pyplot as plt

    others = [a for a in axes if a not in (x, y)]
    keys = list(zip(*[data[a] for a in others], strict=True)) if others else [()] * len(data["run"])
    out = []
    for key in sorted(set(keys), key=repr):
        rows = np.array([k == key for k in keys])
        xs, ys = np.unique(data[x][rows]), np.unique(data[y][rows])
        grid = np.full((ys.size, xs.size), np.nan)
        grid[np.searchsorted(ys, data[y][rows]), np.searchsorted(xs, data[x][rows])] = data[measure][rows]
        tag = "-".join(f"{a.split('.')[-1]}={v}" for a, v in zip(others, key, strict=True))
        stem = f"map-{measure}" + (f"-{tag}" if tag else "")
        fig, ax = plt.subplots(figsize=(6, 5))
        extent = (*_edges(xs), *_edges(ys))  # each cell centred on its grid value
        cmap = "viridis_r" if measure == "time_to_balance" else ("magma" if measure == "lyapunov" else "viridis")
        image = ax.imshow(grid, origin="lower", extent=extent, aspect="auto", cmap=cmap, interpolation="nearest")
        label = {"time_to_balance": "time to balance [s] (blank: never)", "lyapunov": "largest Lyapunov exponent [1/s]"}
        fig.colorbar(image, ax=ax, label=label.get(measure, measure))
        ax.set_xlabel(x)
        ax.set_ylabel(y)
        ax.set_title(f"{measure} over {y} x {x}" + (f"\n{tag}" if tag else ""))
        png = folder / f"{stem}.png"
        fig.savefig(png, dpi=110, bbox_inches="tight")
        plt.close(fig)
        lines = [",".join([f"{y}\\{x}", *(repr(float(v)) for v in xs)])]
        lines += [",".join([repr(float(yv)), *(repr(float(v)) for v in row)]) for yv, row in zip(ys, grid, strict=True)]
        write_text_atomically(folder / f"{stem}.csv", "\n".join(lines) + "\n")
        out += [png, folder / f"{stem}.csv"]
    return out


def _edges(values: Any) -> tuple[float, float]:
    """The outer edges of cells centred on sorted grid ``values`` (half a spacing beyond each end; +-0.5 for one)."""
    half = 0.5 * (values[-1] - values[0]) / (values.size - 1) if values.size > 1 else 0.5
    return float(values[0] - half), float(values[-1] + half)


def _sensitivity(data: dict[str, Any], params: list[str], measure: str, folder: Path) -> list[Path]:
    import matplotlib.pyplot as plt

    values = np.asarray(data[measure], dtype=np.float64)
    labels, means = [], []
    for p in params:
        for v in np.unique(data[p]):
            chosen = values[data[p] == v]
            finite = chosen[np.isfinite(chosen)]
            labels.append(f"{p.split('.', 1)[1]}={v:g}")
            means.append(float(finite.mean()) if finite.size else math.nan)
    fig, ax = plt.subplots(figsize=(max(5, 0.7 * len(labels)), 4))
    ax.bar(range(len(labels)), np.nan_to_num(means), color="tab:blue")
    ax.set_xticks(range(len(labels)), labels, rotation=45, ha="right")
    ax.set_ylabel(f"mean {measure}")
    ax.set_title(f"sensitivity of {measure} to the parameters")
    png = folder / f"sensitivity-{measure}.png"
    fig.savefig(png, dpi=110, bbox_inches="tight")
    plt.close(fig)
    lines = ["parameter,value,mean"] + [
        f"{lab.split('=')[0]},{lab.split('=')[1]},{m!r}" for lab, m in zip(labels, means, strict=True)
    ]
    write_text_atomically(folder / f"sensitivity-{measure}.csv", "\n".join(lines) + "\n")
    return [png, folder / f"sensitivity-{measure}.csv"]
