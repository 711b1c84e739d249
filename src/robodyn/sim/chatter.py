"""Chattering stops: a joint that strikes its stop again and again within a few steps.

At restitution 0 a joint that reaches its stop is stopped there, and held while the forces push
it on; striking the same stop many times within a few steps means something keeps throwing it
off again. On the tiny inertias of a finger, that is joint losses too stiff for the step: the
diagonal estimate of :mod:`robodyn.sim.stiffness` misses the stiffness of two light bodies
coupled through M, and the oscillation the step excites is stopped at the stops, so the run
goes on (no energy bound is crossed) with many impacts, a ledger error, and a long wall time.

:func:`chattering` finds the worst such joint in a run's impact record (the first
:data:`robodyn.sim.events.IMPACTS_KEPT` impacts); the finding goes into the metadata
(``chattering``) and ``robodyn simulate`` prints one warning line from it (:func:`warning_line`).
The advice it gives is followed by ``tests/test_chatter.py``, which sees each cure work: a run
without the losses (``--no-damping``) or with the suggested step.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any

from robodyn.sim.stiffness import below

# A joint chatters when it strikes its stops at least CHATTER_IMPACTS times within CHATTER_STEPS
# consecutive steps: one impact every 5 steps, kept up, where a stopped joint (restitution 0) is held.
CHATTER_IMPACTS = 10
CHATTER_STEPS = 50
# Impact times are located inside their steps: a span a hair over a whole number of steps is that number.
SPAN_RTOL = 1e-9
# The suggested step is below dt / STEP_FACTOR (and below the stiffness finding's stable step, if any).
STEP_FACTOR = 10.0


def chattering(meta: dict[str, Any]) -> dict[str, Any] | None:
    """The worst chattering joint of a run (from its metadata's ``impact_log`` and ``dt``), or None.

    Returns ``{"joint", "impacts", "steps", "joints", "dt", "dt_suggested", "lossy"}``: the
    joint with the most impacts within CHATTER_STEPS steps, that count, the steps they span, every
    chattering joint (worst first), the run's dt [s], the suggested dt [s], and whether the run
    had joint losses (damping or friction; only then is the advice printed, as only then is it tried).
    """
    dt = float(meta.get("dt") or 0.0)
    log = meta.get("impact_log") or []
    if dt <= 0.0 or len(log) < CHATTER_IMPACTS:
        return None
    times: dict[str, list[float]] = defaultdict(list)
    for record in log:
        times[str(record["joint"])].append(float(record["time"]))
    window = CHATTER_STEPS * dt
    worst: dict[str, tuple[int, int]] = {}  # joint: (impacts within the window, the steps they span)
    for joint, ts in times.items():
        ts.sort()
        most, lo = (0, 0), 0
        for hi, t in enumerate(ts):
            while t - ts[lo] >= window:
                lo += 1
            most = max(most, (hi - lo + 1, -max(1, math.ceil((t - ts[lo]) / dt - SPAN_RTOL))))
        if most[0] >= CHATTER_IMPACTS:
            worst[joint] = (most[0], -most[1])
    if not worst:
        return None
    ranked = sorted(worst, key=lambda j: (-worst[j][0], worst[j][1]))
    suggested = dt / STEP_FACTOR
    stiff = meta.get("stiff_friction")
    if stiff:
        suggested = min(suggested, float(stiff["dt_max"]))
    lossy = any(float(x) > 0.0 for x in [*(meta.get("damping") or []), *(meta.get("friction") or [])])
    return {
        "joint": ranked[0],
        "impacts": worst[ranked[0]][0],
        "steps": worst[ranked[0]][1],
        "joints": ranked,
        "dt": dt,
        "dt_suggested": below(suggested),
        "lossy": lossy,
    }


def warning_line(finding: dict[str, Any]) -> str:
    """One line: the joint, how often it struck its stops, and (with joint losses) what to do."""
    more = len(finding["joints"]) - 1
    others = f" (and {more} more joint{'s' if more > 1 else ''})" if more else ""
    line = (
        f"warning: the stops of {finding['joint']}{others} chatter: {finding['impacts']} impacts within "
        f"{finding['steps']} steps at dt = {finding['dt']:g} s, so expect a ledger error and a long run"
    )
    if finding["lossy"]:
        line += (
            f"; the joint losses on light bodies are too stiff for this step: use --dt {finding['dt_suggested']:g} "
            "or --no-damping"
        )
    return line
