"""Benettin's twin directions from a counter-based generator: the same numbers in Python, numba and CUDA.

A Lyapunov estimate starts each run's twin ``d0`` away from it in a random direction. A sweep of
10⁶ runs on a GPU cannot afford a NumPy generator per run on the host, so the direction's
components are drawn by a stateless hash instead: component ``i`` of the direction of stream
``stream`` (a sweep's seed plus the run's number) is

    u1 = uniform(stream, 2 i), u2 = uniform(stream, 2 i + 1)          (0 < u <= 1)
    z_i = sqrt(-2 ln u1) cos(2 pi u2)                                  (Box-Muller)

with ``uniform(s, c) = (splitmix64(splitmix64(s) + c) >> 11 + 1) / 2^53``, SplitMix64 being
Steele, Lea and Flood's 64-bit finaliser (Java's ``SplittableRandom``). The direction is then
scaled to length ``d0`` by dividing by the root of the components' squares summed in order.

The functions below are written once, as scalar functions of ``np.uint64`` integers (whose
arithmetic wraps modulo 2^64 in NumPy, in numba and in CUDA alike), so that
:func:`robodyn.integrators.stability.lyapunov` calls them as Python, and
:mod:`robodyn.engine.cuda.batch` compiles them with ``numba.njit`` and ``cuda.jit(device=True)``:
a run's twin starts at the same offset on every path. Python evaluates them under
``np.errstate(over="ignore")`` (:func:`direction`): the wraparound is the point, not an error.
"""

from __future__ import annotations

import math
import types
from typing import Any

import numpy as np
from numpy.typing import NDArray

# SplitMix64's constants (the golden-ratio increment and the two multipliers of its finaliser).
GOLDEN = 0x9E3779B97F4A7C15
MIX1 = 0xBF58476D1CE4E5B9
MIX2 = 0x94D049BB133111EB
# 2^-53: a 53-bit integer times this is a double in [0, 1) without rounding.
UNIT = 1.0 / 9007199254740992.0


def splitmix64(x):  # type: ignore[no-untyped-def]
    """SplitMix64's output for state ``x`` (a ``np.uint64``): a well-mixed ``np.uint64``."""
    z = x + np.uint64(GOLDEN)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(MIX1)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(MIX2)
    return z ^ (z >> np.uint64(31))


def uniform(stream, counter):  # type: ignore[no-untyped-def]
    """A uniform double in (0, 1] keyed by (stream, counter), both ``np.uint64``."""
    z = splitmix64(splitmix64(stream) + counter)
    return np.float64((z >> np.uint64(11)) + np.uint64(1)) * UNIT


def normal(stream, i):  # type: ignore[no-untyped-def]
    """Component ``i`` (a ``np.uint64``) of stream ``stream``'s direction: a standard normal (Box-Muller)."""
    u1 = uniform(stream, np.uint64(2) * i)
    u2 = uniform(stream, np.uint64(2) * i + np.uint64(1))
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


def compiled_normal(jit: Any) -> Any:
    """:func:`normal` compiled by ``jit`` (``numba.njit`` or ``cuda.jit(device=True)``), its callees compiled too.

    The functions' own code objects are reused with their callees' names bound to the compiled
    versions: no second copy of the generator.
    """
    mix = jit(splitmix64)
    unit = jit(types.FunctionType(uniform.__code__, {**uniform.__globals__, "splitmix64": mix}, "uniform"))
    return jit(types.FunctionType(normal.__code__, {**normal.__globals__, "uniform": unit}, "normal"))


def direction(stream: int, size: int, d0: float) -> NDArray[np.float64]:
    """The twin offset (size,) of length ``d0`` for ``stream`` (an int in [0, 2^64)), as the kernels draw it."""
    if not 0 <= stream < 2**64:
        raise ValueError(f"a twin stream is an integer in [0, 2^64), got {stream}")
    s = np.uint64(stream)
    with np.errstate(over="ignore"):
        z = np.array([normal(s, np.uint64(i)) for i in range(size)], dtype=np.float64)
    total = 0.0
    for x in z:  # summed in order, as the kernels do
        total += float(x) * float(x)
    return z * (d0 / math.sqrt(total))
