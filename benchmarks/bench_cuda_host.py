"""The host side of a ``device = "cuda"`` sweep chunk, measured on a CPU: what is left when the GPU is fast.

A 10^6-run Pendubot chaos map (measures final_state, energy_drift, lyapunov) is planned as one
chunk and computed by the sweep's own :func:`robodyn.sweep.chunk.execute`, with the GPU kernels
replaced by the same device functions on the CPU's cores (``cuda_sweep.measures(cpu=True)``) and
a duration of ``--steps`` steps, so that the kernels take little time and what remains is the
host's work: planning (the states, the chunk's digest), building the columns, and writing the
chunk's Parquet file with the sweep's store. Prints each part's seconds and saves them in
``OUT/cuda_host.json``::

    python benchmarks/bench_cuda_host.py --out bench-out --runs 1000000
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import platform
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

DT = 1e-3  # [s]


def measure(runs: int, steps: int) -> dict[str, Any]:
    import pyarrow.parquet  # noqa: F401 - imported outside the timing, as a worker has it loaded

    import robodyn.sweep as sweep
    from robodyn.engine.cuda import sweep as cuda_sweep
    from robodyn.sweep.store import Store

    side = math.isqrt(runs)
    spec = {
        "model": "pendubot",
        "duration": steps * DT,
        "dt": DT,
        "device": "cuda",
        "chunk": side * side,
        "measure": ["final_state", "energy_drift", "lyapunov"],
        "q0": {"joint1": {"from": -3.0, "to": 3.0, "n": side}, "joint2": {"from": -3.0, "to": 3.0, "n": side}},
    }
    kernels: dict[str, float] = {"kernel_s": 0.0}
    original = cuda_sweep.measures

    def on_cpu(*args: Any, **kwargs: Any) -> Any:  # the GPU launch replaced by the same functions on the CPU
        measured = original(*args, **{**kwargs, "cpu": True})
        kernels["kernel_s"] += measured.kernel_s + measured.lyapunov_s
        return measured

    cuda_sweep.compile_measures("pendubot", lyapunov=True, cpu=True)
    cuda_sweep.measures = functools.update_wrapper(on_cpu, original)  # type: ignore[assignment]
    out: dict[str, Any] = {"runs": side * side, "steps": steps}
    with tempfile.TemporaryDirectory() as folder:
        sweep.prepare(spec, folder)  # load the model and its closed form once, as a worker keeps them
        start = time.perf_counter()
        prepared = sweep.prepare(spec, folder)
        out["prepare_s"] = time.perf_counter() - start
        (chunk,) = prepared.plan.chunks
        sweep.chunk.execute(chunk, prepared.job)  # load the model, compile: outside the timing
        kernels["kernel_s"] = 0.0
        start = time.perf_counter()
        columns = sweep.chunk.execute(chunk, prepared.job)
        out["execute_s"] = time.perf_counter() - start
        out["kernels_on_cpu_s"] = kernels["kernel_s"]
        out["execute_host_s"] = out["execute_s"] - kernels["kernel_s"]
        store = Store(Path(folder), prepared.spec.digest, prepared.spec.source)
        start = time.perf_counter()
        store.write(chunk.id, columns)
        out["store_write_s"] = time.perf_counter() - start
        out["paths_simulate"] = sum(p == "simulate" for p in columns["path"])
    cuda_sweep.measures = original  # type: ignore[assignment]
    out["host_s"] = out["prepare_s"] + out["execute_host_s"] + out["store_write_s"]
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="folder for cuda_host.json")
    parser.add_argument("--runs", type=int, default=1_000_000, help="runs in the chunk (a square grid: rounded down)")
    parser.add_argument("--steps", type=int, default=2, help=f"RK4 steps of {DT * 1e3:g} ms a run (default 2)")
    args = parser.parse_args()
    if args.runs < 1 or args.steps < 1:
        parser.error("--runs and --steps must be >= 1")
    figures = measure(args.runs, args.steps)
    figures["run"] = {
        "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
        "cpu_cores": os.cpu_count(),
        "python": platform.python_version(),
        "command": " ".join(sys.argv),
    }
    f, n = figures, figures["runs"]
    print(
        f"cuda chunk of {n:,} runs, host side: prepare {f['prepare_s']:.3g} s, execute {f['execute_s']:.3g} s "
        f"(of which the kernels on the CPU {f['kernels_on_cpu_s']:.3g} s, host {f['execute_host_s']:.3g} s), "
        f"Parquet write {f['store_write_s']:.3g} s; host in all {f['host_s']:.3g} s "
        f"({f['host_s'] / n * 1e6:.3g} us a run); {f['paths_simulate']} runs recomputed by simulate"
    )
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "cuda_host.json"
    path.write_text(json.dumps(figures, indent=2) + "\n")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
