"""A sweep chunk's measures on the GPU, from arrays alone: only the measures come back.

:func:`measures` runs one kernel launch over a chunk's runs. Each GPU thread steps its run
(:func:`robodyn.engine.cuda.batch._advance`, RK4 without torque) and computes, on the device, what
the sweep keeps: the final state, the energy drift E(T) - E(0) (the kind's closed form:
``mass`` for ½ vᵀ M v, ``potential`` plus the model's offset), and two flags: the run passed
a URDF position limit on the way (``simulate`` stops it there), or its energy error passes
``simulate``'s divergence bound (growth × max(K0 + |V0|, reference energy)) or is not finite.
Only those columns, (n,) each, are copied back; the host does no per-run work. Benettin's
estimate runs in a second launch (:func:`robodyn.engine.cuda.batch.lyapunov`), its twins seeded
in the thread.

Everything here needs NumPy, numba and :mod:`robodyn.kinds` only: a :class:`DeviceModel` (the
kind, its parameter vector, damping, position limits, potential offset and reference energy)
is what a sweep ships to a GPU worker without Pinocchio (``benchmarks/bench_gpu.py --run``
loads one from ``models.npz``). The runs flagged come back as indices for the client to compute
again with :func:`robodyn.simulate`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.engine.cuda import batch as cuda_batch
from robodyn.errors import InputError
from robodyn.kinds.catalog import closed_form

Array = NDArray[np.float64]

# numba.cuda, set by measures_kernel(): the kernel reaches it as a module global (numba's simulator patches those).
cuda: Any = None

# Flag bits of a run (measures()'s ``flags``): it left the position limits, or its energy error passed the bound.
LEFT_LIMITS = 1
DIVERGED = 2
# What the device computes: the rest of a chunk's columns are the inputs.
DEVICE_MEASURES = frozenset({"final_state", "energy_drift", "wall_time", "lyapunov"})


@dataclass(frozen=True)
class DeviceModel:
    """What a GPU worker needs of a built-in kind's model: arrays, no Pinocchio.

    ``params`` in the kind's ``PARAMS`` order, ``damping`` (nv,) [N m s/rad | N s/m], position
    limits ``lower``, ``upper`` (nq,) [rad | m] (±inf where none), ``potential_offset`` [J] (the
    closed form's zero to the model's) and ``reference_energy`` [J] (the floor of ``simulate``'s
    energy scale), with ``growth`` the divergence bound's factor.
    """

    kind: str
    params: Array
    damping: Array
    lower: Array
    upper: Array
    potential_offset: float
    reference_energy: float
    growth: float

    def arrays(self, prefix: str) -> dict[str, Any]:
        """The fields as named arrays (for ``np.savez``): ``prefix.kind``, ``prefix.params``, ..."""
        return {f"{prefix}.{name}": np.asarray(getattr(self, name)) for name in self.__dataclass_fields__}

    @classmethod
    def from_arrays(cls, arrays: Any, prefix: str) -> DeviceModel:
        """The model saved by :meth:`arrays` (an ``np.load`` of the file)."""
        get = {name: arrays[f"{prefix}.{name}"] for name in cls.__dataclass_fields__}
        return cls(
            str(get["kind"]),
            np.asarray(get["params"], dtype=np.float64),
            np.asarray(get["damping"], dtype=np.float64),
            np.asarray(get["lower"], dtype=np.float64),
            np.asarray(get["upper"], dtype=np.float64),
            float(get["potential_offset"]),
            float(get["reference_energy"]),
            float(get["growth"]),
        )


def _energy(jit: Any, kind: str) -> Any:
    """``energy(p, offset, q0, q1, v0, v1) -> (K, V)`` [J]: the kind's mass and potential, as robodyn.sim.fast's."""
    form = closed_form(kind)
    mass, potential = jit(form.mass), jit(form.potential)
    if form.dof == 2:

        @jit
        def energy(p, offset, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
            m11, m12, m22 = mass(p, q0, q1)
            return 0.5 * (m11 * v0 * v0 + 2.0 * m12 * v0 * v1 + m22 * v1 * v1), potential(p, q0, q1) + offset

    else:

        @jit
        def energy(p, offset, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
            return 0.5 * mass(p, q0)[0] * v0 * v0, potential(p, q0) + offset

    return energy


def _verdict(jit: Any) -> Any:
    """``verdict(limits, k0, u0, k1, u1, lo0, lo1, hi0, hi1) -> (drift, flag)``: the run's drift [J] and flag bits.

    ``limits`` = (offset, growth, reference energy, lower0, lower1, upper0, upper1); the bound is
    ``simulate``'s, growth x max(K0 + |V0|, reference energy), and a drift that is not finite fails it.
    """

    @jit
    def verdict(limits, k0, u0, k1, u1, lo0, lo1, hi0, hi1):  # type: ignore[no-untyped-def]
        drift = (k1 + u1) - (k0 + u0)
        bound = limits[1] * max(k0 + abs(u0), limits[2])
        flag = 0
        if lo0 < limits[3] or lo1 < limits[4] or hi0 > limits[5] or hi1 > limits[6]:
            flag += 1
        if not abs(drift) <= bound:
            flag += 2
        return drift, flag

    return verdict


def _thread(jit: Any, kind: str, precision: str) -> Any:
    """``run(p, pe, b, nv, limits, q0, q1, v0, v1, dt, n)``: one run's final state, drift and flags.

    ``p``, ``b``, the state and ``dt`` are in ``precision``; ``pe`` (the float64 parameters) and
    ``limits`` = (offset, growth, reference energy, lower0, lower1, upper0, upper1) serve the
    energies and flags, in float64 from the state's float64 value.
    """
    advance = cuda_batch._advance(jit, kind, precision=precision)
    energy, verdict = _energy(jit, kind), _verdict(jit)

    @jit
    def run(p, pe, b, nv, limits, q0, q1, v0, v1, dt, n):  # type: ignore[no-untyped-def]
        offset = limits[0]
        k0, u0 = energy(pe, offset, np.float64(q0), np.float64(q1), np.float64(v0), np.float64(v1))
        q0, q1, v0, v1, lo0, lo1, hi0, hi1 = advance(p, b, nv, q0, q1, v0, v1, dt, n)
        k1, u1 = energy(pe, offset, np.float64(q0), np.float64(q1), np.float64(v0), np.float64(v1))
        drift, flag = verdict(limits, k0, u0, k1, u1, lo0, lo1, hi0, hi1)
        return q0, q1, v0, v1, drift, flag

    return run


def _thread_with_twin(jit: Any, kind: str) -> Any:
    """``run(p, b, nv, limits, q0, q1, v0, v1, dt, steps, count, span, stream, d0)``: a run, its twin, its measures.

    One thread steps the run ``count`` intervals of ``steps`` steps (the run's whole duration) and
    its Benettin twin beside it, in the order of :func:`robodyn.engine.cuda.batch._benettin` (the twin
    drawn from ``stream``, pulled back to ``d0`` after each interval); once a separation is not
    finite and positive the twin stops and the estimate is NaN, while the run goes on. Returns
    (q0, q1, v0, v1, drift, flag, exponent): :func:`_thread`'s and Benettin's numbers in one pass.
    """
    advance = cuda_batch._advance(jit, kind)
    energy, verdict, offset = _energy(jit, kind), _verdict(jit), cuda_batch._twin_offset(jit)

    @jit
    def run(p, b, nv, limits, q0, q1, v0, v1, dt, steps, count, span, stream, d0):  # type: ignore[no-untyped-def]
        e0, e1, e2, e3 = offset(nv, stream, d0)
        t0, t1, u0, u1 = q0 + e0, q1 + e1, v0 + e2, v1 + e3
        k0, w0 = energy(p, limits[0], q0, q1, v0, v1)
        lo0, lo1, hi0, hi1 = q0, q1, q0, q1
        total = 0.0
        alive = True
        for _ in range(count):
            q0, q1, v0, v1, a0, a1, c0, c1 = advance(p, b, nv, q0, q1, v0, v1, dt, steps)
            lo0, lo1, hi0, hi1 = min(lo0, a0), min(lo1, a1), max(hi0, c0), max(hi1, c1)
            if alive:
                t0, t1, u0, u1, _y0, _y1, _y2, _y3 = advance(p, b, nv, t0, t1, u0, u1, dt, steps)
                s0, s1, s2, s3 = t0 - q0, t1 - q1, u0 - v0, u1 - v1
                d = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2 + s3 * s3)
                if d > 0.0 and d < math.inf:
                    total += math.log(d / d0)
                    f = d0 / d
                    t0, t1, u0, u1 = q0 + s0 * f, q1 + s1 * f, v0 + s2 * f, v1 + s3 * f
                else:
                    alive = False
        exponent = total / span if alive else math.nan
        k1, w1 = energy(p, limits[0], q0, q1, v0, v1)
        drift, flag = verdict(limits, k0, w0, k1, w1, lo0, lo1, hi0, hi1)
        return q0, q1, v0, v1, drift, flag, exponent

    return run


def _twin_row(jit: Any, kind: str) -> Any:
    """``row(r, p, b, nv, limits, Q, V, S, drift, flags, out, dt, steps, count, span, d0)``: run r with its twin."""
    run = _thread_with_twin(jit, kind)

    @jit
    def row(r, p, b, nv, limits, Q, V, S, drift, flags, out, dt, steps, count, span, d0):  # type: ignore[no-untyped-def]
        q0, q1, v0, v1, d, f, x = run(
            p, b, nv, limits, Q[r, 0], Q[r, 1], V[r, 0], V[r, 1], dt, steps, count, span, S[r], d0
        )
        Q[r, 0], Q[r, 1], V[r, 0], V[r, 1] = q0, q1, v0, v1
        drift[r], flags[r], out[r] = d, f, x

    return row


@cache
def twin_kernel(kind: str) -> Any:
    """The CUDA kernel ``(p, b, nv, limits, Q, V, S, drift, flags, out, dt, steps, count, span, d0)``, in place."""
    global cuda
    module = cuda = cuda_batch.cuda_module()
    row = _twin_row(module.jit(device=True), kind)

    @module.jit
    def kernel(p, b, nv, limits, Q, V, S, drift, flags, out, dt, steps, count, span, d0):  # type: ignore[no-untyped-def]
        r = cuda.grid(1)
        if r < Q.shape[0]:
            row(r, p, b, nv, limits, Q, V, S, drift, flags, out, dt, steps, count, span, d0)

    return kernel


@cache
def cpu_twin_kernel(kind: str) -> Any:
    """:func:`twin_kernel`'s thread on the CPU's cores (numba ``prange``)."""
    import numba

    row = _twin_row(numba.njit, kind)

    @numba.njit(parallel=True)
    def kernel(p, b, nv, limits, Q, V, S, drift, flags, out, dt, steps, count, span, d0):  # type: ignore[no-untyped-def]
        for r in numba.prange(Q.shape[0]):
            row(r, p, b, nv, limits, Q, V, S, drift, flags, out, dt, steps, count, span, d0)

    return kernel


def _measures_row(jit: Any, kind: str, precision: str) -> Any:
    """``row(r, p, pe, b, nv, limits, Q, V, drift, flags, dt, n)``: run r's measures, in place, compiled by ``jit``."""
    run = _thread(jit, kind, precision)

    @jit
    def row(r, p, pe, b, nv, limits, Q, V, drift, flags, dt, n):  # type: ignore[no-untyped-def]
        q0, q1, v0, v1, d, f = run(p, pe, b, nv, limits, Q[r, 0], Q[r, 1], V[r, 0], V[r, 1], dt, n)
        Q[r, 0], Q[r, 1], V[r, 0], V[r, 1] = q0, q1, v0, v1
        drift[r], flags[r] = d, f

    return row


@cache
def measures_kernel(kind: str, precision: str = "float64") -> Any:
    """The CUDA kernel ``(p, pe, b, nv, limits, Q, V, drift, flags, dt, steps)``: a run a thread, in place."""
    global cuda
    module = cuda = cuda_batch.cuda_module()
    row = _measures_row(module.jit(device=True), kind, precision)

    @module.jit
    def kernel(p, pe, b, nv, limits, Q, V, drift, flags, dt, n):  # type: ignore[no-untyped-def]
        r = cuda.grid(1)
        if r < Q.shape[0]:
            row(r, p, pe, b, nv, limits, Q, V, drift, flags, dt, n)

    return kernel


@cache
def cpu_measures_kernel(kind: str, precision: str = "float64") -> Any:
    """The same thread on the CPU's cores (numba ``prange``): the GPU worker's CPU twin, for tests and benchmarks."""
    import numba

    row = _measures_row(numba.njit, kind, precision)

    @numba.njit(parallel=True)
    def kernel(p, pe, b, nv, limits, Q, V, drift, flags, dt, n):  # type: ignore[no-untyped-def]
        for r in numba.prange(Q.shape[0]):
            row(r, p, pe, b, nv, limits, Q, V, drift, flags, dt, n)

    return kernel


@dataclass(frozen=True, eq=False)
class DeviceMeasures:
    """A chunk's measures from the device: final q, v (n, nv) (float64), energy drift (n,) [J], flags (n,) int8.

    ``again`` are the runs (indices into the chunk) that ``simulate`` must compute again (a flag
    set); ``lyapunov`` (n,) [1/s] or None; ``kernel_s`` the rollout kernel's time and
    ``lyapunov_s`` Benettin's launch's [s], copies included for the latter.
    """

    q: Array
    v: Array
    drift: Array
    flags: NDArray[np.int8]
    lyapunov: Array | None
    kernel_s: float
    lyapunov_s: float

    @property
    def again(self) -> NDArray[np.intp]:
        """Indices of the runs to compute again with ``simulate``."""
        return np.flatnonzero(self.flags)

    @property
    def finite(self) -> NDArray[np.bool_]:
        """True where the final state is finite (n,)."""
        return np.asarray(np.isfinite(self.q).all(axis=1) & np.isfinite(self.v).all(axis=1), dtype=np.bool_)


def measures(
    model: DeviceModel,
    q0: Array,
    v0: Array,
    *,
    dt: float,
    steps: int,
    streams: NDArray[np.uint64] | None = None,
    lyapunov_interval: float = 0.1,
    d0: float = 1e-8,
    precision: str = "float64",
    cpu: bool = False,
    fused: bool = True,
) -> DeviceMeasures:
    """Every run (q0 (n, nv), v0 (n, nv)) stepped ``steps`` RK4 steps of ``dt`` [s]: its measures, computed on the GPU.

    With ``streams`` (n,) uint64 (:func:`robodyn.engine.cuda.batch.streams_of`) Benettin's estimate
    of each run is computed too, over the same duration in intervals of ``lyapunov_interval`` [s]
    (shortened to the duration), twins ``d0`` away. ``cpu=True`` runs the same device functions on
    the CPU's cores. ``precision="float32"`` steps in float32 (the energies stay float64; no Lyapunov).
    When the twin's intervals make up the run's ``steps`` exactly, one launch steps each run and its
    twin together (:func:`_thread_with_twin`: the same numbers, a third less work); ``fused=False``
    (or intervals that do not fit) launches the measures kernel, then Benettin's.
    """
    dtype = cuda_batch._dtype(precision)
    if streams is not None and precision != "float64":
        raise InputError("the Lyapunov estimate is float64 only: twins 1e-8 apart are below float32's resolution")
    if streams is not None:
        interval = min(lyapunov_interval, steps * dt)
        count, interval_steps = round(steps * dt / interval), round(interval / dt)
        if fused and count * interval_steps == steps:  # the twin's intervals cover the run: one pass
            return _with_twin(model, q0, v0, streams, dt, interval_steps, count, count * interval, d0, cpu)
    n, nv = q0.shape
    p, b, Q, V = cuda_batch._padded(model.params, model.damping, q0, v0, dtype)
    pe = np.ascontiguousarray(model.params, dtype=np.float64)
    lower, upper = np.full(2, -np.inf), np.full(2, np.inf)
    lower[:nv], upper[:nv] = model.lower, model.upper
    limits = np.array([model.potential_offset, model.growth, model.reference_energy, *lower, *upper])
    drift, flags = np.empty(n), np.empty(n, dtype=np.int8)
    h = dtype.type(dt)
    if cpu:
        kernel = cpu_measures_kernel(model.kind, precision)
        start = time.perf_counter()
        kernel(p, pe, b, nv, limits, Q, V, drift, flags, h, steps)
        wall = time.perf_counter() - start
    else:
        module = cuda_batch.cuda_module()
        kernel = measures_kernel(model.kind, precision)
        args = [module.to_device(x) for x in (p, pe, b)] + [nv] + [module.to_device(x) for x in (limits, Q, V)]
        drift_d, flags_d = module.device_array(n, dtype=np.float64), module.device_array(n, dtype=np.int8)
        blocks = cuda_batch.blocks_for(n)
        with cuda_batch.quiet():
            module.synchronize()
            start = time.perf_counter()
            kernel[blocks, cuda_batch.THREADS_PER_BLOCK](*args, drift_d, flags_d, h, steps)
            module.synchronize()
            wall = time.perf_counter() - start
        Q, V = args[5].copy_to_host(), args[6].copy_to_host()
        drift, flags = drift_d.copy_to_host(), flags_d.copy_to_host()
    exponents, lyapunov_s = None, 0.0
    if streams is not None:
        start = time.perf_counter()
        exponents = cuda_batch.lyapunov(
            model.kind,
            model.params,
            model.damping,
            q0,
            v0,
            streams,
            d0=d0,
            dt=dt,
            steps=interval_steps,
            count=count,
            interval=interval,
            cpu=cpu,
        )
        lyapunov_s = time.perf_counter() - start
    q = np.asarray(Q[:, :nv], dtype=np.float64)
    v = np.asarray(V[:, :nv], dtype=np.float64)
    return DeviceMeasures(q, v, np.asarray(drift), np.asarray(flags), exponents, wall, lyapunov_s)


def _with_twin(
    model: DeviceModel,
    q0: Array,
    v0: Array,
    streams: NDArray[np.uint64],
    dt: float,
    steps: int,
    count: int,
    span: float,
    d0: float,
    cpu: bool,
) -> DeviceMeasures:
    """:func:`measures` in one launch of :func:`twin_kernel` (float64): each run and its twin in one thread."""
    n, nv = q0.shape
    p, b, Q, V = cuda_batch._padded(model.params, model.damping, q0, v0, np.float64)
    lower, upper = np.full(2, -np.inf), np.full(2, np.inf)
    lower[:nv], upper[:nv] = model.lower, model.upper
    limits = np.array([model.potential_offset, model.growth, model.reference_energy, *lower, *upper])
    S = np.ascontiguousarray(streams, dtype=np.uint64)
    if S.shape != (n,):
        raise InputError(f"streams must have shape ({n},), got {S.shape}")
    drift, flags, out = np.empty(n), np.empty(n, dtype=np.int8), np.empty(n)
    if cpu:
        kernel = cpu_twin_kernel(model.kind)
        start = time.perf_counter()
        kernel(p, b, nv, limits, Q, V, S, drift, flags, out, dt, steps, count, span, d0)
        wall = time.perf_counter() - start
    else:
        module = cuda_batch.cuda_module()
        kernel = twin_kernel(model.kind)
        p_d, b_d, limits_d, Q_d, V_d, S_d = (module.to_device(x) for x in (p, b, limits, Q, V, S))
        drift_d, flags_d = module.device_array(n, dtype=np.float64), module.device_array(n, dtype=np.int8)
        out_d = module.device_array(n, dtype=np.float64)
        blocks = cuda_batch.blocks_for(n)
        with cuda_batch.quiet():
            module.synchronize()
            start = time.perf_counter()
            kernel[blocks, cuda_batch.THREADS_PER_BLOCK](
                p_d, b_d, nv, limits_d, Q_d, V_d, S_d, drift_d, flags_d, out_d, dt, steps, count, span, d0
            )
            module.synchronize()
            wall = time.perf_counter() - start
        Q, V = Q_d.copy_to_host(), V_d.copy_to_host()
        drift, flags, out = drift_d.copy_to_host(), flags_d.copy_to_host(), out_d.copy_to_host()
    q, v = np.asarray(Q[:, :nv], dtype=np.float64), np.asarray(V[:, :nv], dtype=np.float64)
    return DeviceMeasures(q, v, np.asarray(drift), np.asarray(flags), np.asarray(out), wall, 0.0)


def columns(measured: DeviceMeasures, names: tuple[str, ...], joint_names: tuple[str, ...]) -> dict[str, Any]:
    """The sweep's measure columns from the device's arrays, without a loop over the runs.

    ``status`` (a list: "ok", or "diverged" where the final state is not finite), then the
    measures in the order of ``names`` (``final_state`` as ``q.<joint>``, ``v.<joint>`` joint by
    joint; ``wall_time`` the kernel's time shared evenly [s]), ``lyapunov`` [1/s] last: the
    columns, in that order, that a sweep's per-run rows give.
    """
    n = measured.q.shape[0]
    status = ["ok"] * n
    for k in np.flatnonzero(~measured.finite):
        status[k] = "diverged"
    out: dict[str, Any] = {"status": status}
    for name in names:
        if name == "final_state":
            for j, joint in enumerate(joint_names):
                out[f"q.{joint}"], out[f"v.{joint}"] = measured.q[:, j].copy(), measured.v[:, j].copy()
        elif name == "energy_drift":
            out["energy_drift"] = measured.drift.copy()
        elif name == "wall_time":
            out["wall_time"] = np.full(n, measured.kernel_s / n)
    if "lyapunov" in names and measured.lyapunov is not None:
        out["lyapunov"] = measured.lyapunov.copy()
    return out


@dataclass(frozen=True, eq=False)
class DeviceTask:
    """A chunk's work for a GPU worker, as arrays: :func:`measures`'s arguments (see there)."""

    model: DeviceModel
    q0: Array
    v0: Array
    dt: float
    steps: int
    streams: NDArray[np.uint64] | None
    lyapunov_interval: float
    d0: float
    precision: str


def run_task(task: DeviceTask) -> DeviceMeasures:
    """Run a :class:`DeviceTask` on this process's GPU (what a sweep's GPU worker calls; no Pinocchio)."""
    return measures(
        task.model,
        task.q0,
        task.v0,
        dt=task.dt,
        steps=task.steps,
        streams=task.streams,
        lyapunov_interval=task.lyapunov_interval,
        d0=task.d0,
        precision=task.precision,
    )


def compile_measures(kind: str, precision: str = "float64", *, lyapunov: bool = False, cpu: bool = False) -> None:
    """Compile (or load) the kernels of :func:`measures` on one run of one step, outside any timing."""
    form = closed_form(kind)
    free = np.full(form.dof, math.inf)
    model = DeviceModel(kind, np.ones(len(form.params)), np.zeros(form.dof), -free, free, 0.0, 1.0, 1.0)
    streams = np.zeros(1, dtype=np.uint64) if lyapunov else None
    zero = np.zeros((1, form.dof))
    measures(model, zero, zero, dt=1e-3, steps=1, streams=streams, precision=precision, cpu=cpu)
