"""robodyn check MODEL --against ENGINE: each engine's reading of a URDF, and the cause of each difference.

Engine versions: the causes below are what mujoco 4.0.0, pybullet 3.2.7 and drake 1.51.1 do. MuJoCo and PyBullet
are in the test extra, so these tests run in CI; Drake (a 42 MB wheel) is too. Where an engine is not installed,
the tests that read it skip, saying which extra installs it.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn import dynamics
from robodyn.cli import main
from robodyn.errors import EXIT_BAD_INPUT, EXIT_MISMATCH, EXIT_MISSING_DEPENDENCY, EXIT_OK, MissingDependencyError
from robodyn.other_engines import against, compare
from robodyn.other_engines.reading import BodyInertia, EngineReading
from tests import _against_urdfs as urdfs

ENGINES = ("mujoco", "pybullet", "drake")
SAMPLES = 5  # seeded states per comparison: every cause here moves M, C v or G at any state
# Engines that agree do so to ~1e-15 (double-precision sums in another order); a cause moves M by >= 1e-6.
RTOL = 1e-9
VERSIONS = {"mujoco": "4.0.0", "pybullet": "3.2.7", "drake": "1.51.1"}


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("against")


def _report(folder: Path, case: str, engines: tuple[str, ...] = ENGINES) -> robodyn.AgainstReport:
    urdfs.needs(engines)
    return against(robodyn.load(urdfs.write(case, folder)), engines, samples=SAMPLES, rtol=RTOL)


def _causes(report: robodyn.AgainstReport, engine: str, reading: str) -> list[str]:
    (comparison,) = [c for c in report.comparisons if c.engine == engine and c.reading == reading]
    assert comparison.refused is None, comparison.refused
    assert comparison.unexplained is None, comparison.unexplained  # every difference carries its cause
    return [f"{cause.where}: {cause.what}" for cause in comparison.causes]


def test_versions_are_the_ones_these_causes_were_seen_with(folder: Path) -> None:
    report = _report(folder, "collision")
    assert {c.engine: c.version for c in report.comparisons} == VERSIONS


def test_pendubot_reads_alike_in_mujoco_and_drake_but_for_a_zero_effort_limit() -> None:
    urdfs.needs(("mujoco", "drake"))
    report = against(robodyn.load("pendubot"), ("mujoco", "drake"), samples=SAMPLES)
    assert [(c.engine, c.reading) for c in report.comparisons] == [
        ("mujoco", "default"),
        ("mujoco", "trusted"),
        ("drake", "default"),  # Drake has no option that trusts the file more
    ]
    assert max(max(c.differences.values()) for c in report.comparisons) < RTOL
    # the passive elbow's <limit effort="0">: Pinocchio holds 0 N m, MuJoCo reads 0 as no limit; Drake holds none
    said = "effort limit read differently: robodyn 0 N m, mujoco none (no effect on M, C v, G; caps the motion in simulation)"
    assert [(cause.where, cause.what) for cause in report.comparisons[0].causes] == [("joint2", said)]
    assert report.comparisons[2].status == "agree"


def test_effort_velocity_and_friction_joint_by_joint(folder: Path) -> None:
    report = _report(folder, "effort_friction")
    assert _causes(report, "mujoco", "default") == [
        "joint2: effort limit read differently: robodyn 0 N m, mujoco none (no effect on M, C v, G; caps the motion "
        "in simulation)"  # MuJoCo's URDF compiler limits the actuator force only for an effort > 0
    ]
    assert _causes(report, "pybullet", "trusted") == []  # jointMaxForce 0, jointMaxVelocity 3, jointFriction 0.4
    assert _causes(report, "drake", "default") == [
        "joint2: friction read differently: robodyn 0.4 N m, drake 0 N m (Drake's MultibodyPlant has no joint friction: "
        "its parser drops it) (no effect on M, C v, G; acts in simulation)"
    ]
    (mujoco,) = [c for c in report.comparisons if c.engine == "mujoco" and c.reading == "default"]
    assert mujoco.causes[0].effect == {"M": 0.0, "Cv": 0.0, "G": 0.0}


def test_drake_s_friction_warning_is_said_once_as_a_cause(folder: Path, caplog: pytest.LogCaptureFixture) -> None:
    # Drake's parser logs a warning per joint with <dynamics friction>; the report names the same thing as a cause
    with caplog.at_level("WARNING"):
        report = _report(folder, "effort_friction", ("drake",))
    assert [cause.what.split(":")[0] for cause in report.comparisons[0].causes] == ["friction read differently"]
    assert not [r for r in caplog.records if "friction" in r.getMessage()]


def test_pybullet_takes_inertia_from_the_collision_shape_unless_told(folder: Path) -> None:
    report = _report(folder, "collision", ("pybullet",))
    said = _causes(report, "pybullet", "default")
    assert said == [
        "link1 (joint1): inertia taken from the collision shape",
        "link2 (joint2): inertia taken from the collision shape",
    ]
    assert {c.option for c in report.comparisons[0].causes} == {"flags=URDF_USE_INERTIA_FROM_FILE"}
    assert _causes(report, "pybullet", "trusted") == []


def test_a_link_without_inertial(folder: Path) -> None:
    report = _report(folder, "no_inertial")
    assert _causes(report, "mujoco", "default") == [
        "link2 (joint2): no <inertial> on tip: mujoco gives it a mass from its geometry (robodyn 0.5 kg, mujoco 2 kg)"
    ]
    assert _causes(report, "mujoco", "trusted") == []  # inertiafromgeom="false": the tip weighs nothing
    expected = (
        "link2 (joint2): no <inertial> on tip: pybullet gives it its default 1 kg (robodyn 0.5 kg, pybullet 1.5 kg)"
    )
    assert expected in _causes(report, "pybullet", "default")
    assert _causes(report, "pybullet", "trusted") == [expected]  # URDF_USE_INERTIA_FROM_FILE does not remove it
    assert _causes(report, "drake", "default") == []  # Drake gives a link without <inertial> mass 0 from URDF
    (cause,) = report.comparisons[1 + 2].causes  # pybullet, trusted
    assert cause.effect["G"] > 0.1  # a kilogram at the tip: a torque that is not there


@pytest.mark.parametrize(
    "case",
    ["zero_mass", "zero_mass_moving", "rotated", "merged_rotated", "continuous", "continuous_limit", "prismatic"],
)
def test_read_right_by_these_versions(folder: Path, case: str) -> None:
    # MuJoCo 4.0.0 keeps a rotated inertia's rotation (mujoco#3559) and merges a fixed link with a rotated,
    # non-diagonal inertia in the right frame (mujoco#2982); PyBullet keeps both once it trusts the file.
    # A continuous joint's (cos, sin) in robodyn is one angle in each engine; a prismatic joint moves in metres.
    report = _report(folder, case)
    for engine, reading in (
        ("mujoco", "default"),
        ("mujoco", "trusted"),
        ("pybullet", "trusted"),
        ("drake", "default"),
    ):
        assert _causes(report, engine, reading) == [], (engine, reading)


def test_a_quantity_zero_at_every_state_is_no_false_alarm(folder: Path) -> None:
    # the wheel's C v and G are zero up to round-off (robodyn's and each engine's, in its own order of sums):
    # measured against the robot's torques M v^2, not against that round-off, every engine agrees
    report = _report(folder, "wheel")
    for c in report.comparisons:
        assert c.unexplained is None, (c.engine, c.reading, c.differences)
        if (c.engine, c.reading) == ("pybullet", "default"):  # no collision shape to take an inertia from
            assert [cause.what for cause in c.causes] == ["inertia taken from the collision shape"]
            continue
        assert c.causes == () and max(c.differences.values()) < RTOL, (c.engine, c.reading, c.differences)


def test_armature_from_an_srdf(folder: Path) -> None:
    report = _report(folder, "armature")
    for engine in ENGINES:
        said = [c for c in _causes(report, engine, "default") if c.startswith("joint2: armature")]
        assert said == [
            f"joint2: armature: robodyn 0.0032 kg m^2 (SRDF <rotor_params>), {engine} 0 kg m^2"
            + (" (PyBullet has no armature)" if engine == "pybullet" else "")
        ]
    cause = next(c for c in report.comparisons[0].causes if c.what.startswith("armature"))
    assert cause.effect["M"] > 1e-2 and cause.effect["G"] == 0.0 and cause.effect["Cv"] == 0.0


def test_a_limit_without_bounds_is_read_differently(folder: Path) -> None:
    # URDF's lower and upper default to 0: Pinocchio holds [0, 0]; every engine here reads no limit at all.
    report = _report(folder, "limit_defaults")
    for engine in ENGINES:
        said = [c for c in _causes(report, engine, "default") if "limits" in c]
        assert said == [
            f"joint2: limits read differently: robodyn [0, 0] rad, {engine} none (no effect on M, C v, G; "
            "acts in simulation)"
        ]


def test_damping_is_read_alike(folder: Path) -> None:
    report = _report(folder, "damping")
    assert not [c for c in report.comparisons for cause in c.causes if "damping" in cause.what]


def test_a_prismatic_joint_s_causes_carry_its_units() -> None:
    # damping [N s/m], armature [kg], friction [N] on a prismatic joint; each value printed with its unit
    from robodyn.other_engines.causes import joint_causes
    from robodyn.other_engines.reading import JointReading

    axis = np.array([0.0, 0.6, 0.8])
    mine = JointReading(axis, -0.1, 0.15, 0.7, 0.0032, effort=20.0, velocity=1.0, friction=0.4)
    theirs = JointReading(axis, -0.1, 0.15, 0.0, 0.0, effort=20.0, velocity=1.0, friction=0.0)
    said = [what for what, _ in joint_causes("mujoco", "prismatic", mine, theirs)]
    assert said == [
        "damping read differently: robodyn 0.7 N s/m, mujoco 0 N s/m (no effect on M, C v, G; acts in simulation)",
        "friction read differently: robodyn 0.4 N, mujoco 0 N (no effect on M, C v, G; acts in simulation)",
        "armature: robodyn 0.0032 kg (SRDF <rotor_params>), mujoco 0 kg",
    ]


def test_a_cause_without_effect_says_so(folder: Path) -> None:
    # PyBullet's collision-shape inertia on a carriage that only slides: the body differs, M, C v and G do not
    from robodyn.other_engines import format_report

    report = _report(folder, "rail", ("pybullet",))
    assert _causes(report, "pybullet", "default") == ["carriage (rail): inertia taken from the collision shape"]
    assert (
        "    carriage (rail): inertia taken from the collision shape [effect: none on M, C v, G beyond rtol 1e-09]; "
        "removed by flags=URDF_USE_INERTIA_FROM_FILE"
    ) in format_report(report).splitlines()


def test_a_dropped_rotation_is_named_and_explains_the_whole_difference(
    folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # An engine that drops the <inertial> rpy (as MuJoCo did before mujoco#3559 was fixed), built from MuJoCo's reading.
    robot = robodyn.load(urdfs.write("rotated", folder))
    read = compare._read

    def dropping(robot: robodyn.Robot, engine: str, reading: str) -> EngineReading:
        honest = read(robot, engine, reading)
        body = honest.bodies["joint2"]
        moments = np.diag(np.linalg.eigvalsh(body.inertia))
        wrong = BodyInertia(body.links, body.mass, body.com, moments)
        model = robot.model.copy()
        compare._set_inertia(model, model.getJointId("joint2"), wrong)
        data = model.createData()

        def evaluate(q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            qq = np.array(q, dtype=float)
            M = dynamics.mass_matrix(model, data, qq)
            G = dynamics.gravity(model, data, qq)
            return M, dynamics.nonlinear_effects(model, data, qq, v) - G, G

        return EngineReading(
            engine,
            honest.version,
            reading,
            honest.option,
            honest.names,
            {**honest.bodies, "joint2": wrong},
            honest.joints,
            evaluate,
        )

    monkeypatch.setattr(compare, "_read", dropping)
    report = against(robot, "mujoco", samples=SAMPLES, readings=("default",))
    assert _causes(report, "mujoco", "default") == [
        "link2 (joint2): inertia rotation dropped: mujoco keeps the principal moments in the link's axes"
    ]
    assert report.comparisons[0].causes[0].effect["M"] > 1e-3


def test_cli_exit_codes(folder: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", str(urdfs.write("collision", folder)), "--against", "mujoco", "--samples", "5"]) == EXIT_OK
    assert "every engine agrees with robodyn" in capsys.readouterr().out
    assert main(["check", "pendubot", "--against", "pybullet", "--samples", "5"]) == EXIT_MISMATCH
    out = capsys.readouterr().out
    assert "link2 (joint2): no <inertial> on tip: pybullet gives it its default 1 kg" in out
    # moments 0.003, 0.0025, 0.002 rotated: Pinocchio takes them; MuJoCo's A + B >= C test fails by a rounding
    path = urdfs.write("rotated", folder).with_name("refused.urdf")
    path.write_text(urdfs.CASES["rotated"].replace('iyy="0.0025" izz="0.002"', 'iyy="0.002" izz="0.001"'))
    assert main(["check", str(path), "--against", "mujoco", "--samples", "5"]) == EXIT_BAD_INPUT
    out = capsys.readouterr().out
    assert "REFUSED: mujoco 4.0.0 refuses refused.urdf: Error: inertia must satisfy A + B >= C" in out


def test_cli_json_and_rows(folder: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = str(urdfs.write("collision", folder))
    assert main(["check", path, "--against", "mujoco", "--samples", "5", "--json"]) == EXIT_OK
    printed = json.loads(capsys.readouterr().out)
    assert [c["status"] for c in printed["comparisons"]] == ["agree", "agree"] and printed["samples"] == SAMPLES
    report = against(robodyn.load("pendubot"), "pybullet", samples=SAMPLES)
    data = json.loads(json.dumps(report.as_dict()))
    assert (
        data["status"] == "differ"
        and data["comparisons"][0]["causes"][0]["option"] == "flags=URDF_USE_INERTIA_FROM_FILE"
    )
    assert {row["cause"] for row in report.rows()} >= {"inertia taken from the collision shape"}


def test_json_stays_json_when_pybullet_prints(folder: Path, capfd: pytest.CaptureFixture[str]) -> None:
    # the shoulder's axis (0.267, 0.535, 0.802) is not quite unit: PyBullet's inverse dynamics prints a b3Warning
    # on file descriptor 1 when it builds its tree, which landed in the middle of --json's output
    path = str(urdfs.write("floating_base", folder))
    assert main(["check", path, "--against", "pybullet", "--samples", "2", "--json"]) == EXIT_MISMATCH
    printed = json.loads(capfd.readouterr().out)
    assert [c["engine"] for c in printed["comparisons"]] == ["pybullet", "pybullet"]


def test_to_dataframe_holds_the_rows(folder: Path) -> None:
    pd = pytest.importorskip("pandas", reason="to_dataframe needs pandas (in the test extra)")
    report = _report(folder, "collision", ("pybullet",))
    frame = report.to_dataframe()
    assert isinstance(frame, pd.DataFrame) and len(frame) == len(report.rows())
    assert list(frame.columns) == ["engine", "reading", "status", "where", "cause", "option", "M", "Cv", "G"]
    shape = frame[frame["cause"] == "inertia taken from the collision shape"]
    assert list(shape["where"]) == ["link1 (joint1)", "link2 (joint2)"] and (shape["M"] > RTOL).all()
    assert frame.loc[frame["reading"] == "trusted", "status"].tolist() == ["agree"]


def test_an_engine_not_installed(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "mujoco" else real(name, *a))
    with pytest.raises(MissingDependencyError, match=r"pip install 'robodyn\[mujoco\]'"):
        against(robodyn.load("pendubot"), "mujoco")
    assert main(["check", "pendubot", "--against", "mujoco"]) == EXIT_MISSING_DEPENDENCY
    assert "robodyn[mujoco]" in capsys.readouterr().err


def test_a_formula_and_an_unknown_engine_are_refused_with_against(capsys: pytest.CaptureFixture[str]) -> None:
    # --free-flyer is honoured (tests/test_against_free_flyer.py)
    assert main(["check", "pendubot", "--against", "mujoco", "--formula", "pendubot"]) == EXIT_BAD_INPUT
    with pytest.raises(SystemExit) as exited:
        main(["check", "pendubot", "--against", "bullet"])
    assert exited.value.code == EXIT_BAD_INPUT
    assert "expected one or more of mujoco, pybullet, drake" in capsys.readouterr().err


def test_drake_s_refusal_names_the_user_s_file_not_robodyn_s_copy(folder: Path) -> None:
    # talos_arm's fixed gripper joints carry <mimic>: Drake's Parser refuses the file. Its message began with the
    # temporary copy's path and line (gone, and not the file's line), now with the file's name only.
    urdfs.needs(("drake",))
    path = folder / "mimic.urdf"
    path.write_text(urdfs.CASES["no_inertial"].replace('type="fixed"><parent link="link2"/>',
                                                       'type="fixed"><mimic joint="joint2"/><parent link="link2"/>'))  # fmt: skip
    report = against(robodyn.load(path), "drake", samples=SAMPLES)
    assert report.comparisons[0].refused == (
        "drake refuses mimic.urdf: error: Joint 'tip_joint' which has 0 DOF cannot mimic joint 'joint2' which has 1 DOF."
    )


def test_drake_s_warnings_name_the_user_s_file(folder: Path, caplog: pytest.LogCaptureFixture) -> None:
    # the base's invalid inertia: Drake warns that it replaces it, naming the file it parsed (robodyn's copy)
    with caplog.at_level("WARNING"):
        _report(folder, "invalid_base", ("drake",))
    said = [r.getMessage() for r in caplog.records if r.name == "drake"]
    assert said and all(m.startswith("invalid_base.urdf: warning: ") and "robodyn-against" not in m for m in said)


def test_a_root_link_named_world_on_a_fixed_base(folder: Path) -> None:
    # pybullet_data's pendulum5.urdf: Drake's Parser welds the robot to its own world body `world` by itself; welding
    # it again was refused ("would connect body world to itself") where Drake reads the file as robodyn does
    report = _report(folder, "world_root", ("mujoco", "drake"))
    for c in report.comparisons:
        assert _causes(report, c.engine, c.reading) == [] and c.status == "agree", (c.engine, c.reading)


def test_a_robot_without_a_moving_joint_is_one_line(folder: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # a single link (pybullet_data's cube.urdf, plane.urdf): no M, C v, G to compare, so bad input, not a traceback
    urdfs.needs(("mujoco", "drake"))
    path = folder / "block.urdf"
    path.write_text(f'<robot name="block"><link name="block">{urdfs.inertial(0.37)}{urdfs.BOX}</link></robot>')
    assert main(["check", str(path), "--against", "mujoco,drake"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "block: no moving joint" in err and len(err.strip().splitlines()) == 1


def test_a_real_run() -> None:
    urdfs.needs(("mujoco", "drake"))
    run = subprocess.run(
        [sys.executable, "-m", "robodyn", "check", "pendubot", "--against", "mujoco,drake", "--samples", "5"],
        capture_output=True,
        text=True,
        check=False,
        timeout=300,
    )
    assert run.returncode == EXIT_MISMATCH, run.stderr  # the pendubot's effort="0" elbow: MuJoCo reads no limit
    assert "drake 1.51.1, default reading" in run.stdout


def test_a_difference_no_cause_explains_is_reported(folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # An engine whose gravity is 1 % stronger: no body, joint or armature differs, yet G does.
    robot = robodyn.load(urdfs.write("collision", folder))
    read = compare._read

    def stronger(robot: robodyn.Robot, engine: str, reading: str) -> EngineReading:
        honest = read(robot, engine, reading)

        def evaluate(q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            M, Cv, G = honest.evaluate(q, v)
            return M, Cv, 1.01 * G

        return EngineReading(engine, honest.version, reading, honest.option, honest.names, honest.bodies,
                             honest.joints, evaluate)  # fmt: skip

    monkeypatch.setattr(compare, "_read", stronger)
    (comparison,) = against(robot, "mujoco", samples=SAMPLES, readings=("default",)).comparisons
    assert comparison.causes == () and comparison.status == "differ"
    assert comparison.unexplained is not None
    assert comparison.unexplained["G"] == pytest.approx(0.01, rel=1e-6) and comparison.unexplained["M"] < RTOL
