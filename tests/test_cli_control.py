"""Controllers from the command line and scene files: ``robodyn simulate --controller/--gains`` and ``[control]``.

The closed loop through the CLI must be the closed loop of :func:`robodyn.control.make` with the
same gains (identical arithmetic, so bit-equal trajectories); the cart-pole swing-up must reach
upright and stay there; every bad input is one line on stderr, exit 2, no file written.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn import control
from robodyn.cli import main
from robodyn.errors import EXIT_BAD_INPUT, EXIT_NOT_BALANCED, SceneError
from robodyn.scene import read_scene

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import bench_swing_up  # the swing-up benchmark's cart-pole template

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

# The "upright": the pole within 0.05 rad of the upward vertical over the last second.
UPRIGHT_TOL = 0.05  # [rad]
HANGING = "0,3.14159"  # cart-pole at rest, pole down (2.7e-6 rad off, so the swing-up has a side to start)
TILTED = "0,0.1"  # cart-pole 0.1 rad off upright, inside the LQR's region

# A user's controller file: a PD on the cart with gains kp, kd (defaults 1, 0); make raises on
# line 6 for kp < 0, and tau divides by zero on line 10 once t > bad_after.
USER_FILE = """import numpy as np


def make(robot, kp=1.0, kd=0.0, bad_after=None):
    if kp < 0:
        raise ValueError("kp must be >= 0")
    def tau(t, q, v):
        if bad_after is not None and t > bad_after:
            x = 0.0
            return np.array([1.0 / x])
        return np.array([-kp * q[0] - kd * v[0]])
    return tau
"""


def wrapped(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi] [rad]."""
    return np.angle(np.exp(1j * angle))


def reference(name: str, q0: list[float], duration: float, **gains: object) -> robodyn.Trajectory:
    """The same closed loop through the library: ``robodyn.simulate`` with ``control.make(name, ...)``."""
    robot = robodyn.load("cart_pole")
    controller = control.make(name, robot, **gains)
    return robodyn.simulate(robot, q0, [0.0, 0.0], duration=duration, dt=1e-3, torque=controller)


def simulate(tmp_path: Path, *args: str, out: str = "run.npz") -> tuple[int, robodyn.Trajectory | None]:
    path = tmp_path / out
    code = main(["simulate", "cart_pole", *args, "--out", str(path)])
    return code, robodyn.Trajectory.load(path) if path.exists() else None


# ------------------------------------------------------------------ robodyn simulate --controller
def test_swing_up_through_the_cli_reaches_upright_and_stays(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, traj = simulate(tmp_path, "--q0", HANGING, "--controller", "swing_up", "--duration", "8")
    text = capsys.readouterr().out
    assert code == 0 and traj is not None
    assert "controller: swing_up (default gains)" in text
    assert {k: traj.meta["controller"][k] for k in ("name", "gains")} == {"name": "swing_up", "gains": {}}
    assert traj.meta["controller"]["mode"][-1] == 1  # the LQR holds it at the end
    last_second = traj.t >= traj.t[-1] - 1.0
    assert np.max(np.abs(wrapped(traj.q[last_second, 1]))) < UPRIGHT_TOL
    assert np.max(np.abs(wrapped(traj.q[:, 1]))) > 3.0  # it started hanging: the CLI did not start it upright


def test_gains_reach_the_controller_inline_and_from_a_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gains = {"Q": [10, 10, 1, 1], "R": 0.1}
    args = ["--q0", TILTED, "--controller", "lqr", "--duration", "0.5"]
    code, inline = simulate(tmp_path, *args, "--gains", json.dumps(gains), out="inline.npz")
    assert code == 0 and inline is not None
    assert "controller: lqr (gains: Q=[10, 10, 1, 1], R=0.1)" in capsys.readouterr().out
    expected = reference("lqr", [0.0, 0.1], 0.5, **gains)
    np.testing.assert_array_equal(inline.q, expected.q)  # the same arithmetic: bit-equal
    default = reference("lqr", [0.0, 0.1], 0.5)
    assert np.max(np.abs(inline.q - default.q)) > 1e-3  # and R = 0.1 is not the default R = 1
    file = tmp_path / "gains.json"
    file.write_text(json.dumps(gains), encoding="utf-8")
    code, from_file = simulate(tmp_path, *args, "--gains", str(file), out="file.npz")
    assert code == 0 and from_file is not None
    np.testing.assert_array_equal(from_file.q, expected.q)
    assert from_file.meta["controller"]["gains"] == gains


def test_a_users_controller_file_with_its_gains(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    file = tmp_path / "pd.py"
    file.write_text(USER_FILE, encoding="utf-8")
    robot = robodyn.load("cart_pole")
    kp, kd = 5.0, 2.0
    code, traj = simulate(
        tmp_path,
        "--q0",
        "0.5,0",
        "--controller",
        str(file),
        "--gains",
        f'{{"kp": {kp}, "kd": {kd}}}',
        "--duration",
        "1",
    )
    assert code == 0 and traj is not None
    assert f"controller: {file}" in capsys.readouterr().out
    expected = robodyn.simulate(
        robot, [0.5, 0.0], [0.0, 0.0], duration=1.0, dt=1e-3, torque=lambda t, q, v: np.array([-kp * q[0] - kd * v[0]])
    )
    np.testing.assert_array_equal(traj.q, expected.q)


def test_json_summary_names_the_controller(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["simulate", "cart_pole", "--q0", TILTED, "--controller", "lqr", "--gains", '{"R": 2}', "--duration", "0.1"]
    assert main([*args, "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["controller"] == {"name": "lqr", "gains": {"R": 2}}


def test_controller_list(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "--controller", "list"]) == 0
    text = capsys.readouterr().out
    assert all(name in text for name in control.names())
    assert main(["simulate", "--controller", "list", "--json"]) == 0
    assert {row["name"] for row in json.loads(capsys.readouterr().out)} == set(control.names())


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--controller", "swing_ip"], "--controller: unknown controller 'swing_ip'; did you mean 'swing_up'?"),
        (
            ["--controller", "lqr", "--gains", '{"Qq": 1}'],
            "--gains: unknown gain of controller 'lqr' 'Qq'; did you mean 'Q'?",
        ),
        (["--controller", "lqr", "--gains", '{"Q": [1, 2, 3]}'], "or a (4, 4) matrix, got shape (3,)"),
        (["--controller", "lqr", "--gains", '{"K": [1, 2, 3]}'], "K must have shape (1, 4)"),
        (["--controller", "lqr", "--gains", '{"q_eq": [0, 0.5]}'], "is not an equilibrium: residual nle(q) - B u"),
        (
            ["--controller", "swing_up", "--gains", '{"k_d": 1}'],
            "unknown gain of controller 'swing_up (cart_pole)' 'k_d'",
        ),
        (["--controller", "lqr", "--torque", "1"], "--controller and --torque both give the input"),
        (["--gains", '{"R": 1}'], "--gains needs --controller"),
        (["--controller", "lqr", "--gains", "[1, 2]"], "--gains: expected a JSON object of gains"),
        (["--controller", "lqr", "--gains", '{"R": 1'], "--gains: not valid JSON"),
        (["--controller", "lqr", "--gains", "nothere.json"], "neither a JSON object"),
        (["--controller", "nothere.py"], "nothere.py: no such controller file"),
    ],
)
def test_bad_controller_input_is_one_line_and_exit_2(
    tmp_path: Path, args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, traj = simulate(tmp_path, "--duration", "0.1", *args)
    err = capsys.readouterr().err
    assert code == EXIT_BAD_INPUT and traj is None
    assert message in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_a_controller_file_that_raises_names_its_file_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    file = tmp_path / "pd.py"
    file.write_text(USER_FILE, encoding="utf-8")
    code, traj = simulate(tmp_path, "--controller", str(file), "--gains", '{"bad_after": 0.05}', "--duration", "0.1")
    err = capsys.readouterr().err
    assert code == EXIT_BAD_INPUT and traj is None and not list(tmp_path.glob("run*"))
    assert f"{file}:10: the controller raised ZeroDivisionError" in err
    assert err.count("\n") == 1


# ------------------------------------------------------------------ scene [control]
SCENE = """
[model]
name = "cart_pole"

[initial]
q = {{ slider = 0.0, hinge = 0.1 }}

[control]
{control}

[simulate]
duration = 0.5
dt = 1e-3
"""


def scene_file(tmp_path: Path, control_table: str) -> Path:
    path = tmp_path / "scene.toml"
    path.write_text(SCENE.format(control=control_table), encoding="utf-8")
    return path


def test_scene_lqr_takes_its_gains(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = scene_file(tmp_path, 'kind = "lqr"\nQ = [10.0, 10.0, 1.0, 1.0]\nR = 0.1')
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 0
    assert "control: lqr (gains: Q=[10.0, 10.0, 1.0, 1.0], R=0.1)" in capsys.readouterr().out
    traj = robodyn.Trajectory.load(tmp_path / "out" / "scene.npz")
    np.testing.assert_array_equal(traj.q, reference("lqr", [0.0, 0.1], 0.5, Q=[10, 10, 1, 1], R=0.1).q)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["control"] == {"kind": "lqr", "gains": {"Q": [10.0, 10.0, 1.0, 1.0], "R": 0.1}}


def test_scene_file_controller_is_read_beside_the_scene(tmp_path: Path) -> None:
    (tmp_path / "pd.py").write_text(USER_FILE, encoding="utf-8")
    path = scene_file(tmp_path, 'kind = "file"\npath = "pd.py"\ngains = { kp = 5.0, kd = 2.0 }')
    scene = read_scene(path)
    robot, reduction = scene.build()
    tau = scene.torque(robot, reduction)
    assert callable(tau)
    np.testing.assert_array_equal(tau(0.0, np.array([0.5, 0.0]), np.array([0.1, 0.0])), [-5.0 * 0.5 - 2.0 * 0.1])


def test_the_swing_up_example_scene_balances(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(EXAMPLES / "cart_pole_swing_up.toml"), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "control: swing_up" in out
    assert "  outcome: balanced from t = " in out  # the one decision, as simulate prints it
    assert " N of " in out.split("outcome: balanced", 1)[1].splitlines()[0]  # the cart's force is in newtons
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["simulate"]["outcome"]["balanced"] is True
    traj = robodyn.Trajectory.load(tmp_path / "cart_pole_swing_up.npz")
    assert np.max(np.abs(wrapped(traj.q[:, 1]))) > 3.0  # from hanging
    assert np.max(np.abs(wrapped(traj.q[traj.t >= traj.t[-1] - 1.0, 1]))) < UPRIGHT_TOL


def test_a_swing_up_scene_that_does_not_balance_exits_6(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """As simulate: the outcome line, the reason on one stderr line, the verdict in summary.json, exit 6."""
    weak = Path(__file__).parent / "fixtures" / "spong_pendubot_weak.urdf"
    scene = tmp_path / "weak.toml"
    scene.write_text(
        f'[model]\nurdf = "{weak.as_posix()}"\npassive = ["joint2"]\n\n'
        "[initial]\nq = { joint1 = -1.5707963268, joint2 = 0.0 }\n\n"
        '[control]\nkind = "swing_up"\n\n[simulate]\nduration = 1.5\ndt = 1e-3\nintegrator = "rk4"\n',
        encoding="utf-8",
    )
    assert main(["run", str(scene), "--out", str(tmp_path / "out")]) == EXIT_NOT_BALANCED
    captured = capsys.readouterr()
    assert "  outcome: did not balance" in captured.out
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("robodyn run: the controller did not reach its goal: the effort limit")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["simulate"]["outcome"]["balanced"] is False


CLOSES_STDOUT = (
    "import sys\nimport numpy as np\nsys.stdout.close()\n\n\ndef make(robot):\n    return lambda t, q, v: np.zeros(1)\n"
)


def test_a_scene_controller_that_closes_stdout_at_import_leaves_robodyn_its_report(tmp_path: Path) -> None:
    """issue 39 item 11: robodyn's report, printed in the watched child, hit 'I/O operation on closed file'."""
    (tmp_path / "closer.py").write_text(CLOSES_STDOUT, encoding="utf-8")
    path = scene_file(tmp_path, 'kind = "file"\npath = "closer.py"')
    done = subprocess.run(
        [sys.executable, "-m", "robodyn", "run", str(path), "--out", str(tmp_path / "out")],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stderr == "" and "summary:" in done.stdout, done.stdout + done.stderr


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ('kind = "lqr"\nk_energy = 1.0', r'\[control\] k_energy: only kind = "swing_up" takes k_energy'),
        ('kind = "lqr"\nQ = ["a"]', r"\[control\] Q: expected a number, got 'a'"),
        ('kind = "lqr"\nQ = [1.0, 2.0]', r"\[control\] Q: lqr weight Q must be .* got shape \(2,\)"),
        ('kind = "lqr"\nK = [[1.0, 2.0]]', r"\[control\] K: lqr gain K must have shape \(1, 4\)"),
        ('kind = "lqr"\nq_eq = [0.0, 0.5]', r"\[control\] q_eq: .*not an equilibrium: residual"),
        ('kind = "swing_up"\nk_d = 1.0', r"\[control\] k_d: unknown gain of controller 'swing_up \(cart_pole\)'"),
        ('kind = "swing_up"\nsamples = 0', r"\[control\] samples: swing_up gain samples must be a whole number"),
        ('kind = "file"', r'\[control\] path: missing: kind = "file" needs path'),
        ('kind = "file"\npath = "nothere.py"', r"\[control\] path: no such file"),
        ('kind = "file"\npath = "pd.txt"', r"\[control\] path: expected a Python file"),
        (
            'kind = "file"\npath = "pd.py"\ngains = { kp = -1.0 }',
            r"\[control\] path: .*pd.py:6: make\(robot, \*\*gains\) raised",
        ),
        ('kind = "pd"\nR = 1.0', r'\[control\] R: only kind = "lqr" or kind = "swing_up" takes R'),
    ],
)
def test_bad_scene_control_names_file_table_and_key(tmp_path: Path, table: str, message: str) -> None:
    (tmp_path / "pd.py").write_text(USER_FILE, encoding="utf-8")
    path = scene_file(tmp_path, table)
    with pytest.raises(SceneError, match=message) as info:
        scene = read_scene(path)
        robot, reduction = scene.build()
        scene.torque(robot, reduction)
    assert str(info.value).startswith(f"{path}: [control]") and "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ('kind = "lqr"\nR = [1.0, 2.0]', "[control] R: lqr weight R must be"),
        (
            'kind = "file"\npath = "pd.py"\ngains = { bad_after = 0.05 }',
            "pd.py:10: the controller raised ZeroDivisionError",
        ),
    ],
)
def test_bad_scene_control_exits_2_through_run(
    tmp_path: Path, table: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "pd.py").write_text(USER_FILE, encoding="utf-8")
    path = scene_file(tmp_path, table)
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "out" / "scene.npz").exists()


# The swing-up benchmark's cart-pole (revolute hinge) and the same with the hinge continuous, as
# pybullet_data's cartpole.urdf writes it: its configuration is (y, cos theta, sin theta), nq = 3 against nv = 2.
REVOLUTE_CART_POLE = bench_swing_up.CART_POLE.format(m_cart=1.0, m=0.1, l=0.5, I=8.3e-3, effort=10)
REVOLUTE_HINGE = 'type="revolute"><parent link="cart"/><child link="pole"/><axis xyz="0 1 0"/>\n<limit lower="-1000" upper="1000" effort="0" velocity="100"/>'
CONTINUOUS_CART_POLE = REVOLUTE_CART_POLE.replace(
    REVOLUTE_HINGE, 'type="continuous"><parent link="cart"/><child link="pole"/><axis xyz="0 1 0"/>'
)


def test_a_continuous_pole_is_named_with_the_change_that_lets_a_controller_drive_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "continuous_cart_pole.urdf"
    path.write_text(CONTINUOUS_CART_POLE, encoding="utf-8")
    argv = ["simulate", str(path), "--passive", "hinge", "--controller", "lqr", "--q0=0,0.1", "--duration", "0.5"]
    assert main(argv) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "hinge is continuous (cos, sin)" in err and 'type="revolute"' in err
    # the change it names works: the same file with the hinge revolute balances under the LQR
    path.write_text(REVOLUTE_CART_POLE, encoding="utf-8")
    assert main([*argv, "--out", str(tmp_path / "run.npz")]) == 0
    q = np.load(tmp_path / "run.npz")["q"]
    assert abs(q[-1, 1]) < UPRIGHT_TOL


def test_every_joint_passive_names_them_and_where_they_were_declared(capsys: pytest.CaptureFixture[str]) -> None:
    # the built-in Pendubot's SRDF declares joint2 passive; --passive joint1 leaves nothing actuated
    argv = ["simulate", "pendubot", "--passive", "joint1", "--controller", "swing_up", "--duration", "0.1"]
    assert main(argv) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "(joint1, joint2 declared passive by its SRDF pendubot.srdf or --passive)" in err
