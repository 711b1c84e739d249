"""The one RK4 step of the closed forms (engine/rk4.py): classic RK4, and the only one the closed-form paths take.

The step is a plain Python function that numba compiles for the CPU (engine/closed_form.py) and
for CUDA (engine/cuda/batch.py, engine/cuda/closed_loop.py); given the identity as its compiler it
runs as Python, which is how it is checked here against the Python reference integrator. The GPU
paths' own check against an independent oracle is in tests/test_cuda_batch.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robodyn.engine.rk4 import rk4_step
from robodyn.integrators import ArrayProblem, get
from robodyn.kinds.catalog import closed_form
from robodyn.kinds.formula import solve_2x2

ENGINE = Path(__file__).resolve().parents[1] / "src" / "robodyn" / "engine"
# The same stages and weights in float64; the reference groups 2 (u2 + u3) where the step adds
# 2 w + 2 x: the two differ by a few ulps of the state.
STEP_RTOL = 1e-14
DT = 1e-2  # [s]: a step long enough that every stage moves the state
# Modules of the closed forms' compiled paths: each takes the step of engine/rk4.py, none writes its own.
CLOSED_FORM_PATHS = ("closed_form.py", "cuda/batch.py", "cuda/closed_loop.py", "cuda/sweep.py")


def _pendubot_rates(tau: tuple[float, float], damping: tuple[float, float]):  # type: ignore[no-untyped-def]
    """The Pendubot's closed form as the step's rates (ctx: the parameter vector), with a power booked."""
    form = closed_form("pendubot")

    def rates(p, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        m11, m12, m22 = form.mass(p, q0, q1)
        c11, c12, c21, c22 = form.coriolis(p, q0, q1, v0, v1)
        g0, g1 = form.gravity(p, q0, q1)
        r0 = tau[0] - damping[0] * v0 - (c11 * v0 + c12 * v1) - g0
        r1 = tau[1] - damping[1] * v1 - (c21 * v0 + c22 * v1) - g1
        a0, a1 = solve_2x2(m11, m12, m22, r0, r1)
        return a0, a1, (tau[0] - damping[0] * v0) * v0 + (tau[1] - damping[1] * v1) * v1

    return rates


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_one_step_is_the_reference_integrators_classic_rk4(seed: int) -> None:
    rng = np.random.default_rng(seed)
    p = rng.uniform(0.2, 1.5, len(closed_form("pendubot").params))
    tau, damping = (0.7, -0.3), (0.05, 0.02)
    rates = _pendubot_rates(tau, damping)
    step = rk4_step(lambda f: f, rates)  # the identity as the compiler: the step runs as Python
    q, v = rng.uniform(-2.0, 2.0, 2), rng.uniform(-1.0, 1.0, 2)

    def accel(t: float, q_: np.ndarray, u: np.ndarray) -> np.ndarray:  # [a0, a1, power]: work carried in u
        a0, a1, power = rates(p, q_[0], q_[1], u[0], u[1])
        return np.array([a0, a1, power])

    ref_q, ref_u, _ = get("rk4").step(ArrayProblem(accel, nq=2, nv=2, nw=1), 0.0, q, np.array([*v, 0.0]), DT)
    a0, a1, p1 = rates(p, *q, *v)
    got = np.array(step(p, q[0], q[1], v[0], v[1], a0, a1, p1, DT))
    want = np.array([*ref_q, *ref_u])
    assert np.max(np.abs(got - want)) <= STEP_RTOL * np.max(np.abs(want)), (got, want)
    assert np.max(np.abs(got[:4] - [*q, *v])) > 1e-3  # the step moved the state: no comparison of two copies


def test_no_closed_form_path_writes_an_rk4_step_of_its_own() -> None:
    """The RK4 weights h/6 (1, 2, 2, 1) appear in engine/rk4.py only; every closed-form path imports its step."""
    for name in CLOSED_FORM_PATHS:
        text = (ENGINE / name).read_text()
        assert "h / 6.0" not in text, f"engine/{name} writes out an RK4 step: call robodyn.engine.rk4.rk4_step"
        assert "rk4_step" in text or "_advance" in text, f"engine/{name} takes no RK4 step at all"
    assert (ENGINE / "rk4.py").read_text().count("h / 6.0") == 5  # q0, q1, v0, v1 and the work, once each
