"""The command-line frame: subcommands, usage errors, negative vector values."""

from __future__ import annotations

import pytest

import robodyn
from robodyn.cli import _attach_negative_values, get_argument_parser, main


def test_every_subcommand_is_registered():
    parser = get_argument_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    assert set(sub.choices) == {
        "info", "params", "check", "derive", "simulate", "view", "portrait", "bench", "run", "sweep", "grade", "warmup",
    }  # fmt: skip


def test_help_is_plain_text(capsys):
    """``robodyn --help`` and each subcommand's help show no reST markup (``x``, :func:, :class:)."""
    for argv in (
        ["--help"],
        *([name, "--help"] for name in ("info", "params", "check", "simulate", "bench", "grade", "warmup")),
    ):
        with pytest.raises(SystemExit):
            main(argv)
        out = capsys.readouterr().out
        assert out and not any(mark in out for mark in ("``", ":func:", ":class:", ":mod:")), out


def test_negative_vector_values_attach_to_their_option():
    assert _attach_negative_values(["simulate", "pendubot", "--q0", "-1.2,0.3", "--v0", "-.5,0"]) == [
        "simulate", "pendubot", "--q0=-1.2,0.3", "--v0=-.5,0",
    ]  # fmt: skip
    assert _attach_negative_values(["check", "x", "--samples", "5"]) == ["check", "x", "--samples", "5"]


def test_usage_errors_exit_2(capsys):
    for argv in ([], ["frobnicate"], ["check"], ["check", "pendubot", "--samples", "many"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
    assert "error" in capsys.readouterr().err


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and f"robodyn {robodyn.__version__}" in capsys.readouterr().out


def test_broken_pipe_is_quiet_and_exit_0():
    import subprocess
    import sys

    proc = subprocess.run(
        f"{sys.executable} -m robodyn info talos | head -1", shell=True, capture_output=True, text=True, check=False
    )
    assert proc.stdout.startswith("talos:")
    assert "Traceback" not in proc.stderr and "BrokenPipe" not in proc.stderr


def test_usage_error_is_one_line(capsys):
    with pytest.raises(SystemExit):
        main(["check", "pendubot", "--samples", "0"])
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "robodyn check: error: argument --samples: expected a positive whole number, got '0' (see 'robodyn check --help')"
    ]


def test_a_path_the_system_refuses_is_one_line(capsys, tmp_path, monkeypatch):
    """A name longer than the file system allows made Path.is_file raise OSError (found by benchmarks/fuzz.py)."""
    from robodyn.cli import main

    monkeypatch.chdir(tmp_path)
    code = main(["simulate", "a" * 400, "--duration", "0.05"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "File name too long" in err[0] and "Traceback" not in err[0]
    assert list(tmp_path.iterdir()) == []
