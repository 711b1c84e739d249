"""bench_gpu.py's MJX column: a batch of torque-free RK4 runs in MJX (float32) beside robodyn's float64 GPU kernel.

``run(label, urdf, joints, Q, V, steps=, dt=, reference=, armature=)`` loads the URDF text into
MuJoCo (contacts, limits and equality constraints off, no damping or friction loss, the tree's
armatures where given), steps ``jax.jit(jax.vmap(...))`` of ``mjx.step`` from the same starts as
robodyn's kernel (best of ``REPEATS`` after one compiling call), and compares the final states with
``reference(Q, V)`` (robodyn's kernel: ``(q, v, ..., kernel wall time [s])``). Returns the figures,
or why MJX did not run (not installed) or failed on the model: a result, not a crash.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np

REPEATS = 3


def run(
    label: str,
    urdf: str,
    joints: Any,
    Q: np.ndarray,
    V: np.ndarray,
    *,
    steps: int,
    dt: float,
    reference: Callable[[np.ndarray, np.ndarray], Any],
    armature: np.ndarray | None = None,
) -> dict[str, Any]:
    """MJX (float32) from the starts Q, V (n, nv): speed, speed of robodyn's kernel over it, largest difference."""
    try:
        import jax
        import mujoco
        from mujoco import mjx
    except Exception as exc:  # not installed here: the figure is left out, and the reason is kept
        print(f"{label:10s} MJX not run: {type(exc).__name__}: {exc}")
        return {"skipped": f"{type(exc).__name__}: {exc}"}
    try:
        m = mujoco.MjModel.from_xml_string(urdf)
        m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
        m.opt.timestep = dt
        off = mujoco.mjtDisableBit
        m.opt.disableflags |= off.mjDSBL_CONTACT | off.mjDSBL_LIMIT | off.mjDSBL_EQUALITY
        names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)]
        idx = np.array([int(m.jnt_dofadr[names.index(str(j))]) for j in joints])
        if m.nv != idx.size:
            raise ValueError(f"MuJoCo has {m.nv} degrees of freedom, robodyn's model {idx.size}")
        m.dof_damping[:] = 0.0
        m.dof_frictionloss[:] = 0.0
        if armature is not None:
            m.dof_armature[idx] = armature
        mx = mjx.put_model(m)
        n = Q.shape[0]
        qpos, qvel = np.zeros((n, m.nq), np.float32), np.zeros((n, m.nv), np.float32)
        qpos[:, idx], qvel[:, idx] = Q, V

        def one(q: Any, v: Any) -> Any:
            d = mjx.make_data(mx).replace(qpos=q, qvel=v)
            d = jax.lax.fori_loop(0, steps, lambda _, x: mjx.step(mx, x), d)
            return d.qpos, d.qvel

        fn = jax.jit(jax.vmap(one))
        start = time.perf_counter()
        jax.block_until_ready(fn(qpos, qvel))
        compile_s = time.perf_counter() - start
        best = float("inf")
        for _ in range(REPEATS):
            start = time.perf_counter()
            out = jax.block_until_ready(fn(qpos, qvel))
            best = min(best, time.perf_counter() - start)
        ref = reference(Q, V)
        diff = max(
            float(np.max(np.abs(np.asarray(out[0])[:, idx] - ref[0]))),
            float(np.max(np.abs(np.asarray(out[1])[:, idx] - ref[1]))),
        )
        ratio = best / ref[-1]  # robodyn's float64 state-steps per second over MJX's float32 ones
        print(f"{label:10s} {n:>8,} states  MJX float32 {n * steps / best:9.3g} state-steps/s (compiled in "
              f"{compile_s:.3g} s)  GPU float64 / MJX {ratio:.3g}x  max |diff| {diff:.2g}")  # fmt: skip
        return {
            "states": n,
            "dtype": "float32",
            "compile_s": compile_s,
            "mjx_s": best,
            "mjx_state_steps_per_s": n * steps / best,
            "gpu_float64_s": ref[-1],
            "gpu_float64_over_mjx_float32": ratio,
            "mjx_vs_gpu_float64_max_abs_diff": diff,
            "jax": jax.__version__,
            "mujoco": mujoco.__version__,
        }
    except Exception as exc:  # MJX failing on this model is a result to report, not a crash of the benchmark
        print(f"{label:10s} MJX failed: {type(exc).__name__}: {str(exc)[:200]}")
        return {"failed": f"{type(exc).__name__}: {str(exc)[:500]}"}


if __name__ == "__main__":  # pragma: no cover - a helper of bench_gpu.py
    raise SystemExit(f"run benchmarks/bench_gpu.py, not {os.path.basename(__file__)}")
