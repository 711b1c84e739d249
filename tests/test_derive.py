"""robodyn derive: the symbolic Lagrangian against Pinocchio, in textbook form, in the user's coordinates.

The oracle is Pinocchio (CRBA, the Coriolis matrix, RNEA gravity) at seeded random states,
through :func:`robodyn.lagrange.selfcheck.self_check`, which evaluates the printed expressions;
the hanging double pendulum is also compared with the textbook's expressions written out here.
Planted bugs (a Christoffel sign, a dropped inertia term) must fail that check.
"""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robodyn.cli import main
from robodyn.errors import InputError
from robodyn.lagrange.coordinates import read_coordinates
from robodyn.lagrange.derivation import Coordinate, derive
from robodyn.lagrange.selfcheck import RTOL, self_check
from robodyn.lagrange.symbolic import symbolic
from robodyn.lagrange.trig import Trig
from robodyn.model.links import link_table
from robodyn.model.load import load
from tests._chains import SYSTEMS

sp = pytest.importorskip("sympy")

ROOT = Path(__file__).resolve().parents[1]

# robodyn's kinds and example-robot-data robots of up to 6 joints (ur5 has 6).
MODELS = ["pendubot", "cart_pole", "geared_arm", "double_pendulum", "double_pendulum_continuous", "finger_edu", "ur5"]


def _derived(robot, coordinates=None):
    table = link_table(robot)
    return symbolic(derive(table, coordinates))


@pytest.mark.parametrize("name", MODELS)
def test_agrees_with_pinocchio(name):
    robot = load(name)
    check = self_check(_derived(robot), robot, samples=10, seed=3)
    assert check.passed, check.failures()
    assert check.max_relative <= RTOL


@pytest.mark.parametrize("system", sorted(SYSTEMS))
def test_agrees_with_pinocchio_on_systems_that_are_not_kinds(system, tmp_path):
    robot = load(str(SYSTEMS[system](tmp_path / f"{system}.urdf")))
    check = self_check(_derived(robot), robot, samples=10, seed=1)
    assert check.passed, check.failures()


def test_pendubot_in_textbook_form():
    s = _derived(load("pendubot"))
    assert [p.name for p in s.derivation.params] == ["m1", "lc1", "l1", "I1", "m2", "lc2", "I2", "g"]
    assert sp.sstr(s.M[0, 1]) == "I2 + m2*(l1*lc2*cos(q2) + lc2**2)"
    assert sp.sstr(s.M[0, 0]) == "I1 + I2 + lc1**2*m1 + m2*(l1**2 + 2*l1*lc2*cos(q2) + lc2**2)"
    assert sp.sstr(s.C[1, 0]) == "l1*lc2*m2*v1*sin(q2)"
    assert sp.sstr(s.G[1, 0]) == "g*lc2*m2*cos(q1 + q2)"


def _textbook_double_pendulum():
    """Angles from the downward vertical, counter-clockwise: the textbook's M, G and V."""
    q1, q2, m1, m2, l1, lc1, lc2, I1, I2, g = sp.symbols("q1 q2 m1 m2 l1 lc1 lc2 I1 I2 g", real=True)
    M = sp.Matrix(
        [
            [
                I1 + I2 + m1 * lc1**2 + m2 * (l1**2 + lc2**2 + 2 * l1 * lc2 * sp.cos(q2)),
                I2 + m2 * (lc2**2 + l1 * lc2 * sp.cos(q2)),
            ],
            [I2 + m2 * (lc2**2 + l1 * lc2 * sp.cos(q2)), I2 + m2 * lc2**2],
        ]
    )
    V = -g * (m1 * lc1 + m2 * l1) * sp.cos(q1) - g * m2 * lc2 * sp.cos(q1 + q2)
    return M, V


def _same(a, b):
    return sp.simplify(sp.expand(a - b)) == 0


def test_hanging_double_pendulum_in_its_own_coordinates(tmp_path):
    """Rods along -z turning about +y: the textbook's counter-clockwise angle is -q_urdf (sign -1)."""
    robot = load(str(SYSTEMS["hanging_double_pendulum"](tmp_path / "hdp.urdf")))
    coords = [Coordinate("j1", "revolute", -1.0, 0.0), Coordinate("j2", "revolute", -1.0, 0.0)]
    s = _derived(robot, coords)
    assert self_check(s, robot, samples=10).passed
    M, V = _textbook_double_pendulum()
    names = {str(x): x for x in (*s.q, *s.params)}
    rename = {sym: names[str(sym)] for sym in M.free_symbols | V.free_symbols}
    assert all(_same(s.M[i, j], M[i, j].xreplace(rename)) for i in range(2) for j in range(2))
    assert _same(s.V, V.xreplace(rename))


def test_offsets_turn_the_pendubot_into_a_hanging_double_pendulum():
    """The Pendubot measured from the downward vertical: q1 = q_urdf1 + pi/2 (sign +1, offset pi/2)."""
    robot = load("pendubot")
    coords = [Coordinate("joint1", "revolute", 1.0, math.pi / 2), Coordinate("joint2", "revolute", 1.0, 0.0)]
    s = _derived(robot, coords)
    assert self_check(s, robot, samples=10).passed
    M, V = _textbook_double_pendulum()
    names = {str(x): x for x in (*s.q, *s.params)}
    rename = {sym: names[str(sym)] for sym in M.free_symbols | V.free_symbols}
    assert _same(s.M[0, 0], M[0, 0].xreplace(rename))
    assert _same(s.V, V.xreplace(rename))
    assert sp.sstr(s.G[1, 0]) == "g*lc2*m2*sin(q1 + q2)"


def test_coordinates_in_another_order_and_sign(tmp_path):
    robot = load(str(SYSTEMS["cart_double_pendulum"](tmp_path / "cdp.urdf")))
    coords = [
        Coordinate("hinge2", "continuous", -1.0, 0.3),
        Coordinate("rail", "prismatic", -1.0, 0.1),
        Coordinate("hinge1", "revolute", 1.0, -1.0),
    ]
    assert self_check(_derived(robot, coords), robot, samples=10, seed=2).passed


def _planted(s, *, christoffel=None, M=None):
    d = s.derivation
    return symbolic(dataclasses.replace(d, christoffel=christoffel or d.christoffel, M=M or d.M))


def test_a_sign_in_the_christoffel_symbols_fails_the_self_check():
    robot = load("pendubot")
    s = _derived(robot)
    gamma = [[list(row) for row in plane] for plane in s.derivation.christoffel]
    gamma[1][0][0] = -gamma[1][0][0]  # Gamma_211 = +h sin q2 written as -h sin q2
    bad = _planted(s, christoffel=tuple(tuple(tuple(row) for row in plane) for plane in gamma))
    check = self_check(bad, robot, samples=10)
    assert not check.passed
    assert {d.quantity for d in check.failures()} == {"C", "C v"}


def test_a_dropped_inertia_term_fails_the_self_check():
    robot = load("pendubot")
    s = _derived(robot)
    d = s.derivation
    first = sum(1 for x in d.variable_of if x is not None)
    i2 = first + [p.name for p in d.params].index("I2")
    M = [list(row) for row in d.M]
    kept = {key: c for key, c in M[0][0].terms.items() if not (key[2] >> (8 * i2)) & 0xFF}
    assert len(kept) < len(M[0][0].terms)
    M[0][0] = Trig(d.n_angles, kept)  # I1 + m1 lc1^2 + ... without I2
    check = self_check(_planted(s, M=tuple(tuple(row) for row in M)), robot, samples=10)
    assert [f.entry for f in check.failures()] == ["M[0,0]"]


# ---------------------------------------------------------------- the algebra


def test_trig_products_are_sums_of_angles():
    c1, s1, c2, s2 = Trig.cos(2, 0), Trig.sin(2, 0), Trig.cos(2, 1), Trig.sin(2, 1)
    assert list(c1 * c2 - s1 * s2) == [(0, (1, 1), {}, 1.0)]  # cos(q1 + q2)
    assert list(c2 * c2 + s2 * s2) == [(0, (0, 0), {}, 1.0)]  # 1
    assert list(s1 * c2 - c1 * s2) == [(1, (1, -1), {}, 1.0)]  # sin(q1 - q2)
    assert list((s1 * c2 + c1 * s2).d_angle(1)) == [(0, (1, 1), {}, 1.0)]
    x = Trig.variable(2, 0)
    assert list((x * x * c1).d_variable(0)) == [(0, (1, 0), {0: 1}, 2.0)]


def test_trig_against_numbers():
    rng = np.random.default_rng(0)
    a, b = rng.uniform(-3, 3, 2)
    c1, s1, c2, s2 = Trig.cos(2, 0), Trig.sin(2, 0), Trig.cos(2, 1), Trig.sin(2, 1)
    expr = (c1 * s2 - s1 * s1 * c2) * (c2 + s1)

    def value(t):
        return sum(c * (np.sin if kind else np.cos)(f[0] * a + f[1] * b) for kind, f, _, c in t)

    direct = (np.cos(a) * np.sin(b) - np.sin(a) ** 2 * np.cos(b)) * (np.cos(b) + np.sin(a))
    assert value(expr) == pytest.approx(direct, rel=1e-14)


# ---------------------------------------------------------------- the command line


def test_cli_prints_the_textbook_form_and_the_self_check(capsys):
    assert main(["derive", "pendubot"]) == 0
    out = capsys.readouterr().out
    assert "M[0,1] = M[1,0] = I2 + m2*(l1*lc2*cos(q2) + lc2**2)" in out
    assert "lc1 = 0.1 m" in out and "g   = 9.81 m/s^2" in out
    assert "self-check: M, C, C v and G agree with Pinocchio at 20 seeded states" in out


def test_cli_steps_and_latex(capsys):
    assert main(["derive", "pendubot", "--steps"]) == 0
    out = capsys.readouterr().out
    assert "r2 = [l1*cos(q1) + lc2*cos(q1 + q2), 0, l1*sin(q1) + lc2*sin(q1 + q2)]" in out
    assert "Gamma_211 = l1*lc2*m2*sin(q2)" in out
    assert main(["derive", "cart_pole", "--format", "latex"]) == 0
    assert r"M_{12} &= lc_{2} m_{2} \cos{\left(q_{2} \right)} \\" in capsys.readouterr().out


def test_cli_coordinates_file(tmp_path, capsys):
    formula = tmp_path / "mine.py"
    formula.write_text(
        'import math\nKIND = "any"\nJOINTS = ["joint1", "joint2"]\n'
        'COORDINATES = {"joint1": (1.0, math.pi / 2), "joint2": (1, 0)}\n'
        "def mass_matrix(q, p):\n    raise SystemExit('never run')\n"
    )
    assert main(["derive", "pendubot", "--coordinates", str(formula)]) == 0
    assert "G[1] = g*lc2*m2*sin(q1 + q2)" in capsys.readouterr().out


def test_cli_locks_joints_outside_joints(tmp_path, capsys):
    formula = tmp_path / "arm.py"
    formula.write_text('JOINTS = ["panda_joint2", "panda_joint4"]\n')
    assert main(["derive", "panda", "--coordinates", str(formula), "--samples", "5"]) == 0
    out = capsys.readouterr().out
    assert "the Lagrangian of 2 joints (panda_joint2, panda_joint4)" in out


def test_cli_python_output_is_written_atomically(tmp_path, capsys):
    out = tmp_path / "pendubot_derived.py"
    assert main(["derive", "pendubot", "--format", "python", "--out", str(out)]) == 0
    text = out.read_text()
    assert 'KIND = "any"' in text and "def parameters(robot):" in text and "'lc1': robot['joint1'].com[0]" in text
    namespace: dict = {}
    exec(compile(text, str(out), "exec"), namespace)  # the file we just wrote, not a user's
    table = link_table(load("pendubot"))
    p = namespace["parameters"](table)
    robot = load("pendubot")
    q = np.array([0.3, -0.7])
    assert np.allclose(namespace["mass_matrix"](q, p), robot.M(q), rtol=1e-12, atol=0)
    assert f"wrote {out}" in capsys.readouterr().out


CHECKED = [
    ("pendubot", None),
    ("cart_pole", None),
    ("geared_arm", None),
    ("ur5", None),
    ("examples/urdf/double_pendulum.urdf", "examples/formulas/double_pendulum.py"),
    ("spatial_arm", None),
    ("cart_double_pendulum", None),
    ("panda", "locked"),
]


@pytest.mark.parametrize(("model", "coordinates"), CHECKED, ids=[m.split("/")[-1] for m, _ in CHECKED])
def test_python_output_passes_robodyn_check(model, coordinates, tmp_path, capsys):
    if model in SYSTEMS:
        model = str(SYSTEMS[model](tmp_path / f"{model}.urdf"))
    args = ["--samples", "5"]
    if coordinates == "locked":
        coordinates = tmp_path / "locked.py"
        coordinates.write_text('JOINTS = ["panda_joint4", "panda_joint2"]\nLOCKED = {"panda_joint3": 0.4}\n')
    if coordinates is not None:
        args += ["--coordinates", str(ROOT / coordinates)]
    out = tmp_path / "derived.py"
    model_arg = str(ROOT / model) if model.startswith("examples/") else model
    assert main(["derive", model_arg, "--format", "python", "--out", str(out), *args]) == 0
    capsys.readouterr()
    assert main(["check", model_arg, "--formula", str(out), "--samples", "20"]) == 0, capsys.readouterr().out
    assert "PASS: everything agrees within tolerance" in capsys.readouterr().out


def test_cli_refuses_more_than_six_joints_in_one_line(capsys):
    assert main(["derive", "talos_arm"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "takes at most 6" in err and "--coordinates" in err


def test_cli_refusals(tmp_path, capsys):
    assert main(["derive", "pendubot", "--steps", "--format", "python"]) == 2
    bad = tmp_path / "bad.py"
    bad.write_text('JOINTS = ["joint1", "nope"]\n')
    assert main(["derive", "pendubot", "--coordinates", str(bad)]) == 2
    assert "unknown joint of pendubot" in capsys.readouterr().err
    bad.write_text('JOINTS = ["joint1"]\nCOORDINATES = {"joint1": (2, 0)}\n')
    assert main(["derive", "pendubot", "--coordinates", str(bad)]) == 2
    assert "with sign +1 or -1" in capsys.readouterr().err
    bad.write_text('JOINTS = ["joint1"]\nCOORDINATES = {"joint1": (1, __import__("os").getpid())}\n')
    assert main(["derive", "pendubot", "--coordinates", str(bad)]) == 2
    assert "must be written with constants" in capsys.readouterr().err


def test_read_coordinates_takes_pi_and_arithmetic(tmp_path):
    f = tmp_path / "c.py"
    f.write_text(
        'import numpy as np\nJOINTS = ("a", "b")\nCOORDINATES = {"a": (-1, -np.pi / 2 + 0.5), "b": (1.0, 2 * pi)}\n'
    )
    joints, cmap, locked = read_coordinates(f)
    assert joints == ["a", "b"] and cmap.signs == (-1.0, 1.0)
    assert cmap.b.tolist() == [-math.pi / 2 + 0.5, 2 * math.pi]
    assert locked == {}
    f.write_text("X = 1\n")
    with pytest.raises(InputError, match="no JOINTS"):
        read_coordinates(f)


def test_cli_time_limit(capsys):
    assert main(["derive", "ur5", "--time-limit", "1e-9"]) == 2
    assert "took longer than its limit of 1e-09 s" in capsys.readouterr().err


def test_cli_without_sympy_says_which_extra(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "sympy", None)  # import sympy raises ImportError
    assert main(["derive", "pendubot"]) == 4
    assert "pip install 'robodyn[derive]'" in capsys.readouterr().err


@pytest.mark.parametrize("fmt", ["python", "text", "latex"])
def test_cli_self_check_failure_is_exit_1_naming_the_entry(fmt, monkeypatch, tmp_path, capsys):
    from robodyn.lagrange import symbolic as module

    real = module.symbolic

    def planted(derivation):
        s = real(derivation)
        return dataclasses.replace(s, G=s.G * 2)  # G off by a factor 2

    monkeypatch.setattr(module, "symbolic", planted)
    out = tmp_path / "x.py"
    assert main(["derive", "pendubot", "--format", fmt, "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "disagrees with Pinocchio: G[" in err and not out.exists()


def test_cli_ctrl_c_is_130_and_writes_nothing(monkeypatch, tmp_path, capsys):
    from robodyn.lagrange import selfcheck

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(selfcheck, "self_check", interrupted)
    out = tmp_path / "x.py"
    assert main(["derive", "pendubot", "--format", "python", "--out", str(out)]) == 130
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_real_subprocess():
    done = subprocess.run(
        [sys.executable, "-m", "robodyn", "derive", "geared_arm"], capture_output=True, text=True, cwd=ROOT, check=False
    )
    assert done.returncode == 0, done.stderr
    assert "M[0,0] = I1 + Ja1 + lc1**2*m1" in done.stdout


def test_cli_time_limit_cuts_off_the_stage_that_runs_past_it(monkeypatch, capsys):
    """A stage that would run on (sympy writing it out, here a loop of 20 s) is cut off at the limit, and named."""
    import time

    from robodyn.lagrange import symbolic as module

    finished = []

    def endless(derivation):
        until = time.monotonic() + 20.0
        while time.monotonic() < until:  # pure Python, as sympy's simplification is
            pass
        finished.append(True)

    monkeypatch.setattr(module, "symbolic", endless)
    assert main(["derive", "pendubot", "--time-limit", "3"]) == 2
    err = capsys.readouterr().err
    assert "took longer than its limit of 3 s (at writing it out with sympy: cut off after " in err
    assert finished == []  # the stage was interrupted, not waited for


def test_cli_no_physics_check_is_the_way_past_the_inertia_refusal(tmp_path, capsys):
    """The refusal's advice works: derive takes --no-physics-check, as check and simulate do."""
    urdf = tmp_path / "impossible.urdf"
    text = (ROOT / "models/pendubot.urdf").read_text()
    assert 'ixx="4.0e-4" iyy="6.19e-3" izz="6.0e-3"' in text
    urdf.write_text(text.replace('ixx="4.0e-4" iyy="6.19e-3"', 'ixx="1.0e-4" iyy="6.19e-3"'))  # 1e-4 + 6e-3 < 6.19e-3
    assert main(["derive", str(urdf)]) == 2
    err = capsys.readouterr().err
    assert "break the triangle inequality" in err and "--no-physics-check" in err
    assert main(["derive", str(urdf), "--no-physics-check"]) == 0
    captured = capsys.readouterr()
    assert "self-check: M, C, C v and G agree with Pinocchio" in captured.out
    assert captured.err.count("\n") == 1 and "warning: --no-physics-check: pendubot is loaded" in captured.err
