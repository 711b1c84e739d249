"""Counts in messages: singular for one, plural otherwise."""

from __future__ import annotations

from robodyn.wording import count


def test_one_is_singular_and_every_other_count_plural():
    assert count(1, "step") == "1 step"
    assert count(0, "step") == "0 steps"
    assert count(2, "step") == "2 steps"
    assert count(20001, "sample", thousands=True) == "20,001 samples"
    assert count(1, "mismatch", "mismatches") == "1 mismatch"
    assert count(7, "mismatch", "mismatches") == "7 mismatches"
    assert count(1, "dynamics evaluation") == "1 dynamics evaluation"
