"""The one classic RK4 step of the closed forms: two coordinates, written once, compiled for the CPU and the GPU.

:func:`rk4_step` takes a compiler (``numba.njit``, ``cuda.jit(device=True)``, or the identity for
plain Python) and the rates of the system, ``rates(ctx, q0, q1, v0, v1) -> (a0, a1, power)``,
and returns ``step(ctx, q0, q1, v0, v1, a0, a1, p1, h) -> (q0, q1, v0, v1, work)``: one step of
``h`` [s] from the state (q, v) whose rates (a, p1) the caller already has (a run records them,
a batch needs them anyway). ``ctx`` is whatever the rates read besides the state (a tuple of the
kind's parameters, its damping, the torque or the controller's vector), handed through untouched;
``power`` [W] is the power of the forces whose work a run books (0.0 where none is booked), and
``work`` [J] its integral over the step with the RK4 weights.

The order of the operations is the specification every closed-form path shares:

    b = a(q + h/2 v,  v + h/2 a)          w = v + h/2 a
    c = a(q + h/2 w,  v + h/2 b)          x = v + h/2 b
    d = a(q + h x,    v + h c)            y = v + h c
    q' = q + h/6 (v + 2 w + 2 x + y)      v' = v + h/6 (a + 2 b + 2 c + d)

The CPU run and the CPU batch (:mod:`robodyn.engine.closed_form`), the GPU batch
(:mod:`robodyn.engine.cuda.batch`) and the GPU closed loop (:mod:`robodyn.engine.cuda.closed_loop`)
all call it, so they agree to the bit wherever their compilers do the same float64 arithmetic
(the CPU, numba's CUDA simulator; a GPU's fused multiply-adds round differently).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


def rk4_step(jit: Callable[[Any], Any], rates: Any) -> Any:
    """``step(ctx, q0, q1, v0, v1, a0, a1, p1, h)``: one RK4 step of ``rates``, compiled by ``jit``.

    Returns (q0, q1, v0, v1, work): the state after the step and the work [J] of the booked power.
    """

    @jit
    def step(ctx, q0, q1, v0, v1, a0, a1, p1, h):  # type: ignore[no-untyped-def]
        b0, b1, p2 = rates(ctx, q0 + 0.5 * h * v0, q1 + 0.5 * h * v1, v0 + 0.5 * h * a0, v1 + 0.5 * h * a1)
        w0 = v0 + 0.5 * h * a0
        w1 = v1 + 0.5 * h * a1
        c0, c1, p3 = rates(ctx, q0 + 0.5 * h * w0, q1 + 0.5 * h * w1, v0 + 0.5 * h * b0, v1 + 0.5 * h * b1)
        x0 = v0 + 0.5 * h * b0
        x1 = v1 + 0.5 * h * b1
        d0, d1, p4 = rates(ctx, q0 + h * x0, q1 + h * x1, v0 + h * c0, v1 + h * c1)
        y0 = v0 + h * c0
        y1 = v1 + h * c1
        return (
            q0 + h / 6.0 * (v0 + 2.0 * w0 + 2.0 * x0 + y0),
            q1 + h / 6.0 * (v1 + 2.0 * w1 + 2.0 * x1 + y1),
            v0 + h / 6.0 * (a0 + 2.0 * b0 + 2.0 * c0 + d0),
            v1 + h / 6.0 * (a1 + 2.0 * b1 + 2.0 * c1 + d1),
            h / 6.0 * (p1 + 2.0 * p2 + 2.0 * p3 + p4),
        )

    return step
