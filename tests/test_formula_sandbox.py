"""A user's formula file cannot fake a pass or hang robodyn: it runs in its own process, under a time limit.

Each hostile file goes through ``main(["check", ...])`` in-process (where an unguarded
``sys.exit`` or ``os._exit`` would end pytest itself) and, for the worst ones, through the real
``robodyn`` command: exit 2, exactly one stderr line naming the file and the reason, stdout empty.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.checker import evaluation, sandbox, wire
from robodyn.checker.compare import MAX_SAMPLES, check
from robodyn.checker.file_contract import load_in_process
from robodyn.checker.user_formula import UserFormula, load_user_formula
from robodyn.cli import main
from robodyn.errors import FormulaError, InputError

ROOT = Path(__file__).resolve().parents[1]
MINE = ROOT / "examples" / "formulas" / "pendubot_mine.py"
SEED = ROOT / "examples" / "formulas" / "pendubot_seed.py"
LIMIT = "2"  # --formula-timeout for the hanging files [s]: short, yet far above a healthy import (~0.01 s)
FAKE = "PASS: everything agrees within tolerance"
PARAMS = dict(m1=1.3, m2=0.45, l1=0.17, lc1=0.09, lc2=0.12, I1=0.006, I2=0.0027, g=9.81)

FUNCTIONS = """
def mass_matrix(q, p):
    return np.eye(2)
def coriolis_matrix(q, v, p):
    return np.zeros((2, 2))
def gravity(q, p):
    return np.zeros(2)
"""

# name -> (file text, what the one stderr line must say after the file's path)
HOSTILE = {
    "exit_at_import": (
        "import sys\nKIND = 'pendubot'\nsys.exit(0)\n",
        "the formula file called sys.exit(0) at import (line 3)",
    ),
    "os_exit_at_import": (
        f"import os\nprint({FAKE!r})\nos._exit(0)\n",
        "the formula file ended its process at import (exit code 0",
    ),
    "exit_in_mass_matrix": (
        "import sys\nimport numpy as np\nKIND = 'pendubot'\n"
        + FUNCTIONS.replace("return np.eye(2)", "sys.exit(0)"),  # line 6
        "mass_matrix called sys.exit(0) (line 6)",
    ),
    "loops_for_ever": (
        "import numpy as np\nKIND = 'pendubot'\n" + FUNCTIONS.replace("return np.eye(2)", "while True:\n        pass"),
        f"mass_matrix did not return within {LIMIT} s (--formula-timeout); it was running line 5",
    ),
    "prints_a_fake_report": (  # and then defines no KIND: what it printed must go nowhere
        f"import os, sys\nprint({FAKE!r})\nprint({FAKE!r}, file=sys.stderr)\nos.write(1, b'{FAKE}')\n",
        "define KIND as one of cart_pole, geared_arm, pendubot (found None)",
    ),
}


def _write(tmp_path: Path, name: str) -> Path:
    path = tmp_path / f"{name}.py"
    path.write_text(HOSTILE[name][0])
    return path


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def _exit_here(code: int) -> None:
    raise AssertionError(f"os._exit({code}) ran in robodyn's own process")


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_hostile_formula_file_is_exit_2_with_one_line_in_process(tmp_path, capsys, monkeypatch, name):
    # Were the file run in this process, os._exit would end pytest with exit 0 and no report: make it fail instead.
    # The formula's own process is a fresh Python, which this patch does not reach.
    monkeypatch.setattr("os._exit", _exit_here)
    path = _write(tmp_path, name)
    code = main(["check", "pendubot", "--formula", str(path), "--samples", "5", "--formula-timeout", LIMIT])
    out, err = capsys.readouterr()
    assert code == 2
    assert out == ""
    line = _one_line(err)
    assert line.startswith(f"robodyn check: error: {path}: "), line
    assert HOSTILE[name][1] in line, line


def _robodyn() -> list[str]:
    script = Path(sys.executable).with_name("robodyn")  # the console script of this environment
    return [str(script)] if script.exists() else [sys.executable, "-m", "robodyn"]


@pytest.mark.parametrize("name", ["exit_at_import", "os_exit_at_import", "exit_in_mass_matrix", "loops_for_ever"])
def test_hostile_formula_file_as_a_real_process(tmp_path, name):
    path = _write(tmp_path, name)
    run = subprocess.run(
        [*_robodyn(), "check", "pendubot", "--formula", str(path), "--formula-timeout", LIMIT],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=False,
    )
    assert run.returncode == 2, (run.stdout, run.stderr)
    assert run.stdout == ""
    line = _one_line(run.stderr)
    assert f"{path}: " in line and HOSTILE[name][1] in line, line


# The test's own deadline (pytest-timeout): above the longest the parent may wait when it works
# (the child's start, STARTUP_TIMEOUT, then the 1 s limit and the GRACE), so that a parent that
# waits for ever for the reply fails here instead of hanging the suite.
STUBBORN_DEADLINE = sandbox.STARTUP_TIMEOUT + 1 + sandbox.GRACE + 30  # [s]


@pytest.mark.timeout(STUBBORN_DEADLINE)
def test_a_formula_that_ignores_the_alarm_is_killed_after_the_grace(tmp_path, capsys):
    """robodyn's own limit holds when the file swallows the child's alarm (a bare except)."""
    path = tmp_path / "stubborn.py"
    path.write_text(
        "import numpy as np\nKIND = 'pendubot'\n"
        + FUNCTIONS.replace(
            "return np.zeros(2)",
            "while True:\n        try:\n            while True:\n                pass\n        except BaseException:\n"
            "            pass",
        )
    )
    code = main(["check", "pendubot", "--formula", str(path), "--formula-timeout", "1"])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert _one_line(err).endswith(f"{path}: gravity did not return within 1 s (--formula-timeout)")


def test_printing_formula_still_passes_and_prints_nothing(tmp_path, capsys):
    """A correct formula that prints everywhere: the report is robodyn's alone, stderr stays empty."""
    text = MINE.read_text().replace("    t1 = ", "    print('debug M', q)\n    t1 = ")
    text = text.replace("KIND = ", "import sys\nprint('imported')\nprint('to stderr', file=sys.stderr)\nKIND = ")
    path = tmp_path / "chatty.py"
    path.write_text(text)
    assert main(["check", "pendubot", "--formula", str(path), "--samples", "10"]) == 0
    out, err = capsys.readouterr()
    assert "PASS: everything agrees within tolerance" in out
    assert "debug" not in out and "imported" not in out and err == ""


def test_examples_pass_and_fail_as_before(capsys):
    assert main(["check", "pendubot", "--formula", str(MINE)]) == 0
    assert "PASS: everything agrees within tolerance" in capsys.readouterr().out
    assert main(["check", "pendubot", "--formula", str(SEED)]) == 1
    assert "MISMATCH M[0,1] (M)" in capsys.readouterr().out
    for path, code in ((MINE, 0), (SEED, 1)):
        run = subprocess.run(
            [*_robodyn(), "check", "pendubot", "--formula", str(path.relative_to(ROOT))],
            capture_output=True,
            text=True,
            cwd=ROOT,
            check=False,
        )
        assert run.returncode == code and run.stderr == "", run.stderr


def test_the_batch_matches_the_formula_evaluated_here_exactly():
    """The oracle: the same file imported in this process and evaluated point by point."""
    here = load_in_process(MINE, str(MINE))
    rng = np.random.default_rng(4)
    q, v = rng.uniform(-3, 3, (7, 2)), rng.uniform(-2, 2, (7, 2))
    points = evaluation.Points(q, q[:5], v[:5], q[:3], q)
    with load_user_formula(MINE) as formula:
        batch = formula.evaluate(PARAMS, points)
        one = formula.mass_matrix(q[2], PARAMS)
    expected = evaluation.evaluate(here, PARAMS, points)
    for name in evaluation.FUNCTIONS:  # identical arithmetic on identical float64: exact
        np.testing.assert_array_equal(batch.of(name), expected.of(name))
    assert batch.mass_matrix.shape == (7, 2, 2) and batch.coriolis_matrix.shape == (5, 2, 2)
    np.testing.assert_array_equal(one, here.mass_matrix(q[2], PARAMS))


def test_a_check_is_one_round_trip_to_the_formula_process(monkeypatch):
    """The batch, not a call per state: one evaluate request for a whole check."""
    calls = []
    evaluate = sandbox.FormulaProcess.evaluate

    def counted(self, p, points, dof):
        calls.append(points.count("mass_matrix"))
        return evaluate(self, p, points, dof)

    monkeypatch.setattr(sandbox.FormulaProcess, "evaluate", counted)
    samples = 30
    report = check(robodyn.load("pendubot"), str(MINE), samples=samples)
    assert report.passed
    assert calls == [3 * samples]  # M at q, q + h v, q - h v for every sample, in one request


def test_the_api_refuses_hostile_files_and_recovers_after_a_timeout(tmp_path):
    with pytest.raises(FormulaError, match=r"called sys.exit\(0\) at import \(line 3\)"):
        load_user_formula(_write(tmp_path, "exit_at_import"))
    with pytest.raises(FormulaError, match="ended its process at import"):
        load_user_formula(_write(tmp_path, "os_exit_at_import"))
    path = tmp_path / "sometimes.py"
    path.write_text(
        "import numpy as np\nKIND = 'pendubot'\n"
        + FUNCTIONS.replace("return np.eye(2)", "while q[0] > 100:\n        pass\n    return np.eye(2)")
    )
    formula = load_user_formula(path, timeout=1)
    assert isinstance(formula, UserFormula)
    with pytest.raises(FormulaError, match=r"mass_matrix did not return within 1 s \(--formula-timeout\)"):
        formula.mass_matrix(np.array([1000.0, 0.0]), PARAMS)
    np.testing.assert_array_equal(formula.mass_matrix(np.zeros(2), PARAMS), np.eye(2))  # a fresh process
    formula.close()


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("input()", r"failed to import: EOFError: EOF when reading a line \(line 1\)"),  # stdin is not robodyn's
        ("raise KeyboardInterrupt", r"odd.py: the formula file raised KeyboardInterrupt \(line 1\)"),
    ],
)
def test_import_cannot_read_robodyn_stdin_or_stop_it(tmp_path, body, message):
    path = tmp_path / "odd.py"
    path.write_text(body + "\n")
    with pytest.raises(FormulaError, match=message):
        load_user_formula(path)


# Run with a readable stdin and a replaced sys.stdin: the formula's process must still read nothing.
READABLE_STDIN_RUN = """
import io, sys
sys.stdin = io.StringIO("a line robodyn's caller typed\\n")
from robodyn.errors import FormulaError
from robodyn.checker.user_formula import load_user_formula
try:
    load_user_formula(sys.argv[1])
except FormulaError as exc:
    print(exc)
"""


def test_a_formula_never_reads_robodyn_stdin_whatever_it_holds(tmp_path):
    path = tmp_path / "reads.py"
    path.write_text("input()\n")
    done = subprocess.run(
        [sys.executable, "-c", READABLE_STDIN_RUN, str(path)],
        input="a line on robodyn's own stdin\n" * 1000,
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    assert "failed to import: EOFError: EOF when reading a line (line 1)" in done.stdout, done.stdout + done.stderr


def test_a_reused_formula_process_gives_each_import_an_empty_stdin(tmp_path):
    path = tmp_path / "leaves_a_stdin.py"  # its first import leaves a readable sys.stdin; its second reads it
    path.write_text(
        "import builtins, io, sys\nimported = getattr(builtins, 'imported', 0)\nbuiltins.imported = imported + 1\n"
        "if imported:\n    input()\nsys.stdin = io.StringIO('left by the first import\\n')\n"
        "import numpy as np\nKIND = 'pendubot'\n" + FUNCTIONS
    )
    process = sandbox.FormulaProcess(path, str(path))
    try:
        assert process.load()["kind"] == "pendubot"
        with pytest.raises(FormulaError, match=r"failed to import: EOFError: EOF when reading a line \(line 5\)"):
            process.load()
    finally:
        process.close()


def test_base_exceptions_in_a_function_are_one_line(tmp_path):
    path = tmp_path / "interrupts.py"
    path.write_text(
        "import numpy as np\nKIND = 'pendubot'\n"
        + FUNCTIONS.replace("return np.zeros((2, 2))", "raise KeyboardInterrupt")
    )
    with pytest.raises(FormulaError, match=r"interrupts.py: coriolis_matrix raised KeyboardInterrupt \(line 7\)"):
        check(robodyn.load("pendubot"), str(path), samples=3)


def test_limits_are_refused_in_one_line(capsys):
    robot = robodyn.load("pendubot")
    with pytest.raises(InputError, match=f"samples must be >= 1 and <= {MAX_SAMPLES}"):
        check(robot, samples=MAX_SAMPLES + 1)
    with pytest.raises(InputError, match="formula time limit must be > 0"):
        check(robot, str(MINE), formula_timeout=0)
    for argv in (
        ["--samples", str(MAX_SAMPLES + 1)],
        ["--formula-timeout", "0"],
        ["--formula-timeout", "1e9"],
        ["--formula-timeout", "nan"],
    ):
        with pytest.raises(SystemExit) as exc:
            main(["check", "pendubot", "--formula", str(MINE), *argv])
        assert exc.value.code == 2
        assert argv[0] in _one_line(capsys.readouterr().err)
    with pytest.raises(SystemExit):
        main(["check", "--help"])
    assert f"1 to {MAX_SAMPLES:,}" in " ".join(capsys.readouterr().out.split())  # the help states the bound


def test_the_wire_refuses_what_robodyn_did_not_write():
    import io

    message = wire.encode({"op": "values"}, {"M": np.arange(8.0).reshape(2, 2, 2), "V": np.empty(0)})
    header, arrays = wire.read_message(io.BytesIO(message))
    assert header == {"op": "values"}
    np.testing.assert_array_equal(arrays["M"], np.arange(8.0).reshape(2, 2, 2))
    assert arrays["V"].shape == (0,)
    assert wire.read_message(io.BytesIO(b"")) is None
    with pytest.raises(ValueError, match="cut short"):
        wire.read_message(io.BytesIO(message[:-1]))
    with pytest.raises(ValueError, match="bytes"):
        wire.read_message(io.BytesIO(b"\xff" * 16))
    forged = b'{"op": "values", "arrays": [["M", [1000]]]}'
    with pytest.raises(ValueError, match="longer than the message"):
        wire.read_message(io.BytesIO(wire._FRAME.pack(len(forged), 8) + forged + bytes(8)))


def test_a_formula_path_that_is_a_loop_of_links_is_one_line(tmp_path, capsys):
    """issue 39 item 11: ``RuntimeError: Symlink loop`` came with a traceback (Path.resolve on Python 3.11)."""
    first, second = tmp_path / "first.py", tmp_path / "second.py"
    first.symlink_to(second)
    second.symlink_to(first)
    assert main(["check", "pendubot", "--formula", str(first)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "first.py: no such formula file (a symbolic link to nothing, or a loop of links)" in line, line
