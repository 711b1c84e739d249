"""Many initial states at once: one parallel region per rollout, each thread stepping a block through all of time.

A batch of n states of a torque-free, lossless robot with nq == nv is split into blocks; one
numba ``prange`` hands the blocks to the threads, and each thread steps its states one after
the other through every step (no thread team per evaluation, no barrier per step). Blocks are
handed out dynamically (chunk size 1), so a thread that shares its core with another process
takes fewer blocks instead of holding the others back.

The step is the compiled one of :func:`robodyn.simulate`: the built-in kinds' closed form
(:mod:`robodyn.sim.fast`, classic RK4) or the compiled tree algorithms
(:mod:`robodyn.sim.tree`, any fixed-step explicit method: rk4, heun, euler), both checked
against Pinocchio before use, so a batch run equals n single runs up to round-off.

Threads: :func:`default_threads` uses the cores that are idle by the 1-minute load average
(at least 1): on a busy machine one thread, which measured never slower than two there.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import integrators
from robodyn.errors import InputError, RobodynError
from robodyn.kinds import params as params_module
from robodyn.sim import tree
from robodyn.sim.fast import KINDS, FastDynamics, batch_rk4

if TYPE_CHECKING:
    from robodyn.robot import Robot

Array = NDArray[np.float64]

# Blocks per thread: enough for a thread on a shared core to hand work to the others, few
# enough that a block's start-up (a workspace) stays negligible.
BLOCKS_PER_THREAD = 8
# Blocks hold at least this many states.
MIN_BLOCK = 4

_BATCH_METHODS = ("rk4", "heun", "euler")
DEVICES = ("cpu", "cuda")


@dataclass(frozen=True, eq=False)
class BatchResult:
    """Final states q (n, nq), v (n, nv) after ``steps`` steps of ``dt`` [s]; cost of the run.

    ``path`` is ``"closed_form"`` (a built-in kind's compiled closed form) or ``"tree"`` (the
    compiled tree algorithms); ``evaluations`` counts batch evaluations (stages times steps).
    ``device`` is ``"cpu"`` or ``"cuda"`` (one GPU thread a state: ``threads`` is then the batch
    size, and ``wall_time_s`` the kernel's time without the copies to and from the GPU).
    """

    q: Array
    v: Array
    dt: float
    steps: int
    integrator: str
    threads: int
    wall_time_s: float
    evaluations: int
    path: str = "tree"
    device: str = "cpu"

    @property
    def state_steps_per_second(self) -> float:
        """Throughput: states times steps advanced per wall-clock second."""
        return self.q.shape[0] * self.steps / self.wall_time_s


def default_threads() -> int:
    """Threads for a batch: the CPUs left idle by the 1-minute load average, at least 1."""
    cpus = os.cpu_count() or 1
    try:
        load = os.getloadavg()[0]
    except OSError:  # pragma: no cover - platforms without a load average
        return 1
    return max(1, min(cpus, int(cpus - load + 0.5)))


def blocks_for(n: int, threads: int) -> NDArray[np.int64]:
    """Block boundaries (nb + 1,) over n states: about ``BLOCKS_PER_THREAD`` blocks a thread."""
    nb = max(1, min(threads * BLOCKS_PER_THREAD, n // MIN_BLOCK))
    return np.linspace(0, n, nb + 1).round().astype(np.int64)


def _closed_form(robot: Robot, integrator: str) -> FastDynamics | None:
    if integrator != "rk4":
        return None
    kind = params_module.detect_kind(robot)
    if kind not in KINDS:
        return None
    try:
        return FastDynamics.from_robot(robot, kind)
    except RobodynError:
        return None


def rollout(
    robot: Robot,
    q0: ArrayLike,
    v0: ArrayLike,
    *,
    duration: float,
    dt: float,
    integrator: str = "rk4",
    threads: int | None = None,
    device: str = "cpu",
    dtype: Any = np.float64,
) -> BatchResult:
    """Advance every state of the batch (q0 (n, nq), v0 (n, nv)) by ``duration`` [s] in steps of ``dt`` [s].

    ``threads`` defaults to :func:`default_threads`. Only fixed-step explicit integrators
    (rk4, heun, euler) apply; the robot must be torque-free here, lossless and have nq == nv.
    ``device="cuda"`` runs on an NVIDIA GPU, one thread a state, float64: a built-in kind's closed
    form with rk4 (:mod:`robodyn.engine.cuda.batch`), any other robot the compiled tree path takes
    with rk4, heun or euler (:mod:`robodyn.engine.cuda.tree`, the CPU batch's kernels compiled for CUDA).
    ``dtype=np.float32`` (or ``"float32"``) runs a built-in kind's closed-form kernel in single
    precision, compiled from the same source, and returns float32 states
    (``benchmarks/bench_gpu.py`` states its error against float64); the tree kernels and the CPU
    paths are float64 only.

    Raises:
        InputError: shapes, an integrator or a robot the batch path does not take.
        MissingDependencyError: ``device="cuda"`` without numba's CUDA target (the ``cuda`` extra).
        UnavailableError: ``device="cuda"`` on a machine without a CUDA GPU.
    """
    if device not in DEVICES:
        raise InputError(f"device {device!r}: expected one of {', '.join(DEVICES)}")
    precision = _precision(dtype, device)
    if not robot.nq_equals_nv:
        raise InputError(f"{robot.name}: the batch path needs nq == nv, got nq={robot.nq}, nv={robot.nv}")
    if np.any(robot.damping) or np.any(robot.friction):
        raise InputError(f"{robot.name}: the batch path has no joint losses; damping or friction is set")
    Q = np.array(np.atleast_2d(np.asarray(q0, dtype=np.float64)))
    V = np.array(np.atleast_2d(np.asarray(v0, dtype=np.float64)))
    if Q.shape[1] != robot.nq or V.shape != Q.shape:
        raise InputError(f"q0 and v0 must both have shape (n, {robot.nq}), got {Q.shape} and {V.shape}")
    method = integrators.get(integrator)
    if method.name not in _BATCH_METHODS:
        raise InputError(
            f"integrator {integrator!r}: the batch path takes explicit fixed-step methods ({', '.join(_BATCH_METHODS)})"
        )
    if threads is not None and (not isinstance(threads, int) or threads < 1):
        raise InputError(f"threads must be a whole number >= 1, got {threads!r}")
    steps = integrators.step_count(duration, dt)
    n, nv = Q.shape
    if device == "cuda":
        return _cuda_rollout(robot, Q, V, dt=dt, steps=steps, integrator=method.name, precision=precision)
    threads = threads or default_threads()
    blocks = blocks_for(n, threads)
    fast = _closed_form(robot, method.name)
    if fast is None:
        from robodyn.sim.whole_run import method_code

        try:
            compiled = tree.compiled_of(robot)
        except RobodynError as exc:
            raise InputError(f"{robot.name}: the batch path cannot take this robot: {exc}") from None
        code = method_code(method)
        if code is None:  # pragma: no cover - rk4, heun and euler are the kernels' own
            raise InputError(f"integrator {integrator!r}: its step is not the one the batch kernels mirror")
        mcode, tab = code
        t = compiled.tree
        kernels = tree.kernels(t.flyer is not None)
        forces, springs = np.zeros((4, nv)), np.zeros((4, 0))
        forces[3, 0] = 1.0
    import numba

    numba.set_num_threads(min(threads, int(numba.config.NUMBA_NUM_THREADS)))  # type: ignore[attr-defined]
    with numba.parallel_chunksize(1):
        if fast is not None:
            Qp, Vp = np.zeros((n, 2)), np.zeros((n, 2))
            Qp[:, :nv], Vp[:, :nv] = Q, V
            one = np.array([0, 1], dtype=np.int64)  # load (or compile) the kernel outside the timing
            batch_rk4(fast, Qp[:1].copy(), Vp[:1].copy(), dt=dt, steps=0, blocks=one)
            start = time.perf_counter()
            batch_rk4(fast, Qp, Vp, dt=dt, steps=steps, blocks=blocks)
            wall = time.perf_counter() - start
            Q, V = Qp[:, :nv].copy(), Vp[:, :nv].copy()
        else:
            one = np.array([0, 1], dtype=np.int64)
            kernels.batch_rollout(
                t.itree, t.ftree, t.grav, t.flyer, mcode, tab, dt, 0, Q[:1].copy(), V[:1].copy(), forces, springs, one
            )
            start = time.perf_counter()
            kernels.batch_rollout(
                t.itree, t.ftree, t.grav, t.flyer, mcode, tab, dt, steps, Q, V, forces, springs, blocks
            )
            wall = time.perf_counter() - start
    stages = {"rk4": 4, "heun": 2, "euler": 1}[method.name]
    path = "closed_form" if fast is not None else "tree"
    return BatchResult(Q, V, dt, steps, method.name, threads, wall, stages * steps, path)


def _precision(dtype: Any, device: str) -> str:
    """``dtype`` as "float64" or "float32"; float32 on device cuda only (one line naming what was given)."""
    try:
        name = np.dtype(dtype).name
    except TypeError:
        name = ""
    if name not in ("float64", "float32"):
        raise InputError(f"dtype {dtype!r}: expected float64 (the default) or float32 (device cuda)")
    if name == "float32" and device != "cuda":
        raise InputError("dtype float32 runs on device cuda only; the CPU batch paths compute in float64")
    return name


def _cuda_rollout(
    robot: Robot, Q: Array, V: Array, *, dt: float, steps: int, integrator: str, precision: str = "float64"
) -> BatchResult:
    """The batch on the GPU: a built-in kind's closed form with rk4 (checked against ABA first), else the tree path.

    Any other robot the compiled tree path takes (checked against Pinocchio first) runs on
    :mod:`robodyn.engine.cuda.tree`, with the method the CPU batch would use (rk4, heun or euler),
    in float64 only.
    """
    fast = _closed_form(robot, integrator)
    if fast is not None:
        from robodyn.engine.cuda import batch as cuda_batch

        q, v, _, _, wall = cuda_batch.rollout(
            fast.kind, fast.param_vector, fast.damping, Q, V, dt=dt, steps=steps, precision=precision
        )
        return BatchResult(q, v, dt, steps, integrator, Q.shape[0], wall, 4 * steps, "closed_form", "cuda")
    if precision != "float64":
        raise InputError(
            f"{robot.name}: dtype {precision} runs a built-in kind's closed form with rk4 only "
            f"({', '.join(KINDS)}); the compiled tree kernels on device cuda are float64"
        )
    try:
        tree.compiled_of(robot)  # checked against Pinocchio once (cuda_tree_rollout takes it from the cache)
    except RobodynError as exc:
        raise InputError(
            f"{robot.name}: device cuda takes the built-in kinds ({', '.join(KINDS)}) and the robots "
            f"the compiled tree path takes; this one is neither: {exc}"
        ) from None
    q, v, _, _, wall = cuda_tree_rollout(robot, Q, V, dt=dt, steps=steps, integrator=integrator)
    stages = {"rk4": 4, "heun": 2, "euler": 1}[integrator]
    return BatchResult(q, v, dt, steps, integrator, Q.shape[0], wall, stages * steps, "tree", "cuda")


def cuda_tree_refusal(robot: Robot, integrator: str) -> str:
    """Why the GPU's tree kernels cannot run ``robot`` torque-free with ``integrator`` ("" when they can)."""
    from robodyn.engine.cuda.tree import METHODS

    if integrator not in METHODS:
        return f"integrator {', '.join(METHODS)} only, got {integrator!r}"
    why = tree.unsupported(robot)
    if why is not None:
        return f"the built-in kinds and the robots the compiled tree path takes only; {robot.name}: {why}"
    if not robot.nq_equals_nv:
        return f"robots with nq == nv only; {robot.name} has nq={robot.nq}, nv={robot.nv}"
    if np.any(robot.damping) or np.any(robot.friction):
        return "lossless runs only; the model has joint damping or friction"
    return ""


def cuda_tree_rollout(
    robot: Robot, Q: Array, V: Array, *, dt: float, steps: int, integrator: str
) -> tuple[Array, Array, Array, Array, float]:
    """The GPU's tree kernels (:func:`robodyn.engine.cuda.tree.rollout`) on ``robot``'s checked arrays.

    ``integrator`` is the CPU batch path's (rk4, heun, euler). Returns (q, v, q_min, q_max) and the
    kernel's wall time [s].

    Raises:
        AssumptionError: the compiled tree path cannot take the robot (:func:`robodyn.sim.tree.compiled_of`).
    """
    from robodyn.engine.cuda.tree import METHODS, rollout
    from robodyn.sim.whole_run import method_code

    t = tree.compiled_of(robot).tree
    code = method_code(integrators.get(integrator))
    if code is None or integrator not in METHODS:
        raise InputError(f"integrator {integrator!r}: device cuda takes {', '.join(METHODS)} on this path")
    return rollout(t.itree, t.ftree, t.grav, Q, V, dt=dt, steps=steps, method=code[0], tab=code[1])
