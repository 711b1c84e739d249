"""The built-in kinds' batch rollout on an NVIDIA GPU: the same closed form, compiled by numba's CUDA target.

One GPU thread advances one state of the batch through every step of classic RK4 at a fixed
``dt``, in float64, with no torque (as :func:`robodyn.sim.batch.rollout` on the CPU). The closed
forms are not written here: ``cuda.jit(device=True)`` compiles each kind's own four scalar
functions (``mass``, ``coriolis``, ``gravity`` of :mod:`robodyn.kinds.pendubot`,
:mod:`~robodyn.kinds.cart_pole`, :mod:`~robodyn.kinds.geared_arm`) and
:func:`robodyn.kinds.formula.solve_2x2`, the functions :mod:`robodyn.sim.fast` hands to
``numba.njit``. The step is the CPU kernel's own (:func:`robodyn.engine.rk4.rk4_step`, which
``batch_rk4`` in :mod:`robodyn.engine.closed_form` calls too), so the two paths agree to round-off
(to the bit in numba's CUDA simulator).

Each thread also keeps the smallest and largest value of each coordinate it passed through, so
that a caller can tell which runs left the URDF's position limits on the way (the sweep hands
those to :func:`robodyn.simulate`, which stops them there). :func:`lyapunov` steps a run and its
Benettin twin in one thread and returns only the exponents; the thread draws its twin's direction
itself, from the counter-based generator of :mod:`robodyn.integrators.twins` keyed by the run's
stream (:func:`streams_of`), the direction every other path draws for that run.

float32 on request (``precision="float32"``): the same functions, re-made from their source with
every float literal a float32 constant (:func:`float32_source`), so that numba does not promote
the step to float64; torque-free float64 kernels are unchanged.

This module needs only NumPy, numba's CUDA target and :mod:`robodyn.kinds` (no Pinocchio): a
GPU worker runs it from a kind's name and parameter vector (``benchmarks/bench_gpu.py --run``).
It is imported only when ``device="cuda"`` is asked for; ``numba.cuda`` loads on first use.

Setting ``NUMBA_ENABLE_CUDASIM=1`` before numba is first imported runs the same kernels in
numba's CUDA simulator on the CPU (slow: a Python thread per state), as the tests do.
"""

from __future__ import annotations

import ast
import inspect
import math
import textwrap
import time
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.engine.rk4 import rk4_step
from robodyn.errors import InputError, MissingDependencyError, UnavailableError
from robodyn.integrators.twins import compiled_normal
from robodyn.kinds.catalog import closed_form
from robodyn.kinds.formula import solve_2x2

Array = NDArray[np.float64]

# The kinds that run on the GPU, as in robodyn.sim.fast.
CUDA_KINDS = ("pendubot", "cart_pole", "geared_arm")
# What the kernels compute in: float64 by default, float32 on request (rollouts only).
PRECISIONS = ("float64", "float32")
# Threads per CUDA block: a multiple of the warp (32); each thread holds a dozen float64 registers.
THREADS_PER_BLOCK = 128


def blocks_for(n: int) -> int:
    """Blocks of THREADS_PER_BLOCK threads that cover n states: ceil(n / THREADS_PER_BLOCK), at least 1.

    Rounded up, never down: 130 states are 2 blocks (the last one 126 threads idle), not 1 that leaves 2 unstepped.
    """
    return max(1, -(-int(n) // THREADS_PER_BLOCK))


NO_GPU = (
    "device cuda: no CUDA GPU found (numba.cuda.is_available() is False); "
    "run without --device cuda or on a machine with an NVIDIA GPU"
)

# numba.cuda, set by cuda_module(). The kernels reach it as a module global: numba's CUDA
# simulator patches a kernel's globals, not the names a closure captured.
cuda: Any = None


def cuda_module() -> Any:
    """``numba.cuda`` once a GPU (or numba's CUDA simulator) is there.

    Raises:
        MissingDependencyError: numba's CUDA target does not import (exit 4: install the ``cuda`` extra).
        UnavailableError: it imports but finds no CUDA GPU (exit 5).
    """
    global cuda
    if cuda is None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if not hasattr(np, "row_stack"):  # numba-cuda still overloads np.row_stack, gone from numpy 2.5
                np.row_stack = np.vstack  # type: ignore[attr-defined]
            try:
                from numba import cuda as module
            except ImportError as exc:
                raise MissingDependencyError(
                    f"device cuda: numba's CUDA target does not import ({exc}); pip install 'robodyn[cuda]'"
                ) from None
        cuda = module
    if not cuda.is_available():
        raise UnavailableError(NO_GPU)
    return cuda


@contextmanager
def quiet() -> Iterator[None]:
    """Keep numba's performance warnings (a grid of a few blocks, a host array) off the user's stderr."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


def device_name() -> str:
    """The GPU's name (``"numba CUDA simulator"`` in numba's CUDA simulator)."""
    module = cuda_module()
    if not hasattr(module, "get_current_device"):  # the simulator's numba.cuda has none
        return "numba CUDA simulator"
    name = module.get_current_device().name
    return name.decode() if isinstance(name, bytes) else str(name)


def _advance(jit: Any, kind: str, *, precision: str = "float64") -> Any:
    """``advance(p, b, nv, q0, q1, v0, v1, dt, n)``: n RK4 steps of one state, compiled by ``jit``.

    Returns (q0, q1, v0, v1, lo0, lo1, hi0, hi1): the final state and each coordinate's range.
    ``jit`` is ``cuda.jit(device=True)`` (the GPU kernel) or ``numba.njit`` (:func:`cpu_rollout`).
    ``precision="float32"`` compiles every function here, and the kind's closed form, from the same
    source with its float literals made float32 (:func:`float32_jit`).
    """
    if kind not in CUDA_KINDS:
        raise InputError(f"device cuda: kind {kind!r} has no GPU kernel; expected one of {', '.join(CUDA_KINDS)}")
    if precision == "float32":
        jit = float32_jit(jit)
    form = closed_form(kind)
    mass, coriolis, gravity, solve = (jit(f) for f in (form.mass, form.coriolis, form.gravity, solve_2x2))

    if form.dof == 2:

        @jit
        def acc(p, b, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
            m11, m12, m22 = mass(p, q0, q1)
            c11, c12, c21, c22 = coriolis(p, q0, q1, v0, v1)
            g0, g1 = gravity(p, q0, q1)
            r0 = 0.0 - b[0] * v0 - (c11 * v0 + c12 * v1) - g0
            r1 = 0.0 - b[1] * v1 - (c21 * v0 + c22 * v1) - g1
            return solve(m11, m12, m22, r0, r1)

    else:

        @jit
        def acc(p, b, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
            m = mass(p, q0)[0]
            return (0.0 - b[0] * v0 - coriolis(p, q0, v0)[0] * v0 - gravity(p, q0)[0]) / m, 0.0

    @jit
    def rates(ctx, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        """The one RK4 step's rates: ctx = (p, b); no power booked."""
        a0, a1 = acc(ctx[0], ctx[1], q0, q1, v0, v1)
        return a0, a1, 0.0

    rk4 = rk4_step(jit, rates)

    @jit
    def advance(p, b, nv, q0, q1, v0, v1, dt, n):  # type: ignore[no-untyped-def]
        h = dt
        lo0, lo1, hi0, hi1 = q0, q1, q0, q1
        for _ in range(n):
            a0, a1, p1 = rates((p, b), q0, q1, v0, v1)
            q0, q1, v0, v1, _work = rk4((p, b), q0, q1, v0, v1, a0, a1, p1, h)
            if nv == 1:
                q1 = 0.0
                v1 = 0.0
            lo0 = min(lo0, q0)
            lo1 = min(lo1, q1)
            hi0 = max(hi0, q0)
            hi1 = max(hi1, q1)
        return q0, q1, v0, v1, lo0, lo1, hi0, hi1

    return advance


class _Float32Literals(ast.NodeTransformer):
    """Wrap every float literal in ``_float32(...)``: numba types a bare ``2.0`` as float64, which promotes float32."""

    def visit_Constant(self, node: ast.Constant) -> ast.AST:
        if isinstance(node.value, float):
            return ast.copy_location(ast.Call(ast.Name("_float32", ast.Load()), [node], []), node)
        return node


def float32_source(f: Callable[..., Any]) -> Callable[..., Any]:
    """``f`` re-made from its own source with every float literal a ``np.float32`` (decorators dropped).

    Its globals are ``f``'s, and the names its closure captured (the compiled callees) are bound
    to what they hold now: compile the callees with the same transform first. Given float32
    arguments, the result computes in float32 throughout (numba would otherwise promote
    ``x * 2.0`` to float64 and silently compute the whole step in double).
    """
    tree = ast.parse(textwrap.dedent(inspect.getsource(f)))
    ast.increment_lineno(tree, f.__code__.co_firstlineno - 1)  # errors point at the lines of the source file
    node = tree.body[0]
    if not isinstance(node, ast.FunctionDef):  # pragma: no cover - only functions are passed
        raise TypeError(f"{f!r} is not a function")
    node.decorator_list = []
    tree = ast.fix_missing_locations(_Float32Literals().visit(tree))
    namespace = dict(f.__globals__)
    if f.__closure__:
        namespace.update(zip(f.__code__.co_freevars, (c.cell_contents for c in f.__closure__), strict=True))
    namespace["_float32"] = np.float32
    exec(compile(tree, inspect.getsourcefile(f) or "<float32>", "exec"), namespace)  # our own source, re-made
    made: Callable[..., Any] = namespace[node.name]
    return made


def float32_jit(jit: Any) -> Callable[[Callable[..., Any]], Any]:
    """``jit`` (``numba.njit`` or ``cuda.jit(device=True)``) applied to :func:`float32_source` of each function."""

    def compile32(f: Callable[..., Any]) -> Any:
        return jit(float32_source(f))

    return compile32


def _dtype(precision: str) -> Any:
    """The NumPy dtype of ``precision`` ("float64" or "float32"); anything else is an InputError."""
    if precision not in PRECISIONS:
        raise InputError(f"device cuda: precision {precision!r}: expected one of {', '.join(PRECISIONS)}")
    return np.dtype(precision)


def _rk4_row(jit: Any, kind: str, precision: str) -> Any:
    """``row(r, p, b, nv, Q, V, qmin, qmax, dt, n)``: run r of the batch advanced in place, compiled by ``jit``.

    The body :func:`rk4_kernel` (a GPU thread a run) and :func:`cpu_kernel` (numba ``prange``) share.
    """
    advance = _advance(jit, kind, precision=precision)

    @jit
    def row(r, p, b, nv, Q, V, qmin, qmax, dt, n):  # type: ignore[no-untyped-def]
        q0, q1, v0, v1, lo0, lo1, hi0, hi1 = advance(p, b, nv, Q[r, 0], Q[r, 1], V[r, 0], V[r, 1], dt, n)
        Q[r, 0], Q[r, 1], V[r, 0], V[r, 1] = q0, q1, v0, v1
        qmin[r, 0], qmin[r, 1], qmax[r, 0], qmax[r, 1] = lo0, lo1, hi0, hi1

    return row


@cache
def rk4_kernel(kind: str, precision: str = "float64") -> Any:
    """The CUDA kernel ``(p, b, nv, Q, V, qmin, qmax, dt, steps)`` of one built-in kind (compiled on first launch)."""
    module = cuda_module()
    row = _rk4_row(module.jit(device=True), kind, precision)

    @module.jit
    def kernel(p, b, nv, Q, V, qmin, qmax, dt, n):  # type: ignore[no-untyped-def]
        r = cuda.grid(1)
        if r < Q.shape[0]:
            row(r, p, b, nv, Q, V, qmin, qmax, dt, n)

    return kernel


def _benettin(jit: Any, kind: str) -> Any:
    """``benettin(p, b, nv, q0, q1, v0, v1, e0, e1, e2, e3, d0, dt, steps, count, span)`` compiled by ``jit``.

    Steps one run (q, v) and its twin started at (q, v) + e (e = dq0, dq1, dv0, dv1) ``count``
    intervals of ``steps`` RK4 steps; after each it measures their separation d, adds ln(d / d0)
    and pulls the twin back to d0 along it (the order of
    :func:`robodyn.integrators.stability.lyapunov`). Returns the sum over ``span`` [s], or NaN once a
    separation is not finite or zero.
    """
    advance = _advance(jit, kind)

    @jit
    def benettin(p, b, nv, q0, q1, v0, v1, e0, e1, e2, e3, d0, dt, steps, count, span):  # type: ignore[no-untyped-def]
        t0, t1, u0, u1 = q0 + e0, q1 + e1, v0 + e2, v1 + e3
        total = 0.0
        for _ in range(count):
            q0, q1, v0, v1, _x0, _x1, _x2, _x3 = advance(p, b, nv, q0, q1, v0, v1, dt, steps)
            t0, t1, u0, u1, _y0, _y1, _y2, _y3 = advance(p, b, nv, t0, t1, u0, u1, dt, steps)
            s0, s1, s2, s3 = t0 - q0, t1 - q1, u0 - v0, u1 - v1
            d = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2 + s3 * s3)
            if not (d > 0.0 and d < math.inf):
                return math.nan
            total += math.log(d / d0)
            f = d0 / d
            t0, t1, u0, u1 = q0 + s0 * f, q1 + s1 * f, v0 + s2 * f, v1 + s3 * f
        return total / span

    return benettin


def _twin_offset(jit: Any) -> Any:
    """``offset(nv, stream, d0) -> (dq0, dq1, dv0, dv1)``: the twin's start offset, drawn in the thread.

    The direction of :func:`robodyn.integrators.twins.direction` (components in the order dq, dv;
    its squares summed in that order, zeros of a one-joint kind adding nothing), scaled to ``d0``.
    """
    normal = compiled_normal(jit)

    @jit
    def offset(nv, stream, d0):  # type: ignore[no-untyped-def]
        s = np.uint64(stream)
        z0 = normal(s, np.uint64(0))
        if nv == 2:
            z1 = normal(s, np.uint64(1))
            z2 = normal(s, np.uint64(2))
            z3 = normal(s, np.uint64(3))
        else:
            z1 = 0.0
            z2 = normal(s, np.uint64(1))
            z3 = 0.0
        f = d0 / math.sqrt(z0 * z0 + z1 * z1 + z2 * z2 + z3 * z3)
        return z0 * f, z1 * f, z2 * f, z3 * f

    return offset


def _benettin_row(jit: Any, kind: str) -> Any:
    """``row(r, p, b, nv, Q, V, S, d0, dt, steps, count, span, out)``: run r's estimate into ``out[r]``, by ``jit``."""
    benettin, offset = _benettin(jit, kind), _twin_offset(jit)

    @jit
    def row(r, p, b, nv, Q, V, S, d0, dt, steps, count, span, out):  # type: ignore[no-untyped-def]
        e0, e1, e2, e3 = offset(nv, S[r], d0)
        out[r] = benettin(p, b, nv, Q[r, 0], Q[r, 1], V[r, 0], V[r, 1], e0, e1, e2, e3, d0, dt, steps, count, span)

    return row


@cache
def benettin_kernel(kind: str) -> Any:
    """The CUDA kernel ``(p, b, nv, Q, V, S, d0, dt, steps, count, span, out)``: Benettin's estimate, a run a thread.

    ``S`` (n,) uint64 holds each run's twin stream (the sweep's seed plus the run's number): the
    thread draws its twin's start offset from it (:func:`_twin_offset`); ``out`` (n,) the estimates [1/s].
    """
    module = cuda_module()
    row = _benettin_row(module.jit(device=True), kind)

    @module.jit
    def kernel(p, b, nv, Q, V, S, d0, dt, steps, count, span, out):  # type: ignore[no-untyped-def]
        r = cuda.grid(1)
        if r < Q.shape[0]:
            row(r, p, b, nv, Q, V, S, d0, dt, steps, count, span, out)

    return kernel


@cache
def cpu_benettin_kernel(kind: str) -> Any:
    """Benettin's device function on the CPU's cores: numba ``prange`` over the runs (the benchmark's CPU column)."""
    import numba

    row = _benettin_row(numba.njit, kind)

    @numba.njit(parallel=True)
    def kernel(p, b, nv, Q, V, S, d0, dt, steps, count, span, out):  # type: ignore[no-untyped-def]
        for r in numba.prange(Q.shape[0]):
            row(r, p, b, nv, Q, V, S, d0, dt, steps, count, span, out)

    return kernel


@cache
def cpu_kernel(kind: str, precision: str = "float64") -> Any:
    """The same step on the CPU's cores: numba ``prange`` over the states (the GPU benchmark's CPU column)."""
    import numba

    row = _rk4_row(numba.njit, kind, precision)

    @numba.njit(parallel=True)
    def kernel(p, b, nv, Q, V, qmin, qmax, dt, n):  # type: ignore[no-untyped-def]
        for r in numba.prange(Q.shape[0]):
            row(r, p, b, nv, Q, V, qmin, qmax, dt, n)

    return kernel


def _padded(p: Array, b: Array, Q: Array, V: Array, dtype: Any) -> tuple[Any, Any, Any, Any]:
    """(p, b (2,), Q (n, 2), V (n, 2)) in ``dtype``: a one-joint kind's second column is zeros."""
    n, nv = Q.shape
    Qp, Vp, b2 = np.zeros((n, 2), dtype=dtype), np.zeros((n, 2), dtype=dtype), np.zeros(2, dtype=dtype)
    Qp[:, :nv], Vp[:, :nv], b2[:nv] = Q, V, b
    return np.ascontiguousarray(p, dtype=dtype), b2, Qp, Vp


def rollout(
    kind: str, p: Array, b: Array, Q: Array, V: Array, *, dt: float, steps: int, precision: str = "float64"
) -> tuple[Array, Array, Array, Array, float]:
    """RK4 without torque on the GPU from Q, V (n, nv): (q, v, q_min, q_max), (n, nv) each, and the kernel's time [s].

    ``p`` is the kind's parameter vector (``PARAMS`` order), ``b`` its viscous damping (nv,)
    [N m s/rad | N s/m]. The wall time covers the kernel alone (compiled beforehand), not the copies.
    ``precision="float32"`` computes in float32 (the kernel from the same source, :func:`float32_jit`)
    and returns float32 arrays.
    """
    dtype = _dtype(precision)
    module = cuda_module()
    kernel = rk4_kernel(kind, precision)
    n, nv = Q.shape
    p_, b2, Qp, Vp = _padded(p, b, Q, V, dtype)
    p_d, b_d = module.to_device(p_), module.to_device(b2)
    Q_d, V_d = module.to_device(Qp), module.to_device(Vp)
    lo_d, hi_d = module.device_array((n, 2), dtype=dtype), module.device_array((n, 2), dtype=dtype)
    blocks = blocks_for(n)
    h = dtype.type(dt)
    with quiet():
        one = [module.device_array((1, 2), dtype=dtype) for _ in range(4)]
        kernel[1, 1](p_d, b_d, nv, *one, h, 0)  # compile (or load) outside the timing
        module.synchronize()
        start = time.perf_counter()
        kernel[blocks, THREADS_PER_BLOCK](p_d, b_d, nv, Q_d, V_d, lo_d, hi_d, h, steps)
        module.synchronize()
        wall = time.perf_counter() - start
    out = [a.copy_to_host()[:, :nv].copy() for a in (Q_d, V_d, lo_d, hi_d)]
    return out[0], out[1], out[2], out[3], wall


def cpu_rollout(
    kind: str, p: Array, b: Array, Q: Array, V: Array, *, dt: float, steps: int, precision: str = "float64"
) -> tuple[Array, Array, Array, Array, float]:
    """:func:`rollout`'s step on the CPU's cores (numba's threads): the same outputs and the loop's wall time [s]."""
    dtype = _dtype(precision)
    kernel = cpu_kernel(kind, precision)
    n, nv = Q.shape
    p_, b2, Qp, Vp = _padded(p, b, Q, V, dtype)
    lo, hi = np.zeros((n, 2), dtype=dtype), np.zeros((n, 2), dtype=dtype)
    h = dtype.type(dt)
    kernel(p_, b2, nv, Qp[:1].copy(), Vp[:1].copy(), lo[:1].copy(), hi[:1].copy(), h, 0)  # compile outside the timing
    start = time.perf_counter()
    kernel(p_, b2, nv, Qp, Vp, lo, hi, h, steps)
    wall = time.perf_counter() - start
    return Qp[:, :nv].copy(), Vp[:, :nv].copy(), lo[:, :nv].copy(), hi[:, :nv].copy(), wall


def streams_of(seed: int, runs: NDArray[np.int64]) -> NDArray[np.uint64]:
    """Each run's twin stream (n,) uint64: ``seed + run`` (:mod:`robodyn.integrators.twins`)."""
    runs = np.asarray(runs)
    if seed < 0 or (runs.size and int(runs.min()) < 0):
        raise InputError(f"twin streams need a seed and run numbers >= 0, got seed {seed}")
    return np.asarray(runs, dtype=np.uint64) + np.uint64(seed)


def lyapunov(
    kind: str,
    p: Array,
    b: Array,
    Q: Array,
    V: Array,
    streams: NDArray[np.uint64],
    *,
    d0: float,
    dt: float,
    steps: int,
    count: int,
    interval: float,
    cpu: bool = False,
) -> Array:
    """Benettin's largest Lyapunov exponent [1/s] of every run (n,) on the GPU; only the exponents come back.

    ``streams`` (n,) uint64 seeds each run's twin: the thread draws its start offset, of length
    ``d0``, as :func:`robodyn.integrators.twins.direction` (:func:`streams_of` gives the sweep's).
    ``count`` intervals of ``steps`` steps of ``dt`` [s] (``interval`` [s] each). NaN where a
    separation stopped being finite and positive. ``cpu=True`` runs the same device functions on
    the CPU's cores instead. float64 only: a twin 1e-8 away is below float32's resolution.
    """
    n = Q.shape[0]
    p_, b2, Qp, Vp = _padded(p, b, Q, V, np.float64)
    S = np.ascontiguousarray(streams, dtype=np.uint64)
    if S.shape != (n,):
        raise InputError(f"streams must have shape ({n},), got {S.shape}")
    if cpu:
        result = np.empty(n)
        cpu_benettin_kernel(kind)(p_, b2, Q.shape[1], Qp, Vp, S, d0, dt, steps, count, count * interval, result)
        return result
    module = cuda_module()
    kernel = benettin_kernel(kind)
    out = module.device_array(n, dtype=np.float64)
    blocks = blocks_for(n)
    args = [module.to_device(x) for x in (p_, b2)] + [Q.shape[1]] + [module.to_device(x) for x in (Qp, Vp, S)]
    with quiet():
        kernel[blocks, THREADS_PER_BLOCK](*args, d0, dt, steps, count, count * interval, out)
    return np.asarray(out.copy_to_host())
