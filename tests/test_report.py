"""Report text: each sentence follows its numbers, and says DISAGREE when they disagree."""

from __future__ import annotations

import math

import numpy as np

from robodyn.studies import report
from robodyn.studies.bench import BenchResult, Reference, Sweep, SweepPlan
from robodyn.studies.stability import BackendAccuracy, Chaos, Limit, Lyapunov, NearSingular, StiffRun

INF = math.inf


def _limit(predicted: float, measured: float, energy: float | None = None, *, integrator: str = "rk4") -> Limit:
    return Limit("toy", integrator, 1000.0, predicted, measured, measured if energy is None else energy, 2000, 20)


def test_limit_agreement_follows_the_numbers():
    agree = report.limit_verdict(_limit(2.0e-3, 2.006e-3))
    assert agree == "toy, rk4: predicted and measured limits agree within 0.3 % (tolerance 10 %)"
    assert report.limit_agrees(_limit(2.0e-3, 2.006e-3)) is True
    disagree = report.limit_verdict(_limit(2.0e-3, 2.9e-3, energy=2.02e-3))
    assert disagree == (
        "toy, rk4: DISAGREE: measured 0.0029 s is 45 % above the predicted 0.002 s (tolerance 10 %); "
        "the energy-error limit 0.00202 s is 1 % above it, within tolerance"
    )
    assert report.limit_agrees(_limit(2.0e-3, 2.9e-3)) is False
    assert "agree within 8 %" in report.limit_verdict(_limit(2.0e-3, 1.84e-3))  # below, within tolerance
    assert "DISAGREE" in report.limit_verdict(_limit(2.0e-3, 1.0e-3), rtol=0.1)


def test_limits_without_a_finite_prediction():
    assert report.limit_agrees(_limit(INF, INF)) is True
    assert "as predicted" in report.limit_verdict(_limit(INF, INF))
    assert report.limit_verdict(_limit(INF, 0.5, integrator="implicit_midpoint")) == (
        "toy, implicit_midpoint: DISAGREE: predicted stable at every dt, measured a blow-up at 0.5 s (h |lambda| = 500)"
    )
    assert report.limit_agrees(_limit(0.0, 0.0)) is True
    assert report.limit_agrees(_limit(0.0, 7e-3)) is None  # slow growth: nothing to compare
    assert "no limit to compare" in report.limit_verdict(_limit(0.0, 7e-3))
    assert "DISAGREE" in report.limit_verdict(_limit(0.0, INF))
    assert "DISAGREE" in report.limit_verdict(_limit(2e-3, INF))


def test_limits_summary_counts_and_names_the_disagreements():
    limits = [_limit(2e-3, 2.001e-3), _limit(2e-3, 2.9e-3, 2.6e-3, integrator="heun"), _limit(0.0, 7e-3)]
    lines = report.limits_summary(limits)
    assert lines[0] == "1 of 2 compared limits: predicted and measured agree (tolerance 10 %)."
    assert lines[1:] == [
        "- toy, heun: DISAGREE: measured 0.0029 s is 45 % above the predicted 0.002 s (tolerance 10 %); "
        "the energy-error limit 0.0026 s is 30 % above it, also outside."
    ]
    assert report.limits_summary([_limit(0.0, 7e-3)]) == ["No limit had a prediction and a measurement to compare."]


def _stiff_runs() -> list[StiffRun]:
    return [
        StiffRun("rk4", 0.01, None, True, INF, 12, 0.0),
        StiffRun("implicit_midpoint", 0.01, None, False, 3e-3, 400, 0.0),
    ]


def test_stiff_time_constant_comes_from_the_eigenvalues():
    eig = np.array([-999.14 + 0j, -0.0357 + 0j])
    fast, slow = report.time_constants(eig)
    assert fast == 1 / 999.14 and slow == 1 / 0.0357
    text = "\n".join(report.stiff_section("arm", eig, _stiff_runs()))
    assert "time constant 1 ms" in text and "dt = 9.99 time constants" in text
    assert "Diverged at this step: rk4. Finished: implicit_midpoint (error 0.003)." in text
    slower = "\n".join(report.stiff_section("arm", np.array([-100.0 + 0j, -1.0 + 0j]), _stiff_runs()))
    assert "time constant 10 ms" in slower and "dt = 1 time constants" in slower
    undamped = "\n".join(report.stiff_section("arm", np.array([30j, -30j]), _stiff_runs()))
    assert "no decaying mode" in undamped and "time constant" not in undamped


def _accuracy(model: str, **errors: float) -> BackendAccuracy:
    return BackendAccuracy(model, 1.8e6 if model == "light" else 19.0, 50, dict(errors))


def test_backend_accuracy_names_the_backend_that_is_not_round_off():
    good = [_accuracy("light", aba=5e-16, crba=6e-16, formula=3e-16), _accuracy("normal", aba=9e-16, crba=1e-15)]
    text = report.accuracy_sentence(good)
    assert text.startswith("Every backend within 1e-15 of the extended-precision reference on every model")
    assert "cond(M) eps = 4e-10" in text and "DISAGREE" not in text
    bad = [_accuracy("light", aba=5e-16, crba=4e-10), _accuracy("normal", aba=9e-16, crba=1e-15)]
    text = report.accuracy_sentence(bad)
    assert text.startswith("DISAGREE with round-off: crba on light is 4e-10 from it")
    assert "Every backend" not in text


def test_spread_sentence_follows_the_runs():
    assert "stay within round-off" in report.spread_sentence("light", {"aba": 0.0, "crba": 1e-14})
    bad = report.spread_sentence("light", {"aba": 0.0, "crba": 1e-14, "formula": 1e-6})
    assert bad.startswith("DISAGREE: on light, RK4 runs drift from the ABA run by crba 1e-14, formula 1e-06")


def _chaos(exponent: float, separation: float) -> Chaos:
    lyap = Lyapunov(exponent, 0.1, 300, np.full(300, exponent), math.log(1 / 2.2e-16) / exponent)
    t = np.linspace(0.0, 30.0, 301)
    return Chaos("pendubot", np.array([0.5, -0.3]), np.zeros(2), lyap, separation, t, np.full(t.size, 1.11e-16))


def test_chaos_separation_against_the_exponent():
    # ln(0.1 / 1.11e-16) / 2.72 = 12.66 s
    agree = report.chaos_paragraph(_chaos(2.72, 12.7))
    assert "were measured 0.1 rad apart after 12.7 s; the exponent predicts" in agree
    assert "= 12.7 s (measured / predicted 1.00, tolerance a factor 2)" in agree and "DISAGREE" not in agree
    late = report.chaos_paragraph(_chaos(2.72, 29.0))
    assert "DISAGREE: Two runs 1.1e-16 rad apart were measured 0.1 rad apart after 29 s" in late
    never = report.chaos_paragraph(_chaos(2.72, INF))
    assert "DISAGREE: two runs 1.1e-16 rad apart never separated by 0.1 rad in 30 s" in never
    regular = report.chaos_paragraph(_chaos(-0.1, INF))
    assert "not positive, so this start shows no exponential separation" in regular


def _result(backend: str, error: float, wall: float, *, name: str = "rk4", dt: float = 0.01) -> BenchResult:
    return BenchResult("toy", name, backend, dt, None, error, wall, 100, 0.0, False, 4, False, False, 1.0)


def test_backend_sentence_says_which_backend_disagrees():
    runs = [_result("aba", 1e-6, 1.0), _result("crba", 1e-6 * (1 + 1e-9), 1.2), _result("fast", 1e-6, 0.02)]
    agree = report.backend_sentence(runs)
    assert agree.startswith("Backends crba, fast give the same errors as ABA on rk4 (same steps) within the tolerance")
    assert "the compiled fast path ran 50x to 50x faster than ABA" in agree
    runs[1] = _result("crba", 2e-6, 1.2)
    bad = report.backend_sentence(runs)
    assert bad.startswith("DISAGREE: rk4/crba at dt 0.01 has error 2e-06 against ABA's 1e-06")
    assert report.backend_sentence([_result("aba", 1e-6, 1.0)]) == ""
    assert "ran 2x to 2x slower than ABA" in report.backend_sentence(
        [_result("aba", 1e-6, 1.0), _result("fast", 1e-6, 2.0)]
    )


def test_orders_reference_and_speed():
    assert report.order_verdict(4, 3.98) == "declared 4, measured 3.98: agree within 0.25"
    assert report.order_verdict(4, 2.1) == "declared 4, measured 2.10: DISAGREE by 1.90 (band 0.25)"
    assert "not measured" in report.order_verdict(2, None)
    ref = Reference(np.zeros(2), np.zeros((2, 1)), np.zeros((2, 1)), 1e-12, 3e-12, 0.1)
    assert report.reference_sentence(ref).endswith("3e-12, within the 1e-10 required.")
    bad = Reference(np.zeros(2), np.zeros((2, 1)), np.zeros((2, 1)), 1e-12, 3e-9, 0.1)
    assert "DISAGREE: above the 1e-10 required" in report.reference_sentence(bad)
    assert report.speed_phrase(2.34) == "2.3x faster" and report.speed_phrase(0.5) == "2.0x slower"


def test_reading_groups_levels_and_names_the_missed_ones():
    runs = [_result("aba", 5e-7, 1.0, dt=0.01), _result("aba", 2e-9, 3.0, dt=0.0025)]
    text = report.reading(runs)
    assert text == (
        "Reading: the cheapest way to a given accuracy is rk4/aba (dt 0.01) below 0.01 to 1e-06, "
        "rk4/aba (dt 0.0025) below 1e-08. No run reached 1e-10."
    )
    assert report.reading([_result("aba", 0.5, 1.0)]) == "Reading: no run reached even 0.01."


def _sweep(crba_error: float) -> Sweep:
    plan = SweepPlan(1.0, 2.0, 0.02, (0.01, 0.005), (), ("rk4",), (), ("aba", "crba"), ("rk4",))
    ref = Reference(np.zeros(2), np.zeros((2, 1)), np.zeros((2, 1)), 1e-12, 1e-13, 0.1)
    results = (
        _result("aba", 1.6e-7, 1.0),
        _result("aba", 1e-8, 2.0, dt=0.005),
        _result("crba", crba_error, 1.1),
        _result("crba", 1e-8, 2.2, dt=0.005),
    )
    return Sweep("toy", None, np.zeros(1), np.zeros(1), plan, ref, results)


def _findings(measured: float) -> report.StabilityFindings:
    ns = NearSingular(
        _accuracy("light", aba=5e-16, crba=6e-16),
        _accuracy("normal", aba=9e-16, crba=1e-15),
        {"aba": 0.0, "crba": 1e-14},
    )
    return report.StabilityFindings(
        limits=(_limit(2e-3, measured),),
        steps_per_trial=300,
        stiff_model="arm",
        stiff_eigenvalues=np.array([-999.14 + 0j, -0.0357 + 0j]),
        stiff_runs=tuple(_stiff_runs()),
        chaos=_chaos(2.72, 12.7),
        near_singular=ns,
        tip_masses={"light": 5e-7, "normal": 0.5},
    )


def test_whole_report_changes_with_its_numbers():
    good = report.bench_report([_sweep(1.6e-7)], {"toy": ["wp.png"]}, _findings(2.01e-3), quick=True, seconds=12)
    assert "DISAGREE" not in good
    for needle in ("# robodyn bench report", "## toy", "![wp.png](wp.png)", "rk4: declared 4, measured 4.00: agree"):
        assert needle in good
    assert "1 of 1 compared limits: predicted and measured agree" in good
    assert "distal link mass 5e-07 kg against 0.5 kg" in good and "1e+06 times lighter" in good
    bad = report.bench_report([_sweep(3e-7)], {}, _findings(2.9e-3), quick=False, seconds=60)
    assert "DISAGREE: rk4/crba at dt 0.01 has error 3e-07" in bad
    assert "0 of 1 compared limits" in bad and "| DISAGREE (+45 %) |" in bad
    assert "## Stability" not in report.bench_report([_sweep(1.6e-7)], {}, None, quick=True, seconds=1)


def test_the_report_states_the_machines_load_with_its_timings():
    text = report.bench_report([_sweep(1.6e-7)], {}, None, quick=True, seconds=12, load=(2.41, 3.96, 2))
    assert "Quick run, 12 s, on 2 CPUs at a 1-minute load average of 2.4 at the start and 4.0 at the end." in text
    assert "Quick run, 12 s. " in report.bench_report([_sweep(1.6e-7)], {}, None, quick=True, seconds=12)
