"""Words of the messages robodyn prints: a count with its noun, singular or plural as the count asks.

``count(1, "step")`` is ``1 step``, ``count(2, "step")`` ``2 steps``, ``count(0, "step")``
``0 steps``; ``count(20001, "sample", thousands=True)`` is ``20,001 samples``. A noun whose
plural is not the singular plus ``s`` gives it: ``count(7, "mismatch", "mismatches")``.
"""

from __future__ import annotations


def count(n: int, noun: str, plural: str | None = None, *, thousands: bool = False) -> str:
    """``n`` followed by ``noun``, or by its plural (``noun + "s"`` unless given) when ``n`` is not 1."""
    number = f"{n:,}" if thousands else str(n)
    return f"{number} {noun if n == 1 else (plural if plural is not None else noun + 's')}"
