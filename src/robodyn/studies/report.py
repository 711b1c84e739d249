"""Report text computed from results: each sentence states what was measured, and says when it disagrees.

Pure functions from result objects (:mod:`robodyn.studies.bench`, :mod:`robodyn.studies.stability`,
:mod:`robodyn.studies.exactness`) to strings, testable without running a study: ``robodyn bench``
writes :func:`bench_report` to ``report.md``; ``robodyn run`` and the benchmarks print
:func:`speed_phrase`. A conclusion ("agree", "round-off") is printed only when the numbers next to
it meet the tolerance it names; otherwise the sentence says DISAGREE and gives the numbers.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from robodyn.studies import bench
from robodyn.studies.chaos import SEPARATION_RAD

if TYPE_CHECKING:
    from robodyn.studies.stability import BackendAccuracy, Chaos, Limit, NearSingular, StiffRun

# Measured / predicted stability limit within this is agreement: the runs start 0.05 rad off
# equilibrium (the nonlinearity shifts the fast mode by a few %) and the bisection stops at 1-3 %.
LIMIT_RTOL = 0.10
# A fitted convergence order within this of the declared one agrees (as tests/test_bench.py).
ORDER_BAND = 0.25
# The same method and steps on another backend change only round-off, grown over the horizon:
# errors agree when |e - e_aba| <= BACKEND_RTOL * e_aba + BACKEND_ATOL.
BACKEND_RTOL = 1e-6
BACKEND_ATOL = 1e-13
# Accelerations within this (relative) of the extended-precision closed form are round-off (a few
# hundred ulps); losing the conditioning would show as cond(M) * eps, 4e-10 on the light tip.
ACCEL_ROUNDOFF = 1e-13
# Runs on two backends within this (relative state) of each other are round-off apart, grown by
# the chaotic motion (e^(lambda t) is about 1e2 over the 2 s run).
SPREAD_ROUNDOFF = 1e-10
# One pair of runs one ulp apart separates within this factor of the Lyapunov prediction
# ln(threshold / gap0) / lambda (the exponent is an average over the whole run).
SEPARATION_FACTOR = 2.0
EPS = float(np.finfo(np.float64).eps)


@dataclass(frozen=True, eq=False)
class StabilityFindings:
    """What the stability section reads: the results of ``robodyn bench``'s stability study.

    ``stiff_eigenvalues`` [1/s] are those of the stiff case linearised about its hanging
    equilibrium; ``tip_masses`` maps the near-singular models to their distal link mass [kg];
    ``notes`` name the cases that gave no limits. The stiff, chaos and near-singular studies are
    the built-in models' (None in a bench of other robots, and left out of its report).
    """

    limits: tuple[Limit, ...]
    steps_per_trial: int
    stiff_model: str | None = None
    stiff_eigenvalues: NDArray[np.complex128] | None = None
    stiff_runs: tuple[StiffRun, ...] = ()
    chaos: Chaos | None = None
    near_singular: NearSingular | None = None
    tip_masses: Mapping[str, float] = field(default_factory=dict)
    notes: tuple[str, ...] = ()


# ------------------------------------------------------------------------------ phrases
def fmt(x: float | None, spec: str = ".3g") -> str:
    """A number for a table cell; None and nan as "-"."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    return format(x, spec)


def percent(fraction: float) -> str:
    """``0.003`` -> ``"0.3 %"`` (two significant digits, sign dropped)."""
    return f"{100 * abs(fraction):.2g} %"


def speed_phrase(ratio: float) -> str:
    """How many times faster (ratio > 1) or slower (< 1) something ran: ``"3.2x faster"``, ``"1.5x slower"``."""
    if not (math.isfinite(ratio) and ratio > 0):
        return f"speed ratio {ratio:g}"
    if ratio >= 1.0:
        return f"{ratio:.1f}x faster"
    return f"{1.0 / ratio:.1f}x slower"


def speed_range(ratios: Sequence[float]) -> str:
    """``"20x to 41x faster"``, ``"1.5x to 2x slower"`` or ``"between 2x slower and 3x faster"``."""
    lo, hi = min(ratios), max(ratios)
    if lo >= 1.0:
        return f"{lo:.3g}x to {hi:.3g}x faster"
    if hi < 1.0:
        return f"{1 / hi:.3g}x to {1 / lo:.3g}x slower"
    return f"between {speed_phrase(lo)} and {speed_phrase(hi)}"


def _above(gap: float) -> str:
    return "above" if gap > 0 else "below"


# ------------------------------------------------------------------------------ the sweep
def reference_sentence(ref: bench.Reference, agreement: float = bench.REFERENCE_AGREEMENT) -> str:
    """The reference's self-check against its rerun at rtol / 10."""
    within = ref.self_error <= agreement
    verdict = "within" if within else "DISAGREE: above"
    return (
        f"Reference self-check (rtol {ref.rtol:g} against {ref.rtol / 10:g}): {ref.self_error:.2g}, "
        f"{verdict} the {agreement:g} required."
    )


def order_verdict(declared: int, measured: float | None, band: float = ORDER_BAND) -> str:
    """Declared against fitted order, e.g. ``"declared 4, measured 3.98: agree within 0.25"``."""
    if measured is None:
        return f"declared {declared}, not measured (fewer than two errors in the fit band)"
    gap = measured - declared
    if abs(gap) <= band:
        return f"declared {declared}, measured {measured:.2f}: agree within {band:g}"
    return f"declared {declared}, measured {measured:.2f}: DISAGREE by {abs(gap):.2f} (band {band:g})"


def backend_sentence(
    results: Sequence[bench.BenchResult], rtol: float = BACKEND_RTOL, atol: float = BACKEND_ATOL
) -> str:
    """Do the other backends reproduce ABA's errors (same method, same step), and at what cost?

    Empty when no method ran on more than the ABA backend.
    """
    aba = {(r.integrator, r.dt, r.rtol): r for r in results if r.backend == "aba"}
    pairs = [(r, aba[key]) for r in results if r.backend != "aba" and (key := (r.integrator, r.dt, r.rtol)) in aba]
    if not pairs:
        return ""
    backends = sorted({r.backend for r, _ in pairs})
    bad = [(r, a) for r, a in pairs if not abs(r.error - a.error) <= rtol * a.error + atol]
    methods = ", ".join(sorted({r.integrator for r, _ in pairs}))
    if bad:
        text = "DISAGREE: " + "; ".join(
            f"{r.label} at {_step(r)} has error {r.error:.3g} against ABA's {a.error:.3g}" for r, a in bad
        )
        text += f" (tolerance {rtol:g} relative + {atol:g})."
    else:
        r, a = max(pairs, key=lambda p: abs(p[0].error - p[1].error) / (rtol * p[1].error + atol))
        text = (
            f"Backends {', '.join(backends)} give the same errors as ABA on {methods} (same steps) within the "
            f"tolerance {rtol:g} relative + {atol:g}: the largest difference is {abs(r.error - a.error):.2g} "
            f"on an error of {a.error:.2g} ({r.label}, {_step(r)})."
        )
    fast = [(r, a) for r, a in pairs if r.backend == "fast" and not r.diverged and r.wall_time_s > 0]
    if fast:
        ratios = [a.wall_time_s / r.wall_time_s for r, a in fast]
        text += f" Wall time: the compiled fast path ran {speed_range(ratios)} than ABA on the same runs."
    return text


def _step(r: bench.BenchResult) -> str:
    return f"dt {r.dt:g}" if r.dt is not None else f"rtol {r.rtol:g}"


def reading(results: Sequence[bench.BenchResult]) -> str:
    """The cheapest run at each accuracy level of :func:`robodyn.studies.bench.best_by_accuracy`."""
    table = bench.best_by_accuracy(results)
    reached = [(level, r) for level, r in table if r is not None]
    if not reached:
        return f"Reading: no run reached even {table[0][0]:g}." if table else "Reading: no accuracy levels."
    groups: list[tuple[list[float], bench.BenchResult]] = []
    for level, r in reached:  # consecutive levels met by the same run read as one range
        if groups and groups[-1][1] is r:
            groups[-1][0].append(level)
        else:
            groups.append(([level], r))
    parts = [
        f"{r.label} ({_step(r)}) below {levels[0]:g}" + (f" to {levels[-1]:g}" if len(levels) > 1 else "")
        for levels, r in groups
    ]
    text = "Reading: the cheapest way to a given accuracy is " + ", ".join(parts) + "."
    missed = [level for level, r in table if r is None]
    if missed:
        text += f" No run reached {', '.join(f'{x:g}' for x in missed)}."
    return text


def sweep_section(s: bench.Sweep, figures: Sequence[str] = ()) -> list[str]:
    """The report's section of one model's sweep."""
    p = s.plan
    lines = [
        f"## {s.model}",
        "",
        f"Start q0 = {list(map(float, s.q0))}, v0 = {list(map(float, s.v0))}; error horizon {p.error_horizon:g} s, "
        f"energy horizon {p.energy_horizon:g} s. {reference_sentence(s.reference)}",
        "",
        *(f"![{f}]({f})" for f in figures if f.endswith(".png")),
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
            lines.append(f"| {level:g} | {r.label} | {_step(r)} | {r.wall_time_s:.3g} | {r.evaluations} |")
    lo, hi = bench.ORDER_FIT_BAND
    lines += ["", f"Measured orders (ABA backend, fitted where the error lies in {lo:g}..{hi:g}):", ""]
    for m in p.fixed:
        declared = next((r.order for r in s.results if r.integrator == m), None)
        if declared is not None:
            lines.append(f"- {m}: {order_verdict(declared, bench.measured_order(s.results, m))}")
    if s.skipped:
        lines += ["", "Skipped: " + "; ".join(s.skipped)]
    backends = backend_sentence(s.results)
    lines += ["", reading(s.results) + (f" {backends}" if backends else ""), ""]
    return lines


# ------------------------------------------------------------------------------ stability limits
def limit_agrees(limit: Limit, rtol: float = LIMIT_RTOL) -> bool | None:
    """Whether measurement meets prediction; None when the prediction has no limit to compare.

    A prediction of 0 (unstable at every dt, yet growing slowly) gives a finite run a finite
    limit: that is no disagreement, and nothing to compare either.
    """
    p, m = limit.predicted_dt_max, limit.measured_dt_max
    if 0 < p < math.inf and 0 < m < math.inf:
        return abs(m / p - 1.0) <= rtol
    if p == 0:
        return True if m == 0 else (False if m == math.inf else None)
    return p == m  # inf against inf, or a finite prediction measured 0 or inf


def limit_verdict(limit: Limit, rtol: float = LIMIT_RTOL) -> str:
    """One sentence on one limit, e.g. "predicted and measured limits agree within 0.3 % (tolerance 10 %)"."""
    p, m, e = limit.predicted_dt_max, limit.measured_dt_max, limit.energy_dt_max
    agrees = limit_agrees(limit, rtol)
    where = f"{limit.case}, {limit.integrator}"
    if 0 < p < math.inf and 0 < m < math.inf:
        gap = m / p - 1.0
        if agrees:
            return f"{where}: predicted and measured limits agree within {percent(gap)} (tolerance {percent(rtol)})"
        text = (
            f"{where}: DISAGREE: measured {m:.4g} s is {percent(gap)} {_above(gap)} the predicted {p:.4g} s "
            f"(tolerance {percent(rtol)})"
        )
        if 0 < e < math.inf:
            egap = e / p - 1.0
            within = "within tolerance" if abs(egap) <= rtol else "also outside"
            text += f"; the energy-error limit {e:.4g} s is {percent(egap)} {_above(egap)} it, {within}"
        return text
    if p == 0:
        if agrees:
            return f"{where}: unstable at every dt, as predicted"
        if agrees is None:
            return (
                f"{where}: predicted unstable at every dt (no limit to compare); the {limit.steps}-step runs "
                f"first blow up at dt = {m:.4g} s"
            )
        return f"{where}: DISAGREE: predicted unstable at every dt, measured stable at every dt tried"
    if p == math.inf:
        if agrees:
            return f"{where}: stable at every dt tried, as predicted"
        found = "unstable at every dt" if m == 0 else f"a blow-up at {m:.4g} s (h |lambda| = {m * limit.fastest:.3g})"
        return f"{where}: DISAGREE: predicted stable at every dt, measured {found}"
    measured = "unstable at every dt tried" if m == 0 else "stable at every dt tried"
    return f"{where}: DISAGREE: predicted {p:.4g} s, measured {measured}"


def _cell(limit: Limit, rtol: float) -> str:
    agrees = limit_agrees(limit, rtol)
    if agrees is None:
        return "no limit predicted"
    if 0 < limit.predicted_dt_max < math.inf and 0 < limit.measured_dt_max < math.inf:
        gap = limit.measured_dt_max / limit.predicted_dt_max - 1.0
        return f"{'agree' if agrees else 'DISAGREE'} ({'+' if gap >= 0 else '-'}{percent(gap)})"
    return "agree" if agrees else "DISAGREE"


def limits_summary(limits: Sequence[Limit], rtol: float = LIMIT_RTOL) -> list[str]:
    """A count of the limits that agree, then one sentence per disagreement."""
    compared = [x for x in limits if limit_agrees(x, rtol) is not None]
    bad = [x for x in compared if not limit_agrees(x, rtol)]
    if not compared:
        return ["No limit had a prediction and a measurement to compare."]
    head = (
        f"{len(compared) - len(bad)} of {len(compared)} compared limits: predicted and measured agree "
        f"(tolerance {percent(rtol)})."
    )
    return [head, *(f"- {limit_verdict(x, rtol)}." for x in bad)]


# ------------------------------------------------------------------------------ stiff, chaos, conditioning
def time_constants(eigenvalues: NDArray[np.complex128] | Sequence[complex]) -> tuple[float, float] | None:
    """(fastest, slowest) time constant [s] = 1 / decay rate of the decaying modes; None if none decays."""
    rates = sorted(-complex(z).real for z in eigenvalues if complex(z).real < 0)
    if not rates:
        return None
    return 1.0 / rates[-1], 1.0 / rates[0]


def stiff_section(model: str, eigenvalues: NDArray[np.complex128], runs: Sequence[StiffRun]) -> list[str]:
    """The stiff case: its time constant from the linearisation's eigenvalues, and every method's run."""
    dt = runs[0].dt if runs else math.nan
    taus = time_constants(eigenvalues)
    if taus is None:
        scale = f"no decaying mode in the linearisation (eigenvalues {fmt(float(np.max(np.abs(eigenvalues))))} 1/s)"
    else:
        fast, slow = taus
        scale = (
            f"time constant {fast * 1e3:.3g} ms from the linearisation's fastest decay rate {1 / fast:.4g} 1/s, "
            f"stiffness ratio {slow / fast:.2g}; dt = {dt / fast:.3g} time constants"
        )
    lines = [
        f"Stiff case ({model}, {scale}) at dt = {dt:g} s, against a Radau reference:",
        "",
        "| method | rtol | diverged | error | evaluations |",
        "|---|---|---|---|---|",
    ]
    lines += [f"| {r.integrator} | {fmt(r.rtol)} | {r.diverged} | {fmt(r.error)} | {r.evaluations} |" for r in runs]
    diverged = [r.integrator for r in runs if r.diverged]
    finished = [f"{r.integrator} (error {r.error:.2g})" for r in runs if not r.diverged]
    lines += [
        "",
        f"Diverged at this step: {', '.join(diverged) or 'none'}. Finished: {', '.join(finished) or 'none'}.",
    ]
    return lines


def chaos_paragraph(chaos: Chaos, *, threshold: float = SEPARATION_RAD, factor: float = SEPARATION_FACTOR) -> str:
    """The Lyapunov exponent, and the measured separation of two runs one ulp apart against its prediction."""
    ly = chaos.lyapunov
    text = (
        f"Chaos ({chaos.model}, torque-free from q0 = {[float(x) for x in chaos.q0]}): largest Lyapunov exponent "
        f"{ly.exponent:.3g} 1/s (Benettin, {ly.renormalisations} renormalisations every {ly.interval:g} s)"
    )
    measured = chaos.separation_time_s
    if not ly.exponent > 0:
        return text + (
            ": not positive, so this start shows no exponential separation"
            + (f"; yet two runs one ulp apart separated after {measured:.3g} s." if measured < math.inf else ".")
        )
    gap0 = float(chaos.gap[0]) if chaos.gap.size and chaos.gap[0] > 0 else float(np.max(np.spacing(chaos.q0)))
    predicted = math.log(threshold / gap0) / ly.exponent
    text += f", so a one-ulp error reaches O(1) after ln(1/eps)/lambda = {ly.horizon_s:.3g} s. "
    lasted = float(chaos.gap_t[-1]) if chaos.gap_t.size else 0.0
    expect = f"the exponent predicts ln({threshold:g} / {gap0:.2g}) / lambda = {predicted:.3g} s"
    if measured == math.inf:
        if predicted > lasted:
            return (
                text
                + f"Two runs {gap0:.2g} rad apart stayed within {threshold:g} rad for the {lasted:g} s run; {expect}."
            )
        return (
            text
            + f"DISAGREE: two runs {gap0:.2g} rad apart never separated by {threshold:g} rad in {lasted:g} s; {expect}."
        )
    ratio = measured / predicted
    verdict = "" if 1 / factor <= ratio <= factor else "DISAGREE: "
    text += (
        f"{verdict}Two runs {gap0:.2g} rad apart were measured {threshold:g} rad apart after {measured:.3g} s; "
        f"{expect} (measured / predicted {ratio:.2f}, tolerance a factor {factor:g})."
    )
    if not verdict:
        text += " Beyond that no double-precision state of this motion means anything; only statistics (energy) do."
    return text


def accuracy_sentence(accuracies: Sequence[BackendAccuracy], tolerance: float = ACCEL_ROUNDOFF) -> str:
    """Every backend within ``tolerance`` of the extended-precision reference, or the ones that are not."""
    errors = [(a.model, b, e) for a in accuracies for b, e in a.errors.items()]
    cond = max((a.condition for a in accuracies), default=math.nan)
    lost = f"losing the conditioning would show as cond(M) eps = {cond * EPS:.2g}"
    bad = [(model, b, e) for model, b, e in errors if not e <= tolerance]
    if not bad:
        worst = max((e for _, _, e in errors), default=math.nan)
        return (
            f"Every backend within {worst:.2g} of the extended-precision reference on every model: round-off "
            f"(tolerance {tolerance:g}; {lost})."
        )
    named = ", ".join(f"{b} on {model} is {e:.2g} from it" for model, b, e in bad)
    return f"DISAGREE with round-off: {named} (tolerance {tolerance:g}; {lost})."


def spread_sentence(model: str, spread: Mapping[str, float], tolerance: float = SPREAD_ROUNDOFF) -> str:
    """Do RK4 runs on each backend stay within ``tolerance`` of the ABA run?"""
    others = {b: s for b, s in spread.items() if b != "aba"}
    listed = ", ".join(f"{b} {s:.2g}" for b, s in others.items())
    bad = [b for b, s in others.items() if not s <= tolerance]
    if bad:
        return (
            f"DISAGREE: on {model}, RK4 runs drift from the ABA run by {listed} "
            f"(relative state; tolerance {tolerance:g})."
        )
    return (
        f"RK4 runs on {model} stay within round-off of the ABA run on every backend: {listed} (relative state; "
        f"tolerance {tolerance:g})."
    )


def near_singular_section(ns: NearSingular, tip_masses: Mapping[str, float]) -> list[str]:
    """Backend accuracy on the light-tip and the normal model, and what the conditioning costs."""
    light, normal = ns.light, ns.normal
    m_light, m_normal = tip_masses.get(light.model, math.nan), tip_masses.get(normal.model, math.nan)
    backends = list(light.errors)
    lines = [
        f"Near-singular mass matrix ({light.model}, distal link mass {m_light:g} kg against {m_normal:g} kg on "
        f"{normal.model}): largest relative acceleration error over {light.states} seeded states against an "
        "extended-precision closed form:",
        "",
        "| model | cond(M) | " + " | ".join(backends) + " |",
        "|---|---|" + "---|" * len(backends),
    ]
    for a in (light, normal):
        lines.append(f"| {a.model} | {fmt(a.condition)} | " + " | ".join(fmt(a.errors.get(b)) for b in backends) + " |")
    lines += [
        "",
        f"cond(M) is {light.condition / normal.condition:.2g} times larger on {light.model} for a distal link "
        f"{m_normal / m_light:.2g} times lighter. {accuracy_sentence((light, normal))} "
        f"{spread_sentence(light.model, ns.spread)}",
    ]
    return lines


def stability_section(found: StabilityFindings, rtol: float = LIMIT_RTOL) -> list[str]:
    """The report's stability section."""
    from robodyn.studies import stability

    lines = [
        "## Stability: where methods fail",
        "",
        "Largest stable dt predicted from the linearisation about the hanging equilibrium "
        "(one step of the method on q'' = K q + D v, spectral radius <= 1) and measured by bisection "
        f"on {found.steps_per_trial}-step torque-free runs from {stability.SMALL_OFFSET:g} rad off equilibrium "
        f"(blow-up: energy error > {stability.BLOWUP_FACTOR:g}x the energy above equilibrium; the energy column: "
        f"energy error > {100 * stability.ENERGY_ERROR_FRACTION:g} %). 0 = unstable at every dt; "
        "'inf' = stable up to the largest dt tried.",
        "",
        "![stability](stability.png)",
        "",
        "| model | method | max abs(lambda) [1/s] | predicted dt_max [s] | measured [s] | measured / predicted "
        f"| energy error limit [s] | verdict ({percent(rtol)}) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for x in found.limits:
        lines.append(
            f"| {x.case} | {x.integrator} | {fmt(x.fastest)} | {fmt(x.predicted_dt_max, '.4g')} | "
            f"{fmt(x.measured_dt_max, '.4g')} | {fmt(x.ratio, '.3f')} | {fmt(x.energy_dt_max, '.4g')} | "
            f"{_cell(x, rtol)} |"
        )
    lines += ["", *limits_summary(found.limits, rtol), ""]
    if found.stiff_model is not None and found.stiff_eigenvalues is not None:
        lines += stiff_section(found.stiff_model, found.stiff_eigenvalues, found.stiff_runs)
    if found.chaos is not None:
        lines += ["", chaos_paragraph(found.chaos), "", "![lyapunov](lyapunov.png)", ""]
    if found.near_singular is not None:
        lines += near_singular_section(found.near_singular, found.tip_masses)
    if found.notes:
        lines += ["", "Notes: " + "; ".join(found.notes)]
    return lines


# ------------------------------------------------------------------------------ the whole report
def _load_phrase(load: tuple[float, float, int] | None) -> str:
    """The phrase after the run's seconds: its CPUs and load average at the start and the end ("" without them)."""
    if load is None or not all(math.isfinite(x) for x in load[:2]):
        return ""
    start, end, cpus = load
    where = f"{cpus} CPU{'s' if cpus != 1 else ''}"
    return f", on {where} at a 1-minute load average of {start:.1f} at the start and {end:.1f} at the end"


def bench_report(
    sweeps: Sequence[bench.Sweep],
    figures: Mapping[str, Sequence[str]],
    stability: StabilityFindings | None,
    *,
    quick: bool,
    seconds: float,
    load: tuple[float, float, int] | None = None,
) -> str:
    """``report.md`` of ``robodyn bench``: every sweep's section, then the stability section.

    ``load`` is the 1-minute load average at the start and at the end, and the CPU count: the wall
    times in the report hold for a machine that busy.
    """
    rtols = sorted({s.plan.reference_rtol for s in sweeps})
    lines = [
        "# robodyn bench report",
        "",
        f"{'Quick' if quick else 'Full'} run, {seconds:.0f} s{_load_phrase(load)}. Error: relative state error "
        "max |x - x_ref| / max |x_ref| over the error horizon against scipy DOP853 at rtol "
        f"{', '.join(f'{r:g}' for r in rtols) or '-'}; cost: wall time per simulated second; energy drift: "
        "max |E - E0 - W| / energy scale over the long horizon. Numbers: `bench.json`.",
        "",
    ]
    for s in sweeps:
        lines += sweep_section(s, figures.get(s.model, ()))
    if stability is not None:
        lines += stability_section(stability)
    return "\n".join(lines) + "\n"
