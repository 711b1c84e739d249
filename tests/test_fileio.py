"""Files a user hands robodyn: never opened unless regular, and every number bounded (robodyn.fileio and its readers)."""

from __future__ import annotations

import json
import os
import threading
from pathlib import Path

import numpy as np
import pytest

from robodyn.cli import main
from robodyn.cli.check import read_params
from robodyn.cli.simulate import read_constraints
from robodyn.errors import InputError
from robodyn.fileio import is_number, read_user_file
from robodyn.integrators import step_count
from robodyn.scene import read_scene
from robodyn.sweep import spec as sweep_spec

# A reader that opens a FIFO blocks until a writer comes: give it this long [s] to have refused instead.
BLOCKED_AFTER_S = 20.0
READERS = {
    "scene": read_scene,
    "sweep": sweep_spec.load,
    "params": read_params,
    "constraints": read_constraints,
}


def _refusal_within(call, path: Path) -> BaseException | None:
    """What ``call(path)`` raised, from a thread; None if it is still blocked after BLOCKED_AFTER_S."""
    outcome: list[BaseException] = []

    def target() -> None:
        try:
            call(path)
        except BaseException as exc:  # the refusal under test (or anything else: the test shows it)
            outcome.append(exc)

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(BLOCKED_AFTER_S)
    if thread.is_alive():
        fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK)  # a writer that closes at once: the blocked reader gets EOF
        os.close(fd)
        thread.join(5)
        return None
    return outcome[0] if outcome else AssertionError("accepted a FIFO")


@pytest.mark.parametrize("reader", sorted(READERS))
def test_a_fifo_is_refused_without_waiting_for_a_writer(reader, tmp_path):
    fifo = tmp_path / "input"
    os.mkfifo(fifo)
    exc = _refusal_within(READERS[reader], fifo)
    assert exc is not None, f"the {reader} reader blocked on a FIFO"
    assert isinstance(exc, InputError), repr(exc)
    assert "is a FIFO (named pipe), not a regular file" in str(exc)


@pytest.mark.parametrize("reader", sorted(READERS))
def test_a_folder_and_a_device_are_refused_in_one_line(reader, tmp_path):
    with pytest.raises(InputError, match="is a folder"):
        READERS[reader](tmp_path)
    with pytest.raises(InputError, match="is a character device"):
        READERS[reader](Path("/dev/zero"))


def test_read_user_file_reads_a_regular_file_and_bounds_its_size(tmp_path):
    path = tmp_path / "f.toml"
    path.write_bytes(b"x" * 10)
    assert read_user_file(path, what="scene", expected="a .toml file", limit=10) == b"x" * 10
    with pytest.raises(InputError, match="larger than"):
        read_user_file(path, what="scene", expected="a .toml file", limit=9)
    with pytest.raises(InputError, match="no such scene file"):
        read_user_file(tmp_path / "nope.toml", what="scene", expected="a .toml file", limit=9)


@pytest.mark.parametrize(
    ("value", "integer", "expected"),
    [
        (1, False, True),
        (1.5, False, True),
        (np.float64(2.0), False, True),
        (np.int64(3), True, True),
        (2**63 - 1, True, True),
        (-(2**63), True, True),
        (2**63, True, False),  # past TOML's 64 bits
        (10**400, False, False),  # would overflow the first float conversion
        (-(10**400), False, False),
        (float("nan"), False, False),
        (float("inf"), False, False),
        (1.5, True, False),
        (True, False, False),
        (np.bool_(True), False, False),
        ("1", False, False),
        (None, False, False),
        ([1.0], False, False),
    ],
)
def test_is_number_accepts_finite_floats_and_64_bit_whole_numbers_only(value, integer, expected):
    assert is_number(value, integer=integer) is expected


def test_step_count_refuses_a_count_past_2_to_the_53(tmp_path):
    with pytest.raises(InputError, match="at most 2\\^53"):
        step_count(1e300, 1e-300)
    with pytest.raises(InputError, match="positive number of seconds"):
        step_count(10**400, 1e-3)


HUGE = "1" + "0" * 400  # a TOML integer of 401 digits: Python reads it, float() overflows on it

SCENE_NUMBERS = [
    ("[model]\nname = 'pendubot'\n[simulate]\nduration = {n}\ndt = 0.01\n", r"\[simulate\] duration"),
    ("[model]\nname = 'pendubot'\n[simulate]\nduration = 0.1\ndt = {n}\n", r"\[simulate\] dt"),
    ("[model]\nname = 'pendubot'\n[check]\nseed = {n}\n", r"\[check\] seed"),
    ("[model]\nname = 'pendubot'\n[initial]\nq = [{n}, 0]\n", r"\[initial\] q"),
    ("[model]\nname = 'pendubot'\n[control]\ntorque = [{n}, 0]\n", r"\[control\] torque"),
    ("[model]\nname = 'pendubot'\n[springs]\njoint1 = {{ stiffness = {n}, rest = 0 }}\n", "spring stiffness"),
    (
        "[model]\nname = 'pendubot'\n[constraints]\ncouplings = [{{ joint = 'joint2', leader = 'joint1', ratio = {n} }}]\n",
        "ratio",
    ),
]


@pytest.mark.parametrize(("text", "message"), SCENE_NUMBERS, ids=[m for _, m in SCENE_NUMBERS])
def test_a_400_digit_number_in_a_scene_is_one_line_exit_2(text, message, tmp_path, capsys):
    scene = tmp_path / "scene.toml"
    scene.write_text(text.format(n=HUGE))
    code = main(["run", str(scene), "--no-view", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert message.replace("\\", "") in err or __import__("re").search(message, err), err
    assert not (tmp_path / "out").exists()


def test_a_coupling_ratio_past_a_million_is_refused_before_its_square_overflows(tmp_path, capsys):
    scene = tmp_path / "scene.toml"
    scene.write_text(
        "[model]\nname = 'pendubot'\n[constraints]\n"
        "couplings = [{ joint = 'joint2', leader = 'joint1', ratio = 1e200 }]\n[simulate]\nduration = 0.01\n"
    )
    code = main(["run", str(scene), "--no-view", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and "ratio must be at most 1e+06" in err, err


@pytest.mark.parametrize("key", ["duration", "dt", "chunk", "seed"])
def test_a_400_digit_number_in_a_sweep_is_one_line(key, tmp_path):
    path = tmp_path / "sweep.toml"
    path.write_text(f"model = 'pendubot'\n{key} = {HUGE}\n")
    with pytest.raises(InputError, match=key):
        sweep_spec.load(path)


def test_a_400_digit_number_in_a_constraints_file_is_one_line(tmp_path):
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"restitution": 0}).replace("0", HUGE))
    with pytest.raises(InputError, match="finite number"):
        read_constraints(path)


def test_a_sweep_nested_too_deeply_is_one_line(tmp_path):
    path = tmp_path / "sweep.toml"
    path.write_text("model = 'pendubot'\ndt = " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(InputError, match="nested too deeply"):
        sweep_spec.load(path)


@pytest.mark.parametrize(
    "argv",
    [
        ["check", "pendubot", "--formula", "pendubot", "--params", "p.json", "--samples", "2"],
        ["simulate", "pendubot", "--controller", "swing_up", "--gains", "g.json", "--duration", "0.1"],
    ],
    ids=["params", "swing_up gain"],
)
def test_a_400_digit_number_in_a_json_file_is_one_line(argv, tmp_path, capsys, monkeypatch):
    params = {"m1": 1.336, "m2": 0.5, "l1": 0.15, "lc1": 0.1, "lc2": 0.126, "I1": 6.19e-3, "I2": 2.65e-3, "g": 9.81}
    (tmp_path / "p.json").write_text(json.dumps(params).replace("1.336", HUGE))
    (tmp_path / "g.json").write_text('{"k_energy": ' + HUGE + "}")
    monkeypatch.chdir(tmp_path)
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
