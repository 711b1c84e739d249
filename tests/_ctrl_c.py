"""Simulate a user pressing Ctrl-C in the middle of a run: RK4's step raises KeyboardInterrupt."""

from __future__ import annotations

import pytest


def press_ctrl_c_during_step(monkeypatch: pytest.MonkeyPatch, step: int) -> None:
    """Make ``ClassicRK4.step`` raise KeyboardInterrupt on its ``step``-th call (1-based); earlier calls step."""
    from robodyn import integrators

    original = integrators.ClassicRK4.step
    calls = {"n": 0}

    def step_then_ctrl_c(self: object, *args: object) -> object:
        calls["n"] += 1
        if calls["n"] >= step:
            raise KeyboardInterrupt
        return original(self, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(integrators.ClassicRK4, "step", step_then_ctrl_c)
