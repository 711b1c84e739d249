"""simulate: accuracy against a DOP853 oracle, energy conservation, the work ledger, failure."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import robodyn
from robodyn import dynamics
from robodyn.errors import DivergenceError, InputError, UnknownNameError
from robodyn.sim.energy import EnergyMeter, cross_check
from robodyn.sim.simulation import simulate
from robodyn.sim.system import robot_system

# RK4 at dt = 1e-4 over 2 s against DOP853 at rtol = atol = 1e-12 (the bar).
REFERENCE_TOL = 1e-8
# Energy conserved with no torque and no damping, relative to max(|E0|, max T).
CONSERVATION_RTOL = 1e-10
# The ledger of a 4th-order method: halving dt divides the residual by 16 (band for the
# pre-asymptotic wobble), and at dt = 1e-4 it is below this fraction of the energy scale.
LEDGER_RATIO_BAND = (11.0, 23.0)
LEDGER_RTOL = 1e-10
# Different algorithms for the same dynamics (ABA, CRBA + Cholesky, the closed form).
BACKEND_TOL = 1e-9
# Same motion through pin.integrate on SO(2) and through plain angles: rounding only.
MANIFOLD_TOL = 1e-10

STATES = {
    "pendubot": ([0.3, -0.2], [0.5, -1.0]),
    "cart_pole": ([0.1, 0.4], [0.2, -0.5]),
    "geared_arm": ([1.0], [2.0]),
}


def damped_copy(tmp_path: Path, name: str, damping: float) -> robodyn.Robot:
    """The built-in ``name`` with <dynamics damping> set on every joint (its SRDF alongside)."""
    folder = Path(robodyn.load(name).urdf_path).parent  # type: ignore[arg-type]
    text = (folder / f"{name}.urdf").read_text().replace('damping="0"', f'damping="{damping}"')
    urdf = tmp_path / f"{name}.urdf"
    urdf.write_text(text)
    (tmp_path / f"{name}.srdf").write_text((folder / f"{name}.srdf").read_text())
    return robodyn.load(urdf)


def dop853_reference(robot: robodyn.Robot, q0: list[float], v0: list[float], t: np.ndarray) -> np.ndarray:
    """The oracle: scipy DOP853 on [q, v] with Robot.forward_dynamics, no robodyn integrator."""
    n = robot.nq
    tau = np.zeros(robot.nv)

    def fun(_: float, y: np.ndarray) -> np.ndarray:
        return np.concatenate([y[n:], robot.forward_dynamics(y[:n], y[n:], tau)])

    sol = solve_ivp(fun, (t[0], t[-1]), np.concatenate([q0, v0]), method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t)
    assert sol.success
    return sol.y.T


@pytest.fixture(scope="module")
def rk4_runs() -> dict[str, tuple[robodyn.Robot, robodyn.Trajectory]]:
    runs = {}
    for name, (q0, v0) in STATES.items():
        robot = robodyn.load(name)
        runs[name] = (robot, simulate(robot, q0, v0, duration=2.0, dt=1e-4, integrator="rk4"))
    return runs


# ----------------------------------------------------------------------------- accuracy
@pytest.mark.parametrize("name", sorted(STATES))
def test_rk4_matches_dop853_reference(name: str, rk4_runs: dict) -> None:
    robot, traj = rk4_runs[name]
    q0, v0 = STATES[name]
    ref = dop853_reference(robot, q0, v0, traj.t)
    error = np.max(np.abs(ref - np.hstack([traj.q, traj.v])), axis=0)
    assert traj.n_steps == 20000 and traj.t[-1] == 2.0
    assert np.all(error < REFERENCE_TOL), error


@pytest.mark.parametrize("name", sorted(STATES))
def test_energy_is_conserved_without_torque_or_damping(name: str, rk4_runs: dict) -> None:
    _, traj = rk4_runs[name]
    assert traj.relative_energy_drift < CONSERVATION_RTOL
    assert np.all(traj.work_input == 0) and np.all(traj.work_damping == 0)


def test_recorded_accelerations_and_evaluations(rk4_runs: dict) -> None:
    robot, traj = rk4_runs["pendubot"]
    k = 12345
    expected = robot.forward_dynamics(traj.q[k], traj.v[k], np.zeros(2))
    np.testing.assert_allclose(traj.a[k], expected, rtol=0, atol=1e-12)
    assert traj.evaluations == 4 * traj.n_steps + 1  # four stages a step, one for a(T)
    assert traj.meta["model"] == "pendubot" and traj.meta["integrator"] == "rk4" and traj.meta["dt"] == 1e-4


def test_adaptive_dopri5_matches_reference() -> None:
    robot = robodyn.load("pendubot")
    q0, v0 = STATES["pendubot"]
    traj = simulate(robot, q0, v0, duration=1.0, dt=0.01, integrator="dopri5", rtol=1e-11, atol=1e-11)
    ref = dop853_reference(robot, q0, v0, traj.t)
    assert np.max(np.abs(ref - np.hstack([traj.q, traj.v]))) < 1e-8
    assert traj.meta["accepted_steps"] > 100  # error control, not one step per output


def test_backends_agree() -> None:
    robot = robodyn.load("pendubot")
    q0, v0 = STATES["pendubot"]
    runs = {b: simulate(robot, q0, v0, duration=0.5, dt=1e-3, backend=b) for b in ("aba", "crba", "formula")}
    for b in ("crba", "formula"):
        assert np.max(np.abs(runs[b].q - runs["aba"].q)) < BACKEND_TOL
        assert runs[b].meta["backend"] == b


def test_callable_torque_drives_the_motion() -> None:
    robot = robodyn.load("geared_arm")
    calls = []

    def pd(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        calls.append(t)
        return np.array([2.0 * (1.0 - q[0]) - 0.2 * v[0]])  # hold the link at 1 rad

    traj = simulate(robot, [0.0], [0.0], duration=3.0, dt=1e-3, torque=pd)
    assert calls and abs(traj.q[-1, 0] - 0.93) < 0.1  # gravity sags it below the target
    # The first samples command 2 N m, beyond the gearhead's effort of 1.5 N m: clamped there.
    command = 2.0 * (1.0 - traj.q[:, 0]) - 0.2 * traj.v[:, 0]
    np.testing.assert_allclose(traj.tau[:, 0], np.clip(command, -1.5, 1.5), atol=1e-12)
    assert traj.meta["effort_clamped_samples"] == np.count_nonzero(command > 1.5) > 0
    assert traj.max_ledger_residual < 1e-6 * traj.meta["energy_scale"]  # RK4 at dt = 1e-3


# ----------------------------------------------------------------------------- ledger
@pytest.mark.parametrize(("name", "torque"), [("pendubot", [0.4, 0.0]), ("cart_pole", [1.5]), ("geared_arm", [0.3])])
def test_ledger_closes_with_torque_and_damping(tmp_path: Path, name: str, torque: list[float]) -> None:
    robot = damped_copy(tmp_path, name, 0.05)
    q0, v0 = STATES[name]
    coarse = simulate(robot, q0, v0, duration=1.0, dt=2e-3, torque=torque)
    fine = simulate(robot, q0, v0, duration=1.0, dt=1e-3, torque=torque)
    finest = simulate(robot, q0, v0, duration=1.0, dt=1e-4, torque=torque)
    # Both books are really moving...
    assert finest.work_input[-1] != 0 and finest.work_damping[-1] < 0
    assert np.all(np.diff(finest.work_damping) <= 0)  # damping only ever removes energy
    # ...and the residual is the integrator's error: 4th order, tiny at dt = 1e-4.
    ratio = coarse.max_ledger_residual / fine.max_ledger_residual
    assert LEDGER_RATIO_BAND[0] < ratio < LEDGER_RATIO_BAND[1]
    assert finest.max_ledger_residual < LEDGER_RTOL * finest.meta["energy_scale"]
    # The damping work agrees with an independent quadrature of -v^T D v over the samples.
    power = -np.einsum("ni,i,ni->n", finest.v, robot.damping, finest.v)
    trapezoid = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(finest.t))])
    assert np.max(np.abs(trapezoid - finest.work_damping)) < 1e-6 * abs(finest.work_damping[-1])


def test_constant_torque_work_is_torque_times_displacement(tmp_path: Path) -> None:
    robot = robodyn.load("cart_pole")
    traj = simulate(robot, [0.0, 0.2], [0.0, 0.0], duration=1.0, dt=1e-3, torque=[2.0])
    np.testing.assert_allclose(traj.work_input, 2.0 * (traj.q[:, 0] - traj.q[0, 0]), rtol=0, atol=1e-10)


# ----------------------------------------------------------------------------- energy routines
def test_kinetic_energy_includes_reflected_rotor_inertia() -> None:
    robot = robodyn.load("geared_arm")
    traj = simulate(robot, [0.0], [2.0], duration=1e-3, dt=1e-3)
    j_link = 1.840725e-3 + 0.243 * 0.15**2
    assert traj.kinetic[0] == pytest.approx(0.5 * (j_link + 1.08e-6 * 50**2) * 2.0**2, rel=1e-12)


def test_energy_meter_refuses_pinocchio_energy_that_misses_armature() -> None:
    robot = robodyn.load("pendubot")  # axes 0 -1 0: RevoluteUnaligned joints
    robot.model.armature = np.array([0.01, 0.02])
    assert not EnergyMeter.for_robot(robot, robot.neutral()).fast
    assert cross_check(robot, np.array([0.3, 0.1]), np.array([1.0, -2.0])).relative_error < 1e-12
    traj = simulate(robot, [0.3, -0.2], [1.0, 0.0], duration=1.0, dt=1e-3)
    assert traj.relative_energy_drift < 1e-8  # 1/2 v^T M v with armature: conserved


# ----------------------------------------------------------------------------- long runs
PENDULUM_START = ([-np.pi / 2 + 0.5, 0.4], [0.0, 0.0])  # near hanging: a regular motion


def quarter_maxima(traj: robodyn.Trajectory) -> list[float]:
    e = np.abs(traj.energy - traj.energy[0])
    n = len(e)
    return [float(e[i * n // 4 : (i + 1) * n // 4].max()) for i in range(4)]


def test_explicit_euler_energy_grows_on_pendubot() -> None:
    robot = robodyn.load("pendubot")
    traj = simulate(robot, *PENDULUM_START, duration=10.0, dt=1e-3, integrator="euler", max_energy_growth=None)
    quarters = quarter_maxima(traj)
    assert all(b > 1.2 * a for a, b in itertools.pairwise(quarters))
    assert traj.energy[-1] - traj.energy[0] > 0.05 * traj.meta["energy_scale"]


@pytest.mark.parametrize("name", ["symplectic_euler", "implicit_midpoint"])
def test_symplectic_energy_error_stays_bounded_over_1e5_steps(name: str) -> None:
    robot = robodyn.load("pendubot")
    traj = simulate(robot, *PENDULUM_START, duration=200.0, dt=2e-3, integrator=name, max_energy_growth=None)
    assert traj.n_steps == 100_000
    quarters = quarter_maxima(traj)
    assert quarters[-1] < 1.1 * quarters[0]  # no drift: the last quarter is no worse than the first
    assert quarters[-1] < 0.02 * traj.meta["energy_scale"]


def test_kick_drift_euler_drifts_on_pendubot() -> None:
    robot = robodyn.load("pendubot")
    traj = simulate(
        robot, *PENDULUM_START, duration=100.0, dt=2e-3, integrator="semi_implicit_euler", max_energy_growth=None
    )
    quarters = quarter_maxima(traj)
    assert quarters[-1] > 1.5 * quarters[0]


# ----------------------------------------------------------------------------- manifold
CONTINUOUS_URDF = """<?xml version="1.0"?>
<robot name="wheel_pendulum">
  <link name="base"/>
  <link name="bob">
    <inertial><origin xyz="0.2 0 0"/><mass value="0.5"/>
      <inertia ixx="1e-4" iyy="2e-3" izz="2e-3" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="spin" type="{kind}">
    <parent link="base"/><child link="bob"/><axis xyz="0 1 0"/>
    <limit lower="-100" upper="100" effort="1" velocity="100"/>
  </joint>
</robot>
"""


@pytest.mark.parametrize("integrator", ["rk4", "implicit_midpoint", "dopri5"])
def test_continuous_joint_is_integrated_on_its_manifold(tmp_path: Path, integrator: str) -> None:
    paths = {}
    for kind in ("continuous", "revolute"):
        paths[kind] = tmp_path / f"{kind}.urdf"
        paths[kind].write_text(CONTINUOUS_URDF.format(kind=kind))
    wheel, plain = robodyn.load(paths["continuous"]), robodyn.load(paths["revolute"])
    assert (wheel.nq, wheel.nv) == (2, 1)
    a = simulate(wheel, [0.3], [15.0], duration=2.0, dt=1e-3, integrator=integrator)  # nv angles accepted
    b = simulate(plain, [0.3], [15.0], duration=2.0, dt=1e-3, integrator=integrator)
    angle = np.arctan2(a.q[:, 1], a.q[:, 0])
    assert np.max(np.abs(np.angle(np.exp(1j * (angle - b.q[:, 0]))))) < MANIFOLD_TOL
    np.testing.assert_allclose(np.hypot(a.q[:, 0], a.q[:, 1]), 1.0, atol=1e-13)  # stays on the circle
    assert abs(b.q[-1, 0]) > 2 * np.pi  # it went round at least once
    np.testing.assert_allclose(a.energy, b.energy, atol=1e-10)


# ----------------------------------------------------------------------------- failure
def test_explicit_euler_divergence_is_caught_at_its_step() -> None:
    robot = robodyn.load("pendubot")
    with pytest.raises(DivergenceError) as info:
        simulate(robot, [0.3, -0.2], [0.0, 0.0], duration=5.0, dt=0.05, integrator="euler")
    exc = info.value
    traj = exc.trajectory
    assert isinstance(traj, robodyn.Trajectory) and traj.diverged
    message = str(exc)
    assert message.startswith(f"diverged at step {exc.step} (t = {exc.time:g} s): the energy error")
    assert "likely cause: explicit Euler is unstable at dt = 0.05 s" in message
    assert message.count("try") == 1 and message.count("likely cause") == 1  # one cause, one suggestion
    assert traj.n_steps == exc.step and traj.t[-1] == pytest.approx(exc.time)
    # The work done for what is kept: one rate a step, and a(t) at the last sample; not the
    # 100 - 7 steps the check block took past the failure.
    assert traj.evaluations == exc.step + 1 == 8
    residual = np.abs(traj.ledger_residual)
    assert residual[-1] > traj.meta["energy_scale"] and np.all(residual[:-1] <= traj.meta["energy_scale"])


def test_non_finite_state_is_caught_at_its_step() -> None:
    robot = robodyn.load("geared_arm")

    def kick(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.array([np.inf if t >= 0.25 else 0.0])

    with pytest.raises(DivergenceError, match="not finite") as info:
        simulate(robot, [0.1], [0.0], duration=1.0, dt=0.01, torque=kick)
    traj = info.value.trajectory
    assert np.all(np.isfinite(traj.q)) and traj.t[-1] <= 0.25 + 1e-12
    assert "torque callable" in str(info.value)


def test_torque_on_a_passive_joint_is_refused() -> None:
    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match="'joint2'.*passive"):
        simulate(robot, [0.0, 0.0], [0.0, 0.0], duration=0.1, dt=0.01, torque=[0.0, 1.0])
    with pytest.raises(InputError, match="passive"):
        simulate(robot, [0.0, 0.0], [0.0, 0.0], duration=0.1, dt=0.01, torque=lambda t, q, v: [0.1, 0.1])
    traj = simulate(robot, [0.0, 0.0], [0.0, 0.0], duration=0.1, dt=0.01, torque=[0.7])  # one per actuated joint
    np.testing.assert_array_equal(traj.tau[-1], [0.7, 0.0])


@pytest.mark.parametrize(
    ("options", "error", "match"),
    [
        ({"q0": [0.0]}, InputError, "q0 must have 2 entries"),
        ({"v0": [0.0, 0.0, 0.0]}, InputError, "v0 must have 2 entries"),
        ({"dt": 0.0}, InputError, "dt must be a positive"),
        ({"dt": -1e-3}, InputError, "dt must be a positive"),
        ({"duration": float("nan")}, InputError, "duration must be a positive"),
        ({"dt": 2.0}, InputError, "must not exceed duration"),
        ({"integrator": "rk5"}, UnknownNameError, "expected one of"),
        ({"backend": "mujoco"}, UnknownNameError, "aba, crba, formula"),
        ({"torque": [1.0, 2.0, 3.0]}, InputError, "torque must have 2"),
        ({"max_energy_growth": 0.0}, InputError, "max_energy_growth"),
    ],
)
def test_bad_input_is_refused(options: dict, error: type, match: str) -> None:
    robot = robodyn.load("pendubot")
    kwargs = {"q0": [0.1, 0.2], "v0": [0.0, 0.0], "duration": 1.0, "dt": 1e-3} | options
    q0, v0 = kwargs.pop("q0"), kwargs.pop("v0")
    with pytest.raises(error, match=match):
        simulate(robot, q0, v0, **kwargs)


def test_formula_backend_needs_a_seed_kind(tmp_path: Path) -> None:
    urdf = tmp_path / "wheel.urdf"
    urdf.write_text(CONTINUOUS_URDF.format(kind="revolute").replace('xyz="0.2 0 0"', 'xyz="0.2 0.05 0"'))
    robot = robodyn.load(urdf)
    with pytest.raises(InputError, match="formula"):
        robot_system(robot, backend="formula")


def test_simulate_is_callable_from_the_package() -> None:
    robot = robodyn.load("geared_arm")
    traj = robodyn.simulate(robot, [0.2], [0.0], duration=0.01, dt=1e-3)
    assert isinstance(traj, robodyn.Trajectory) and traj.n_steps == 10


def test_momentum_rate_is_the_derivative_of_m_v(rk4_runs: dict) -> None:
    # dp/dt = tau + C^T v - G against central differences of p = M(q) v along the motion.
    robot, traj = rk4_runs["pendubot"]
    k, dt = 5000, 1e-4
    p = [dynamics.mass_matrix(robot.model, robot.data, traj.q[i]) @ traj.v[i] for i in (k - 1, k + 1)]
    rate = dynamics.momentum_rate(robot.model, robot.data, traj.q[k], traj.v[k], np.zeros(2))
    np.testing.assert_allclose((p[1] - p[0]) / (2 * dt), rate, rtol=0, atol=1e-6)


def test_coulomb_friction_is_applied_and_booked(tmp_path: Path) -> None:
    folder = Path(robodyn.load("geared_arm").urdf_path).parent  # type: ignore[arg-type]
    urdf = tmp_path / "geared_arm.urdf"
    urdf.write_text((folder / "geared_arm.urdf").read_text().replace('friction="0"', 'friction="0.02"'))
    (tmp_path / "geared_arm.srdf").write_text((folder / "geared_arm.srdf").read_text())
    robot = robodyn.load(urdf)
    assert robot.friction[0] == 0.02
    traj = simulate(robot, [1.0], [0.0], duration=2.0, dt=1e-4)
    lossless = simulate(robot, [1.0], [0.0], duration=2.0, dt=1e-4, losses=False)
    assert traj.work_damping[-1] < -0.01  # friction took energy out...
    assert traj.energy[-1] < lossless.energy[-1] - 0.01
    assert traj.max_ledger_residual < 1e-8 * traj.meta["energy_scale"]  # ...and the books still close


# ----------------------------------------------------------------------------- mimic joints
# The rotor as a mimic-coupled body and the rotor as armature J_m n^2 are the same dynamics
# on a fixed base: the two runs differ by rounding (CRBA + Cholesky against ABA).
MIMIC_TOL = 1e-9


def test_mimic_model_simulates_with_crba_and_keeps_the_books() -> None:
    rotor = robodyn.load(robodyn.model.files.models_dir() / "variants" / "geared_arm_rotor.urdf", mimic=True)
    assert dynamics.has_mimic_joints(rotor.model)
    traj = simulate(rotor, [1.0], [0.0], duration=1.0, dt=1e-3, backend="crba")
    assert traj.meta["backend"] == "crba" and traj.n_steps == 1000
    default = simulate(rotor, [1.0], [0.0], duration=1.0, dt=1e-3)  # crba chosen for a mimic model
    assert default.meta["backend"] == "crba"
    np.testing.assert_array_equal(default.q, traj.q)
    armature = simulate(robodyn.load("geared_arm"), [1.0], [0.0], duration=1.0, dt=1e-3)
    np.testing.assert_allclose(traj.q, armature.q, rtol=0, atol=MIMIC_TOL)
    np.testing.assert_allclose(traj.energy, armature.energy, rtol=0, atol=MIMIC_TOL)
    assert traj.max_ledger_residual < CONSERVATION_RTOL * traj.meta["energy_scale"]
    # V by the centre of mass and body by body agree; T by CRBA and RNEA too (rotor included).
    check = cross_check(rotor, np.array([0.7]), np.array([1.3]))
    assert check.relative_error < 1e-12
    assert check.kinetic_crba == pytest.approx(0.5 * 1.3**2 * (1.840725e-3 + 0.243 * 0.15**2 + 1.08e-6 * 50**2))
    with pytest.raises(InputError, match=r"mimic joints.*--backend crba"):
        simulate(rotor, [1.0], [0.0], duration=0.1, dt=1e-3, backend="aba")


# ----------------------------------------------------------------------------- invalid states
def test_cos_sin_pairs_and_quaternions_must_be_unit(tmp_path: Path) -> None:
    urdf = tmp_path / "wheel.urdf"
    urdf.write_text(CONTINUOUS_URDF.format(kind="continuous"))
    wheel = robodyn.load(urdf)
    with pytest.raises(InputError, match=r"joint 'spin' has the \(cos, sin\) pair \(2, 0\) of norm 2; .* 1e-09"):
        simulate(wheel, [2.0, 0.0], [0.0], duration=0.1, dt=1e-3)
    with pytest.raises(InputError, match="'spin'"):  # slightly off: refused too, not silently accepted
        simulate(wheel, [1.0 + 1e-6, 0.0], [0.0], duration=0.1, dt=1e-3)
    ok = simulate(wheel, [np.cos(0.3), np.sin(0.3)], [0.0], duration=0.01, dt=1e-3)
    assert ok.n_steps == 10
    flyer = robodyn.load("geared_arm", free_flyer=True)
    q = flyer.neutral()
    q[3:7] = [0.0, 0.0, 0.0, 1.1]
    with pytest.raises(InputError, match=r"joint 'root_joint' has the quaternion"):
        simulate(flyer, q, np.zeros(flyer.nv), duration=0.1, dt=1e-3)


def test_singular_mass_matrix_is_refused_before_the_run() -> None:
    # Thin-rod links have no inertia about their own axis: on a free flyer, turning the base
    # about y while joint 1 turns back moves nothing, and M is singular (~1e-16 relative).
    robot = robodyn.load("pendubot", free_flyer=True)
    with pytest.raises(robodyn.errors.ModelError, match=r"mass matrix M\(q0\) is singular.*root_joint\.wy"):
        simulate(robot, robot.neutral(), np.zeros(robot.nv), duration=0.5, dt=1e-3)


def test_divergence_diagnosis_blames_a_singular_mass_matrix_not_the_integrator() -> None:
    from robodyn.sim.run import diagnose

    method = robodyn.integrators.get("rk4")
    singular = robodyn.load("pendubot", free_flyer=True)
    cause, suggestion = diagnose(method, 1e-3, robot_system(singular), [singular.neutral()])
    assert "mass matrix M(q) is singular" in cause and "not the integrator" in cause and "rk4" not in cause
    regular = robodyn.load("pendubot")
    cause, suggestion = diagnose(method, 1e-3, robot_system(regular), [regular.neutral()])
    assert cause == "rk4 is unstable at dt = 0.001 s" and suggestion == "try a smaller dt, e.g. 0.0001 s"


def test_a_step_that_cannot_be_taken_is_one_sentence() -> None:
    robot = robodyn.load("pendubot")
    with pytest.raises(DivergenceError) as info:
        simulate(robot, [0.3, -0.2], [0.0, 0.0], duration=1.0, dt=0.3, integrator="symplectic_euler")
    message = str(info.value)
    assert message.startswith("diverged at step 1 (t = 0 -> 0.3 s): symplectic Euler's momentum iteration")
    assert "at t = 0 s" not in message  # the interval is said once, at the start
    assert message.count("likely cause") == 1 and message.count("try a smaller dt") == 1
    assert info.value.trajectory.n_steps == 0


def test_ctrl_c_keeps_the_trajectory_so_far() -> None:
    from robodyn.errors import SimulationInterrupted

    def operator(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        if t >= 0.25:
            raise KeyboardInterrupt
        return np.array([0.1])

    robot = robodyn.load("geared_arm")
    with pytest.raises(SimulationInterrupted) as info:
        simulate(robot, [0.1], [0.0], duration=1.0, dt=0.01, torque=operator)
    assert isinstance(info.value, KeyboardInterrupt)
    traj = info.value.trajectory
    assert traj.status == "interrupted" and not traj.diverged and traj.message.startswith("interrupted after step")
    # RK4's last stage of the step from 0.24 s calls the torque at 0.25 s: that step never finished.
    assert traj.n_steps == 24 and traj.t[-1] == pytest.approx(0.24)
    assert np.all(np.isfinite(traj.a)) and traj.meta["interrupted_step"] == 24
    # 24 steps, the four stages begun in the interrupted one, and a(0.24 s) filled in afterwards.
    assert traj.evaluations == 4 * 24 + 4 + 1
    assert traj.max_ledger_residual < 1e-8


def test_coordinate_units() -> None:
    from robodyn.sim.system import coordinate_units

    assert coordinate_units(robodyn.load("cart_pole")) == (["m", "rad"], ["m/s", "rad/s"])
    q_units, v_units = coordinate_units(robodyn.load("geared_arm", free_flyer=True))
    assert q_units == ["m"] * 3 + [""] * 4 + ["rad"] and v_units == ["m/s"] * 3 + ["rad/s"] * 4


def test_a_non_finite_q0_of_the_right_length_is_named_as_such() -> None:
    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match=r"q0 must be finite, got \[nan  0\.\]"):
        robodyn.simulate(robot, [np.nan, 0.0], [0.0, 0.0], duration=0.01, dt=1e-3)
    flyer = robodyn.load("panda", free_flyer=True)
    q0 = flyer.neutral()
    q0[2] = np.inf
    with pytest.raises(InputError, match="q0 must be finite"):
        robodyn.simulate(flyer, q0, np.zeros(flyer.nv), duration=0.01, dt=1e-3)


def test_a_state_whose_energy_overflows_is_bad_input_not_a_divergence() -> None:
    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match=r"the initial energy is not finite \(T0 = inf J"):
        robodyn.simulate(robot, [0.0, 0.0], [0.0, 1e200], duration=0.01, dt=1e-3)
