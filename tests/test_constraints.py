"""Loops, couplings, springs and power: against closed forms, against each other, and bad input in one line.

The loop is the seed's Example 19.3: bars AB and BC (mass m, length l), a collar C (mass m_C)
on a vertical guide through A, a torsional spring k at A. Released from rest at theta0, energy
conservation gives the book's closed form

    omega(theta)^2 = [2 g l (m + m_C)(cos theta0 - cos theta) - k (theta^2 - theta0^2) / 2]
                     / [m l^2 / 3 + (m + 2 m_C) l^2 sin^2 theta],

written here from the book, independently of any robodyn code.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn import constrained
from robodyn.errors import DivergenceError, InputError, UnknownNameError
from robodyn.sim import events
from robodyn.sim.constraints import Constraints, Coupling, Loop, Spring
from robodyn.sim.simulation import simulate

M_BAR, L_BAR, M_COLLAR, G, K_SPRING = 1.0, 0.5, 0.6, 9.81, 5.0
LOOP = [{"frame_a": "bc_tip", "frame_b": "collar", "kind": "point"}]
# omega^2 against the book at dt = 1e-3 (RK4, Baumgarte, projection): the bar is
# 1e-7 of its largest value; measured 5e-9 over the motion through theta = pi.
OMEGA2_RTOL = 1e-7
# The loop stays closed: the bar; projection keeps it at ~1e-12 m.
DRIFT_TOL = 1e-9  # [m]
# Baumgarte alone (no projection) over 1 s at dt = 1e-3: measured 2.0e-8 m, against 1.9e-7 m
# with no correction at all (a factor 9.8; asserted: 5).
BAUMGARTE_DRIFT_TOL = 1e-7  # [m]
BAUMGARTE_GAIN = 5.0
# Two exact routes to the same motion (CRBA on the mimic model vs the loaded mimic model,
# the weld through constraintDynamics vs robodyn's exact hold): round-off.
SAME_MOTION_TOL = 1e-9
# Energy with a spring, no losses, RK4 at dt = 1e-4 over 2 s.
CONSERVATION_RTOL = 1e-10


def linkage_urdf(
    path: Path, *, m: float = M_BAR, l: float = L_BAR, m_c: float = M_COLLAR, guide_x: float = 0.0
) -> Path:
    """The 19.3 linkage as an open tree (collar on a prismatic guide from the world) in the x-z plane.

    ``guide_x`` moves the collar's vertical guide sideways from A [m] (0 in the book).
    """
    inertia = m * l * l / 12
    bar = (
        f'<inertial><origin xyz="0 0 {l / 2!r}"/><mass value="{m!r}"/>'
        f'<inertia ixx="{inertia!r}" iyy="{inertia!r}" izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial>'
    )
    limit = '<limit lower="-100" upper="100" effort="0" velocity="100"/>'
    path.write_text(
        f"""<?xml version="1.0"?>
<robot name="linkage">
  <link name="world"/>
  <link name="ab">{bar}</link>
  <link name="bc">{bar}</link>
  <link name="bc_tip"/>
  <link name="collar"><inertial><origin xyz="0 0 0"/><mass value="{m_c!r}"/>
    <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="joint_a" type="revolute"><parent link="world"/><child link="ab"/>
    <origin xyz="0 0 0"/><axis xyz="0 -1 0"/>{limit}</joint>
  <joint name="joint_b" type="revolute"><parent link="ab"/><child link="bc"/>
    <origin xyz="0 0 {l!r}"/><axis xyz="0 -1 0"/>{limit}</joint>
  <joint name="tip" type="fixed"><parent link="bc"/><child link="bc_tip"/><origin xyz="0 0 {l!r}"/></joint>
  <joint name="guide" type="prismatic"><parent link="world"/><child link="collar"/>
    <origin xyz="{guide_x!r} 0 0"/><axis xyz="0 0 1"/>{limit}</joint>
</robot>"""
    )
    return path


@pytest.fixture(scope="module")
def linkage(tmp_path_factory: pytest.TempPathFactory) -> robodyn.Robot:
    return robodyn.load(linkage_urdf(tmp_path_factory.mktemp("linkage") / "linkage.urdf"))


def closed(theta: float) -> list[float]:
    """The configuration (guide, joint_a, joint_b) on the loop at theta: y = 2 l cos theta, psi = -2 theta."""
    return [2 * L_BAR * np.cos(theta), theta, -2 * theta]


def book_omega2(theta: np.ndarray, theta0: float, k: float) -> np.ndarray:
    """The book's omega(theta)^2 for a release from rest at theta0."""
    work = 2 * G * L_BAR * (M_BAR + M_COLLAR) * (np.cos(theta0) - np.cos(theta)) - 0.5 * k * (theta**2 - theta0**2)
    return work / (M_BAR * L_BAR**2 / 3 + (M_BAR + 2 * M_COLLAR) * L_BAR**2 * np.sin(theta) ** 2)


# ----------------------------------------------------------------------------- loops
@pytest.mark.parametrize("theta0", [0.3, 1.1])
def test_linkage_follows_the_book_with_its_spring(linkage: robodyn.Robot, theta0: float) -> None:
    springs = {"joint_a": {"stiffness": K_SPRING, "rest": 0.0}}
    traj = simulate(linkage, closed(theta0), [0, 0, 0], duration=2.0, dt=1e-3, loops=LOOP, springs=springs)
    theta = traj.q[:, 1]
    expected = book_omega2(theta, theta0, K_SPRING)
    assert np.max(np.abs(traj.v[:, 1] ** 2 - expected)) < OMEGA2_RTOL * np.max(expected)
    assert traj.meta["loop_drift"] < DRIFT_TOL
    assert np.ptp(theta) > 1.0  # it really moved
    # The spring's energy is in V: the books close with no work term for it.
    spring = 0.5 * K_SPRING * theta**2
    assert traj.max_ledger_residual < 1e-6 * traj.meta["energy_scale"]
    gravity_only = traj.potential - spring
    assert np.ptp(gravity_only + traj.kinetic) > 0.1  # without the spring's energy E would not be conserved


def test_baumgarte_holds_the_loop_without_projection(linkage: robodyn.Robot, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(events, "PROJECT_ABOVE", np.inf)
    traj = simulate(linkage, closed(0.3), [0, 0, 0], duration=1.0, dt=1e-3, loops=LOOP)
    assert traj.meta["loop_projections"] == 0
    assert traj.meta["loop_drift"] < BAUMGARTE_DRIFT_TOL
    from robodyn.sim import loops

    monkeypatch.setattr(loops, "KP", 0.0)
    monkeypatch.setattr(loops, "KD", 0.0)
    loose = simulate(linkage, closed(0.3), [0, 0, 0], duration=1.0, dt=1e-3, loops=LOOP)
    assert loose.meta["loop_drift"] > BAUMGARTE_GAIN * traj.meta["loop_drift"]  # the correction does the work


def test_the_drift_of_every_sample_is_the_gap_between_the_frames(
    linkage: robodyn.Robot, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    # Baumgarte alone, so that the gap is well above round-off and varies along the run.
    monkeypatch.setattr(events, "PROJECT_ABOVE", np.inf)
    traj = simulate(linkage, closed(0.3), [0, 0, 0], duration=0.5, dt=1e-3, loops=LOOP)
    drift = traj.constraint_drift
    assert drift is not None and drift.shape == traj.t.shape
    # The oracle: |p_tip - p_collar| from Pinocchio's frame placements, sample by sample.
    import pinocchio as pin

    model = linkage.model
    data = model.createData()
    tip, collar = model.getFrameId("bc_tip"), model.getFrameId("collar")
    gap = np.empty(len(traj.t))
    for k, q in enumerate(traj.q):
        pin.framesForwardKinematics(model, data, q)
        gap[k] = np.linalg.norm(data.oMf[tip].translation - data.oMf[collar].translation)
    assert np.max(np.abs(drift - gap)) < 1e-15  # [m]: the same distance, to round-off
    assert drift[0] < 1e-15 < 1e-12 < np.ptp(drift)  # starts closed, then a series that moves, not a constant
    assert traj.meta["loop_drift"] == np.max(drift) == traj.summary()["loop_drift"]
    path = traj.save(tmp_path / "linkage.npz")
    assert np.array_equal(robodyn.Trajectory.load(path).constraint_drift, drift)
    free = simulate(linkage, closed(0.3), [0, 0, 0], duration=0.01, dt=1e-3)
    assert (
        free.constraint_drift is None
        and robodyn.Trajectory.load(free.save(tmp_path / "f.npz")).constraint_drift is None
    )


def test_an_initial_state_off_the_loop_is_projected_onto_it(linkage: robodyn.Robot) -> None:
    q0 = closed(0.4)
    q0[0] += 0.05  # the collar 5 cm off
    traj = simulate(linkage, q0, [0.3, 0.0, 0.0], duration=0.01, dt=1e-3, loops=LOOP)
    projection = traj.meta["loop_projection"]
    assert projection["residual_m"] == pytest.approx(0.05, rel=1e-6) and projection["moved"] > 0
    system = robodyn.sim.system.robot_system(linkage, constraints=Constraints.build(loops=LOOP))
    assert system.loops is not None
    assert np.max(np.abs(system.loops.residual(traj.q[0]))) < 1e-12
    assert np.max(np.abs(system.loops.jacobian(traj.q[0]) @ traj.v[0])) < 1e-12  # v on the tangent


def test_a_loop_whose_frames_cannot_meet_is_one_line(tmp_path: Path) -> None:
    # Bars of 0.2 m reach 0.4 m from A; the guide runs 1 m away: the closest is 0.6 m off.
    far = robodyn.load(linkage_urdf(tmp_path / "far.urdf", l=0.2, guide_x=1.0))
    with pytest.raises(InputError, match=r"cannot meet.*the residual is [0-9.]+ m") as info:
        simulate(far, [0.3, 0.3, -0.6], [0, 0, 0], duration=0.01, dt=1e-3, loops=LOOP)
    left = float(str(info.value).split("the residual is ")[1].split(" m")[0])
    assert left >= 0.6 - 1e-9 and "\n" not in str(info.value)


def test_a_solver_that_fails_is_a_divergence_with_the_step(
    linkage: robodyn.Robot, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(constrained, "MAX_ITERATIONS", 1)
    with pytest.raises(DivergenceError, match=r"step 1 .*did not converge \(residual [0-9.e+-]+\)") as info:
        simulate(linkage, closed(0.3), [0, 0, 0], duration=0.1, dt=1e-3, loops=LOOP)
    assert info.value.trajectory is not None and info.value.trajectory.n_steps == 0
    assert "\n" not in str(info.value)


def test_a_weld_through_constraint_dynamics_holds_like_robodyns_own_hold() -> None:
    # The pendubot's elbow held at a stop: robodyn's exact hold (open chain) against the
    # 6-D weld solved by Pinocchio's constraintDynamics (the path taken when loops exist).
    robot = robodyn.load("pendubot")
    q, v, tau = np.array([0.3, 0.5]), np.array([1.0, 0.0]), np.array([0.2, 0.0])
    model = robot.model
    weld = constrained.lock_model(model, model.createData(), 2, q, 100.0, 20.0)
    a_weld, converged, _ = constrained.ConstraintSolver(model, [weld]).acceleration(q, v, tau)
    from robodyn.sim.limits import hold

    a_hold, _ = hold(robot.M(q), tau - robot.nle(q, v), np.array([1]))
    assert converged and np.max(np.abs(a_weld - a_hold)) < SAME_MOTION_TOL * np.max(np.abs(a_hold))


# ----------------------------------------------------------------------------- couplings
ROTOR = Coupling(joint="rotor_joint", leader="joint", ratio=50.0)


@pytest.fixture(scope="module")
def rotor_urdf() -> Path:
    return robodyn.model.files.models_dir() / "variants" / "geared_arm_rotor.urdf"


def test_a_coupling_is_the_urdf_mimic_tag(rotor_urdf: Path) -> None:
    mimic = simulate(robodyn.load(rotor_urdf, mimic=True), [1.0], [0.0], duration=1.0, dt=1e-3)
    coupled = simulate(robodyn.load(rotor_urdf), [1.0], [0.0], duration=1.0, dt=1e-3, couplings=[ROTOR])
    np.testing.assert_allclose(coupled.q, mimic.q, rtol=0, atol=SAME_MOTION_TOL)
    assert coupled.meta["backend"] == "crba" and coupled.meta["couplings"] == ["rotor_joint = 50 * joint + 0"]
    # ...and the armature model of the same gear train (J_m n^2 on the link).
    armature = simulate(robodyn.load("geared_arm"), [1.0], [0.0], duration=1.0, dt=1e-3)
    np.testing.assert_allclose(coupled.q, armature.q, rtol=0, atol=SAME_MOTION_TOL)


def test_a_torque_on_the_follower_acts_on_the_leader_through_the_ratio(rotor_urdf: Path) -> None:
    full = robodyn.load(rotor_urdf)
    on_rotor = simulate(full, [1.0, 50.0], [0.0, 0.0], duration=0.5, dt=1e-3, torque=[0.0, 0.01], couplings=[ROTOR])
    on_link = simulate(robodyn.load(rotor_urdf, mimic=True), [1.0], [0.0], duration=0.5, dt=1e-3, torque=[0.5])
    np.testing.assert_allclose(on_rotor.q, on_link.q, rtol=0, atol=SAME_MOTION_TOL)
    np.testing.assert_allclose(on_rotor.tau[:, 0], 50.0 * 0.01, rtol=1e-15)
    assert on_rotor.meta["state_coupled"] is True  # q0 was given in the uncoupled coordinates


def test_a_chain_of_couplings_is_composed_and_a_follower_stop_binds_its_leader(tmp_path: Path) -> None:
    chain = tmp_path / "chain.urdf"
    joint = (
        '<joint name="{n}" type="revolute"><parent link="base"/><child link="{n}_l"/><axis xyz="0 1 0"/>'
        '<limit lower="{lo}" upper="{hi}" effort="1" velocity="10"/></joint>'
    )
    link = (
        '<link name="{n}_l"><inertial><origin xyz="0.1 0 0"/><mass value="0.2"/>'
        '<inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>'
    )
    joints = [("a", -10, 10), ("b", -10, 10), ("c", -3, 3)]
    body = "".join(link.format(n=n) + joint.format(n=n, lo=lo, hi=hi) for n, lo, hi in joints)
    chain.write_text(f'<?xml version="1.0"?><robot name="chain"><link name="base"/>{body}</robot>')
    robot = robodyn.load(chain)
    couplings = [
        {"joint": "c", "leader": "b", "ratio": 2.0, "offset": 0.5},
        {"joint": "b", "leader": "a", "ratio": 3.0},
    ]
    traj = simulate(robot, [0.1], [0.0], duration=0.01, dt=1e-3, couplings=couplings)
    assert sorted(traj.meta["couplings"]) == ["b = 3 * a + 0", "c = 6 * a + 0.5"]
    # c in [-3, 3] means a in [(-3 - 0.5) / 6, (3 - 0.5) / 6]: the leader's stops.
    assert traj.meta["stops"]["a"] == pytest.approx([-3.5 / 6, 2.5 / 6])


# ----------------------------------------------------------------------------- springs
def test_a_spring_adds_its_energy_and_the_books_close() -> None:
    robot = robodyn.load("geared_arm")
    k, rest = 0.8, 0.2
    traj = simulate(robot, [1.0], [0.0], duration=2.0, dt=1e-4, springs={"joint": (k, rest)})
    bare = simulate(robot, [1.0], [0.0], duration=0.0001, dt=1e-4)
    assert traj.potential[0] == pytest.approx(bare.potential[0] + 0.5 * k * (1.0 - rest) ** 2, rel=1e-14)
    assert traj.relative_energy_drift < CONSERVATION_RTOL
    # Its torque is -k (q - rest): the acceleration differs from the bare arm's by that over J.
    J = robot.M([1.0])[0, 0]
    assert traj.a[0, 0] - bare.a[0, 0] == pytest.approx(-k * (1.0 - rest) / J, rel=1e-12)


def test_without_its_energy_the_spring_would_break_the_books(monkeypatch: pytest.MonkeyPatch) -> None:
    # The conservation check above can see a spring: with its V left out, E drifts by far more.
    from robodyn.sim.springs import Springs

    monkeypatch.setattr(Springs, "energy", lambda self, Q: np.zeros(Q.shape[0]))
    robot = robodyn.load("geared_arm")
    traj = simulate(robot, [1.0], [0.0], duration=1.0, dt=1e-3, springs={"joint": 0.8}, max_energy_growth=None)
    assert traj.relative_energy_drift > 1e-3


# ----------------------------------------------------------------------------- power
def test_power_is_tau_times_v_and_integrates_to_the_input_work() -> None:
    robot = robodyn.load("geared_arm")

    def pd(t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.array([1.0 * (1.0 - q[0]) - 0.1 * v[0]])

    errors = []
    for dt in (2e-3, 1e-3):
        traj = simulate(robot, [0.0], [0.0], duration=2.0, dt=dt, torque=pd)
        np.testing.assert_array_equal(traj.power, traj.tau * traj.v)
        np.testing.assert_array_equal(traj.power_total, traj.power.sum(axis=1))
        steps = np.diff(traj.t)
        trapezoid = np.concatenate([[0.0], np.cumsum(0.5 * (traj.power_total[1:] + traj.power_total[:-1]) * steps)])
        errors.append(float(np.max(np.abs(trapezoid - traj.work_input))))
    # The trapezoid of the sampled power converges to the booked work at second order
    # (the work itself is RK4's, 4th order): halving dt divides the gap by ~4.
    assert 3.5 < errors[0] / errors[1] < 4.5
    assert errors[1] < 1e-4 * np.max(np.abs(traj.work_input))
    assert traj.average_power == pytest.approx(traj.work_input[-1] / 2.0)
    assert traj.summary()["average_power"] == traj.average_power


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("options", "error", "match"),
    [
        ({"restitution": 2.0}, InputError, r"restitution must lie in \[0, 1\]"),
        ({"springs": {"joint_a": -1.0}}, InputError, r"springs\.joint_a: spring stiffness must be >= 0"),
        (
            {"springs": {"joint_aa": 1.0}},
            UnknownNameError,
            r"unknown joint \(springs\) 'joint_aa'; did you mean 'joint_a'",
        ),
        ({"loops": [{"frame_a": "bc_tp", "frame_b": "collar"}]}, UnknownNameError, r"did you mean 'bc_tip'"),
        ({"loops": [{"frame_a": "bc", "frame_b": "bc_tip"}]}, InputError, "two different bodies"),
        ({"loops": [{"frame_a": "bc_tip", "frame_b": "collar", "kind": "hinge"}]}, InputError, "loop kind"),
        ({"couplings": [{"joint": "joint_b", "leader": "joint_aa", "ratio": 1}]}, UnknownNameError, "joint_a"),
        (
            {
                "couplings": [
                    {"joint": "joint_b", "leader": "joint_a", "ratio": 1},
                    {"joint": "joint_a", "leader": "joint_b", "ratio": 1},
                ]
            },
            InputError,
            r"coupling cycle: joint_b -> joint_a -> joint_b",
        ),
        ({"couplings": [{"joint": "joint_b", "leader": "joint_a", "ratio": 0}]}, InputError, "non-zero"),
    ],
)
def test_bad_constraints_are_one_line(linkage: robodyn.Robot, options: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match) as info:
        simulate(linkage, closed(0.3), [0, 0, 0], duration=0.01, dt=1e-3, **options)
    assert "\n" not in str(info.value)


def test_the_spec_is_one_door_for_keywords_tables_and_json() -> None:
    table = {"limits": True, "restitution": 0.25, "loops": LOOP, "couplings": []}
    springs = {"joint_a": {"stiffness": 5.0, "rest": 0.1}}
    spec = Constraints.from_mapping(table, springs=springs, where="scene.toml [constraints]")
    assert spec == Constraints.build(
        restitution=0.25, loops=[Loop("bc_tip", "collar")], springs={"joint_a": (5.0, 0.1)}
    )
    assert spec.spring_map == {"joint_a": Spring(5.0, 0.1)}
    with pytest.raises(InputError, match=r"^scene.toml \[constraints\]: unknown key 'limit'; expected limits"):
        Constraints.from_mapping({"limit": False}, where="scene.toml [constraints]")
    with pytest.raises(InputError, match=r"^scene.toml \[constraints\]: springs.a: missing stiffness"):
        Constraints.from_mapping({}, springs={"a": {"rest": 0.0}}, where="scene.toml [constraints]")
    robot = robodyn.load("geared_arm")
    with pytest.raises(InputError, match="not both"):
        simulate(robot, [0.1], [0.0], duration=0.01, dt=1e-3, restitution=0.5, constraints=spec)
    via_spec = simulate(robot, [0.1], [0.0], duration=0.01, dt=1e-3, constraints=Constraints(effort_limits=False))
    assert via_spec.meta["constraints"]["effort_limits"] is False
