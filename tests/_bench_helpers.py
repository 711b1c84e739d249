"""What the bench tests share: the keys every record of ``bench.json`` must carry (from the issue)."""

from __future__ import annotations

RECORD_KEYS = frozenset(
    {
        "model",
        "integrator",
        "backend",
        "dt",
        "rtol",
        "error",
        "wall_time_s",
        "evaluations",
        "energy_drift",
        "diverged",
    }
)
