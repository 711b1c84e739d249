"""Charts render from finished results to PNG and SVG, and matplotlib stays out of import robodyn."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from robodyn import charts
from robodyn.studies.bench import BenchResult, EnergySeries

PNG_MAGIC = b"\x89PNG"


def _results() -> list[BenchResult]:
    out = []
    for name, order in (("euler", 1), ("rk4", 4)):
        for backend in ("aba", "fast"):
            for dt in (0.02, 0.01, 0.005):
                out.append(
                    BenchResult(
                        "toy",
                        name,
                        backend,
                        dt,
                        None,
                        3.0 * dt**order,
                        1e-3 / dt,
                        int(1 / dt),
                        0.1 * dt,
                        False,
                        order,
                        False,
                        False,
                        1.0,
                    )
                )
    out.append(
        BenchResult("toy", "euler", "aba", 0.04, None, float("inf"), 1e-2, 10, float("inf"), True, 1, False, False, 0.3)
    )
    return out


def _check(paths: tuple) -> None:
    png, svg = paths
    assert png.read_bytes()[:4] == PNG_MAGIC
    assert b"<svg" in svg.read_bytes()[:2000]


def test_work_precision_and_error_vs_dt(tmp_path):
    _check(charts.work_precision(_results(), tmp_path / "wp"))
    _check(charts.error_vs_dt(_results(), tmp_path / "dt", orders={"euler": 1.0, "rk4": None}))


def test_energy_and_stability_and_lyapunov(tmp_path):
    t = np.linspace(0, 1, 50)
    _check(charts.energy_error([EnergySeries("rk4", "aba", 0.01, t, 1e-8 * t)], tmp_path / "e"))
    re = np.linspace(-3, 1, 9)
    im = np.linspace(-3, 3, 9)
    rho = np.hypot(1 + re[None, :], im[:, None])  # explicit Euler's |1 + z|
    cases = [{"case": "toy", "integrator": "euler", "predicted_dt_max": 0.002, "measured_dt_max": 0.00201}]
    _check(charts.stability(cases, {"euler": (re, im, rho)}, tmp_path / "s"))
    _check(charts.lyapunov(t, 2 + 0 * t, t, 1e-16 * np.exp(30 * t), tmp_path / "l"))
    _check(charts.speed_bars(["a", "b"], [5.0, 0.2], tmp_path / "b", unit="us/step", title="speed"))


def test_import_robodyn_does_not_load_matplotlib_or_numba():
    code = "import sys, robodyn, robodyn.cli; print(any(m in sys.modules for m in ('matplotlib', 'numba', 'mujoco')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
