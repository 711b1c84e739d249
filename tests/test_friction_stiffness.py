"""Stiff regularised Coulomb friction: the finding in the metadata and the one CLI warning line.

The robot is written here: light "fingers" hinged on a fixed base about z with their centre
of mass on the axis, so M(q) is diagonal with M_jj = izz_j + J_m,j n_j^2 exactly (the link's
inertia about the axis plus the rotor's reflected armature from the SRDF), at any q. A joint's
regularised friction F tanh(v / v_f) relaxes v at the rate F / (v_f M_jj), and a fixed-step
method is stable on it while rate * dt <= x*, the method's real-axis stability limit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.cli import main
from robodyn.sim.stiffness import polynomial_limit, real_axis_limit, stability_polynomial
from robodyn.sim.system import V_FRICTION
from tests._urdf import _inertial

# RK4's real-axis limit: R(-x) = 1 - x + x^2/2 - x^3/6 + x^4/24 returns to +1 where
# x^3 - 4 x^2 + 12 x - 24 = 0. Its one real root by Cardano, with x = y + 4/3:
# y^3 + p y + r = 0, p = 20/3, r = -344/27.
_P, _R = 20.0 / 3.0, -344.0 / 27.0
_D = np.sqrt(_R**2 / 4.0 + _P**3 / 27.0)
RK4_LIMIT = 4.0 / 3.0 + np.cbrt(-_R / 2.0 + _D) + np.cbrt(-_R / 2.0 - _D)
# Explicit Euler and Heun: |1 - x| and |1 - x + x^2/2| reach 1 at x = 2.
EULER_LIMIT = HEUN_LIMIT = 2.0

# Fingers: (name, izz [kg m^2], rotor J_m [kg m^2], gear ratio n, friction F [N m]).
FINGERS = (
    ("finger_a", 1.0e-4, 1.0e-6, 10.0, 0.5),  # M = 2e-4, rate 2.5e6 1/s
    ("finger_b", 3.0e-4, 2.0e-6, 5.0, 0.2),  # M = 3.5e-4, rate 5.7e5 1/s
    ("finger_c", 2.0e-4, 0.0, 1.0, 0.8),  # M = 2e-4, rate 4e6 1/s (the stiffest)
    ("finger_d", 5.0e-4, 1.0e-6, 20.0, 0.1),  # M = 9e-4, rate 1.1e5 1/s
    ("finger_e", 1.0e-4, 0.0, 1.0, 0.05),  # M = 1e-4, rate 5e5 1/s
    ("arm", 2.0, 0.0, 1.0, 1.0),  # M = 2, rate 500 1/s: never stiff at dt = 1 ms
)


def _fingers_urdf(folder: Path, fingers=FINGERS) -> Path:
    links, joints, rotors = ['<link name="base"/>'], [], []
    for k, (name, izz, J_m, n, F) in enumerate(fingers):
        inertia = np.diag([izz, izz, izz])
        links.append(f'<link name="{name}_link">{_inertial(0.05, (0.0, 0.0, 0.0), inertia)}</link>')
        joints.append(
            f'<joint name="{name}" type="revolute"><parent link="base"/><child link="{name}_link"/>'
            f'<origin xyz="{0.1 * k!r} 0 0"/><axis xyz="0 0 1"/>'
            '<limit lower="-3" upper="3" effort="10" velocity="10"/>'
            f'<dynamics damping="0" friction="{F!r}"/></joint>'
        )
        if J_m:
            rotors.append(f'<joint name="{name}" mass="{J_m!r}" gear_ratio="{n!r}"/>')
    path = folder / "fingers.urdf"
    path.write_text('<?xml version="1.0"?><robot name="fingers">' + "".join(links + joints) + "</robot>")
    path.with_suffix(".srdf").write_text(
        '<robot name="fingers"><rotor_params>' + "".join(rotors) + "</rotor_params></robot>"
    )
    return path


def _analytic(fingers=FINGERS) -> dict[str, tuple[float, float]]:
    """Joint -> (rate F / (v_f m) [1/s], RK4's largest stable dt = x* v_f m / F [s]), m = izz + J_m n^2."""
    out = {}
    for name, izz, J_m, n, F in fingers:
        m = izz + J_m * n**2
        out[name] = (F / (V_FRICTION * m), RK4_LIMIT * V_FRICTION * m / F)
    return out


@pytest.fixture
def fingers(tmp_path: Path) -> robodyn.Robot:
    return robodyn.load(_fingers_urdf(tmp_path))


def _simulate(robot: robodyn.Robot, integrator: str, dt: float, **options: object) -> robodyn.Trajectory:
    q0 = np.linspace(-0.4, 0.4, robot.nq)  # M is the same at every q: the fingers' COMs are on their axes
    return robodyn.simulate(robot, q0, np.zeros(robot.nv), duration=5 * dt, dt=dt, integrator=integrator, **options)


def test_the_real_axis_limits_come_from_the_tableaux() -> None:
    assert abs(RK4_LIMIT**3 - 4 * RK4_LIMIT**2 + 12 * RK4_LIMIT - 24) < 1e-12  # the constant is the root
    assert real_axis_limit(robodyn.integrators.get("rk4")) == pytest.approx(RK4_LIMIT, rel=1e-14)
    assert real_axis_limit(robodyn.integrators.get("heun")) == pytest.approx(HEUN_LIMIT, rel=1e-14)
    assert real_axis_limit(robodyn.integrators.get("euler")) == pytest.approx(EULER_LIMIT, rel=1e-14)
    # semi-implicit Euler kicks v by explicit Euler: v_1 = (1 - h lambda) v_0
    assert real_axis_limit(robodyn.integrators.get("semi_implicit_euler")) == pytest.approx(2.0, rel=1e-14)
    np.testing.assert_allclose(
        stability_polynomial(robodyn.integrators.get("rk4")), [1, 1, 1 / 2, 1 / 6, 1 / 24], rtol=1e-15
    )
    for name in ("implicit_midpoint", "symplectic_euler", "dopri5", "scipy_radau"):
        assert real_axis_limit(robodyn.integrators.get(name)) is None
    # a polynomial whose region never ends on the real axis: R = 1 (no step at all changes v)
    assert polynomial_limit(np.array([1.0])) == float("inf")


def test_the_mass_matrix_is_the_written_one(fingers: robodyn.Robot) -> None:
    """The armature of the SRDF reached the model: M = diag(izz + J_m n^2)."""
    written = {name: (izz + J_m * n**2, J_m * n**2) for name, izz, J_m, n, _ in FINGERS}
    order = list(fingers.joint_names)  # Pinocchio's order, not the file's
    assert sorted(order) == sorted(written)
    M = fingers.M(np.full(fingers.nq, 0.3))
    np.testing.assert_allclose(M, np.diag([written[name][0] for name in order]), rtol=1e-12, atol=0)
    np.testing.assert_allclose(fingers.armature, [written[name][1] for name in order], rtol=1e-12, atol=0)


def test_rk4_at_1ms_records_the_stiff_joints(fingers: robodyn.Robot) -> None:
    traj = _simulate(fingers, "rk4", 1e-3)
    found = traj.meta["stiff_friction"]
    analytic = _analytic()
    stiff = sorted((name for name in analytic if analytic[name][0] * 1e-3 > RK4_LIMIT), key=lambda n: -analytic[n][0])
    assert stiff == ["finger_c", "finger_a", "finger_b", "finger_e", "finger_d"]  # the arm (500 1/s) is fine
    assert found["joints"] == stiff and found["integrator"] == "rk4" and found["dt"] == 1e-3
    for name, rate, dt_stable in zip(found["joints"], found["rates"], found["dt_stable"], strict=True):
        assert rate == pytest.approx(analytic[name][0], rel=1e-12)
        assert dt_stable == pytest.approx(analytic[name][1], rel=1e-12)
    assert found["rate"] == pytest.approx(analytic["finger_c"][0], rel=1e-12)
    assert found["dt_max"] == pytest.approx(analytic["finger_c"][1], rel=1e-12)
    assert found["real_axis_limit"] == pytest.approx(RK4_LIMIT, rel=1e-14)
    assert found["v_friction"] == V_FRICTION


def test_heun_uses_its_own_limit(fingers: robodyn.Robot) -> None:
    found = _simulate(fingers, "heun", 1e-3).meta["stiff_friction"]
    m_c = FINGERS[2][1]
    assert found["dt_max"] == pytest.approx(HEUN_LIMIT * V_FRICTION * m_c / FINGERS[2][4], rel=1e-12)


def test_no_finding_below_the_limit_or_for_adaptive_and_implicit_methods(fingers: robodyn.Robot) -> None:
    dt_max = min(dt for _, dt in _analytic().values())
    assert "stiff_friction" not in _simulate(fingers, "rk4", 0.99 * dt_max).meta
    # just above the limit the stiffest joint alone is named
    assert _simulate(fingers, "rk4", 1.01 * dt_max).meta["stiff_friction"]["joints"] == ["finger_c"]
    for method in ("implicit_midpoint", "dopri5"):
        assert "stiff_friction" not in _simulate(fingers, method, 1e-3).meta
    assert "stiff_friction" not in _simulate(fingers, "rk4", 1e-3, losses=False).meta


def test_cli_prints_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    urdf = _fingers_urdf(tmp_path)
    out = tmp_path / "run.npz"
    argv = ["simulate", str(urdf), "--duration", "0.005", "--dt", "1e-3", "--out", str(out)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    lines = [line for line in text.splitlines() if line.startswith("warning:")]
    assert text.count("Coulomb friction") == 1
    rate, dt_max = _analytic()["finger_c"]
    assert (f"{rate:.2g}", f"{dt_max:.2g}") == ("4e+06", "7e-07")  # as the line rounds them
    assert lines == [
        "warning: Coulomb friction on finger_c, finger_a, finger_b and 2 more is too stiff for rk4 at dt = 1e-3 s "
        "(rate 4e6 1/s; stable below dt = 7e-7 s): expect jitter and a ledger error; "
        "use a smaller --dt, an implicit method, or --no-damping"
    ]
    assert robodyn.Trajectory.load(out).meta["stiff_friction"]["joints"][0] == "finger_c"
    for extra in (["--no-damping"], ["--integrator", "implicit_midpoint"], ["--dt", "1e-7", "--duration", "5e-7"]):
        assert main([*argv[:-2], *extra]) == 0
        assert "warning:" not in capsys.readouterr().out


def test_two_joints_are_both_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    urdf = _fingers_urdf(tmp_path, FINGERS[:2])
    assert main(["simulate", str(urdf), "--duration", "0.003", "--dt", "1e-3"]) == 0
    (line,) = [x for x in capsys.readouterr().out.splitlines() if x.startswith("warning:")]
    assert line.startswith("warning: Coulomb friction on finger_a, finger_b is too stiff for rk4 at dt = 1e-3 s")


# One light finger with viscous damping only: rate D / izz = 0.5 / 1e-6 = 5e5 1/s, so RK4 is stable
# below dt = 2.785 / 5e5 = 5.6e-6 s; at dt = 1e-3 s (and at the 1e-4 s that "a smaller dt" meant) it blows up.
DAMPED_IZZ, DAMPED_D = 1.0e-6, 0.5


def _damped_urdf(folder: Path, *, friction: float = 0.0) -> Path:
    inertia = np.diag([DAMPED_IZZ] * 3)
    path = folder / "damped.urdf"
    path.write_text(
        '<?xml version="1.0"?><robot name="damped"><link name="base"/>'
        f'<link name="finger_link">{_inertial(0.01, (0.0, 0.0, 0.0), inertia)}</link>'
        '<joint name="finger" type="revolute"><parent link="base"/><child link="finger_link"/>'
        '<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="10"/>'
        f'<dynamics damping="{DAMPED_D!r}" friction="{friction!r}"/></joint></robot>'
    )
    return path


def test_stiff_damping_is_the_divergence_cause_and_both_cures_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    base = ["simulate", str(_damped_urdf(tmp_path)), "--v0", "1"]
    assert main([*base, "--duration", "0.01"]) == 3
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "likely cause: damping on finger is too stiff for rk4 at dt = 1e-3 s" in err
    assert "time constant 2e-6 s" in err  # izz / D
    dt_max = RK4_LIMIT * DAMPED_IZZ / DAMPED_D
    suggested = float(err.split("dt <= ")[1].split(" s")[0])
    assert 0.5 * dt_max < suggested < dt_max  # one significant digit, rounded down
    assert "e.g." not in err  # the plain "try a smaller dt, e.g. dt / 10" fails too:
    assert main([*base, "--duration", "0.001", "--dt", "1e-4"]) == 3
    capsys.readouterr()
    for cure in (
        ["--duration", "0.01", "--no-damping"],
        ["--dt", repr(suggested), "--duration", repr(200 * suggested)],
    ):
        assert main([*base, *cure]) == 0, cure
        assert "warning:" not in capsys.readouterr().out


def test_stiff_damping_is_warned_as_damping(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    robot = robodyn.load(_damped_urdf(tmp_path, friction=1e-4))  # friction's 0.1 N m s/rad < D = 0.5
    found = _simulate(robot, "rk4", 1e-6).meta.get("stiff_friction")
    assert found is None  # 1e-6 s is below the 4.6e-6 s limit of D + F / v_f = 0.6 N m s/rad
    found = robodyn.simulate(robot, [0.0], [0.0], duration=2e-5, dt=1e-5, integrator="rk4").meta["stiff_friction"]
    assert found["terms"] == ["damping"]
    assert found["rate"] == pytest.approx((DAMPED_D + 1e-4 / V_FRICTION) / DAMPED_IZZ, rel=1e-12)
    assert main(["simulate", str(tmp_path / "damped.urdf"), "--duration", "2e-5", "--dt", "1e-5"]) == 0
    (line,) = [x for x in capsys.readouterr().out.splitlines() if x.startswith("warning:")]
    assert line.startswith("warning: damping on finger is too stiff for rk4 at dt = 1e-5 s (rate 6e5 1/s;")


def test_a_chattering_stop_at_restitution_0_is_not_told_to_lower_it(tmp_path: Path) -> None:
    from robodyn.sim.constraints import Constraints
    from robodyn.sim.run import diagnose
    from robodyn.sim.system import robot_system

    robot = robodyn.load(_fingers_urdf(tmp_path, FINGERS[-1:]))  # the arm alone: not stiff at 1 ms
    reason = "more than 64 stop events within one step at joint(s) arm (chattering)"
    method = robodyn.integrators.get("rk4")
    for e, expected in ((0.0, "try a smaller dt, e.g. 0.0001 s"), (0.5, "lower the restitution (now 0.5)")):
        system = robot_system(robot, constraints=Constraints.build(restitution=e))
        cause, cure = diagnose(method, 1e-3, system, [np.zeros(1)], reason=reason)
        assert cause == "a joint chatters on its stop" and cure.startswith(expected)
        assert ("restitution" in cure) == (e > 0)
