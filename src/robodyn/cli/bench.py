"""``robodyn bench``: work--precision charts, stability limits and a report, written to a folder."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from robodyn.cli._common import _json_default

BUILTINS = ("pendubot", "cart_pole", "geared_arm")


def add_parser(sub: Any) -> None:
    """Register ``robodyn bench``."""
    p = sub.add_parser(
        "bench",
        help="work-precision charts, stability limits and a report for one or more models",
        description="Run every integrator over a ladder of steps (and tolerances) on every dynamics backend, "
        "measure error against a DOP853 reference, cost and energy drift; find where each method "
        "becomes unstable; write bench.json, stability.json, charts (PNG + SVG) and report.md.",
    )
    p.add_argument(
        "models",
        nargs="*",
        metavar="MODEL",
        help=f"built-in name or URDF path (default: {', '.join(BUILTINS)})",
    )
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (created if needed)")
    p.add_argument("--quick", action="store_true", help="a CI-sized subset (under a minute)")
    p.add_argument("--no-stability", action="store_true", help="skip the stability study (stability.json)")
    p.add_argument("--no-progress", action="store_true", help="do not draw the progress bar on stderr")
    p.set_defaults(handler=run)


class ProgressBar:
    """A one-line progress bar on stderr, redrawn only when it changes."""

    WIDTH = 30

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.last = ""

    def __call__(self, done: int, total: int, label: str) -> None:
        """Draw ``done`` of ``total`` with ``label``."""
        if not self.enabled:
            return
        filled = int(self.WIDTH * done / max(total, 1))
        line = f"\r[{'#' * filled}{'.' * (self.WIDTH - filled)}] {done}/{total} {label}"[:110]
        if line != self.last:
            sys.stderr.write(line.ljust(len(self.last)))
            sys.stderr.flush()
            self.last = line
        if done == total:
            sys.stderr.write("\n")
            self.last = ""

    def note(self, text: str) -> None:
        """A line of status (e.g. the stage starting)."""
        if self.enabled:
            sys.stderr.write(f"{text}\n")
            sys.stderr.flush()


def _write_json(path: Path, obj: Any) -> None:
    path.write_text(json.dumps(obj, indent=1, default=_json_default, allow_nan=False) + "\n")


def _clean(obj: Any) -> Any:
    """JSON-ready copy with inf and nan as None (JSON has no such numbers)."""
    from robodyn.studies.stability import as_dict

    out = as_dict(obj)
    return _none_for_text_numbers(out)


def _none_for_text_numbers(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _none_for_text_numbers(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_none_for_text_numbers(v) for v in obj]
    if isinstance(obj, str) and obj in ("inf", "-inf", "nan"):
        return None
    return obj


def run(args: argparse.Namespace) -> int:
    """Run the sweeps, then the stability study; write everything under ``--out``."""
    from robodyn import charts
    from robodyn.cli._output import writable_path
    from robodyn.model.load import load
    from robodyn.studies import bench

    out: Path = args.out
    writable_path(out / "bench.json")
    progress = ProgressBar(not args.no_progress)
    names = args.models or list(BUILTINS)
    robots = [load(name) for name in names]  # bad names fail here, before any work
    plan = bench.default_plan(quick=args.quick)
    sweeps: list[bench.Sweep] = []
    figures: dict[str, list[str]] = {}
    started = time.perf_counter()
    for robot in robots:
        progress.note(f"robodyn bench: work-precision sweep of {robot.name}")
        result = bench.sweep(robot, plan=plan, progress=progress)
        sweeps.append(result)
        _write_json(out / "bench.json", bench.records(sweeps))  # partial results first
        figures[robot.name] = _sweep_charts(result, out, charts)
    stability_summary = None
    if not args.no_stability:
        progress.note("robodyn bench: stability study")
        stability_summary = _stability(robots, out, quick=args.quick, progress=progress)
    report = _report(sweeps, figures, stability_summary, quick=args.quick, seconds=time.perf_counter() - started)
    (out / "report.md").write_text(report)
    print(f"wrote {out / 'bench.json'} ({sum(len(s.results) for s in sweeps)} runs), charts and {out / 'report.md'}")
    return 0


def _sweep_charts(result: Any, out: Path, charts: Any) -> list[str]:
    from robodyn.studies import bench

    name = result.model
    orders = {m: bench.measured_order(result.results, m) for m in (*result.plan.fixed,)}
    files = []
    files += charts.work_precision(result.results, out / f"work_precision_{name}", title=f"{name}: work-precision")
    files += charts.error_vs_dt(
        result.results, out / f"error_vs_dt_{name}", orders=orders, title=f"{name}: error vs dt"
    )
    files += charts.energy_error(result.energy, out / f"energy_{name}", title=f"{name}: energy error vs time")
    _write_json(
        out / f"energy_{name}.json",
        [
            {"integrator": s.integrator, "backend": s.backend, "dt": s.dt, "t": s.t, "energy_error": s.error}
            for s in result.energy
        ],
    )
    return [Path(f).name for f in files]


def _stability(robots: list[Any], out: Path, *, quick: bool, progress: ProgressBar) -> dict[str, Any]:
    import numpy as np

    from robodyn import charts
    from robodyn.errors import RobodynError
    from robodyn.model.load import load
    from robodyn.studies import stability
    from robodyn.studies.bench import start_state

    methods = stability.QUICK_FIXED_METHODS if quick else stability.FIXED_METHODS
    steps = 300 if quick else 2000
    stiff = load(stability.variant_path(stability.STIFF_VARIANT))
    light = load(stability.variant_path(stability.LIGHT_VARIANT))
    cases = [stiff, *(robots[:1] if quick else robots)]
    if not quick:
        cases.append(light)
    summary: dict[str, Any] = {"quick": quick, "steps_per_trial": steps, "limits": [], "notes": []}
    for k, robot in enumerate(cases, start=1):
        progress(k - 1, len(cases), f"limits of {robot.name}")
        try:
            found = stability.limits(robot, methods=methods, steps=steps, rtol=0.03 if quick else 0.01)
        except RobodynError as exc:
            summary["notes"].append(f"{robot.name}: no stability limits ({exc})")
            continue
        summary["limits"] += [{**_clean(x), "ratio": _clean(x.ratio)} for x in found]
        _write_json(out / "stability.json", summary)
    progress(len(cases), len(cases), "limits done")
    progress.note("robodyn bench: stiff runs, chaos, near-singular mass matrix")
    summary["stiff"] = {
        "model": stiff.name,
        "runs": _clean(stability.stiff_runs(stiff, dt=0.01, duration=0.2 if quick else 1.0, quick=quick)),
    }
    pendubot = load("pendubot")
    q0, v0 = start_state(pendubot)
    found_chaos = stability.chaos(pendubot, q0, v0, duration=30.0 if quick else 60.0)
    summary["chaos"] = _clean(found_chaos)
    summary["near_singular"] = _clean(stability.near_singular(light, pendubot, duration=1.0 if quick else 2.0))
    n = 31 if quick else 71
    re = np.linspace(-3.5, 1.0, n)
    im = np.linspace(-3.5, 3.5, n)
    regions = {m: (re, im, stability.region_grid(m, re, im)) for m in methods}
    summary["regions"] = {
        m: {
            "real_axis_limit": _clean(stability.region_radius(m, np.pi)),
            "imaginary_axis_limit": _clean(stability.region_radius(m, np.pi / 2)),
        }
        for m in methods
    }
    _write_json(out / "stability.json", summary)
    files = list(charts.stability(summary["limits"], regions, out / "stability"))
    lyap = found_chaos.lyapunov
    t_run = lyap.interval * np.arange(1, lyap.renormalisations + 1)
    files += charts.lyapunov(t_run, lyap.running, found_chaos.gap_t, found_chaos.gap, out / "lyapunov")
    summary["figures"] = [Path(f).name for f in files]
    _write_json(out / "stability.json", summary)
    return summary


def _fmt(x: Any, spec: str = ".3g") -> str:
    if x is None:
        return "-"
    if isinstance(x, float):
        return format(x, spec)
    return str(x)


def _report(
    sweeps: list[Any], figures: dict[str, list[str]], stab: dict[str, Any] | None, *, quick: bool, seconds: float
) -> str:
    from robodyn.studies import bench

    lines = [
        "# robodyn bench report",
        "",
        f"{'Quick' if quick else 'Full'} run, {seconds:.0f} s. Error: relative state error "
        "max |x - x_ref| / max |x_ref| over the error horizon against scipy DOP853 at rtol 1e-12; "
        "cost: wall time per simulated second; energy drift: max |E - E0 - W| / energy scale over the long "
        "horizon. Numbers: `bench.json`.",
        "",
    ]
    for s in sweeps:
        p = s.plan
        lines += [
            f"## {s.model}",
            "",
            f"Start q0 = {list(map(float, s.q0))}, v0 = {list(map(float, s.v0))}; error horizon {p.error_horizon:g} s, "
            f"energy horizon {p.energy_horizon:g} s. Reference self-check (rtol 1e-12 vs 1e-13): "
            f"{s.reference.self_error:.2g}.",
            "",
        ]
        lines += [f"![{f}]({f})" for f in figures.get(s.model, []) if f.endswith(".png")]
        lines += [
            "",
            "Cheapest run reaching each accuracy:",
            "",
            "| error <= | method / backend | step or rtol | s per simulated s | evaluations |",
            "|---|---|---|---|---|",
        ]
        for level, r in bench.best_by_accuracy(s.results):
            if r is None:
                lines.append(f"| {level:g} | none reached it | - | - | - |")
            else:
                step = f"dt {r.dt:g}" if r.dt is not None else f"rtol {r.rtol:g}"
                lines.append(f"| {level:g} | {r.label} | {step} | {r.wall_time_s:.3g} | {r.evaluations} |")
        lines += ["", "Measured orders (ABA backend, fitted where the error lies in 1e-11..1e-1):", ""]
        for m in p.fixed:
            order = bench.measured_order(s.results, m)
            declared = next((r.order for r in s.results if r.integrator == m), None)
            lines.append(f"- {m}: declared {declared}, measured {_fmt(order, '.2f')}")
        if s.skipped:
            lines += ["", "Skipped: " + "; ".join(s.skipped)]
        lines += ["", _reading(s), ""]
    if stab is not None:
        lines += _stability_report(stab)
    return "\n".join(lines) + "\n"


def _reading(s: Any) -> str:
    from robodyn.studies import bench

    table = [(lvl, r) for lvl, r in bench.best_by_accuracy(s.results) if r is not None]
    if not table:
        return "Reading: no run reached even 1e-2."
    parts = [f"{r.label} below {lvl:g}" for lvl, r in table]
    fast = [r for r in s.results if r.backend == "fast" and not r.diverged]
    aba = {(r.integrator, r.dt): r for r in s.results if r.backend == "aba" and r.dt is not None}
    speedups = [aba[(r.integrator, r.dt)].wall_time_s / r.wall_time_s for r in fast if (r.integrator, r.dt) in aba]
    text = "Reading: the cheapest way to a given accuracy is " + ", ".join(parts) + "."
    if speedups:
        text += (
            f" The compiled fast path gives the same errors as the ABA path (same method, same steps) "
            f"at {min(speedups):.0f}-{max(speedups):.0f}x less wall time."
        )
    return text


def _stability_report(stab: dict[str, Any]) -> list[str]:
    lines = [
        "## Stability: where methods fail",
        "",
        "Largest stable dt predicted from the linearisation about the hanging equilibrium "
        "(one step of the method on q'' = K q + D v, spectral radius <= 1) and measured by bisection "
        f"on {stab['steps_per_trial']}-step torque-free runs from 0.05 rad off equilibrium (blow-up: energy error "
        "> 100x the energy above equilibrium; the last column: energy error > 100 %). 0 = unstable at every dt; "
        "'-' = stable up to the largest dt tried.",
        "",
        "![stability](stability.png)",
        "",
        "| model | method | max abs(lambda) [1/s] | predicted dt_max [s] | measured [s] | measured / predicted "
        "| energy error 100 % at [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    notes = (
        "On the linear-like cases (one degree of freedom) measurement and prediction agree. On the Pendubot a "
        "step past RK4's limit makes the fast mode grow until its own nonlinearity detunes it: the run stays "
        "bounded but wrong, so the blow-up column overshoots while the energy column meets the prediction."
    )
    for x in stab["limits"]:
        lines.append(
            f"| {x['case']} | {x['integrator']} | {_fmt(x['fastest'])} | {_fmt(x['predicted_dt_max'], '.4g')} | "
            f"{_fmt(x['measured_dt_max'], '.4g')} | {_fmt(x['ratio'], '.3f')} | {_fmt(x['energy_dt_max'], '.4g')} |"
        )
    st = stab["stiff"]
    lines += [
        "",
        notes,
        "",
        f"Stiff case ({st['model']}, time constant 1 ms) at dt = 0.01 s, against a Radau reference:",
        "",
        "| method | rtol | diverged | error | evaluations |",
        "|---|---|---|---|---|",
    ]
    for r in st["runs"]:
        lines.append(
            f"| {r['integrator']} | {_fmt(r['rtol'])} | {r['diverged']} | {_fmt(r['error'])} | {r['evaluations']} |"
        )
    ch = stab["chaos"]
    ly = ch["lyapunov"]
    lines += [
        "",
        f"Chaos ({ch['model']}, torque-free from q0 = {ch['q0']}): largest Lyapunov exponent "
        f"{_fmt(ly['exponent'])} 1/s (Benettin, {ly['renormalisations']} renormalisations every {ly['interval']} s), "
        f"so a one-ulp error reaches O(1) after ln(1/eps)/lambda = {_fmt(ly['horizon_s'])} s; two runs one ulp apart "
        f"were measured 0.1 rad apart after {_fmt(ch['separation_time_s'])} s. Beyond that no double-precision "
        "integrator's state means anything; only statistics (energy, which the ledger tracks) do.",
        "",
        "![lyapunov](lyapunov.png)",
        "",
    ]
    ns = stab["near_singular"]
    lines += [
        "Near-singular mass matrix (light distal link, m2 = 5e-7 kg): largest relative acceleration error "
        "against an extended-precision closed form:",
        "",
        "| model | cond(M) | ABA | CRBA + Cholesky | NumPy formula |",
        "|---|---|---|---|---|",
    ]
    for key in ("light", "normal"):
        a = ns[key]
        e = a["errors"]
        lines.append(
            f"| {a['model']} | {_fmt(a['condition'])} | {_fmt(e['aba'])} | {_fmt(e['crba'])} | {_fmt(e['formula'])} |"
        )
    lines += [
        "",
        "Spread of an RK4 run (dt = 1 ms) from the ABA run, per backend: "
        + ", ".join(f"{k} {_fmt(v)}" for k, v in ns["spread"].items())
        + ". cond(M) grows as 1/m2, but the ill-conditioning is a diagonal scaling that the Cholesky "
        "solve and ABA's articulated inertias both absorb: every backend stays at round-off.",
    ]
    if stab["notes"]:
        lines += ["", "Notes: " + "; ".join(stab["notes"])]
    return lines
