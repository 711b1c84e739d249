"""Chattering stops: found in the impact record, one warning line, and its advice followed and seen to work."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from robodyn.cli import main
from robodyn.sim.chatter import CHATTER_IMPACTS, CHATTER_STEPS, chattering, warning_line

# A heavy palm swinging a two-joint finger of 5 g bodies (inertia 1e-8 kg m^2) with light damping
# between stops 0.05 rad apart: the diagonal stiffness estimate calls the damping stable at 1 ms
# (rate ~1e3 1/s), but the two light bodies coupled through M are not, and the stops catch the
# oscillation: the tip strikes its stops about every 4 steps and the ledger ends ~8 J off.
FINGER = Path(__file__).resolve().parents[1] / "examples" / "light_finger.urdf"
RUN = ["--duration", "0.05", "--v0", "3,0,0"]
# What a run that followed the advice must reach: no chattering, and a ledger closed to round-off
# (the lossless run closes it to ~1e-10 J, the 0.1 ms run to ~3e-11 J; the chattering one is ~8 J off).
LEDGER_CLOSED_J = 1e-6


def _simulate(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[dict, str]:
    """(the --json summary, the plain summary's text) of one run."""
    assert main(["simulate", *argv, "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert main(["simulate", *argv]) == 0
    return summary, capsys.readouterr().out


@pytest.fixture
def finger() -> str:
    return str(FINGER)


def test_a_chattering_finger_is_named_and_each_cure_works(finger: str, capsys: pytest.CaptureFixture[str]) -> None:
    summary, text = _simulate(capsys, finger, *RUN)
    found = summary["chattering"]
    assert found["joint"] in ("finger_joint", "tip_joint") and found["impacts"] >= CHATTER_IMPACTS
    assert summary["max_ledger_residual"] > 1.0  # the harm the warning is about
    lines = [x for x in text.splitlines() if x.startswith("warning: the stops of ")]
    assert len(lines) == 1, text
    advice = re.search(r"use --dt (\S+) or --no-damping$", lines[0])
    assert advice is not None, lines[0]
    for cure in (["--dt", advice.group(1)], ["--no-damping"]):
        after, text = _simulate(capsys, finger, *RUN, *cure)
        assert "chattering" not in after and "warning: the stops of " not in text, cure
        assert after["max_ledger_residual"] < LEDGER_CLOSED_J, cure


def _log(joint: str, steps: list[float], dt: float) -> list[dict]:
    return [{"time": k * dt, "joint": joint} for k in steps]


def test_the_window_counts_impacts_within_its_steps() -> None:
    dt = 1e-3
    # CHATTER_IMPACTS impacts spread just inside the window chatter; spread just past it they do not
    inside = [k * (CHATTER_STEPS - 1) / (CHATTER_IMPACTS - 1) for k in range(CHATTER_IMPACTS)]
    outside = [k * (CHATTER_STEPS + 1) / (CHATTER_IMPACTS - 1) for k in range(CHATTER_IMPACTS)]
    meta = {"dt": dt, "damping": [0.1], "impact_log": _log("a", inside, dt) + _log("b", outside, dt)}
    found = chattering(meta)
    assert found is not None and found["joints"] == ["a"] and found["impacts"] == CHATTER_IMPACTS
    assert found["steps"] == CHATTER_STEPS - 1  # the steps the impacts span, as the warning says
    assert found["dt_suggested"] < dt
    assert chattering({**meta, "impact_log": _log("b", outside, dt)}) is None


def test_no_advice_without_joint_losses() -> None:
    # the cures tried above act on the losses: a lossless run gets the fact alone
    dt = 1e-3
    meta = {"dt": dt, "damping": [0.0], "friction": [0.0], "impact_log": _log("a", list(range(20)), dt)}
    found = chattering(meta)
    assert found is not None and not found["lossy"]
    assert "--dt" not in warning_line(found) and "--no-damping" not in warning_line(found)
