"""Outputs that look fine and are not: NaN in JSON, blank pages, weights that are not numbers, complex formulas."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import robodyn
from robodyn.cli import main
from robodyn.cli._common import strict_json
from robodyn.errors import InputError
from robodyn.sim.trajectory import Trajectory

ROOT = Path(__file__).resolve().parents[1]


def strict(text: str) -> Any:
    """``text`` parsed as strict JSON: NaN, Infinity and -Infinity are errors."""

    def refuse(name: str) -> Any:
        raise ValueError(f"{name} is not JSON")

    return json.loads(text, parse_constant=refuse)


def test_a_diverged_run_prints_strict_json_saying_which_numbers_were_not(capsys: pytest.CaptureFixture[str]) -> None:
    # v0 = 1e100 overflows the first step: the energy books are NaN
    argv = ["simulate", "pendubot", "--v0", "1e100,0", "--dt", "0.1", "--duration", "1", "--json"]
    assert main(argv) == 3
    summary = strict(capsys.readouterr().out)
    assert summary["status"] == "diverged"
    assert summary["max_ledger_residual"] is None
    assert summary["non_finite"]["max_ledger_residual"] == "nan"


def test_strict_json_names_nested_places() -> None:
    clean = strict_json({"a": [1.0, np.float64("inf")], "b": {"c": float("-inf")}, "d": np.array([np.nan])})
    assert clean == {
        "a": [1.0, None],
        "b": {"c": None},
        "d": [None],
        "non_finite": {"a[1]": "inf", "b.c": "-inf", "d[0]": "nan"},
    }


@pytest.mark.parametrize(
    ("gains", "message"),
    [
        ('{"Q": null}', "lqr gain Q holds null; expected a number"),
        ('{"Q": true}', "lqr gain Q holds true; expected a number"),
        ('{"R": [false]}', "lqr gain R holds false"),
        ('{"R": "0.1"}', "lqr gain R holds a str"),
        ('{"Q": []}', "lqr gain Q holds an empty list"),
    ],
)
def test_gains_that_are_not_numbers_are_refused(capsys: pytest.CaptureFixture[str], gains: str, message: str) -> None:
    assert main(["simulate", "pendubot", "--controller", "lqr", "--gains", gains, "--duration", "0.01"]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.splitlines()) == 1, err


FORMULA = (ROOT / "examples" / "formulas" / "pendubot_mine.py").read_text(encoding="utf-8")
M_RETURN = "    return np.array([[t1 + t2 + 2 * t3 * c2, t2 + t3 * c2], [t2 + t3 * c2, t2]])"


@pytest.mark.parametrize(
    ("line", "message"),
    [
        (M_RETURN.replace("return ", "return (1 + 1e-3j) * "), "mass_matrix returned complex numbers"),
        (M_RETURN + ".astype(object)", "mass_matrix returned Python objects"),
        ("    return [[2**70, 0], [0, 1]]", "mass_matrix returned integers too large for 64 bits"),
        ("    return [['1', '0'], ['0', '1']]", "mass_matrix returned <U1 values"),
        ("    return np.eye(2, dtype=bool)", "mass_matrix returned bool values"),
    ],
    ids=["complex", "object", "2**70", "strings", "bool"],
)
def test_a_formula_whose_values_are_not_real_numbers_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], line: str, message: str
) -> None:
    assert M_RETURN in FORMULA
    path = tmp_path / "f.py"
    path.write_text(FORMULA.replace(M_RETURN, line))
    assert main(["check", "pendubot", "--formula", str(path), "--samples", "2"]) == 2
    err = capsys.readouterr().err
    assert f"{path}: {message}" in err and len(err.splitlines()) == 1, err


def test_a_page_with_nan_is_never_written(tmp_path: Path) -> None:
    pytest.importorskip("meshcat")
    from robodyn import viewer

    robot = robodyn.load("pendubot")
    run = robodyn.simulate(robot, [0.3, 0.2], [0.0, 0.0], duration=0.1, dt=1e-3)
    broken = Trajectory(**{**{k: getattr(run, k) for k in Trajectory._ARRAYS}, "kinetic": run.kinetic * np.nan})
    playback = viewer.build(robot, broken)
    with pytest.raises(InputError, match="hold NaN or infinite numbers; no page written"):
        viewer.to_html(playback)


def test_an_overflowing_power_has_no_curve(tmp_path: Path) -> None:
    pytest.importorskip("meshcat")
    from robodyn import viewer
    from robodyn.viewer.panel import panel_info

    robot = robodyn.load("pendubot")
    run = robodyn.simulate(robot, [0.3, 0.2], [0.0, 0.0], duration=0.1, dt=1e-3)
    huge = Trajectory(**{**{k: getattr(run, k) for k in Trajectory._ARRAYS}, "tau": np.full_like(run.tau, 1e308)})
    with np.errstate(over="ignore", invalid="ignore"):  # the trajectory's own power overflows: that is the case
        playback = viewer.build(robot, huge)
    assert {chart.key for chart in playback.charts} == {
        "energy",
        "ledger",
        "residual",
        "position",
        "torque",
    }  # no power: overflows
    strict(json.dumps(panel_info(playback.charts, playback.runs)))


def test_an_srdf_naming_a_rotor_twice_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # Pinocchio would add both rotors' J n^2 to the armature and keep the last J and n: a model at odds with itself
    srdf = tmp_path / "s.srdf"
    srdf.write_text(
        '<robot name="pendubot"><passive_joint name="joint2"/><rotor_params>'
        '<joint name="joint1" mass="1e-6" gear_ratio="10"/><joint name="joint1" mass="2e-6" gear_ratio="3"/>'
        "</rotor_params></robot>"
    )
    urdf = ROOT / "models" / "pendubot.urdf"
    assert main(["info", str(urdf), "--srdf", str(srdf)]) == 2
    err = capsys.readouterr().err
    assert "<rotor_params> names joint 'joint1' twice (expected one rotor per joint)" in err
    assert len(err.splitlines()) == 1


def test_a_constrained_formula_placing_a_joint_at_a_complex_angle_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # np.asarray(1j, dtype=float64) would drop the imaginary part (with a warning) and check the real one
    linkage = ROOT / "examples" / "textbook" / "linkage"
    path = tmp_path / "reduced.py"
    path.write_text(
        (linkage / "reduced_formula.py")
        .read_text()
        .replace('Path(__file__).with_name("closed_form.py")', repr(str(linkage / "closed_form.py")))
        + "\n_o = on_the_loop\n\ndef on_the_loop(q, v, p):\n    a, b = _o(q, v, p)\n    a['joint_b'] = a['joint_b'] + 0j\n"
        "    return a, b\n"
    )
    assert main(["check", str(linkage / "linkage.toml"), "--formula", str(path), "--samples", "2"]) == 2
    err = capsys.readouterr().err
    assert "on_the_loop's q['joint_b'] is complex128; expected a number" in err and len(err.splitlines()) == 1, err


def test_rotor_parameters_whose_armature_overflows_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # J n^2 = 1e-6 * (1e308)^2 is inf: the model loaded with an infinite inertia and a note about an overflow
    srdf = tmp_path / "s.srdf"
    srdf.write_text(
        '<robot name="p"><rotor_params><joint name="joint1" mass="1e-6" gear_ratio="1e308"/></rotor_params></robot>'
    )
    assert main(["info", str(ROOT / "models" / "pendubot.urdf"), "--srdf", str(srdf), "--json"]) == 2
    err = capsys.readouterr().err
    assert "gear ratio 1e+308 squared is inf (expected a finite armature)" in err and len(err.splitlines()) == 1, err
