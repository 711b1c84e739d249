"""The work-precision sweep: measured orders, backends on one chart, the reference, the records."""

from __future__ import annotations

import pytest

import robodyn
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
    for level, best in bench.best_by_accuracy(sweep.results):
        if best is None:
            continue
        assert best.error <= level
        assert all(r.wall_time_s >= best.wall_time_s for r in sweep.results if r.error <= level and not r.diverged)


def test_energy_series_for_every_fixed_method(sweep):
    assert {s.integrator for s in sweep.energy} == set(PLAN.fixed)


def test_bad_plans_are_refused():
    with pytest.raises(InputError, match="does not divide"):
        bench.SweepPlan(1.0, 2.0, 0.02, (0.003,), (), ("rk4",), (), ("aba",), ())
    with pytest.raises(InputError, match="adaptive"):
        bench.SweepPlan(1.0, 2.0, 0.02, (0.01,), (), ("dopri5",), (), ("aba",), ())
