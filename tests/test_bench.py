"""The work-precision sweep: measured orders, backends on one chart, the reference, the records."""

from __future__ import annotations

import dataclasses

import pytest

import robodyn
from robodyn import integrators
from robodyn.errors import InputError
from robodyn.studies import bench

from ._bench_helpers import RECORD_KEYS

# Fitted orders (errors in 1e-11..1e-1, steps 0.02..0.00125 s on the smooth geared-arm swing)
# must lie within this band of the declared orders.
ORDER_BAND = 0.25
# The same method on another backend changes only round-off, amplified over the horizon.
BACKEND_RTOL = 1e-6

PLAN = bench.SweepPlan(
    error_horizon=1.0,
    energy_horizon=2.0,
    sample_interval=0.02,
    dts=(0.02, 0.01, 0.005, 0.0025, 0.00125),
    rtols=(1e-5, 1e-8),
    fixed=("euler", "semi_implicit_euler", "heun", "rk4"),
    adaptive=("dopri5",),
    backends=("aba", "crba", "formula", "fast"),
    all_backends_for=("rk4",),
)


@pytest.fixture(scope="module")
def sweep() -> bench.Sweep:
    return bench.sweep(robodyn.load("geared_arm"), plan=PLAN)


def test_reference_confirms_itself(sweep):
    assert sweep.reference.self_error <= bench.REFERENCE_AGREEMENT
    assert sweep.reference.t[-1] == pytest.approx(PLAN.error_horizon)


@pytest.mark.parametrize("method", ["euler", "semi_implicit_euler", "heun", "rk4"])
def test_measured_order_matches_declared(sweep, method):
    declared = robodyn.integrators.get(method).order
    measured = bench.measured_order(sweep.results, method)
    assert measured is not None
    assert abs(measured - declared) <= ORDER_BAND


def test_backends_share_the_chart_and_agree(sweep):
    rk4 = {(r.backend, r.dt): r for r in sweep.results if r.integrator == "rk4"}
    assert {b for b, _ in rk4} == {"aba", "crba", "formula", "fast"}
    for (backend, dt), r in rk4.items():
        ref = rk4[("aba", dt)]
        assert r.error == pytest.approx(ref.error, rel=BACKEND_RTOL, abs=1e-13), backend
        assert r.evaluations == ref.evaluations
        assert not r.diverged


def test_records_have_the_issue_keys(sweep):
    for record in bench.records([sweep]):
        assert RECORD_KEYS <= record.keys()
        assert (record["dt"] is None) != (record["rtol"] is None)
    assert len(sweep.results) == 3 * 5 + 4 * 5 + 2


def test_adaptive_tolerance_ladder_tightens_the_error(sweep):
    runs = sorted((r for r in sweep.results if r.integrator == "dopri5"), key=lambda r: -r.rtol)
    assert runs[1].error < runs[0].error
    assert runs[1].evaluations > runs[0].evaluations


def test_best_by_accuracy_picks_the_cheapest(sweep):
    table = bench.best_by_accuracy(sweep.results)
    assert [level for level, _ in table] == list(bench.ACCURACY_LEVELS)
    # rk4 at 1.25 ms reaches 1e-8 on the geared-arm swing: at least four levels have a pick
    assert sum(best is not None for _, best in table) >= 4
    for level, best in table:
        meets = [r for r in sweep.results if not r.diverged and r.error <= level]
        if best is None:
            assert meets == [], level
            continue
        assert best in meets
        assert best.wall_time_s == min(r.wall_time_s for r in meets)


def _run(name: str, error: float, wall: float, *, diverged: bool = False) -> bench.BenchResult:
    return bench.BenchResult("toy", name, "aba", 0.01, None, error, wall, 10, 0.0, diverged, 1, False, False, 1.0)


def test_best_by_accuracy_on_known_runs():
    slow_exact = _run("slow_exact", 1e-9, 5.0)
    cheap_rough = _run("cheap_rough", 1e-3, 1.0)
    middle = _run("middle", 1e-6, 2.0)
    broken = _run("broken", 0.0, 0.1, diverged=True)  # cheapest and "exact", but it blew up
    table = bench.best_by_accuracy([slow_exact, broken, cheap_rough, middle], levels=(1e-2, 1e-3, 1e-6, 1e-8, 1e-12))
    assert table == [(1e-2, cheap_rough), (1e-3, cheap_rough), (1e-6, middle), (1e-8, slow_exact), (1e-12, None)]


def test_default_plan_comes_from_the_registry():
    from robodyn.sim.fast import METHODS as FAST_METHODS

    swept = [integrators.get(n) for n in integrators.names() if n not in bench.NOT_SWEPT]
    full = bench.default_plan()
    assert set(full.fixed) == {m.name for m in swept if not m.adaptive}
    assert set(full.adaptive) == {m.name for m in swept if m.adaptive}
    assert set(full.all_backends_for) == set(FAST_METHODS) & set(full.fixed)
    # today's content, derived
    assert set(full.fixed) == {"euler", "semi_implicit_euler", "symplectic_euler", "heun", "rk4", "implicit_midpoint"}
    assert set(full.adaptive) == {"dopri5", "scipy_rk45", "scipy_dop853", "scipy_radau"}
    quick = bench.default_plan(quick=True)
    assert (quick.fixed, quick.adaptive, quick.all_backends_for) == (
        ("euler", "semi_implicit_euler", "rk4"),
        ("dopri5",),
        ("rk4",),
    )


def test_a_new_integrator_joins_the_plan_without_an_edit(monkeypatch):
    new = {
        "rk3_new": dataclasses.replace(integrators.get("euler"), name="rk3_new", order=3),
        "adaptive_new": dataclasses.replace(integrators.get("scipy_rk45"), name="adaptive_new", order=3),
    }
    names, get = integrators.names, integrators.get
    monkeypatch.setattr(integrators, "names", lambda: (*names(), *new))
    monkeypatch.setattr(integrators, "get", lambda name: new[name] if name in new else get(name))
    full = bench.default_plan()
    assert "rk3_new" in full.fixed and "adaptive_new" in full.adaptive
    quick = bench.default_plan(quick=True)
    assert "rk3_new" not in quick.fixed  # neither the lowest nor the highest explicit order
    assert quick.adaptive == ("adaptive_new",)  # now the lowest-order explicit adaptive method


def test_energy_series_for_every_fixed_method(sweep):
    assert {s.integrator for s in sweep.energy} == set(PLAN.fixed)


def test_bad_plans_are_refused():
    with pytest.raises(InputError, match="does not divide"):
        bench.SweepPlan(1.0, 2.0, 0.02, (0.003,), (), ("rk4",), (), ("aba",), ())
    with pytest.raises(InputError, match="adaptive"):
        bench.SweepPlan(1.0, 2.0, 0.02, (0.01,), (), ("dopri5",), (), ("aba",), ())


# --------------------------------------------------------------------------- the replay's pair
def test_the_pair_is_the_fastest_hit_and_the_cheapest_miss():
    from robodyn.studies.replay_pair import pick_pair

    slow_exact = _run("slow_exact", 1e-9, 5.0)
    fast_good = _run("fast_good", 1e-7, 2.0)
    cheap_rough = _run("cheap_rough", 1e-3, 1.0)
    dear_rough = _run("dear_rough", 1e-2, 3.0)
    broken = _run("broken", 1e-12, 0.1, diverged=True)  # cheapest and "exact" before it blew up: a miss
    pair = pick_pair("toy", [slow_exact, dear_rough, broken, fast_good, cheap_rough], 1e-6)
    assert (pair.met, pair.missed) == (fast_good, broken)
    assert pair.runs == (fast_good, broken)
    pair = pick_pair("toy", [slow_exact, dear_rough, fast_good, cheap_rough], 1e-6)
    assert (pair.met, pair.missed) == (fast_good, cheap_rough)
    assert pair.name(fast_good).startswith("meets 1e-06: fast_good/aba dt 0.01 s, error 1e-07, 2 s per simulated s")
    assert pair.name(cheap_rough).startswith("misses 1e-06: cheap_rough/aba")
    line = pair.describe()
    assert "accuracy 1e-06" in line and "fast_good/aba" in line and "cheap_rough/aba" in line
    assert "saves nothing" not in line  # the miss is cheaper (1 s against 2 s per simulated s)
    # the error equal to the accuracy meets it; ties in wall time go to fewer evaluations
    edge = _run("edge", 1e-6, 2.0)
    fewer = dataclasses.replace(_run("fewer", 1e-8, 2.0), evaluations=5)
    assert pick_pair("toy", [edge, fewer], 1e-6).met == fewer


def test_a_missing_side_is_said_and_nothing_is_made_up():
    from robodyn.studies.replay_pair import pick_pair

    good = [_run("a", 1e-9, 2.0), _run("b", 1e-8, 1.0)]
    every = pick_pair("toy", good, 1e-6)
    assert every.missed is None and every.runs == (good[1],)
    assert "every run meets it; replaying the fastest alone" in every.describe()
    none = pick_pair("toy", good, 1e-10)
    assert none.met is None and none.runs == (good[1],)  # b is the cheaper miss
    assert "no run meets it; replaying the cheapest alone" in none.describe()
    dear_miss = pick_pair("toy", [_run("fast", 1e-9, 1.0), _run("slow", 1e-3, 4.0)], 1e-6)
    assert "it costs 4 times as much: missing the accuracy saves nothing here" in dear_miss.describe()
    for bad in (0.0, -1e-6, float("nan"), float("inf")):
        with pytest.raises(InputError, match="accuracy"):
            pick_pair("toy", good, bad)


@pytest.mark.parametrize("label", ["rk4/aba", "rk4/fast", "euler/aba", "dopri5/aba"])
def test_a_run_replayed_has_the_error_the_sweep_recorded(sweep, label):
    """The replay runs the same arithmetic again: the same error, to the last bit."""
    from robodyn.studies.replay_pair import rerun

    robot = robodyn.load("geared_arm")
    result = next(r for r in sweep.results if r.label == label)
    again = rerun(robot, sweep, result)
    assert again.error == result.error
    assert again.trajectory.t[-1] == pytest.approx(PLAN.energy_horizon) or result.diverged
    with pytest.raises(InputError, match="model"):
        rerun(robodyn.load("pendubot"), sweep, result)
