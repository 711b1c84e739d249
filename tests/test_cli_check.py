"""robodyn check and robodyn params through main([...]) and one real subprocess."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from robodyn.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_check_passes_with_exit_0(capsys):
    assert main(["check", "pendubot", "--formula", "pendubot", "--samples", "20"]) == 0
    out = capsys.readouterr().out
    assert "PASS: everything agrees within tolerance" in out
    assert "m1 = 1.336 kg" in out and "max rel err" in out


def test_check_mismatch_names_the_entry_with_exit_1(capsys):
    code = main(["check", "pendubot", "--formula", str(ROOT / "examples/formulas/pendubot_seed.py"), "--samples", "20"])
    out = capsys.readouterr().out
    assert code == 1
    assert "MISMATCH M[0,1] (M): formula" in out and "MISMATCH C[1,0] (C)" in out
    assert "at sample" in out and "q = [" in out


def test_check_json(capsys):
    assert main(["check", "cart_pole", "--formula", "cart_pole", "--samples", "5", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["passed"] is True and data["kind"] == "cart_pole" and data["samples"] == 5
    assert {r["quantity"] for r in data["rows"]} >= {"M", "C", "G", "N = dM/dt - 2C skew", "G = dV/dq"}


def test_check_without_formula_suggests_the_kind(capsys):
    assert main(["check", "geared_arm", "--samples", "5"]) == 0
    assert "add --formula geared_arm" in capsys.readouterr().out


def test_params_round_trip_into_check(tmp_path, capsys):
    assert main(["params", "pendubot"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["kind"] == "pendubot" and data["params"]["l1"] == 0.15
    (tmp_path / "p.json").write_text(json.dumps(data))
    assert (
        main(["check", "pendubot", "--formula", "pendubot", "--params", str(tmp_path / "p.json"), "--samples", "5"])
        == 0
    )


def test_bad_input_is_one_line_with_exit_2(tmp_path, capsys):
    cases = [
        ["check", str(tmp_path / "missing.urdf")],
        ["check", "nonexistent_robot_name"],
        ["check", "pendubot", "--formula", "cart_pole"],
        ["check", "pendubot", "--formula", str(tmp_path / "absent.py")],
        ["check", "pendubot", "--samples", "0"],
        ["check", "pendubot", "--samples", "100001"],  # past MAX_SAMPLES
        ["check", "pendubot", "--formula-timeout", "0"],
        ["check", "pendubot", "--formula", str(tmp_path / "exits.py")],  # sys.exit(0) at import
        ["params", "pendubot", "--kind", "geared_arm"],
    ]
    (tmp_path / "exits.py").write_text("import sys\nsys.exit(0)\n")
    (tmp_path / "broken.urdf").write_text("<robot name='x'><link name='a'></robot>")
    cases.append(["check", str(tmp_path / "broken.urdf")])
    (tmp_path / "neg.urdf").write_text(
        "<robot name='x'><link name='a'/><link name='b'><inertial><mass value='1'/>"
        "<inertia ixx='1' iyy='1' izz='3' ixy='0' ixz='0' iyz='0'/></inertial></link>"
        "<joint name='j' type='revolute'><parent link='a'/><child link='b'/><axis xyz='0 1 0'/>"
        "<limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>"
    )
    cases.append(["check", str(tmp_path / "neg.urdf")])
    for argv in cases:
        code = None
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse validators exit 2 themselves
            code = exc.code
        err = capsys.readouterr().err
        assert code == 2, (argv, err)
        assert "Traceback" not in err
        assert len([line for line in err.strip().splitlines() if "error" in line]) == 1, err


def test_real_subprocess_exit_codes():
    ok = subprocess.run(
        [sys.executable, "-m", "robodyn", "check", "geared_arm", "--formula", "geared_arm", "--samples", "10"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=False,
    )
    assert ok.returncode == 0, ok.stderr
    bad = subprocess.run(
        [
            sys.executable,
            "-m",
            "robodyn",
            "check",
            "geared_arm",
            "--formula",
            "examples/formulas/geared_arm_seed.py",
            "--samples",
            "10",
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=False,
    )
    assert bad.returncode == 1 and "MISMATCH M[0,0]" in bad.stdout


def test_explain_prints_the_named_terms_and_json_carries_them(capsys):
    seed = str(ROOT / "examples/formulas/pendubot_seed.py")
    assert main(["check", "pendubot", "--formula", seed, "--samples", "40", "--explain"]) == 1
    out = capsys.readouterr().out
    assert "M[0,1]: formula - Pinocchio = m2*l1*lc2*cos(q2)   (coefficient 0.00945 = m2*l1*lc2 at each of 5" in out
    assert "MISMATCH tau[1] (tau (inverse dynamics))" in out and "MISMATCH tau[0] (tau (inverse dynamics))" in out
    assert main(["check", "pendubot", "--formula", seed, "--samples", "40", "--explain", "--json"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert any(line.startswith("C[1,0]: formula - Pinocchio = ") for line in report["explanation"])
    assert [m["entry"] for m in next(r for r in report["rows"] if r["quantity"] == "M")["mismatches"]] == [[0, 1]]
    m01 = next(e for e in report["explain_terms"] if e["label"] == "M[0,1]")  # a built-in kind, in its own names
    assert (m01["status"], [(t["basis"], t["name"]) for t in m01["terms"]]) == ("named", [("cos(q2)", "m2*l1*lc2")])


def test_a_refused_formula_on_a_model_with_mimic_joints_is_one_line(capsys):
    """issue 39 item 11: the mimic warning came before the refusal (two lines for one refusal)."""
    formula = Path(__file__).parents[1] / "examples" / "formulas" / "pendubot_mine.py"
    assert main(["check", "panda", "--formula", str(formula)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a pendubot: expected 2 moving joint(s), found 9" in err, err
    assert main(["check", "panda", "--samples", "2"]) == 0  # a check that runs still says the coupling is ignored
    assert "the coupling is ignored" in capsys.readouterr().err
