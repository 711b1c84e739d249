"""Sweep throughput on Dask: a Pendubot basin map on 1 and 2 workers, the Dask overhead, a 64-core projection.

    python benchmarks/bench_sweep.py --out /tmp/sweep-bench   (default: a temporary folder)

Each basin run: the Pendubot under LQR balance from a tilted start (q1 = pi/2 + dq1, q2 = dq2,
+-0.3 rad, at rest), 5 s at dt = 1 ms, classical RK4 with the torque re-evaluated at every stage,
accelerations from the compiled closed form (the sweep's ``closed_loop`` path, 1,000 runs a chunk,
vectorised over the chunk); measured: final state and time to balance. The "batch path alone" is
the same chunk function on all states in this process, without Dask. The projection times
chaos runs (free Pendubot, 20 s at dt = 1 ms, compiled RK4, Benettin's Lyapunov estimate with a
twin: two 20 s integrations a run) and scales them to 10^6 states on 64 cores.

The machine is shared: every figure is printed with the load average when it was taken.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

import robodyn.sweep as sweep
from robodyn.sweep import chunk as chunk_module
from robodyn.sweep.plan import Chunk

PENDUBOT_UP = float(np.pi / 2)


def basin(n_side: int) -> dict:
    return {
        "model": "pendubot",
        "duration": 5.0,
        "dt": 1e-3,
        "integrator": "rk4",
        "controller": "lqr",
        "measure": ["final_state", "time_to_balance"],
        "chunk": 1000,
        "q0": {
            "joint1": {"from": PENDUBOT_UP - 0.3, "to": PENDUBOT_UP + 0.3, "n": n_side},
            "joint2": {"from": -0.3, "to": 0.3, "n": n_side},
        },
    }


def load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def dask_run(spec: dict, workers: int, out: Path) -> dict:
    import distributed

    start = time.perf_counter()
    with (
        distributed.LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address="127.0.0.1:0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        client.run(chunk_module.fast_of, "pendubot")  # each worker compiles / loads numba's cache once
        ready = time.perf_counter()
        result = sweep.run(spec, out=out, client=client)
        done = time.perf_counter()
    runs = result.plan.n_runs
    return {
        "workers": workers,
        "runs": runs,
        "chunks": len(result.plan.chunks),
        "cluster_start_s": ready - start,
        "sweep_s": done - ready,
        "runs_per_s": runs / (done - ready),
        "load_avg": load(),
    }


def batch_alone(spec: dict, out: Path) -> dict:
    prepared = sweep.prepare(spec, out)
    chunks = prepared.plan.chunks
    q0 = np.concatenate([c.q0 for c in chunks])
    v0 = np.concatenate([c.v0 for c in chunks])
    runs = np.concatenate([c.runs for c in chunks])
    whole = Chunk("all", 0, chunks[0].setting, chunks[0].model, runs, q0, v0)
    chunk_module.fast_of("pendubot")
    start = time.perf_counter()
    chunk_module.execute(whole, prepared.job)
    wall = time.perf_counter() - start
    return {"runs": int(runs.size), "wall_s": wall, "runs_per_s": runs.size / wall, "load_avg": load()}


def chaos_cost(samples: int, out: Path) -> dict:
    spec = {
        "model": "pendubot",
        "duration": 20.0,
        "dt": 1e-3,
        "measure": ["lyapunov"],
        "chunk": samples,
        "q0": {"joint1": {"from": -3.0, "to": 3.0, "n": samples}, "joint2": 1.0},
    }
    prepared = sweep.prepare(spec, out)
    chunk_module.fast_of("pendubot")
    start = time.perf_counter()
    chunk_module.execute(prepared.plan.chunks[0], prepared.job)
    per_run = (time.perf_counter() - start) / samples
    return {"samples": samples, "seconds_per_run": per_run, "load_avg": load()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="folder for sweep.json (default: a temporary folder)")
    parser.add_argument("--side", type=int, default=100, help="basin grid side (default 100: 10^4 states)")
    parser.add_argument("--chaos-samples", type=int, default=8, help="chaos runs timed for the projection")
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="robodyn-sweep-bench-"))
    out.mkdir(parents=True, exist_ok=True)
    spec = basin(args.side)
    print(f"machine: {os.cpu_count()} CPUs, shared; load average at start {load()}")
    alone = batch_alone(spec, out / "alone")
    print(
        f"batch path alone (no Dask, 1 process): {alone['runs']} runs in {alone['wall_s']:.2f} s = "
        f"{alone['runs_per_s']:.0f} runs/s  [load {alone['load_avg']}]"
    )
    one = dask_run(spec, 1, out / "w1")
    two = dask_run(spec, 2, out / "w2")
    for r in (one, two):
        print(
            f"Dask, {r['workers']} worker(s): {r['runs']} runs in {r['chunks']} chunks, {r['sweep_s']:.2f} s = "
            f"{r['runs_per_s']:.0f} runs/s (cluster start {r['cluster_start_s']:.1f} s, not counted)"
            f"  [load {r['load_avg']}]"
        )
    efficiency = two["runs_per_s"] / (2 * one["runs_per_s"])
    overhead = one["sweep_s"] / alone["wall_s"] - 1.0
    print(
        f"scaling efficiency 1 -> 2 workers: {two['runs_per_s']:.0f} / (2 x {one['runs_per_s']:.0f}) = {efficiency:.0%}"
    )
    print(
        f"Dask overhead, 1 worker against the batch path alone: {one['sweep_s']:.2f} s / {alone['wall_s']:.2f} s - 1 "
        f"= {overhead:+.1%}"
    )
    chaos = chaos_cost(args.chaos_samples, out / "chaos")
    t_run = chaos["seconds_per_run"]
    states, cores = 10**6, 64
    eff = min(efficiency, 1.0)
    projected = states * t_run / (cores * eff)
    print(
        f"chaos run (20 s at 1 ms, compiled RK4 + Lyapunov twin): {t_run:.3f} s each on one core"
        f"  [load {chaos['load_avg']}]"
    )
    print(
        f"projection, 10^6 states on 64 cores: 10^6 x {t_run:.3f} s / (64 x {eff:.2f} efficiency) = {projected:,.0f} s "
        f"= {projected / 3600:.2f} h (plus cluster start; 1,000 chunks of 1,000 keep 64 workers busy)"
    )
    result = {
        "basin_run": "Pendubot LQR, 5 s at dt = 1 ms, RK4, closed_loop path (compiled closed form), chunks of 1,000",
        "batch_alone": alone,
        "dask_1_worker": one,
        "dask_2_workers": two,
        "scaling_efficiency": efficiency,
        "dask_overhead_vs_batch": overhead,
        "chaos_run": chaos,
        "projection": {
            "states": states,
            "cores": cores,
            "efficiency": eff,
            "seconds": projected,
            "arithmetic": f"{states} * {t_run:.4f} / ({cores} * {eff:.3f})",
        },
    }
    path = out / "sweep.json"
    path.write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
