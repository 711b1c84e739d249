"""A run left to its default takes the Python loop while the compiled loop's kernels are not built
and compiling them would cost more than the run (robodyn.sim.compile_choice): rent before buying.

The suite's other tests run with ROBODYN_COMPILE=always (conftest.py); these set "auto", the
default, and stand in for numba's cache with ``compile_choice.built``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.errors import InputError
from robodyn.sim import compile_choice, tree

NOT_BUILT = "not used: the compiled loop's kernels are not built on this machine"


@pytest.fixture
def auto(monkeypatch: pytest.MonkeyPatch) -> pytest.MonkeyPatch:
    monkeypatch.setenv(compile_choice.ENV, "auto")
    monkeypatch.setattr(compile_choice, "_SPENT", [0.0])
    return monkeypatch


def _panda(duration: float = 0.05, **options: object) -> robodyn.Trajectory:
    robot = robodyn.load("panda")  # starts held at joint 4's upper stop: its stops matter
    return robodyn.simulate(robot, robot.neutral(), np.zeros(robot.nv), duration=duration, dt=1e-3, **options)


def test_a_short_run_without_built_kernels_takes_the_python_loop_and_says_why(auto: pytest.MonkeyPatch) -> None:
    auto.setattr(compile_choice, "built", lambda *a, **k: False)
    got = _panda()
    ref = _panda(backend="aba")
    assert got.meta["loop"] == "python" and got.meta["backend"] == "aba"
    assert got.meta["compiled_loop"].startswith(NOT_BUILT)
    assert "about 80 s of CPU, once: `robodyn warmup`" in got.meta["compiled_loop"]  # steps and stop events
    np.testing.assert_array_equal(got.q, ref.q)  # the Python loop's run, bit for bit
    assert compile_choice._SPENT[0] > 0.0  # booked against the compile's cost


def test_built_kernels_run_compiled(auto: pytest.MonkeyPatch) -> None:
    auto.setattr(compile_choice, "built", lambda *a, **k: True)
    got = _panda()
    assert got.meta["loop"] == "compiled" and got.meta["compiled_loop"] == "ran"
    assert compile_choice._SPENT[0] == 0.0


def test_a_run_estimated_over_the_compile_compiles(auto: pytest.MonkeyPatch) -> None:
    auto.setattr(compile_choice, "built", lambda *a, **k: False)
    auto.setattr(compile_choice, "python_estimate", lambda *a: 81.0)  # over 20 s + 60 s
    assert _panda().meta["loop"] == "compiled"
    auto.setattr(compile_choice, "python_estimate", lambda *a: 79.0)
    assert _panda().meta["loop"] == "python"


def test_the_rent_of_earlier_runs_counts(auto: pytest.MonkeyPatch) -> None:
    auto.setattr(compile_choice, "built", lambda *a, **k: False)
    auto.setattr(compile_choice, "python_estimate", lambda *a: 30.0)
    auto.setattr(compile_choice, "_SPENT", [45.0])  # 45 s + 30 s under 80 s: rent once more
    assert _panda().meta["loop"] == "python"
    auto.setattr(compile_choice, "_SPENT", [55.0])  # 55 s + 30 s over: buy
    assert _panda().meta["loop"] == "compiled"


def test_a_python_loop_past_its_budget_starts_again_compiled(auto: pytest.MonkeyPatch) -> None:
    """The budget is the compile's cost; the abandoned run leaves no trace (its held stops, its counts)."""
    auto.setattr(compile_choice, "built", lambda *a, **k: False)
    auto.setattr(compile_choice, "python_estimate", lambda *a: 0.0)
    auto.setattr(tree, "COMPILE_S", (1e-4, 1e-4))  # a budget no Python loop of 300 steps meets
    got = _panda(duration=0.3)
    ref = _panda(duration=0.3, backend="numba")
    assert got.meta["loop"] == "compiled" and "python_loop_abandoned" in got.meta
    assert "ran past 0.0002 s" in got.meta["python_loop_abandoned"]
    np.testing.assert_array_equal(got.q, ref.q)
    np.testing.assert_array_equal(got.v, ref.v)
    assert got.evaluations == ref.evaluations
    assert compile_choice._SPENT[0] > 2e-4


def test_always_compiles_and_other_values_are_refused(auto: pytest.MonkeyPatch) -> None:
    auto.setattr(compile_choice, "built", lambda *a, **k: False)
    auto.setenv(compile_choice.ENV, "always")
    assert _panda().meta["loop"] == "compiled"
    auto.setenv(compile_choice.ENV, "sometimes")
    with pytest.raises(InputError, match=r"ROBODYN_COMPILE='sometimes': expected one of auto, always"):
        _panda()


def test_asked_backends_are_never_rented(auto: pytest.MonkeyPatch) -> None:
    auto.setattr(compile_choice, "built", lambda *a, **k: False)
    assert _panda(backend="numba").meta["loop"] == "compiled"
    assert compile_choice._SPENT[0] == 0.0


def test_the_first_cli_run_on_a_fresh_machine_compiles_nothing(tmp_path: Path) -> None:
    """An empty numba cache: no compile note, the Python loop named with why, nothing written to the cache."""
    cache = tmp_path / "numba"
    cache.mkdir()
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), compile_choice.ENV: "auto"}
    done = subprocess.run(
        [sys.executable, "-m", "robodyn", "simulate", "panda", "--duration", "0.2", "--out", str(tmp_path / "t.npz")],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "Python loop: the compiled loop's kernels are not built on this machine" in done.stdout
    assert "compiling" not in done.stderr
    assert not any(cache.rglob("*.nbi"))


def test_an_abandoned_run_leaves_the_counts_as_they_were(auto: pytest.MonkeyPatch) -> None:
    """Abandoned, then handed back by the compiled loop: the Python loop's run counts its own evaluations only."""
    from robodyn.sim import whole_run

    auto.setattr(compile_choice, "built", lambda *a, **k: False)
    auto.setattr(compile_choice, "python_estimate", lambda *a: 0.0)
    auto.setattr(tree, "COMPILE_S", (1e-4, 1e-4))
    auto.setattr(whole_run, "prepare", lambda *a: "planted: the compiled loop refuses")
    got = _panda(duration=0.3)
    ref = _panda(duration=0.3, backend="aba")
    assert "python_loop_abandoned" in got.meta and got.meta["loop"] == "python"
    assert got.evaluations == ref.evaluations
    np.testing.assert_array_equal(got.q, ref.q)


def test_a_variant_found_built_is_not_read_from_the_cache_again(monkeypatch: pytest.MonkeyPatch) -> None:
    """numba's index files are read until a variant is found built, then never again in the process (a short run's hot path)."""
    from robodyn.engine import jit

    reads: list[object] = []
    monkeypatch.setattr(compile_choice, "_BUILT", set())
    monkeypatch.setattr(jit, "is_cached", lambda f, where=None: reads.append(f) or True)
    assert compile_choice.built(False, False, events=True)
    first = len(reads)
    assert first == 5  # ABA, the kinematics, one sample, the steps, the stop events
    assert compile_choice.built(False, False) and compile_choice.built(False, False, events=True)
    assert len(reads) == first
    monkeypatch.setattr(jit, "is_cached", lambda f, where=None: reads.append(f) and False)
    assert not compile_choice.built(True, False)  # another variant, not built: read, and not remembered
    assert not compile_choice.built(True, False)
    assert len(reads) == first + 2
