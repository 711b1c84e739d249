"""Integration on plain arrays: :func:`solve` records every step of q'' = accel(t, q, v).

Also :func:`step_count`, which turns a duration and a step into a whole number of steps
(refusing a duration that is not one). What is recorded by a robot simulation is
:func:`robodyn.simulate`'s business; this is the robot-free recorder.
"""

from __future__ import annotations

import reprlib
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from robodyn.errors import InputError
from robodyn.fileio import is_number
from robodyn.integrators.base import Integrator
from robodyn.integrators.problem import Array, ArrayProblem, SecondOrderProblem
from robodyn.integrators.registry import get

# Past 2^53 steps, k dt no longer names each step's time exactly (and 1e300 / 1e-300 is inf, no count at all).
MAX_STEP_COUNT = 2.0**53


def step_count(duration: float, dt: float) -> int:
    """How many steps of ``dt`` [s] make ``duration`` [s] exactly (to 1e-9 relative).

    Raises:
        InputError: ``dt`` or ``duration`` is not a positive finite number, or ``duration``
            is not a whole number of steps of ``dt``.
    """
    for name, value in (("dt", dt), ("duration", duration)):
        if not (is_number(value) and value > 0):
            raise InputError(f"{name} must be a positive number of seconds, got {reprlib.repr(value)}")
    ratio = float(duration) / float(dt)
    if not ratio <= MAX_STEP_COUNT:  # inf too: 1e300 s in steps of 1e-300 s
        raise InputError(f"duration {duration:g} s in steps of dt = {dt:g} s is {ratio:.3g} steps; at most 2^53")
    n = round(ratio)
    if n < 1 or abs(n * dt - duration) > 1e-9 * duration:
        raise InputError(f"duration {duration} s is not a whole number of steps of dt = {dt} s")
    return n


@dataclass(frozen=True)
class Solution:
    """States at t_k = t0 + k dt from :func:`solve`: t (n+1,), q (n+1, nq), v (n+1, nv)."""

    t: Array
    q: Array
    v: Array
    evaluations: int


def solve(
    accel: Callable[[float, Array, Array], Array] | SecondOrderProblem,
    q0: Array,
    v0: Array,
    *,
    dt: float,
    n_steps: int,
    method: str | Integrator = "rk4",
    t0: float = 0.0,
    rtol: float = 1e-9,
    atol: float = 1e-12,
) -> Solution:
    """Integrate q'' = accel(t, q, v) on plain arrays, recording every step.

    Args:
        accel: (t [s], q (n,), v (n,)) -> a (n,), or a ready :class:`SecondOrderProblem`.
        q0: initial configuration (nq,).
        v0: initial velocity (nv,).
        dt: step (output interval for the adaptive methods) [s], > 0.
        n_steps: number of steps, >= 1.
        method: an integrator name or object.
        t0: initial time [s].
        rtol: relative tolerance of the adaptive methods.
        atol: absolute tolerance of the adaptive methods.
    """
    q = np.array(q0, dtype=np.float64)
    v = np.array(v0, dtype=np.float64)
    if not dt > 0:
        raise InputError(f"dt must be > 0, got {dt!r}")
    if n_steps < 1:
        raise InputError(f"n_steps must be >= 1, got {n_steps!r}")
    problem = accel if isinstance(accel, SecondOrderProblem) else ArrayProblem(accel, q.size, v.size)
    integrator = get(method) if isinstance(method, str) else method
    t_grid = np.asarray(t0 + dt * np.arange(n_steps + 1), dtype=np.float64)
    Q = np.empty((n_steps + 1, q.size))
    V = np.empty((n_steps + 1, v.size))
    Q[0], V[0] = q, v
    u = v
    stepper = integrator.start(problem, t0, q, u, t_end=float(t_grid[-1]), rtol=rtol, atol=atol)
    advance = stepper.advance
    for k in range(n_steps):
        q, u, _ = advance(float(t_grid[k]), q, u, float(t_grid[k + 1] - t_grid[k]))
        Q[k + 1] = q
        V[k + 1] = u[: v.size]
    return Solution(t_grid, Q, V, problem.evaluations)
