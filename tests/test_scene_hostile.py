"""robodyn run on hostile scenes: every section checked before any work, and an overflow is not a check failure."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from robodyn.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SIM = "[simulate]\nduration = 0.05\ndt = 0.01\n"

BAD_SECTIONS = {
    "closed_form not Python": ("[model]\nname = 'pendubot'\n" + SIM + "[check]\nclosed_form = 'scene.toml'\n",
                               "[check] closed_form"),
    "closed_form parameters() fails": ("[model]\nname = 'pendubot'\n" + SIM + "[check]\nclosed_form = 'cf.py'\n",
                                       "parameters() failed"),
    "torque empty": ("[model]\nname = 'pendubot'\n[control]\ntorque = []\n" + SIM, "[control] torque"),
    "torque of no joint": ("[model]\nname = 'pendubot'\n[control]\ntorque = { nope = 1.0 }\n" + SIM, "no joint 'nope'"),
    "q too short": ("[model]\nname = 'pendubot'\n[initial]\nq = [0.1]\n" + SIM, "[initial] q"),
    "loop frame unknown, no [simulate]": (
        "[model]\nname = 'pendubot'\n[constraints]\nloops = [{ frame_a = 'no_such_frame', frame_b = 'link2' }]\n",
        "[constraints] loops[0].frame_a: unknown frame",
    ),
    "NUL in the output folder": ("[model]\nname = 'pendubot'\n" + SIM + '[output]\ndir = "a\\u0000b"\n', "NUL"),
    "spring on no joint, no [simulate]": (
        "[model]\nname = 'pendubot'\n[springs]\nnope = { stiffness = 1.0, rest = 0.0 }\n",
        "nope",
    ),
}  # fmt: skip
CLOSED_FORM = """
def parameters(scene_path):
    raise KeyError("urdf")

def closed_form(t, q, v, params):
    return {}

def simulated(t, q, v, params):
    return {}
"""


@pytest.mark.parametrize("case", sorted(BAD_SECTIONS))
def test_a_bad_section_is_refused_before_any_file_is_written(case, tmp_path, capsys):
    text, expected = BAD_SECTIONS[case]
    (tmp_path / "scene.toml").write_text(text)
    (tmp_path / "cf.py").write_text(CLOSED_FORM)
    code = main(["run", str(tmp_path / "scene.toml"), "--no-view", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and expected in err, err
    assert not (tmp_path / "out").exists(), sorted(p.name for p in (tmp_path / "out").iterdir())


def test_a_torque_of_1e308_is_an_overflow_exit_3_not_a_failed_check(tmp_path, capsys):
    for name in ("power.toml", "cart_flywheel.urdf", "closed_form.py"):
        shutil.copy(EXAMPLES / "textbook" / "power" / name, tmp_path / name)
    scene = tmp_path / "power.toml"
    scene.write_text(scene.read_text().replace("torque = { rail = 3.0,", "torque = { rail = 1e308,"))
    code = main(["run", str(scene), "--no-view", "--out", str(tmp_path / "out")])
    captured = capsys.readouterr()
    assert code == 3, captured.err
    assert len(captured.err.strip().splitlines()) == 1, captured.err
    assert "the run overflowed: simulated() of closed_form.py gives power = inf" in captured.err
    assert "FAILED" not in captured.out
    assert (tmp_path / "out" / "summary.json").is_file()  # the partial results are kept
