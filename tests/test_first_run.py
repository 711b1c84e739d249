"""What a first run compiles (issue 40): only the kernels it uses, seen in a fresh process with an empty numba cache.

A fixed-base robot's run compiles no free-flyer code (the kernels' ``flyer`` None prunes it), an
RK4 run no general-tableau code (``tab`` None), and no run compiles RNEA or CRBA (the compiled
dynamics check them against Pinocchio at their first use instead). Every compiled signature of a
kernel is one numba compiled; an empty ``NUMBA_CACHE_DIR`` makes the process compile, not load.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import weakref
from pathlib import Path

import numpy as np
import pytest

import robodyn
from robodyn.errors import AssumptionError
from robodyn.sim import tree

SRC = Path(__file__).resolve().parents[1] / "src"
# The Pendubot's first run (fixed base, RK4 by default), then the signatures each kernel was compiled for.
FIRST_RUN = """
import json
from robodyn.cli import main
from robodyn.engine import jit
from robodyn.engine.tree import algorithms, events, flyer, steps
from robodyn.sim import tree
code = main(["simulate", "pendubot", "--duration", "0.01"])
flyers = {name: len(getattr(flyer, name).signatures) for name in dir(flyer) if name.startswith("ff_")}
print(json.dumps({
    "exit": code,
    "flyer": flyers,
    "stages": [[str(t) for t in sig] for sig in steps.stages.signatures],
    "rnea": len(algorithms.rnea.signatures),
    "crba": len(algorithms.crba.signatures),
    "cached": {
        "aba": [jit.is_cached(steps.aba, tree.variant(f)) for f in (False, True)],
        "run_steps": [jit.is_cached(events.run_steps, tree.run_variant(False, t)) for t in (False, True)],
    },
}))
"""
TAB_ARG = 5  # stages(itree, ftree, grav, flyer, method, tab, ...)


@pytest.fixture(scope="module")
def first_run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    cache = tmp_path_factory.mktemp("numba-cache")
    env = {**os.environ, "PYTHONPATH": str(SRC), "NUMBA_CACHE_DIR": str(cache)}
    done = subprocess.run([sys.executable, "-c", FIRST_RUN], env=env, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert "compiled loop" in done.stdout  # the run took the compiled tree loop
    return dict(json.loads(done.stdout.splitlines()[-1]))


@pytest.mark.timeout(900)
def test_a_fixed_base_run_compiles_no_free_flyer_code(first_run: dict[str, object]) -> None:
    assert first_run["exit"] == 0
    flyers = first_run["flyer"]
    assert isinstance(flyers, dict) and len(flyers) >= 7  # every ff_ kernel of engine/tree/flyer.py
    assert flyers == dict.fromkeys(flyers, 0)


@pytest.mark.timeout(900)
def test_an_rk4_run_compiles_no_general_tableau_nor_rnea_and_crba(first_run: dict[str, object]) -> None:
    stages = first_run["stages"]
    assert isinstance(stages, list) and stages  # compiled, for RK4 ...
    assert all(sig[TAB_ARG] == "none" for sig in stages)  # ... without a tableau
    assert first_run["rnea"] == first_run["crba"] == 0


@pytest.mark.timeout(900)
def test_the_cache_tells_the_variants_apart(first_run: dict[str, object]) -> None:
    # what the run compiled is cached, and no other variant counts as cached: its compile will say so
    assert first_run["cached"] == {"aba": [True, False], "run_steps": [True, False]}


def test_rnea_and_crba_are_checked_at_their_first_use(monkeypatch: pytest.MonkeyPatch) -> None:
    robot = robodyn.load("double_pendulum")
    compiled = tree.compiled_of(robot)
    assert set(compiled.check) == set(tree.RUN_PARTS)
    rng = np.random.default_rng(4)
    q, v = robot.random_state(rng)
    compiled.inverse_dynamics(q, v, np.zeros(robot.nv))
    compiled.mass_matrix(q)
    assert set(compiled.check) == set(tree.VERIFY_PARTS)
    assert max(compiled.check.values()) <= tree.VERIFY_RTOL
    # the same tree (so not an edited model) whose ABA and energies passed (as if) but whose RNEA and
    # CRBA kernels answer 5 % wrong: refused at first use, naming the part
    rnea, crba = tree.CompiledDynamics._rnea, tree.CompiledDynamics._crba
    monkeypatch.setattr(tree.CompiledDynamics, "_rnea", lambda self, q, v, a: 1.05 * rnea(self, q, v, a))
    monkeypatch.setattr(tree.CompiledDynamics, "_crba", lambda self, q: 1.05 * crba(self, q))
    passed = dict.fromkeys(tree.RUN_PARTS, 0.0)

    def bad() -> tree.CompiledDynamics:
        return tree.CompiledDynamics(compiled.tree, dict(passed), weakref.ref(robot))

    with pytest.raises(AssumptionError, match=r"differ from Pinocchio's \(rnea by"):
        bad().inverse_dynamics(q, v, np.zeros(robot.nv))
    with pytest.raises(AssumptionError, match=r"differ from Pinocchio's \(crba by"):
        bad().mass_matrix(q)
