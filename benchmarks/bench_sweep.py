"""Sweep throughput on Dask: a Pendubot basin map on 1 and 2 workers, the Dask overhead, a 64-core projection.

    python benchmarks/bench_sweep.py                      # writes bench-out/sweep.json (and the sweeps' folders)
    python benchmarks/bench_sweep.py --out /tmp/sweep-bench

Each basin run: the Pendubot under LQR balance from a tilted start (q1 = pi/2 + dq1, q2 = dq2,
+-0.3 rad, at rest), 5 s at dt = 1 ms, classical RK4 with the torque re-evaluated at every stage,
accelerations from the compiled closed form (the sweep's ``closed_loop`` path, 1,000 runs a chunk,
vectorised over the chunk); measured: final state and time to balance. The "batch path alone" is
the same chunk function on the same chunks, one after the other in this process, without Dask.
The projection times chaos runs (free Pendubot, 20 s of chaotic motion at dt = 1 ms, compiled
RK4, Benettin's Lyapunov estimate with a twin) one by one and scales the measured per-run CPU time (which
contention does not inflate, unlike wall time) to 10^6 states on 64 cores, printing its arithmetic.

The machine is shared: every timed phase samples ``os.getloadavg()`` (1-minute average) every
second; each figure is printed with the mean and the peak of those samples. A phase whose mean
load exceeds the CPU count by more than ``CONTENDED_MARGIN`` had more runnable processes than
cores, so its workers waited for a CPU: the report says so and calls that figure
unrepresentative (the 1-minute average lags by tens of seconds, so the samples understate a
load that rose during a short phase).

The JSON (``--out``/sweep.json, default ``bench-out/``) holds ``run`` (the date, the machine, the
load before and after, the versions and the command: ``benchmarks/_common.py``) and every figure
with the load of its phase. The script refuses an ``--out`` inside the checkout's docs/ or one
holding files under version control, unless ``--overwrite-committed`` is given.
"""

from __future__ import annotations

import datetime
import os
import platform
import sys
import threading
import time
from pathlib import Path

import numpy as np

import robodyn
import robodyn.sweep as sweep
from robodyn.sweep import chunk as chunk_module

from _common import argument_parser, output_folder, run_facts, write_json

PENDUBOT_UP = float(np.pi / 2)
# A phase is contended when its mean 1-minute load exceeds the CPU count by more than this.
CONTENDED_MARGIN = 0.5
REPO = Path(__file__).resolve().parents[1]


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


class LoadSampler:
    """Samples os.getloadavg()[0] every ``period`` seconds while the ``with`` block runs."""

    def __init__(self, period: float = 1.0) -> None:
        self.period = period
        self.samples: list[float] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)

    def _loop(self) -> None:
        while True:
            self.samples.append(os.getloadavg()[0])
            if self._stop.wait(self.period):
                return

    def __enter__(self) -> LoadSampler:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()
        self.samples.append(os.getloadavg()[0])

    def summary(self) -> dict:
        cpus = os.cpu_count() or 1
        mean = float(np.mean(self.samples))
        return {
            "load_1min_mean": round(mean, 2),
            "load_1min_max": round(float(np.max(self.samples)), 2),
            "samples": len(self.samples),
            "cpus": cpus,
            "contended": bool(mean > cpus + CONTENDED_MARGIN),
        }


def shown(load: dict) -> str:
    flag = " CONTENDED" if load["contended"] else ""
    return (
        f"[load 1-min mean {load['load_1min_mean']:.2f}, peak {load['load_1min_max']:.2f} on {load['cpus']} CPUs{flag}]"
    )


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
        ready, main_cpu = time.perf_counter(), time.process_time()
        before = client.run(time.process_time)
        with LoadSampler() as sampler:
            result = sweep.run(spec, out=out, client=client)
        done, main_cpu = time.perf_counter(), time.process_time() - main_cpu
        after = client.run(time.process_time)
    workers_cpu = sum(after[w] - before[w] for w in before if w in after)
    if result.computed != len(result.plan.chunks):
        raise SystemExit(f"{out} already held {result.skipped} chunks: choose an empty --out")
    runs = result.plan.n_runs
    return {
        "workers": workers,
        "runs": runs,
        "chunks": len(result.plan.chunks),
        "cluster_start_s": ready - start,
        "sweep_s": done - ready,
        "runs_per_s": runs / (done - ready),
        "workers_cpu_s": workers_cpu,
        "scheduler_and_client_cpu_s": main_cpu,
        "load": sampler.summary(),
    }


def batch_alone(spec: dict, out: Path) -> dict:
    """The same chunks through the same chunk function, one after another in this process (no Dask)."""
    prepared = sweep.prepare(spec, out)
    chunks = prepared.plan.chunks
    chunk_module.fast_of("pendubot")
    start, cpu = time.perf_counter(), time.process_time()
    with LoadSampler() as sampler:
        for c in chunks:
            chunk_module.execute(c, prepared.job)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    runs = prepared.plan.n_runs
    return {
        "runs": runs,
        "chunks": len(chunks),
        "wall_s": wall,
        "cpu_s": cpu,
        "runs_per_s": runs / wall,
        "runs_per_cpu_s": runs / cpu,
        "load": sampler.summary(),
    }


def chaos_cost(samples: int, out: Path) -> dict:
    """Seconds per chaos run (20 s, dt = 1 ms, Lyapunov with a twin), timed one by one in this process."""
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
    c = prepared.plan.chunks[0]
    path = chunk_module.path_of(c, prepared.job)
    start, cpu = time.perf_counter(), time.process_time()
    with LoadSampler() as sampler:
        columns = chunk_module.execute(c, prepared.job)
    per_run = (time.perf_counter() - start) / samples
    cpu_per_run = (time.process_time() - cpu) / samples
    finite = int(np.isfinite(np.asarray(columns["lyapunov"])).sum())
    return {
        "samples": samples,
        "path": path,
        "seconds_per_run": per_run,
        "cpu_seconds_per_run": cpu_per_run,
        "finite": finite,
        "load": sampler.summary(),
    }


def swing_up_cost(runs: int, oracle_runs: int, out: Path) -> dict:
    """Seconds per cart-pole swing-up run (2 s at 1 ms): a closed-loop chunk of ``runs``, and simulate one by one."""
    spec = {
        "model": "cart_pole",
        "duration": 2.0,
        "dt": 1e-3,
        "controller": "swing_up",
        "measure": ["final_state", "time_to_balance"],
        "chunk": runs,
        "q0": {"hinge": {"from": 2.0, "to": 3.1, "n": runs}},
    }
    prepared = sweep.prepare(spec, out)
    (c,) = prepared.plan.chunks
    chunk_module.fast_of("cart_pole")
    with LoadSampler() as sampler:
        start = time.perf_counter()
        columns = chunk_module.execute(c, prepared.job)
        chunked = (time.perf_counter() - start) / runs
        controller = chunk_module.controller_of(c.model, "swing_up", prepared.job.gains)
        robot = chunk_module.robot_of(c.model)
        start = time.perf_counter()
        for k in range(oracle_runs):
            robodyn.simulate(robot, c.q0[k], c.v0[k], duration=2.0, dt=1e-3, torque=controller)
        alone = (time.perf_counter() - start) / oracle_runs
    return {
        "runs": runs,
        "path": sorted(set(columns["path"])),
        "chunk_seconds_per_run": chunked,
        "simulate_runs": oracle_runs,
        "simulate_seconds_per_run": alone,
        "speedup": alone / chunked,
        "load": sampler.summary(),
    }


def refuse_docs(out: Path, allowed: bool) -> None:
    """Exit 2 when ``out`` is inside the checkout's docs/ (unless allowed): figures there are replaced on purpose."""
    resolved = out.resolve()
    if not allowed and (resolved == REPO / "docs" or (REPO / "docs") in resolved.parents):
        print(f"bench_sweep.py: error: --out {out} is inside docs/; pass --overwrite-committed to write there",
              file=sys.stderr)  # fmt: skip
        raise SystemExit(2)


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--side", type=int, default=100, help="basin grid side (default 100: 10^4 states)")
    parser.add_argument("--chaos-samples", type=int, default=32, help="chaos runs timed for the projection")
    parser.add_argument("--swing-up-runs", type=int, default=500, help="runs in the timed swing-up chunk")
    args = parser.parse_args()
    refuse_docs(args.out, args.overwrite_committed)
    out = output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    work = out / f"sweep-runs-{stamp}"  # the sweeps' own folders: fresh, so nothing is resumed
    work.mkdir(parents=True, exist_ok=True)
    spec = basin(args.side)
    cpus = os.cpu_count() or 1
    print(f"machine: {platform.node()}, {cpus} CPUs, shared; load average at start {os.getloadavg()}")
    alone = batch_alone(spec, work / "alone")
    print(
        f"batch path alone (no Dask, 1 process): {alone['runs']} runs in {alone['chunks']} chunks, "
        f"{alone['wall_s']:.2f} s = {alone['runs_per_s']:.0f} runs/s; CPU time {alone['cpu_s']:.2f} s = "
        f"{alone['runs_per_cpu_s']:.0f} runs per CPU-second  {shown(alone['load'])}"
    )
    one = dask_run(spec, 1, work / "w1")
    two = dask_run(spec, 2, work / "w2")
    for r in (one, two):
        print(
            f"Dask, {r['workers']} worker(s): {r['runs']} runs in {r['chunks']} chunks, {r['sweep_s']:.2f} s = "
            f"{r['runs_per_s']:.0f} runs/s (cluster start {r['cluster_start_s']:.1f} s, not counted)  "
            f"{shown(r['load'])}"
        )
    efficiency = two["runs_per_s"] / (2 * one["runs_per_s"])
    overhead = one["sweep_s"] / alone["wall_s"] - 1.0
    print(
        f"scaling efficiency 1 -> 2 workers: {two['runs_per_s']:.0f} / (2 x {one['runs_per_s']:.0f}) = {efficiency:.0%}"
    )
    if two["load"]["contended"] or one["load"]["contended"]:
        which = " and ".join(f"{r['workers']}-worker" for r in (one, two) if r["load"]["contended"])
        print(
            f"  UNREPRESENTATIVE: the {which} run's mean load exceeded {cpus} CPUs + {CONTENDED_MARGIN}; other "
            "processes took CPU from the workers, so this efficiency understates the scaling of an idle machine"
        )
    else:
        print(f"  the 1- and 2-worker runs' mean loads stayed within {cpus} CPUs + {CONTENDED_MARGIN}")
    cpu_one = one["workers_cpu_s"] + one["scheduler_and_client_cpu_s"]
    overhead_cpu = cpu_one / alone["cpu_s"] - 1.0
    print(
        f"Dask overhead, 1 worker against the batch path alone: wall {one['sweep_s']:.2f} s / {alone['wall_s']:.2f} s "
        f"- 1 = {overhead:+.1%}; CPU time (worker {one['workers_cpu_s']:.2f} s + scheduler and client "
        f"{one['scheduler_and_client_cpu_s']:.2f} s) / {alone['cpu_s']:.2f} s - 1 = {overhead_cpu:+.1%} (CPU time is "
        "what contention does not inflate)"
    )
    chaos = chaos_cost(args.chaos_samples, work / "chaos")
    # The projection's cost: this process's CPU time per run, which a contended machine does not inflate
    # (its wall time does: the process waits for a CPU); a dedicated core turns CPU time into wall time.
    t_run = chaos["cpu_seconds_per_run"]
    states, cores = 10**6, 64
    eff = 1.0 if two["load"]["contended"] else min(efficiency, 1.0)
    eff_origin = (
        "1.00 assumed (the measured 2-worker efficiency is unrepresentative under this load)"
        if two["load"]["contended"]
        else f"{eff:.2f} (the measured 1 -> 2 worker efficiency)"
    )
    projected = states * t_run / (cores * eff)
    print(
        f"chaos run (20 s at 1 ms, {chaos['path']} path: compiled RK4 + Benettin twin every 0.1 s): "
        f"{t_run:.4f} CPU-s each ({chaos['seconds_per_run']:.4f} s wall), {chaos['samples']} runs timed "
        f"({chaos['finite']} finite exponents)  {shown(chaos['load'])}"
    )
    print(
        f"projection, 10^6 states on 64 cores: efficiency {eff_origin};\n"
        f"  10^6 runs x {t_run:.4f} CPU-s/run = {states * t_run:,.0f} core-seconds; / (64 cores x {eff:.2f}) = "
        f"{projected:,.0f} s = {projected / 3600:.2f} h (cores as fast as this one; plus cluster start; "
        f"chunks of 1,000 give 1,000 tasks, about 16 per core)"
    )
    swing = swing_up_cost(args.swing_up_runs, 5, work / "swing")
    print(
        f"cart-pole swing-up (2 s at 1 ms, RK4): {swing['path']} chunk of {swing['runs']} runs "
        f"{swing['chunk_seconds_per_run'] * 1e3:.1f} ms/run; "
        f"robodyn.simulate one by one ({swing['simulate_runs']} runs) "
        f"{swing['simulate_seconds_per_run'] * 1e3:.0f} ms/run; {swing['speedup']:.0f}x  {shown(swing['load'])}"
    )
    result = {
        "basin_run": "Pendubot LQR, 5 s at dt = 1 ms, RK4, closed_loop path (compiled closed form), chunks of 1,000",
        "batch_alone": alone,
        "dask_1_worker": one,
        "dask_2_workers": two,
        "scaling_efficiency": efficiency,
        "scaling_representative": not (one["load"]["contended"] or two["load"]["contended"]),
        "dask_overhead_vs_batch": overhead,
        "dask_overhead_vs_batch_cpu": overhead_cpu,
        "chaos_run": chaos,
        "swing_up": swing,
        "projection": {
            "states": states,
            "cores": cores,
            "efficiency": eff,
            "seconds": projected,
            "arithmetic": f"{states} * {t_run:.6f} / ({cores} * {eff:.3f}) = {projected:.1f} s",
        },
    }
    path = write_json(out, "sweep", result, facts)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
