"""bench_gpu.py's Panda: the tree algorithms on the GPU (robodyn.engine.cuda.tree) against the CPU batch kernel and MJX.

``prepare(folder)`` (where robodyn is installed) writes ``DIR/panda.npz``: the Panda of
example-robot-data with its fingers fixed (locked at 0 m), lossless, as the tree arrays the
compiled path reads (``itree``, ``ftree``, ``grav``, checked against Pinocchio by
``tree.compiled_of``), nq, nv, joint names, armatures, and the URDF text MuJoCo reads (geometry
stripped, the finger joints made fixed).

``run(folder, ...)`` (numpy + numba only: no Pinocchio) runs batches of seeded states for
``min(--steps, PANDA_STEPS)`` torque-free RK4 steps of 1 ms with the stops off (no events: the
batch path has none) on the GPU (float64, one thread a state, best of 3), the same arithmetic on all
CPU cores (``tree_steps.batch_rollout``, numba ``prange``) up to ``CPU_MAX_STATES``, and MJX
(float32, one batch of ``MJX_STATES``: its compilation takes 24-45 s per batch size) when it imports.
"""

from __future__ import annotations

import os
import re
import time
from pathlib import Path
from typing import Any

import numpy as np

PANDA_STEPS = 200
FINGERS = ("panda_finger_joint1", "panda_finger_joint2")
# The CPU kernel on 16 cores does ~5e6 Panda state-steps/s: 2^15 states x 200 steps x 3 repeats ~ 4 s.
CPU_MAX_STATES = 2**15
MJX_STATES = 2**15
# The GPU batches stop growing once the next size (twice the last, best of 3) would pass this many seconds.
GPU_BUDGET_S = 60.0
REPEATS = 3
SEED = 1
# The starts: every joint within +-START_RANGE of zero [rad], speeds within +-1 rad/s.
START_RANGE = 1.0


def prepare(folder: Path) -> str:
    import robodyn
    from robodyn.sim import tree

    robot = robodyn.load("panda", lock=dict.fromkeys(FINGERS, 0.0))
    robot.model.damping[:] = 0.0  # the batch path is lossless
    robot.model.friction[:] = 0.0
    t = tree.compiled_of(robot).tree  # checked against Pinocchio on seeded states
    full = robodyn.load("panda")
    np.savez(
        folder / "panda.npz",
        itree=t.itree,
        ftree=t.ftree,
        grav=t.grav,
        nq=t.nq,
        nv=t.nv,
        joints=np.array(robot.joint_names),
        armature=robot.armature,
        urdf=np.array(mujoco_text(Path(full.urdf_path).read_text())),
    )
    return f"panda ({t.itree.shape[0]} joints, fingers fixed: tree arrays, URDF for MuJoCo)"


def mujoco_text(urdf: str) -> str:
    """The URDF without geometry, the finger joints fixed, with MuJoCo's compiler options (as bench_mujoco.py)."""
    text = re.sub(r"<(visual|collision)\b.*?</\1>", "", urdf, flags=re.S)
    for name in FINGERS:
        text, count = re.subn(rf'(<joint\s+name="{name}"\s+type=")prismatic(")', r"\1fixed\2", text)
        if count != 1:
            raise SystemExit(f"the Panda's URDF has no prismatic joint {name}")
    start = re.search(r"<robot\b[^>]*>", text)
    if start is None:
        raise SystemExit("no <robot> tag in the Panda's URDF")
    compiler = (
        '<mujoco><compiler discardvisual="true" fusestatic="false" balanceinertia="false" angle="radian"/></mujoco>'
    )
    return text[: start.end()] + compiler + text[start.end() :]


def starts(n: int, nv: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(SEED)
    return rng.uniform(-START_RANGE, START_RANGE, (n, nv)), rng.uniform(-1.0, 1.0, (n, nv))


def run(folder: Path, *, sizes: tuple[int, ...], steps: int, mjx: bool) -> dict[str, Any]:
    """The Panda's rows for gpu.json: GPU and CPU state-steps/s by batch size, agreement, MJX."""
    from robodyn.engine.cuda import tree as cuda_tree

    model = np.load(folder / "panda.npz")
    itree, ftree, grav = model["itree"], model["ftree"], model["grav"]
    nv = int(model["nv"])
    steps = min(steps, PANDA_STEPS)
    print(f"panda: {itree.shape[0]} joints, {steps} RK4 steps of 1 ms, stops off, float64")
    start = time.perf_counter()
    cuda_tree.rollout(itree, ftree, grav, *starts(1, nv), dt=1e-3, steps=0)  # compile the kernel once, timed
    compile_s = time.perf_counter() - start
    print(f"panda: the CUDA kernel compiled in {compile_s:.3g} s")
    rows, skipped, last, spent = [], [], 0.0, 0.0
    for n in sizes:
        if last and spent + 2 * REPEATS * last > GPU_BUDGET_S:
            skipped.append(n)
            continue
        Q, V = starts(n, nv)
        best, out = float("inf"), None
        for _ in range(REPEATS):
            out = cuda_tree.rollout(itree, ftree, grav, Q, V, dt=1e-3, steps=steps)
            best = min(best, out[-1])
        last, spent = best, spent + REPEATS * best
        row: dict[str, Any] = {"states": n, "gpu_s": best, "gpu_state_steps_per_s": n * steps / best}
        line = f"panda      {n:>8,} states  GPU {n * steps / best:9.3g} state-steps/s"
        if n <= CPU_MAX_STATES:
            cpu_best, cpu = _cpu(itree, ftree, grav, Q, V, steps)
            diff = max(float(np.max(np.abs(out[0] - cpu[0]))), float(np.max(np.abs(out[1] - cpu[1]))))
            row |= {"cpu_s": cpu_best, "cpu_state_steps_per_s": n * steps / cpu_best, "gpu_vs_cpu_max_abs_diff": diff}
            line += f"  CPU {n * steps / cpu_best:9.3g} state-steps/s  GPU/CPU {cpu_best / best:7.3g}x"
            line += f"  max |diff| {diff:.2g} rad, rad/s"
        print(line)
        rows.append(row)
    if skipped:
        left = ", ".join(map(str, skipped))
        print(f"panda: sizes {left} left out: the next would pass {GPU_BUDGET_S:g} s of kernel time")
    entry: dict[str, Any] = {
        "joints": [str(j) for j in model["joints"]],
        "steps": steps,
        "bytes_per_state": cuda_tree.bytes_per_state(itree.shape[0], int(model["nq"]), nv),
        "gpu_compile_s": compile_s,
        "batches": rows,
        "skipped_sizes": skipped,
    }
    if mjx:
        entry["mjx"] = _mjx(model, min(MJX_STATES, max(sizes)), steps)
    return entry


def _cpu(itree: np.ndarray, ftree: np.ndarray, grav: np.ndarray, Q: np.ndarray, V: np.ndarray, steps: int) -> Any:
    """tree_steps.batch_rollout (the CPU batch path's kernel) on all cores: best wall time [s] of REPEATS, (q, v)."""
    import numba

    from robodyn.engine.tree import steps as tree_steps
    from robodyn.engine.tree.layout import flyer_of

    n, nv = Q.shape
    forces, springs, tab = np.zeros((4, nv)), np.zeros((4, 0)), np.zeros((6, 4))
    forces[3, 0] = 1.0
    threads = int(numba.config.NUMBA_NUM_THREADS)
    blocks = np.linspace(0, n, max(1, min(8 * threads, n // 4)) + 1).round().astype(np.int64)
    one = np.array([0, 1], dtype=np.int64)
    flyer = flyer_of(itree)
    with numba.parallel_chunksize(1):
        tree_steps.batch_rollout(
            itree, ftree, grav, flyer, 1, tab, 1e-3, 0, Q[:1].copy(), V[:1].copy(), forces, springs, one
        )
        best, q, v = float("inf"), Q, V
        for _ in range(REPEATS):
            q, v = Q.copy(), V.copy()
            start = time.perf_counter()
            tree_steps.batch_rollout(itree, ftree, grav, flyer, 1, tab, 1e-3, steps, q, v, forces, springs, blocks)
            best = min(best, time.perf_counter() - start)
    return best, (q, v)


def _mjx(model: Any, n: int, steps: int) -> dict[str, Any]:
    """MJX (float32) from the float64 GPU kernel's starts, the tree's armatures in (benchmarks/_gpu_mjx.py)."""
    import _gpu_mjx  # beside this file, on sys.path when bench_gpu.py runs

    from robodyn.engine.cuda import tree as cuda_tree

    Q, V = starts(n, int(model["nv"]))

    def reference(Q: np.ndarray, V: np.ndarray) -> Any:
        return cuda_tree.rollout(model["itree"], model["ftree"], model["grav"], Q, V, dt=1e-3, steps=steps)

    urdf, joints, armature = str(model["urdf"]), model["joints"], model["armature"]
    return _gpu_mjx.run("panda", urdf, joints, Q, V, steps=steps, dt=1e-3, reference=reference, armature=armature)


if __name__ == "__main__":  # pragma: no cover - a helper of bench_gpu.py
    raise SystemExit(f"run benchmarks/bench_gpu.py, not {os.path.basename(__file__)}")
