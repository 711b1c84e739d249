"""Stability: theory (the method's step matrix) against measurement (bisection on blow-up)."""

from __future__ import annotations

import numpy as np
import pytest

import robodyn
from robodyn.errors import InputError
from robodyn.studies import stability as stab

# Stability-region boundaries are found by bisection to 1e-6 relative; quoted constants
# (2.785293563 for RK4 on the real axis, 2 sqrt 2 on the imaginary) are exact to that.
REGION_RTOL = 1e-5
# The band: measured limit within 10 % of the predicted one on the linear cases.
LIMIT_RTOL = 0.10
# Lyapunov estimate of a linear saddle against its exact exponent: the random start direction
# costs ~ln(projection) / T, about 1 % over 60 s.
LYAPUNOV_RTOL = 0.02
# A backend's acceleration against the extended-precision closed form: a few hundred ulps.
BACKEND_RTOL = 1e-13


@pytest.mark.parametrize(
    ("method", "angle", "expected"),
    [
        ("euler", np.pi, 2.0),
        ("euler", np.pi / 2, 0.0),
        ("heun", np.pi, 2.0),
        ("heun", np.pi / 2, 0.0),
        ("rk4", np.pi, 2.785293563405282),
        ("rk4", np.pi / 2, 2.0 * np.sqrt(2.0)),
        ("semi_implicit_euler", np.pi / 2, 2.0),
        ("implicit_midpoint", np.pi, np.inf),
        ("implicit_midpoint", 0.75 * np.pi, np.inf),
    ],
)
def test_stability_region_boundaries(method, angle, expected):
    got = stab.region_radius(method, angle)
    if expected in (0.0, np.inf):
        assert got == expected
    else:
        assert got == pytest.approx(expected, rel=REGION_RTOL)


def test_explicit_euler_is_flagged_unstable_on_an_undamped_oscillator():
    omega = 10.0
    K, D = np.array([[-(omega**2)]]), np.array([[0.0]])
    assert stab.predicted_limit("euler", K, D).dt_max == 0.0
    steps = 200
    for h in (1e-4, 1e-3, 1e-2):
        rho = stab.spectral_radius(stab.step_matrix("euler", K, D, h))
        assert rho == pytest.approx(np.sqrt(1.0 + (omega * h) ** 2), rel=1e-12)
        sol = robodyn.integrators.solve(lambda t, q, v: K @ q, [1.0], [0.0], dt=h, n_steps=steps, method="euler")
        e = 0.5 * sol.v[:, 0] ** 2 + 0.5 * omega**2 * sol.q[:, 0] ** 2
        # explicit Euler multiplies this energy by exactly 1 + (omega h)^2 every step
        assert e[-1] / e[0] == pytest.approx((1.0 + (omega * h) ** 2) ** steps, rel=1e-9)


@pytest.mark.parametrize(
    ("K", "D", "methods"),
    [
        (-100.0, 0.0, ("semi_implicit_euler", "rk4")),  # undamped oscillator, lambda = +-10 i
        (-35.0, -1000.0, ("euler", "semi_implicit_euler", "heun", "rk4")),  # stiff: lambda ~ -1000, -0.035
        (-400.0, -8.0, ("euler", "heun", "rk4", "semi_implicit_euler")),  # lightly damped, complex lambda
    ],
)
def test_bisection_finds_the_predicted_limit_on_linear_cases(K, D, methods):
    K_, D_ = np.array([[K]]), np.array([[D]])
    for method in methods:
        pred = stab.predicted_limit(method, K_, D_)
        assert 0 < pred.dt_max < np.inf
        test = stab.linear_blows_up(method, K_, D_, [0.1, 1.0], steps=2000)
        found = stab.bisect_limit(test, dt_lo=pred.dt_max / 3, dt_hi=pred.dt_max * 3)
        assert found.dt_max == pytest.approx(pred.dt_max, rel=LIMIT_RTOL), method


def test_stiff_geared_arm_explicit_fail_implicit_do_not():
    robot = robodyn.load(stab.variant_path(stab.STIFF_VARIANT))
    found = {x.integrator: x for x in stab.limits(robot, methods=("euler", "rk4", "implicit_midpoint"), steps=400)}
    lam = found["rk4"].fastest
    assert lam == pytest.approx(10.0 / 1.0008275e-2, rel=1e-3)  # b / J: a 1 ms time constant
    assert found["euler"].predicted_dt_max == pytest.approx(2.0 / lam, rel=1e-3)
    assert found["rk4"].predicted_dt_max == pytest.approx(2.785293563 / lam, rel=1e-3)
    for name in ("euler", "rk4"):
        assert found[name].measured_dt_max == pytest.approx(found[name].predicted_dt_max, rel=LIMIT_RTOL)
    assert found["implicit_midpoint"].predicted_dt_max == np.inf
    assert found["implicit_midpoint"].measured_dt_max > 50 * found["rk4"].measured_dt_max


def test_linearisation_of_the_pendubot_about_hanging():
    robot = robodyn.load("pendubot")
    q_eq = stab.hanging_equilibrium(robot)
    np.testing.assert_allclose(q_eq, [-np.pi / 2, 0.0], atol=1e-9)
    lam = stab.linearise(robot, q_eq).eigenvalues
    assert np.max(np.abs(lam.real)) < 1e-9  # no damping: a centre
    # small-oscillation frequencies solve det(G'(q_eq) - w^2 M) = 0
    M = robot.M(q_eq)
    Kq = -M @ stab.linearise(robot, q_eq).K
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(M, Kq)).real)
    np.testing.assert_allclose(np.sort(np.abs(lam.imag))[::2], np.sqrt(w2), rtol=1e-9)


def test_lyapunov_of_a_linear_saddle():
    k = 4.0  # q'' = k q: the unstable exponent is sqrt(k) = 2 1/s

    def step_run(q, v, T):
        sol = robodyn.integrators.solve(lambda t, q, v: k * q, q, v, dt=T / 100, n_steps=100, method="rk4")
        return sol.q[-1], sol.v[-1]

    found = stab.lyapunov(step_run, [0.0], [0.0], duration=60.0, interval=0.5)
    assert found.exponent == pytest.approx(2.0, rel=LYAPUNOV_RTOL)
    assert found.horizon_s == pytest.approx(np.log(1 / np.finfo(float).eps) / found.exponent)


def test_pendubot_is_chaotic_with_a_finite_horizon():
    robot = robodyn.load("pendubot")
    found = stab.chaos(robot, np.array([0.5, -0.3]), np.zeros(2), duration=30.0)
    assert 0.5 < found.lyapunov.exponent < 10.0
    assert 3.0 < found.lyapunov.horizon_s < 80.0
    # two runs one ulp apart separate within a small multiple of the predicted horizon
    assert found.separation_time_s < 3 * found.lyapunov.horizon_s


def test_light_tip_backends_stay_at_round_off():
    light = robodyn.load(stab.variant_path(stab.LIGHT_VARIANT))
    acc = stab.backend_accuracy(light, states=20)
    assert acc.condition > 1e6
    for backend, err in acc.errors.items():
        assert err < BACKEND_RTOL, backend


def test_bad_input_is_refused():
    with pytest.raises(InputError, match="adapts its step"):
        stab.predicted_limit("dopri5", np.array([[-1.0]]), np.array([[0.0]]))
    with pytest.raises(InputError):
        stab.bisect_limit(lambda dt: False, dt_lo=1.0, dt_hi=0.5)
    with pytest.raises(robodyn.UnknownNameError):
        stab.linear_blows_up("rk4", np.array([[-1.0]]), np.array([[0.0]]), [1.0, 0.0], steps=10, criterion="vibes")
