"""Any robot the compiled tree path takes, as a batch on an NVIDIA GPU: the CPU kernels, compiled for CUDA.

One GPU thread advances one state of the batch through every step of a fixed-step explicit method
(rk4, heun, euler: the codes and tableaux of :func:`robodyn.sim.whole_run.method_code`), torque-free,
in float64, from the arrays :mod:`robodyn.sim.tree` extracts from Pinocchio (``itree``, ``ftree``,
``grav``): fixed-base trees and a free-flyer root alike (q (n, nq), v (n, nv)). A robot is handed
here by :func:`robodyn.sim.batch.cuda_tree_rollout`.

No formula is written here. :func:`device_functions` rebuilds each kernel of
:mod:`robodyn.engine.tree.body`, :mod:`~robodyn.engine.tree.flyer`, :mod:`~robodyn.engine.tree.local`
(the ABA's passes in each joint's axes, where the model's ``F_LOCAL`` asks), :mod:`~robodyn.engine.tree.algorithms`
(``offset``, ``parent_acceleration``, ``pass_to_parent``, ``kinematics``, ``aba_passes``, ``aba``,
``integrate``) and :mod:`~robodyn.engine.tree.steps` (``rates``, ``stages``, ``step``) from its Python
source (``py_func``) with the names it calls bound to
their device versions, and compiles it with ``cuda.jit(device=True)``. The one kernel with no GPU form,
``tree_steps._callable_torque`` (a user's torque callable, in numba's object mode), becomes
:func:`_no_torque`, which the batch never reaches (its callable key is -1, as on the CPU). The kernel
below is the per-state loop of :func:`robodyn.engine.tree.steps.batch_rollout`, so the GPU does the CPU
batch path's arithmetic term for term: equal to round-off (to the bit in numba's CUDA simulator).
Each thread also keeps each coordinate's smallest and largest value on the way (a sweep hands the
runs that passed a URDF position limit to :func:`robodyn.simulate`).

Memory: each thread's workspace ``ws`` (n_bodies, WCOLS), stage buffer (2 s + 3, nv + 2) and eight
vectors live in global device arrays with the state index last (``WS[:, :, r]``), so that the
threads of a warp touch consecutive addresses. Per state that is
8 (139 n_bodies + 17 (nv + 2) + 8 max(nq, nv + 2)) bytes (:func:`bytes_per_state`): 9.6 kB for the
Panda with its fingers fixed (7 joints), 42 kB for Talos with a fixed base (32); plus (n, nq + nv)
float64 in and out. A batch whose workspace would pass
:data:`WORKSPACE_BYTES` runs in several launches over one workspace.

Needs only NumPy, numba's CUDA target and the tree kernels' modules (no Pinocchio): a GPU worker
runs it from the saved arrays (``benchmarks/bench_gpu.py --run``). ``NUMBA_ENABLE_CUDASIM=1`` before
numba is first imported runs the same kernels in numba's CUDA simulator (a Python thread a state).
"""

from __future__ import annotations

import time
import types
from collections.abc import Callable
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.engine.cuda import batch as cuda_batch
from robodyn.engine.tree.layout import FCOLS, WCOLS
from robodyn.errors import InputError

Array = NDArray[np.float64]

# Threads per CUDA block, as the built-in kinds' kernel.
THREADS_PER_BLOCK = cuda_batch.THREADS_PER_BLOCK
# The largest workspace of one launch [bytes]: 2^20 Panda states (10 GB) in two launches, Talos's
# (44 GB) in six, well inside an 80 GB GPU beside the batch's own arrays.
WORKSPACE_BYTES = 8 * 2**30
# The stage buffer's stages: tree_steps.batch_rollout's max(tableau stages, 7).
MIN_STAGES = 7
# The methods, as the CPU batch path's (robodyn.sim.batch): explicit, fixed-step, their kernels' own arithmetic.
METHODS = ("rk4", "heun", "euler")
# Rows of the per-thread vectors: qs, k0, q, u, q1, u1, q_min, q_max.
VECTORS = 8

# The kernels compiled for the device, callees before their callers, by module of robodyn.sim.
CHAIN = (
    ("tree_body", ("body",)),
    (
        "tree_flyer",
        ("ff_placement", "ff_motion", "ff_force", "ff_joint_inertia", "ff_root_acceleration", "ff_integrate"),
    ),
    ("tree_flyer", ("ff_kinematics",)),
    (
        "tree_local",
        (
            "_offset",
            "local_inertia",
            "frame",
            "to_local",
            "pass_to_parent_local",
            "parent_acceleration_local",
            "root_gravity_local",
        ),
    ),
    (
        "tree_kernels",
        ("offset", "parent_acceleration", "pass_to_parent", "kinematics", "aba_passes", "aba", "integrate"),
    ),
    ("tree_steps", ("rates", "stages", "step")),
)

# numba.cuda, set by _cuda(). The kernel reaches it as a module global: numba's CUDA simulator
# patches a kernel's globals, not the names a closure captured.
cuda: Any = None


def _no_torque(cb, t, q, v):  # type: ignore[no-untyped-def]
    """Stands for ``tree_steps._callable_torque`` (object mode has no GPU form); never called: cb is -1."""
    return v


def rebuilt(kernel: Any, devices: dict[str, Any]) -> types.FunctionType:
    """``kernel``'s Python function with each global it names that is in ``devices`` bound to that one."""
    f = kernel.py_func
    names = {name: devices[name] for name in f.__code__.co_names if name in devices}
    return types.FunctionType(f.__code__, {**f.__globals__, **names}, f.__name__, f.__defaults__, f.__closure__)


def device_functions(jit: Callable[[Any], Any]) -> dict[str, Any]:
    """Every kernel of :data:`CHAIN` rebuilt over its callees' device versions and compiled by ``jit``, by name.

    ``jit`` is ``cuda.jit(device=True)``; the identity gives the plain Python functions (the tests
    check that none of them still calls a CPU kernel).
    """
    from robodyn.engine.tree import algorithms as tree_kernels
    from robodyn.engine.tree import body as tree_body
    from robodyn.engine.tree import flyer as tree_flyer
    from robodyn.engine.tree import local as tree_local
    from robodyn.engine.tree import steps as tree_steps

    modules = {
        "tree_body": tree_body,
        "tree_flyer": tree_flyer,
        "tree_local": tree_local,
        "tree_kernels": tree_kernels,
        "tree_steps": tree_steps,
    }
    made: dict[str, Any] = {"_callable_torque": jit(_no_torque)}
    for module_name, names in CHAIN:
        module = modules[module_name]
        for name in names:
            made[name] = jit(rebuilt(getattr(module, name), made))
    return made


def _cuda() -> Any:
    global cuda
    cuda = cuda_batch.cuda_module()
    return cuda


@cache
def rollout_kernel() -> Any:
    """The CUDA kernel ``(itree, ftree, grav, method, tab, h, steps, Q, V, forces, springs, WS, BUF, VEC, offset)``.

    Thread r advances state ``offset + r`` of Q (n, nq), V (n, nv) in place through ``steps`` steps of h [s]
    and leaves its coordinates' range in ``VEC[6, :nq, r]`` (smallest) and ``VEC[7, :nq, r]`` (largest).
    """
    module = _cuda()
    step = device_functions(module.jit(device=True))["step"]

    @module.jit
    def kernel(itree, ftree, grav, method, tab, h, steps, Q, V, forces, springs, WS, BUF, VEC, offset):  # type: ignore[no-untyped-def]
        r = cuda.grid(1)
        g = offset + r
        if r >= WS.shape[2] or g >= Q.shape[0]:
            return
        nq = Q.shape[1]
        nv = V.shape[1]
        ws = WS[:, :, r]
        buf = BUF[:, :, r]
        qs, k0, q, u = VEC[0, :nq, r], VEC[1, : nv + 2, r], VEC[2, :nq, r], VEC[3, : nv + 2, r]
        q1, u1, lo, hi = VEC[4, :nq, r], VEC[5, : nv + 2, r], VEC[6, :nq, r], VEC[7, :nq, r]
        for i in range(ws.shape[0]):  # zeros, as batch_rollout's np.zeros (W_LOCK = 0: no joint held)
            for j in range(ws.shape[1]):
                ws[i, j] = 0.0
        for i in range(buf.shape[0]):
            for j in range(buf.shape[1]):
                buf[i, j] = 0.0
        for j in range(nq):
            q[j] = Q[g, j]
            lo[j] = q[j]
            hi[j] = q[j]
        for j in range(nv + 2):
            u[j] = V[g, j] if j < nv else 0.0
            u1[j] = 0.0
        for _ in range(steps):  # flyer True: each row's type decides, one kernel for every tree
            step(itree, ftree, grav, True, method, tab, 0.0, h, q, u, forces, springs, -1, ws, buf, qs, q1, u1, k0)
            for j in range(nq):
                q[j] = q1[j]
                lo[j] = min(lo[j], q1[j])
                hi[j] = max(hi[j], q1[j])
            for j in range(nv + 2):
                u[j] = u1[j]
        for j in range(nq):
            Q[g, j] = q[j]
        for j in range(nv):
            V[g, j] = u[j]

    return kernel


def bytes_per_state(n_bodies: int, nq: int, nv: int, stages: int = MIN_STAGES) -> int:
    """The device memory one state's thread works in [bytes] (workspace, stage buffer, vectors; not Q, V)."""
    return 8 * (n_bodies * WCOLS + (2 * stages + 3) * (nv + 2) + VECTORS * max(nq, nv + 2))


def launch_size(n: int, n_bodies: int, nq: int, nv: int, stages: int = MIN_STAGES) -> int:
    """States per launch: all n, or as many whole blocks of threads as :data:`WORKSPACE_BYTES` holds."""
    fit = WORKSPACE_BYTES // bytes_per_state(n_bodies, nq, nv, stages)
    return int(max(1, min(n, max(THREADS_PER_BLOCK, fit // THREADS_PER_BLOCK * THREADS_PER_BLOCK))))


def rollout(
    itree: NDArray[np.int64],
    ftree: Array,
    grav: Array,
    Q: Array,
    V: Array,
    *,
    dt: float,
    steps: int,
    method: int = 1,
    tab: Array | None = None,
) -> tuple[Array, Array, Array, Array, float]:
    """Torque-free steps on the GPU from Q (n, nq), V (n, nv): (q, v, q_min, q_max) and the kernels' time [s].

    ``method``, ``tab``: a code and tableau of :func:`robodyn.sim.whole_run.method_code` (default: RK4,
    code 1). q_min, q_max (n, nq) are each coordinate's range over the steps. The wall time covers
    the launches alone (compiled beforehand), not the copies.

    Raises:
        InputError: ``ftree`` is not in this robodyn's layout (arrays saved by another version).
    """
    if ftree.ndim != 2 or ftree.shape[1] != FCOLS:
        raise InputError(
            f"ftree has shape {ftree.shape}, expected (bodies, {FCOLS}): the tree's arrays of another robodyn "
            "version; read them from the model again (robodyn.sim.tree.extract)"
        )
    module = _cuda()
    kernel = rollout_kernel()
    tab = np.zeros((6, 4)) if tab is None else np.ascontiguousarray(tab, dtype=np.float64)
    n, nq = Q.shape
    nv = V.shape[1]
    nb = itree.shape[0]
    stages = max(tab.shape[1], MIN_STAGES)
    forces, springs = np.zeros((4, nv)), np.zeros((4, 0))
    forces[3, 0] = 1.0  # the friction velocity scale, as batch.rollout (no friction: unused)
    model = [module.to_device(np.ascontiguousarray(a)) for a in (itree, ftree, grav)]
    extra = [module.to_device(a) for a in (tab, forces, springs)]
    Q_d = module.to_device(np.ascontiguousarray(Q, dtype=np.float64))
    V_d = module.to_device(np.ascontiguousarray(V, dtype=np.float64))
    size = launch_size(n, nb, nq, nv, stages)
    width = max(nq, nv + 2)
    WS = module.device_array((nb, WCOLS, size), dtype=np.float64)
    BUF = module.device_array((2 * stages + 3, nv + 2, size), dtype=np.float64)
    VEC = module.device_array((VECTORS, width, size), dtype=np.float64)
    lo, hi = np.empty((n, nq)), np.empty((n, nq))
    with cuda_batch.quiet():
        # compile (or load) outside the timing: one thread, no step
        kernel[1, 1](*model, method, extra[0], dt, 0, Q_d[:1], V_d[:1], extra[1], extra[2], WS, BUF, VEC, n)
        module.synchronize()
        wall = 0.0
        for offset in range(0, n, size):
            count = min(size, n - offset)
            start = time.perf_counter()
            kernel[cuda_batch.blocks_for(count), THREADS_PER_BLOCK](
                *model, method, extra[0], dt, steps, Q_d, V_d, extra[1], extra[2], WS, BUF, VEC, offset
            )
            module.synchronize()
            wall += time.perf_counter() - start
            ranges = VEC[6:8].copy_to_host()  # a whole leading slice: contiguous on the device
            lo[offset : offset + count] = ranges[0, :nq, :count].T
            hi[offset : offset + count] = ranges[1, :nq, :count].T
    return Q_d.copy_to_host(), V_d.copy_to_host(), lo, hi, wall
