"""Parse the ``--lock`` and ``--keep`` arguments of the subcommands that build a minimal model."""

from __future__ import annotations

import math

from robodyn.errors import InputError


def parse_lock(text: str) -> dict[str, float]:
    """``"joint_a=0.1,joint_b=-0.5"`` -> {name: value}; an InputError names a bad item."""
    values: dict[str, float] = {}
    for item in (x.strip() for x in text.split(",")):
        if not item:
            continue
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise InputError(f"--lock expects name=value items separated by commas, got {item!r}")
        try:
            number = float(value)
        except ValueError:
            raise InputError(f"--lock {name.strip()}: expected a number after '=', got {value!r}") from None
        if not math.isfinite(number):
            raise InputError(f"--lock {name.strip()}: expected a finite number, got {value!r}")
        values[name.strip()] = number
    if not values:
        raise InputError("--lock expects at least one name=value item")
    return values


def parse_keep(text: str) -> tuple[str, ...]:
    """``"joint_a,joint_b"`` -> the names (at least one)."""
    names = tuple(x.strip() for x in text.split(",") if x.strip())
    if not names:
        raise InputError("--keep expects at least one joint name")
    return names
