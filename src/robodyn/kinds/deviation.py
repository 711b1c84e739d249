"""The worst deviation of a simulated motion from a closed form: one number per quantity, computed once.

A closed form predicts named quantities along a motion (``{"speed": (n,) array}``); the same
quantities are read off the simulation. The deviation of a quantity is

    max over the motion |closed form - simulated| / max over the motion |closed form|

(absolute, in the quantity's unit, where the closed form is zero all along). ``robodyn run``
reports it for a scene's ``[check] closed_form``; the textbook's ``closed_form.py`` files give
only the book's formula and the simulated reading.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike


def worst_deviation(expected: Mapping[str, ArrayLike], got: Mapping[str, ArrayLike]) -> dict[str, float]:
    """``{quantity: max |expected - got| / max |expected|}`` over the motion, for every quantity of ``expected``.

    Each value is an array (n,) or a number (broadcast along the motion). A NaN anywhere gives
    NaN (it never passes a tolerance).

    Raises:
        ValueError: the two name different quantities, or a quantity's arrays do not broadcast.
    """
    if set(expected) != set(got):
        raise ValueError(f"the closed form gives {sorted(expected)}, the simulated reading {sorted(got)}")
    out = {}
    for name, value in expected.items():
        e, g = np.broadcast_arrays(np.asarray(value, dtype=np.float64), np.asarray(got[name], dtype=np.float64))
        if e.size == 0:
            raise ValueError(f"{name}: no samples to compare")
        scale = float(np.max(np.abs(e)))
        error = float(np.max(np.abs(e - g)))
        out[str(name)] = error / scale if scale > 0 else error
    return out
