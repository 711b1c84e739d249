"""The system that robodyn.simulate integrates: every backend is the same dynamics.

The symplectic and implicit methods step (q, p = M(q) v) with the momentum rate
dp/dt = tau + C^T v - G of the system; the explicit ones use the acceleration. A wrong
momentum rate (C v for C^T v) leaves rk4 untouched and moves only those methods, so they
are run on the hand-derived ``formula`` backend and on Pinocchio's ``aba`` and must agree,
and the momentum rate the system reports is checked against the rate of M(q) v itself.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest

import robodyn
from robodyn.integrators import FixedStepIntegrator

KINDS = ["pendubot", "cart_pole", "geared_arm"]
DURATION = 1.0  # [s]
DT = 1e-3  # [s]
SEED = 7  # seeds 1-5 and 7 measured; 7 grows the round-off most (the pendubot reaches 39 rad/s)

# backend="formula" and backend="aba" are both exact dynamics, so their runs differ by
# round-off grown over 1000 steps: measured <= 4.7e-13 in q and <= 2.0e-12 in v (pendubot,
# symplectic_euler, seeds 1-5 and 7). 100x that; the C v momentum-rate bug ends ~6.7 rad away.
Q_ATOL = 5e-11  # [rad | m]
V_ATOL = 2e-10  # [rad/s | m/s]

# Constant torques [N m | N], full (nv,) vectors with zeros on the passive joints.
TORQUES = {"pendubot": [0.3, 0.0], "cart_pole": [2.0, 0.0], "geared_arm": [0.5]}
FD_STEP = 1e-6  # central difference of M along v [s]: truncation ~1e-12, round-off ~eps |M| / FD_STEP
MOMENTUM_RTOL = 1e-6  # dp/dt against a finite difference of M: measured <= 1e-11
PROBE_DURATION = 0.2  # [s]: 200 states along an rk4 trajectory


@pytest.mark.parametrize("integrator", ["symplectic_euler", "implicit_midpoint", "rk4"])
@pytest.mark.parametrize("kind", KINDS)
def test_formula_backend_follows_aba_for_one_second(kind, integrator):
    robot = robodyn.load(kind)
    q0, v0 = robot.random_state(np.random.default_rng(SEED))
    runs = {
        backend: robodyn.simulate(
            robot, q0, v0, duration=DURATION, dt=DT, integrator=integrator, backend=backend, max_energy_growth=None
        )
        for backend in ("formula", "aba")
    }
    formula, aba = runs["formula"], runs["aba"]
    assert formula.n_steps == aba.n_steps == round(DURATION / DT)
    np.testing.assert_allclose(formula.q, aba.q, rtol=0, atol=Q_ATOL)
    np.testing.assert_allclose(formula.v, aba.v, rtol=0, atol=V_ATOL)


@dataclass(frozen=True)
class MomentumProbe(FixedStepIntegrator):
    """Steps with rk4 and records (q, v, dp/dt) as the system reports them at every step's start."""

    records: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list, compare=False)

    def step(self, problem, t, q, u, h):
        nv = problem.nv
        self.records.append((q.copy(), u[:nv].copy(), np.array(problem.momentum_rates(t, q, u)[:nv])))
        return robodyn.integrators.get("rk4").step(problem, t, q, u, h)


def _momentum_rate_oracle(robot, q, v, tau):
    """d/dt (M(q) v) = M a + (dM/dt) v along the flow through (q, v), and the size of its terms.

    a by ABA; dM/dt by a central difference of M along v (step FD_STEP). No C in sight.
    """
    M = robot.M(q)
    a = robot.forward_dynamics(q, v, tau)
    mass_rate = (robot.M(robot.integrate(q, FD_STEP * v)) - robot.M(robot.integrate(q, -FD_STEP * v))) / (2 * FD_STEP)
    scale = np.abs(tau).max() + np.abs(robot.G(q)).max() + np.abs(M @ a).max() + np.abs(mass_rate @ v).max()
    return M @ a + mass_rate @ v, float(scale)


@pytest.mark.parametrize("backend", ["formula", "aba", "crba"])
@pytest.mark.parametrize("kind", KINDS)
def test_momentum_rate_is_the_rate_of_M_v(kind, backend):
    robot = robodyn.load(kind)
    tau = np.array(TORQUES[kind])
    q0, v0 = robot.random_state(np.random.default_rng(SEED))
    probe = MomentumProbe(
        name="momentum_probe", order=4, symplectic=False, adaptive=False, implicit=False,
        description="rk4 that records dp/dt",
    )  # fmt: skip
    robodyn.simulate(
        robot, q0, v0, duration=PROBE_DURATION, dt=DT, integrator=probe, torque=tau, backend=backend, losses=False
    )
    assert len(probe.records) == round(PROBE_DURATION / DT)
    for q, v, rate in probe.records:
        expected, scale = _momentum_rate_oracle(robot, q, v, tau)
        np.testing.assert_allclose(rate, expected, rtol=0, atol=MOMENTUM_RTOL * scale)


@pytest.mark.parametrize("kind", KINDS)
def test_momentum_rate_law_holds_for_the_formula_set(kind):
    """tau + C^T v - G of the hand-derived formulas is d/dt (M v): the law the backend uses."""
    robot = robodyn.load(kind)
    formula, p = robodyn.formulas.get(kind), robodyn.extract_params(robot, kind)
    tau = np.array(TORQUES[kind])
    rng = np.random.default_rng(SEED)
    for _ in range(25):
        q, v = robot.random_state(rng)
        law = tau + formula.coriolis_matrix(q, v, p).T @ v - formula.gravity(q, p)
        expected, scale = _momentum_rate_oracle(robot, q, v, tau)
        np.testing.assert_allclose(law, expected, rtol=0, atol=MOMENTUM_RTOL * scale)


def test_the_python_pipeline_is_the_bare_rk4_loop():
    """simulate(backend="aba", rk4) on a torque-free Pendubot is a hand-written pin.aba RK4 loop, to the bit.

    The loop below is the oracle (the one benchmarks/bench_overhead.py times): the stages of the
    system, the stop watch and the records add no arithmetic to the motion.
    """
    import pinocchio as pin

    robot = robodyn.load("pendubot")
    q0, v0 = robot.random_state(np.random.default_rng(SEED), speed=1.0)
    traj = robodyn.simulate(robot, q0, v0, duration=0.2, dt=DT, integrator="rk4", backend="aba")
    model, data = robot.model, robot.model.createData()
    tau = np.zeros(robot.nv)
    q, v = q0.copy(), v0.copy()
    h, h2, h6 = DT, 0.5 * DT, DT / 6.0
    for k in range(traj.t.size - 1):
        a1 = pin.aba(model, data, q, v, tau).copy()
        v2 = v + h2 * a1
        a2 = pin.aba(model, data, q + h2 * v, v2, tau).copy()
        v3 = v + h2 * a2
        a3 = pin.aba(model, data, q + h2 * v2, v3, tau).copy()
        v4 = v + h * a3
        a4 = pin.aba(model, data, q + h * v3, v4, tau).copy()
        q = q + h6 * (v + 2.0 * (v2 + v3) + v4)
        v = v + h6 * (a1 + 2.0 * (a2 + a3) + a4)
        np.testing.assert_array_equal(traj.q[k + 1], q)  # identical arithmetic: exact
        np.testing.assert_array_equal(traj.v[k + 1], v)
