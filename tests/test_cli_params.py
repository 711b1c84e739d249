"""robodyn params --set / --write: every parameter of every built-in kind written, reloaded and checked."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.cli import main
from robodyn.cli.params import DECIMAL_ULPS
from robodyn.kinds.catalog import get
from robodyn.kinds.edit import SETTABLE
from robodyn.kinds.params import extract

from . import _urdf

ROOT = Path(__file__).resolve().parents[1]
# The written file gives back the requested numbers: only a few roundings of rotations apart.
ROUND_TRIP_RTOL = 1e-12
# Pinocchio's M(q) of the written model against the kind's closed form with the new parameters:
# the same numbers by two routes, a few roundings apart at O(1) magnitudes.
FORMULA_RTOL = 1e-12
SAMPLES = 5  # seeded random configurations per check


def _new_value(name: str, old: float) -> float:
    """A different, valid value for parameter ``name`` (lc1, lc2 move the COM behind the joint)."""
    if name in ("lc1", "lc2"):
        return old - 0.2
    if name == "n":
        return old * 1.5
    # Lower, not higher: the geared arm keeps J_l = I + M l^2, so M and l cannot grow much.
    return old * 0.8 + (1e-4 if old == 0 else 0.0)


def _run(argv: list[str]) -> int:
    """Exit code of ``robodyn argv``: argparse's own refusals exit 2 by SystemExit."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code or 0)


def _params_json(capsys) -> dict:
    return json.loads(capsys.readouterr().out)


def _check_mass_matrix(robot, kind: str, expected: dict[str, float]) -> None:
    formula = get(kind)
    rng = np.random.default_rng(7)
    for _ in range(SAMPLES):
        q = rng.uniform(-math.pi, math.pi, robot.nq)
        M_pin = robot.M(q)
        M_formula = formula.mass_matrix(q, expected)
        np.testing.assert_allclose(M_pin, M_formula, rtol=FORMULA_RTOL, atol=FORMULA_RTOL * np.abs(M_formula).max())


CASES = [(kind, name) for kind in ("pendubot", "cart_pole", "geared_arm") for name in SETTABLE[kind]]


@pytest.mark.parametrize(("kind", "name"), CASES)
def test_each_parameter_round_trips(tmp_path, capsys, kind, name):
    before = extract(robodyn.load(kind), kind).as_dict()
    value = _new_value(name, before[name])
    out = tmp_path / "out.urdf"
    assert main(["params", kind, "--set", f"{name}={value!r}", "--write", str(out)]) == 0
    printed = _params_json(capsys)
    assert printed["set"] == {name: value}
    assert printed["written"]["urdf"] == str(out)
    robot = robodyn.load(out)
    after = extract(robot, kind).as_dict()
    expected = dict(before, **{name: value})
    for key in before:
        assert after[key] == pytest.approx(expected[key], rel=ROUND_TRIP_RTOL, abs=0.0), key
        # Printed: the shortest decimal within DECIMAL_ULPS ulp of the value read (the file's own decimals).
        assert abs(printed["params"][key] - after[key]) <= DECIMAL_ULPS * math.ulp(after[key]), key
    _check_mass_matrix(robot, kind, expected)


def test_several_at_once_with_commas_and_repeats(tmp_path, capsys):
    out = tmp_path / "p.urdf"
    argv = ["params", "pendubot", "--set", "m1=0.3,m2=0.6", "--set", "l1=0.2", "--set", "I2=0.004", "--write", str(out)]
    assert main(argv) == 0
    after = extract(robodyn.load(out), "pendubot")
    for key, value in dict(m1=0.3, m2=0.6, l1=0.2, I2=0.004).items():
        assert after[key] == pytest.approx(value, rel=ROUND_TRIP_RTOL, abs=0.0)
    # The SRDF goes along: the elbow stays passive.
    assert robodyn.load(out).passive_joints == ("joint2",)


def test_geared_arm_rotor_and_link_together(tmp_path, capsys):
    out = tmp_path / "arm.urdf"
    assert main(["params", "geared_arm", "--set", "J_m=2e-6,n=30,m=0.3,l=0.1,J_l=0.005", "--write", str(out)]) == 0
    robot = robodyn.load(out)
    after = extract(robot, "geared_arm").as_dict()
    expected = dict(J_m=2e-6, n=30.0, m=0.3, l=0.1, J_l=0.005, g=9.81)
    for key, value in expected.items():
        assert after[key] == pytest.approx(value, rel=ROUND_TRIP_RTOL, abs=0.0), key
    assert (tmp_path / "arm.srdf").is_file()
    _check_mass_matrix(robot, "geared_arm", expected)


def test_without_write_prints_the_modified_parameters_and_writes_nothing(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["params", "cart_pole", "--set", "m=0.25"]) == 0
    printed = _params_json(capsys)
    assert printed["params"]["m"] == pytest.approx(0.25, rel=ROUND_TRIP_RTOL)
    assert printed["params"]["m_cart"] == 1.0 and "written" not in printed
    assert list(tmp_path.iterdir()) == []
    assert main(["params", "cart_pole"]) == 0
    assert _params_json(capsys)["params"]["m"] == 0.1  # the model itself is untouched


def test_body_with_massive_fixed_links_and_rotated_frames(tmp_path, capsys):
    """Link 2 carries a fixed bob and has a rotated inertial frame: the body as a whole is set."""
    src = _urdf.pendubot(tmp_path / "bob.urdf", rpy2=(0.3, 0.0, 0.2), inertia2=np.diag([2e-4, 1.5e-3, 1.6e-3]))
    bob = (
        '<link name="bob"><inertial><origin xyz="0 0.01 0" rpy="0.5 0.1 0"/><mass value="0.2"/>'
        '<inertia ixx="1e-5" iyy="2e-5" izz="3e-5" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        '<joint name="bob_joint" type="fixed"><parent link="l2"/><child link="bob"/>'
        '<origin xyz="0.25 0 0" rpy="0 0.2 0"/></joint></robot>'
    )
    src.write_text(src.read_text().replace("</robot>", bob))
    before = extract(robodyn.load(src), "pendubot").as_dict()
    out = tmp_path / "out" / "bob2.urdf"
    changes = {"m2": before["m2"] * 1.2, "lc2": before["lc2"] + 0.03, "I2": before["I2"] * 0.8, "l1": 0.23}
    sets = ",".join(f"{k}={v!r}" for k, v in changes.items())
    assert main(["params", str(src), "--set", sets, "--write", str(out)]) == 0
    robot = robodyn.load(out)
    after = extract(robot, "pendubot").as_dict()
    expected = dict(before, **changes)
    for key in before:
        assert after[key] == pytest.approx(expected[key], rel=ROUND_TRIP_RTOL, abs=0.0), key
    _check_mass_matrix(robot, "pendubot", expected)
    # The bob is still its own link with its own inertial: only link 2's <inertial> changed.
    assert 'name="bob"' in out.read_text() and 'value="0.2"' in out.read_text()


def test_a_body_cannot_weigh_less_than_its_fixed_links(tmp_path, capsys):
    src = _urdf.pendubot(tmp_path / "p.urdf")
    extra = (
        '<link name="bob"><inertial><mass value="0.5"/><inertia ixx="1e-5" iyy="1e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        '<joint name="bob_joint" type="fixed"><parent link="l2"/><child link="bob"/><origin xyz="0.2 0 0"/></joint>'
        "</robot>"
    )
    src.write_text(src.read_text().replace("</robot>", extra))
    assert main(["params", str(src), "--set", "m2=0.3", "--write", str(tmp_path / "o.urdf")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the links fixed to l2 weigh 0.5 kg" in err
    assert not (tmp_path / "o.urdf").exists()


def test_geared_arm_without_srdf_gets_one_for_its_rotor(tmp_path, capsys):
    src = _urdf.geared_arm(tmp_path / "arm.urdf")
    src.with_suffix(".srdf").unlink()  # no rotor: J_m = 0, n = 1
    out = tmp_path / "o" / "arm2.urdf"
    assert main(["params", str(src), "--set", "n=20", "--write", str(out)]) == 2
    assert "with J_m = 0 there is no rotor" in capsys.readouterr().err
    assert main(["params", str(src), "--set", "J_m=3e-6,n=20", "--write", str(out)]) == 0
    after = extract(robodyn.load(out), "geared_arm")
    assert (after["J_m"], after["n"]) == (3e-6, 20.0)
    assert out.with_suffix(".srdf").is_file()


def test_relative_mesh_paths_still_resolve(tmp_path, capfd):
    src_dir = tmp_path / "robot"
    src_dir.mkdir()
    src = _urdf.pendubot(src_dir / "p.urdf")
    mesh = '<visual><geometry><mesh filename="meshes/l1.stl" scale="1 1 1"/></geometry></visual></link>'
    src.write_text(src.read_text().replace("</link>", mesh, 1))  # into link l1
    out = tmp_path / "elsewhere" / "p2.urdf"
    assert main(["params", str(src), "--set", "m1=1.1", "--write", str(out)]) == 0
    captured = capfd.readouterr()
    assert captured.err == ""  # no print; logging (which pytest captures) is checked by the real run below
    json.loads(captured.out)
    assert 'filename="../robot/meshes/l1.stl"' in out.read_text()


def test_what_yourdfpy_does_not_write_is_kept(tmp_path, capsys):
    src = _urdf.cart_pole(tmp_path / "c.urdf")
    extra = (
        '<transmission name="t"><type>SimpleTransmission</type><joint name="slide"/></transmission>'
        '<gazebo reference="cart"><material>Gazebo/Red</material></gazebo></robot>'
    )
    text = src.read_text().replace("</robot>", extra)
    text = text.replace(
        '<dynamics damping="0.0"/></joint>', '<dynamics damping="0.0"/><calibration rising="0.1"/></joint>', 1
    )
    src.write_text(text)
    out = tmp_path / "c2.urdf"
    assert main(["params", str(src), "--set", "m_cart=2.5", "--write", str(out)]) == 0
    written = out.read_text()
    for piece in ("<transmission", "SimpleTransmission", '<gazebo reference="cart"', '<calibration rising="0.1"'):
        assert piece in written, piece


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--set", "m3=1"], "unknown pendubot parameter 'm3'; did you mean 'm2' or 'm1'?"),
        (["--set", "lc=0.1"], "did you mean 'lc2' or 'lc1'"),
        (["--set", "g=3.7"], "g is gravity (the model's gravity vector), not a URDF quantity"),
        (["--set", "m2=heavy"], "argument --set: expected NAME=NUMBER like m2=0.6"),
        (["--set", "m2"], "argument --set: expected NAME=NUMBER"),
        (["--set", "m2=nan"], "argument --set: expected NAME=NUMBER"),
        (["--set", "m1=-0.5"], "m1 is a mass and must be >= 0, got -0.5"),
        (["--set", "I2=-1e-3"], "I2 is an inertia and must be >= 0"),
        (["--set", "l1=0"], "l1 is the length of link 1"),
        (["--set", "m1=1,m1=2"], "m1 is set twice"),
        (["--set", "m2=0"], "m2 = 0 leaves its body without a centre of mass (lc2 is lost)"),
    ],
)
def test_bad_settings_are_one_line_exit_2(tmp_path, capsys, argv, message):
    assert _run(["params", "pendubot", *argv, "--write", str(tmp_path / "o.urdf")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert list(tmp_path.iterdir()) == []


def test_bad_write_targets_are_one_line_exit_2(tmp_path, capsys):
    own = _urdf.pendubot(tmp_path / "own.urdf")
    cases = [
        (own, "it is the model's own URDF"),
        (tmp_path, "it is a folder"),
        (tmp_path / "o.txt", "expected a .urdf path"),
    ]
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "o.srdf").write_text("<robot name='x'/>")
    cases.append((tmp_path / "sub" / "o.urdf", "would be read with it as its SRDF"))
    text = own.read_text()
    for target, message in cases:
        assert main(["params", str(own), "--set", "m2=0.7", "--write", str(target)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
    assert own.read_text() == text
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["o.srdf", "own.urdf", "sub"]


def test_geared_arm_j_l_below_the_point_mass_is_refused(tmp_path, capsys):
    assert main(["params", "geared_arm", "--set", "J_l=1e-3", "--write", str(tmp_path / "a.urdf")]) == 2
    assert "is less than m l^2" in capsys.readouterr().err


def test_point_bob_gets_a_ring_of_inertia(tmp_path, capsys):
    """From I = 0 (no tensor to scale), a thin ring around the pole's axis is added."""
    src = ROOT / "models" / "variants" / "cart_pole_point_bob.urdf"
    before = extract(robodyn.load(src), "cart_pole").as_dict()
    assert before["I"] == 0.0
    out = tmp_path / "bob.urdf"
    assert main(["params", str(src), "--set", "I=2e-3", "--write", str(out)]) == 0
    robot = robodyn.load(out)
    expected = dict(before, I=2e-3)
    after = extract(robot, "cart_pole").as_dict()
    for key in before:
        assert after[key] == pytest.approx(expected[key], rel=ROUND_TRIP_RTOL, abs=0.0), key
    _check_mass_matrix(robot, "cart_pole", expected)


def test_a_real_run_prints_only_the_json(tmp_path):
    """In a real process (no pytest log capture), yourdfpy must neither log nor print, even for a missing mesh."""
    src = _urdf.pendubot(tmp_path / "p.urdf")
    mesh = '<visual><geometry><mesh filename="meshes/missing.stl"/></geometry></visual></link>'
    src.write_text(src.read_text().replace("</link>", mesh, 1))
    out = tmp_path / "out" / "p2.urdf"
    argv = [sys.executable, "-m", "robodyn", "params", str(src), "--set", "m1=1.2", "--write", str(out)]
    result = subprocess.run(argv, capture_output=True, text=True, timeout=120, check=False)
    assert (result.returncode, result.stderr) == (0, "")
    assert json.loads(result.stdout)["params"]["m1"] == pytest.approx(1.2, rel=ROUND_TRIP_RTOL)
    assert 'filename="../meshes/missing.stl"' in out.read_text()


def test_params_print_the_files_decimals_not_the_round_off_of_reading_them(capsys):
    """The Pendubot's URDF says lc1 = 0.10 and lc2 = 0.126; Pinocchio's rotated placements give them 2 ulp off."""
    from robodyn.cli.params import decimal

    assert main(["params", "pendubot"]) == 0
    printed = json.loads(capsys.readouterr().out)["params"]
    assert printed["lc1"] == 0.1 and printed["lc2"] == 0.126, printed
    exact = robodyn.extract_params(robodyn.load("pendubot"), "pendubot").as_dict()  # the values are left as read
    assert exact["lc1"] != 0.1 and abs(exact["lc1"] - 0.1) <= 4 * math.ulp(0.1)
    # A value with more digits than round-off explains stays as it is; non-finite values too.
    assert decimal(1 / 3) == 1 / 3 and decimal(0.0026502) == 0.0026502 and decimal(0.0) == 0.0
    assert math.isnan(decimal(math.nan)) and decimal(-math.inf) == -math.inf


@pytest.mark.parametrize("model", ["pendubot", "cart_pole", "geared_arm"])
def test_every_printed_parameter_has_its_unit_and_no_mass_is_called_m(model, capsys):
    """One symbol, one meaning: M is only ever the mass matrix; the cart's and a link's mass have names of their own."""
    assert main(["params", model]) == 0
    printed = _params_json(capsys)
    assert "M" not in printed["params"]
    assert set(printed["units"]) == set(printed["params"])
    by_initial = {"m": "kg", "l": "m", "I": "kg m^2", "J": "kg m^2", "g": "m/s^2", "n": "1"}  # the house's names
    assert printed["units"] == {name: by_initial[name[0]] for name in printed["params"]}


def test_the_old_name_m_points_at_the_new_one(capsys):
    assert main(["params", "cart_pole", "--set", "M=2"]) == 2
    assert "did you mean 'm_cart'?" in capsys.readouterr().err
    p = robodyn.kinds.params.extract(robodyn.load("geared_arm"), "geared_arm")
    with pytest.raises(KeyError, match="parameter M is now 'm'"):
        p["M"]
