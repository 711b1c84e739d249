"""The constraint engine on the command line: robodyn simulate's flags and JSON file, a scene's tables.

Physics on a slider falling along gravity onto its lower stop (the drop h = 0.1 m is known, so
the speed at the stop is sqrt(2 g h) and the energy a stop takes is 1/2 m v^2 (1 - e^2)), the
19.3 linkage (a closed loop and a torsional spring), and one line with exit 2 for every bad input.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
LINKAGE = EXAMPLES / "textbook" / "linkage"

G = 9.81  # Pinocchio's |g| [m/s^2]
MASS = 2.0  # the slider's [kg]
DROP = 0.1  # [m]: from q = 0 to the lower stop
EFFORT = 1.0  # [N], the slider's URDF effort limit
IMPACT_RTOL = 1e-9  # the impact is located inside the step and its impulse is exact: round-off
NO_STOP_RTOL = 1e-9  # free fall under RK4 is exact (constant acceleration): round-off
LOOP_DRIFT = 1e-9  # [m] issue 10: a closed loop stays closed to 1e-9 m
LEDGER = 1e-9  # [J] the books close to the integrator's accuracy on these smooth runs

SLIDER = f"""<robot name="slider">
  <link name="base"/>
  <link name="block">
    <inertial><mass value="{MASS}"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="drop" type="prismatic">
    <parent link="base"/><child link="block"/><axis xyz="0 0 1"/>
    <limit lower="{-DROP}" upper="1.0" effort="{EFFORT}" velocity="100"/>
  </joint>
</robot>
"""

LINKAGE_JSON = {
    "loops": [{"frame_a": "bc_tip", "frame_b": "collar", "kind": "point"}],
    "springs": {"joint_a": {"stiffness": 20.0, "rest": 0.0}},
}
LINKAGE_Q0 = "1.1760798934094898,0.2,-0.4"  # guide, joint_a, joint_b: on the loop at theta0 = 0.2


@pytest.fixture
def slider(tmp_path: Path) -> Path:
    path = tmp_path / "slider.urdf"
    path.write_text(SLIDER)
    return path


def _json_file(tmp_path: Path, data: object, name: str = "c.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return path


def _simulate(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    try:
        code = main(["simulate", *argv])
    except SystemExit as exc:  # argparse refuses a flag's value: one line, exit 2
        code = int(exc.code or 0)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _speed_at_stop() -> float:
    return math.sqrt(2 * G * DROP)


# ----------------------------------------------------------------------------- stops and restitution
def test_stops_are_enforced_by_default_and_no_limits_lets_the_slider_fall_through(
    slider: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "stop.npz"
    code, text, _ = _simulate(capsys, str(slider), "--duration", "0.3", "--out", str(out))
    traj = robodyn.Trajectory.load(out)
    assert code == 0 and traj.q[:, 0].min() >= -DROP - 1e-12 and traj.meta["impacts"] == 1
    # Inelastic (e = 0): the stop takes all the kinetic energy at the impact, m g h.
    assert traj.work_limits[-1] == pytest.approx(-MASS * G * DROP, rel=IMPACT_RTOL)
    assert "stops: 1 impact (restitution 0)" in text and "W_limits = -1.962 J" in text
    assert traj.max_ledger_residual < LEDGER

    out = tmp_path / "free.npz"
    code, text, _ = _simulate(capsys, str(slider), "--duration", "0.3", "--no-limits", "--out", str(out))
    traj = robodyn.Trajectory.load(out)
    assert code == 0 and traj.meta["impacts"] == 0 and np.all(traj.work_limits == 0)
    assert traj.q[-1, 0] == pytest.approx(-0.5 * G * 0.3**2, rel=NO_STOP_RTOL)  # straight through the stop
    assert "stops: off (--no-limits)" in text


@pytest.mark.parametrize("e", [0.5, 1.0])
def test_restitution_takes_half_m_v2_times_one_minus_e2(
    e: float, slider: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # One impact only: after it the slider rises at e v and is back at the stop 2 e v / g later (> 0.2 s).
    out = tmp_path / "bounce.npz"
    code, text, _ = _simulate(capsys, str(slider), "--duration", "0.2", "--restitution", str(e), "--out", str(out))
    traj = robodyn.Trajectory.load(out)
    v = _speed_at_stop()
    assert code == 0 and traj.meta["impacts"] == 1 and traj.meta["constraints"]["restitution"] == e
    assert traj.work_limits[-1] == pytest.approx(-0.5 * MASS * v**2 * (1 - e**2), rel=IMPACT_RTOL, abs=1e-12)
    t_hit = math.sqrt(2 * DROP / G)
    assert traj.v[-1, 0] == pytest.approx(e * v - G * (0.2 - t_hit), rel=IMPACT_RTOL)
    assert f"(restitution {e:g})" in text and traj.max_ledger_residual < LEDGER


def test_restitution_flag_overrides_the_file(slider: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _json_file(tmp_path, {"restitution": 0.0, "limits": True})
    out = tmp_path / "x.npz"
    argv = [str(slider), "--duration", "0.2", "--constraints", str(spec), "--restitution", "1", "--out", str(out)]
    assert _simulate(capsys, *argv)[0] == 0
    traj = robodyn.Trajectory.load(out)
    assert traj.meta["constraints"]["restitution"] == 1.0 and traj.work_limits[-1] == pytest.approx(0, abs=1e-12)


# ----------------------------------------------------------------------------- effort limits and power
def test_effort_limits_clamp_the_torque_and_the_summary_counts_it(
    slider: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [str(slider), "--duration", "0.2", "--torque", "30", "--no-limits"]
    code, text, _ = _simulate(capsys, *argv, "--out", str(tmp_path / "a.npz"))
    clamped = robodyn.Trajectory.load(tmp_path / "a.npz")
    assert code == 0 and np.all(clamped.tau == EFFORT)
    assert "tau clamped at the effort limit in 201 of 201 samples" in text
    assert clamped.meta["effort_clamped_samples"] == 201
    # The average power is W_input / T, and W_input the integral of tau v: F x(T) / T for a constant force.
    x_final = clamped.q[-1, 0]
    assert clamped.average_power == pytest.approx(EFFORT * x_final / 0.2, rel=1e-9)
    assert re.search(r"power: average (\S+) W", text).group(1) == f"{clamped.average_power:.6g}"

    code, text, _ = _simulate(capsys, *argv, "--no-effort-limits", "--out", str(tmp_path / "b.npz"))
    free = robodyn.Trajectory.load(tmp_path / "b.npz")
    assert code == 0 and np.all(free.tau == 30.0) and free.meta["effort_clamped_samples"] == 0
    assert free.q[-1, 0] == pytest.approx(0.5 * (30.0 / MASS - G) * 0.2**2, rel=NO_STOP_RTOL)
    assert "robodyn never clamped tau (effort limits off" in text


def test_json_summary_carries_the_constraint_figures(slider: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, text, _ = _simulate(capsys, str(slider), "--duration", "0.3", "--json")
    s = json.loads(text)
    assert code == 0 and s["impacts"] == 1 and s["work_limits"] == pytest.approx(-MASS * G * DROP, rel=IMPACT_RTOL)
    assert s["effort_clamped_samples"] == 0 and s["loop_drift"] is None and s["limit_violation"] >= 0


# ----------------------------------------------------------------------------- loops and springs from a file
@pytest.mark.parametrize("shape", ["flat", "tables"])
def test_constraints_file_closes_the_loop_and_books_the_spring(
    shape: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tables = {"constraints": {"loops": LINKAGE_JSON["loops"]}, "springs": LINKAGE_JSON["springs"]}
    data = LINKAGE_JSON if shape == "flat" else tables
    spec = _json_file(tmp_path, data)
    out = tmp_path / "linkage.npz"
    argv = [str(LINKAGE / "linkage.urdf"), "--constraints", str(spec), "--q0", LINKAGE_Q0, "--duration", "1"]
    code, text, _ = _simulate(capsys, *argv, "--out", str(out))
    traj = robodyn.Trajectory.load(out)
    assert code == 0 and traj.meta["loop_drift"] < LOOP_DRIFT
    assert f"loops: worst drift max|residual| = {traj.meta['loop_drift']:.3e} m" in text
    assert traj.meta["springs"] and traj.max_ledger_residual < LEDGER
    # The spring's energy is in V: released at theta0 = 0.2 rad, V(0) holds k theta0^2 / 2 = 0.4 J.
    robot = robodyn.load(LINKAGE / "linkage.urdf")
    no_spring = robodyn.simulate(robot, traj.q[0], traj.v[0], duration=1e-3, dt=1e-3, loops=LINKAGE_JSON["loops"])
    assert traj.potential[0] - no_spring.potential[0] == pytest.approx(0.5 * 20.0 * 0.2**2, rel=1e-12)


# ----------------------------------------------------------------------------- bad input: one line, exit 2
FAR_GUIDE = (
    (LINKAGE / "linkage.urdf")
    .read_text()
    .replace(
        '<child link="collar"/>\n    <origin xyz="0 0 0" rpy="0 0 0"/>',
        '<child link="collar"/>\n    <origin xyz="2 0 0" rpy="0 0 0"/>',
    )
)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (
            {"loops": [{"frame_a": "bc_tipp", "frame_b": "collar"}]},
            r"unknown frame \(loops\[0\]\.frame_a\) 'bc_tipp'; "
            r"did you mean 'bc_tip'",
        ),
        ({"springs": {"joint_c": {"stiffness": 1.0}}}, r"unknown joint \(springs\) 'joint_c'; did you mean"),
        (
            {"couplings": [{"joint": "joint_x", "leader": "joint_a", "ratio": 1.0}]},
            r"unknown joint \(couplings\[0\]\.joint\) 'joint_x'",
        ),
        (
            {
                "couplings": [
                    {"joint": "joint_a", "leader": "joint_b", "ratio": 1.0},
                    {"joint": "joint_b", "leader": "joint_a", "ratio": 2.0},
                ]
            },
            r"coupling cycle: joint_a -> joint_b -> joint_a",
        ),
        ({"springs": {"joint_a": {"stiffness": -1.0}}}, r"springs\.joint_a: spring stiffness must be >= 0"),
        ({"restitution": 1.5}, r"restitution must lie in \[0, 1\]"),
        ({"restitution": -0.1}, r"restitution must lie in \[0, 1\]"),
        ({"limit": True}, r"unknown key 'limit'; expected limits"),
        ([1, 2], r"expected a JSON object"),
    ],
)
def test_bad_constraints_file_is_one_line_exit_2(
    data: object, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = _json_file(tmp_path, data)
    out = tmp_path / "never.npz"
    argv = [str(LINKAGE / "linkage.urdf"), "--constraints", str(spec), "--q0", LINKAGE_Q0, "--out", str(out)]
    code, _, err = _simulate(capsys, *argv)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert err.startswith(f"robodyn simulate: error: --constraints {spec}: ")
    assert re.search(message, err), err
    assert not out.exists()


def test_a_loop_whose_frames_cannot_meet_is_one_line_with_metres(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    urdf = tmp_path / "far.urdf"
    urdf.write_text(FAR_GUIDE)  # the guide 2 m from A: the bars reach 1.2 m
    spec = _json_file(tmp_path, LINKAGE_JSON)
    code, _, err = _simulate(capsys, str(urdf), "--constraints", str(spec), "--q0", LINKAGE_Q0)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert re.search(r"loops\[0\] \(bc_tip ~ collar \(point\)\): the frames cannot meet: .* residual is \S+ m", err)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--restitution", "1.5"], r"argument --restitution: expected a restitution from 0 to 1, got '1.5'"),
        (["--restitution", "-0.5"], r"argument --restitution: expected a restitution from 0 to 1"),
        (["--constraints", "/nonexistent/c.json"], r"--constraints /nonexistent/c.json: cannot read it"),
    ],
)
def test_bad_flags_are_one_line_exit_2(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _simulate(capsys, "pendubot", *argv)
    assert code == 2 and len(err.strip().splitlines()) == 1 and re.search(message, err), err


def test_not_json_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "c.json"
    spec.write_text("{loops: }")
    code, _, err = _simulate(capsys, "pendubot", "--constraints", str(spec))
    assert code == 2 and "not valid JSON" in err and len(err.strip().splitlines()) == 1


# ----------------------------------------------------------------------------- a solver that fails: exit 3
def _fail_after(monkeypatch: pytest.MonkeyPatch, calls: int) -> None:
    """Make the loop constraint solver report no convergence after ``calls`` solves."""
    from robodyn import constrained

    original = constrained.ConstraintSolver.acceleration
    count = {"n": 0}

    def acceleration(self, q, v, tau):  # type: ignore[no-untyped-def]
        a, converged, residual = original(self, q, v, tau)
        count["n"] += 1
        return (a, False, 0.25) if count["n"] > calls else (a, converged, residual)

    monkeypatch.setattr(constrained.ConstraintSolver, "acceleration", acceleration)


def test_solver_that_fails_to_converge_exits_3_and_keeps_the_partial_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = _json_file(tmp_path, LINKAGE_JSON)
    out = tmp_path / "x.npz"
    _fail_after(monkeypatch, 400)
    argv = [str(LINKAGE / "linkage.urdf"), "--constraints", str(spec), "--q0", LINKAGE_Q0, "--out", str(out)]
    code, _, err = _simulate(capsys, *argv)
    assert code == 3 and not out.exists()
    assert "did not converge" in err and "residual 0.25" in err and "x.partial.npz" in err
    partial = robodyn.Trajectory.load(tmp_path / "x.partial.npz")
    assert partial.diverged and 0 < partial.n_steps < 2000


def test_run_scene_whose_solver_fails_exits_3_with_the_partial_trajectory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _fail_after(monkeypatch, 400)
    code = main(["run", str(LINKAGE / "linkage.toml"), "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 3 and "did not converge" in err and len(err.strip().splitlines()) == 1
    assert (tmp_path / "linkage.partial.npz").exists() and not (tmp_path / "linkage.npz").exists()
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["simulate"]["diverged"] and "closed_form" not in summary


# ----------------------------------------------------------------------------- scene tables through robodyn run
def _scene(tmp_path: Path, slider: Path, extra: str, name: str = "drop") -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(
        f'[model]\nurdf = "{slider.as_posix()}"\n\n[simulate]\nduration = 0.2\ndt = 1e-3\n\n{extra}\n', encoding="utf-8"
    )
    return path


def _run(scene: Path, out: Path) -> robodyn.Trajectory:
    assert main(["run", str(scene), "--out", str(out)]) == 0
    return robodyn.Trajectory.load(out / f"{scene.stem}.npz")


def test_scene_constraints_table_reaches_the_engine(slider: Path, tmp_path: Path) -> None:
    default = _run(_scene(tmp_path, slider, "", "default"), tmp_path / "a")
    assert default.meta["impacts"] == 1 and default.meta["joint_names"] == ["drop"]
    free = _run(_scene(tmp_path, slider, "[constraints]\nlimits = false\n", "free"), tmp_path / "b")
    assert free.meta["impacts"] == 0 and free.q[-1, 0] == pytest.approx(-0.5 * G * 0.2**2, rel=NO_STOP_RTOL)
    bounce = _run(_scene(tmp_path, slider, "[constraints]\nrestitution = 0.5\n", "bounce"), tmp_path / "c")
    v = _speed_at_stop()
    assert bounce.work_limits[-1] == pytest.approx(-0.5 * MASS * v**2 * 0.75, rel=IMPACT_RTOL)
    push = "[control]\ntorque = { drop = 30.0 }\n"
    clamped = _run(_scene(tmp_path, slider, push, "clamped"), tmp_path / "d")
    assert np.all(clamped.tau == EFFORT) and clamped.meta["effort_clamped_samples"] == 201
    unclamped = _run(_scene(tmp_path, slider, push + "[constraints]\neffort_limits = false\n", "raw"), tmp_path / "e")
    assert np.all(unclamped.tau == 30.0) and unclamped.meta["effort_clamped_samples"] == 0
    summary = json.loads((tmp_path / "d" / "summary.json").read_text())
    assert summary["simulate"]["effort_clamped_samples"] == 201


def test_scene_springs_table_reaches_the_engine(slider: Path, tmp_path: Path) -> None:
    # A spring k = 400 N/m holding the block up: the rest at 0.05 m keeps it off the stop (m g / k = 0.049 m).
    extra = "[springs]\ndrop = { stiffness = 400.0, rest = 0.05 }\n"
    traj = _run(_scene(tmp_path, slider, extra, "spring"), tmp_path / "s")
    assert traj.meta["springs"] and traj.meta["impacts"] == 0 and traj.q[:, 0].min() > -DROP
    assert traj.potential[0] == pytest.approx(0.5 * 400.0 * 0.05**2, rel=1e-12)  # V = m g z + k (q - rest)^2 / 2
    assert traj.max_ledger_residual < LEDGER


def test_scene_couplings_fill_the_followers_initial_state(tmp_path: Path) -> None:
    # 19.1: q0 names the slide only; the spin starts where the coupling puts it (ratio * 0.3 m).
    scene = (EXAMPLES / "textbook" / "rolling_disk" / "rolling.toml").read_text()
    scene = scene.replace(
        'urdf = "disk.urdf"', f'urdf = "{(EXAMPLES / "textbook" / "rolling_disk" / "disk.urdf").as_posix()}"'
    )
    scene = scene.replace("q = { slide = 0.0 }", "q = { slide = 0.3 }").replace("duration = 1.5", "duration = 0.1")
    scene = scene.replace('closed_form = "closed_form.py"', "").replace("closed_form_rtol = 1e-9", "")
    path = tmp_path / "rolling.toml"
    path.write_text(scene)
    traj = _run(path, tmp_path / "out")
    assert traj.q[0, 0] == 0.3 and traj.meta["state_coupled"] is True


SCENE_BAD = [
    ("[constraints]\nrestitution = 2.0\n", r"\[constraints\]: restitution must lie in \[0, 1\]"),
    ("[constraints]\nrestitution = -1.0\n", r"\[constraints\]: restitution must lie in \[0, 1\]"),
    ("[constraints]\nlimit = true\n", r"\[constraints\] limit: unknown key; expected one of: limits"),
    ("[constraints]\nlimits = 1\n", r"\[constraints\]: limits must be true or false"),
    ("[springs]\ndrop = { stiffness = -5.0 }\n", r"\[springs\]: springs\.drop: spring stiffness must be >= 0"),
    ("[springs]\ndrop = { stiffnes = 5.0 }\n", r"\[springs\]: springs\.drop: unknown key 'stiffnes'"),
    (
        "[constraints]\ncouplings = [{ joint = 'a', leader = 'b', ratio = 1.0 }, { joint = 'b', leader = 'a', ratio = 1.0 }]\n",
        r"\[constraints\]: coupling cycle: a -> b -> a",
    ),
    ("[check]\nclosed_form = 'nothere.py'\n", r"\[check\] closed_form: no such file"),
    ("[check]\nclosed_form_rtol = 1e-9\n", r"\[check\] closed_form_rtol: needs closed_form"),
]


@pytest.mark.parametrize(("extra", "message"), SCENE_BAD)
def test_bad_scene_tables_are_one_line_exit_2(
    extra: str, message: str, slider: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = _scene(tmp_path, slider, extra)
    code = main(["run", str(scene), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert f"{scene}: " in err and re.search(message, err), err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (("bc_tip", "bc_tipp"), r"\[constraints\] loops\[0\]\.frame_a: unknown frame .* did you mean 'bc_tip'"),
        (
            ("joint_a = { stiffness", "joint_q = { stiffness"),
            r"\[springs\] joint_q: unknown joint \(springs\) 'joint_q'",
        ),
    ],
)
def test_unknown_names_in_a_scene_name_the_table_and_key(
    edit: tuple[str, str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (LINKAGE / "linkage.toml").read_text().replace(*edit, 1)
    text = text.replace('urdf = "linkage.urdf"', f'urdf = "{(LINKAGE / "linkage.urdf").as_posix()}"')
    text = text.replace('closed_form = "closed_form.py"', f'closed_form = "{(LINKAGE / "closed_form.py").as_posix()}"')
    text = text.replace('formula = "reduced_formula.py"', f'formula = "{(LINKAGE / "reduced_formula.py").as_posix()}"')
    scene = tmp_path / "linkage.toml"
    scene.write_text(text)
    code = main(["run", str(scene), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and re.search(message, err), err


def test_scene_loop_that_cannot_meet_names_the_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "far.urdf").write_text(FAR_GUIDE)
    text = (LINKAGE / "linkage.toml").read_text().replace('urdf = "linkage.urdf"', 'urdf = "far.urdf"')
    text = text.replace('closed_form = "closed_form.py"', f'closed_form = "{(LINKAGE / "closed_form.py").as_posix()}"')
    text = text.replace('formula = "reduced_formula.py"', f'formula = "{(LINKAGE / "reduced_formula.py").as_posix()}"')
    scene = tmp_path / "linkage.toml"
    scene.write_text(text)
    code = main(["run", str(scene), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and re.search(r"\[constraints\] loops\[0\]: .*the frames cannot meet", err), err


# ----------------------------------------------------------------------------- [check] closed_form
def _closed_form_scene(tmp_path: Path, body: str, rtol: str = "1e-9") -> Path:
    """The sliding disk (19.1) with a closed-form file of ``body`` beside it."""
    folder = EXAMPLES / "textbook" / "rolling_disk"
    (tmp_path / "cf.py").write_text(body)
    text = (folder / "sliding.toml").read_text()
    text = text.replace('urdf = "disk.urdf"', f'urdf = "{(folder / "disk.urdf").as_posix()}"')
    text = text.replace('closed_form = "closed_form.py"', 'closed_form = "cf.py"')
    text = text.replace("closed_form_rtol = 1e-9", f"closed_form_rtol = {rtol}").replace(
        "duration = 1.5", "duration = 0.2"
    )
    path = tmp_path / "sliding.toml"
    path.write_text(text)
    return path


BOOK = (EXAMPLES / "textbook" / "rolling_disk" / "closed_form.py").read_text()


def test_closed_form_beyond_its_tolerance_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    wrong = BOOK.replace('2.0 * p["g"]', '2.02 * p["g"]')  # g off by 1 %: v(b) off by 0.5 %
    assert wrong != BOOK
    scene = _closed_form_scene(tmp_path, wrong)
    assert main(["run", str(scene), "--out", str(tmp_path / "out")]) == 1
    text = capsys.readouterr().out
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    worst = summary["closed_form"]["worst_deviation"]["speed"]
    assert "closed form: FAILED" in text and worst == pytest.approx(1 - 1 / math.sqrt(1.01), rel=1e-6)


def test_closed_form_within_its_tolerance_passes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = _closed_form_scene(tmp_path, BOOK)
    assert main(["run", str(scene), "--out", str(tmp_path / "out")]) == 0
    assert re.search(
        r"closed form: passed: worst deviation from cf.py over 0.2 s \(201 samples\): speed \S+",
        capsys.readouterr().out,
    )


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("import sys\nsys.exit(0)\n", r"cf.py: the closed-form file called sys.exit\(0\) at import \(line 2\)"),
        (
            "x = 1 / 0\n",
            r"cf.py: the closed-form file failed to import: ZeroDivisionError: division by zero \(line 1\)",
        ),
        ("def parameters(scene):\n    return {}\n", r"cf.py: defines no closed_form\(\) or simulated\(\)"),
        (
            "def parameters(scene):\n    return {}\n\ndef closed_form(t, q, v, p):\n    return q['nope']\n\n"
            "def simulated(t, q, v, p):\n    return {}\n",
            r"closed_form\(\) failed: KeyError: 'nope' \(line 5\)",
        ),
        (
            "def parameters(scene):\n    return {}\n\ndef closed_form(t, q, v, p):\n    return 0.0\n\n"
            "def simulated(t, q, v, p):\n    return {}\n",
            r"closed_form\(\) must return \{quantity: array\}, got float",
        ),
        (
            "def parameters(scene):\n    return {}\n\ndef closed_form(t, q, v, p):\n    return {'speed': t}\n\n"
            "def simulated(t, q, v, p):\n    return {'v': t}\n",
            r"closed_form\(\) and simulated\(\) do not compare: the closed form gives \['speed'\], the simulated",
        ),
    ],
)
def test_closed_form_file_that_breaks_is_one_line_exit_2(
    body: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = _closed_form_scene(tmp_path, body)
    code = main(["run", str(scene), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert f"{scene}: [check] closed_form: " in err and re.search(message, err), err


def test_run_view_of_a_coupled_scene_plays_the_coupled_robot(tmp_path: Path) -> None:
    # The trajectory holds the leaders only: the replay is built on the coupled model (followers as mimic joints).
    folder = EXAMPLES / "textbook" / "rolling_disk"
    scene = tmp_path / "rolling.toml"
    page = tmp_path / "rolling.html"
    text = (
        (folder / "rolling.toml")
        .read_text()
        .replace('urdf = "disk.urdf"', f'urdf = "{(folder / "disk.urdf").as_posix()}"')
    )
    text = text.replace('closed_form = "closed_form.py"', f'closed_form = "{(folder / "closed_form.py").as_posix()}"')
    scene.write_text(text.replace("duration = 1.5", "duration = 0.1") + f'\n[view]\nhtml = "{page.as_posix()}"\n')
    assert main(["run", str(scene), "--out", str(tmp_path / "out")]) == 0
    assert page.stat().st_size > 0 and json.loads((tmp_path / "out" / "summary.json").read_text())["view"]
