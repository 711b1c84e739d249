"""Overhead of robodyn.simulate over a bare Python loop of pin.aba + RK4 on the same problem.

    python benchmarks/bench_overhead.py [--model pendubot] [--duration 10] [--dt 1e-3] [--repeat 7]
                                        [--busy] [--out bench-out]

Both sides integrate the same model from the same state with classic RK4 at the same dt, over
Pinocchio's ABA (``backend="aba"``: simulate's compiled default would compare another loop), and
keep every step. The bare loop is what one would write by hand: four ``pin.aba`` calls and
the RK4 combinations in NumPy, storing q and v. ``simulate`` does that plus everything it
promises: the system layer, the watch on the joint stops (checked after every step), the
energies (CRBA + potential) at every sample and the ledger, divergence checks and the
Trajectory. The figure is the ratio of the best-of-``repeat`` wall times (simulate / bare
loop, the two calls alternating in one process after a warm-up call of each), held to at most
1.3 (exit 1 above it); the ratio of their best CPU times (this process's: without the waits for
a core on a loaded machine) is saved beside it. What the remaining overhead buys is measured
beside it: the same call with ``limits=False`` (no stop watch), the energies of every sample
computed alone, and the fixed cost of a two-step call (the set-up and the Trajectory). --busy
runs one CPU-bound process (a spinning loop) for the whole measurement. It prints the ratio and
writes overhead.json (overhead_busy.json with --busy; with the date, machine and load of the run)
to --out.
"""

from __future__ import annotations

import multiprocessing
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin

import robodyn
from robodyn.sim import energy
from robodyn.sim.simulation import simulate

from _common import argument_parser, output_folder, run_facts, write_json

LIMIT = 1.3  # the largest ratio simulate / bare loop that robodyn accepts for itself


def bare_rk4(model: pin.Model, data: pin.Data, q0: np.ndarray, v0: np.ndarray, dt: float, n: int) -> np.ndarray:
    """RK4 on q'' = aba(q, v, 0) with plain NumPy; returns the states (n + 1, nq + nv)."""
    tau = np.zeros(model.nv)
    out = np.empty((n + 1, model.nq + model.nv))
    q, v = q0.copy(), v0.copy()
    out[0, : model.nq], out[0, model.nq :] = q, v
    h, h2, h6 = dt, 0.5 * dt, dt / 6.0
    for k in range(n):
        a1 = pin.aba(model, data, q, v, tau).copy()
        v2 = v + h2 * a1
        a2 = pin.aba(model, data, q + h2 * v, v2, tau).copy()
        v3 = v + h2 * a2
        a3 = pin.aba(model, data, q + h2 * v2, v3, tau).copy()
        v4 = v + h * a3
        a4 = pin.aba(model, data, q + h * v3, v4, tau).copy()
        q = q + h6 * (v + 2.0 * (v2 + v3) + v4)
        v = v + h6 * (a1 + 2.0 * (a2 + a3) + a4)
        out[k + 1, : model.nq], out[k + 1, model.nq :] = q, v
    return out


def best_of_interleaved(repeat: int, *calls: Callable[[], Any]) -> tuple[list[float], list[float], list[Any]]:
    """Best wall and CPU times [s] of ``repeat`` rounds of the ``calls`` in turn, after a warm-up round; results.

    Alternating the calls spreads the load of a shared machine evenly over them; the CPU time
    (this process's) leaves out the time spent waiting for a core on a loaded machine.
    """
    best = [np.inf] * len(calls)
    best_cpu = [np.inf] * len(calls)
    results: list[Any] = [fn() for fn in calls]  # warm: caches, allocator, branch predictors
    for _ in range(repeat):
        for i, fn in enumerate(calls):
            start, cpu = time.perf_counter(), time.process_time()
            results[i] = fn()
            best[i] = min(best[i], time.perf_counter() - start)
            best_cpu[i] = min(best_cpu[i], time.process_time() - cpu)
    return best, best_cpu, results


def _spin(stop: Any) -> None:
    x = 0
    while not stop.is_set():
        for _ in range(100_000):
            x += 1


def measure(model: str, duration: float, dt: float, repeat: int) -> dict[str, Any]:
    """The ratio simulate / bare loop, and what the overhead buys, on ``model`` (see the module's docstring)."""
    robot = robodyn.load(model)
    rng = np.random.default_rng(0)
    q0, v0 = robot.random_state(rng, speed=1.0)
    n = round(duration / dt)
    common = {"duration": duration, "dt": dt, "integrator": "rk4", "backend": "aba"}
    two_steps = {**common, "duration": 2 * dt}
    (t_bare, t_sim, t_free, t_fixed), cpu, (states, traj, _, _) = best_of_interleaved(
        repeat,
        lambda: bare_rk4(robot.model, robot.model.createData(), q0, v0, dt, n),
        lambda: simulate(robot, q0, v0, **common),
        lambda: simulate(robot, q0, v0, **common, limits=False),
        lambda: simulate(robot, q0, v0, **two_steps),
    )
    assert isinstance(states, np.ndarray) and isinstance(traj, robodyn.Trajectory)
    meter = energy.EnergyMeter.for_robot(robot, q0)
    t_energy, _, _ = best_of_interleaved(repeat, lambda: meter(traj.q, traj.v))
    same = float(np.max(np.abs(states - np.hstack([traj.q, traj.v]))))
    ratio = t_sim / t_bare
    over = t_sim - t_bare
    buys = {  # [s] of the overhead, each measured on its own
        "stop_watch_s": t_sim - t_free,
        "energies_s": t_energy[0],
        "set_up_and_trajectory_s": t_fixed,
    }
    buys["stepper_records_and_checks_s"] = over - sum(buys.values())
    return {
        "model": model,
        "integrator": "rk4",
        "duration_s": duration,
        "dt_s": dt,
        "steps": n,
        "repeat": repeat,
        "statistic": "min",
        "bare_loop_s": t_bare,
        "simulate_s": t_sim,
        "simulate_limits_off_s": t_free,
        "ratio": ratio,
        "ratio_limits_off": t_free / t_bare,
        "cpu_s": {"bare_loop": cpu[0], "simulate": cpu[1], "simulate_limits_off": cpu[2]},
        "ratio_cpu": cpu[1] / cpu[0],
        "judged_on": "wall time",
        "limit": LIMIT,
        "within_limit": ratio < LIMIT,
        "max_state_difference": same,
        "per_step_us": {"bare_loop": 1e6 * t_bare / n, "simulate": 1e6 * t_sim / n},
        "overhead_s": over,
        "overhead_buys": buys,
        "impacts": traj.meta["impacts"],
    }


def main(argv: list[str] | None = None) -> int:
    parser = argument_parser(__doc__)
    parser.add_argument("--model", default="pendubot")
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--dt", type=float, default=1e-3)
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--busy", action="store_true", help="run a CPU-bound process during the measurement")
    args = parser.parse_args(argv)
    output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    stop = multiprocessing.Event()
    spinner = multiprocessing.Process(target=_spin, args=(stop,), daemon=True) if args.busy else None
    if spinner is not None:
        spinner.start()
        time.sleep(1.0)
    try:
        result = measure(args.model, args.duration, args.dt, args.repeat)
    finally:
        if spinner is not None:
            stop.set()
            spinner.join(5)
    result["busy"] = args.busy
    path = write_json(args.out, "overhead_busy" if args.busy else "overhead", result, facts)
    ratio, n = result["ratio"], result["steps"]
    print(
        f"{args.model}, RK4, dt = {args.dt:g} s, {n} steps{' (busy)' if args.busy else ''}: bare pin.aba loop "
        f"{result['bare_loop_s']:.3f} s, simulate {result['simulate_s']:.3f} s (best of {args.repeat}) -> ratio "
        f"{ratio:.2f}, {'within' if ratio < LIMIT else 'OVER'} the limit {LIMIT}; with limits=False "
        f"{result['ratio_limits_off']:.2f}; in CPU time {result['ratio_cpu']:.2f}; max state difference "
        f"{result['max_state_difference']:.1e}"
    )
    b = result["overhead_buys"]

    def ms(x: float) -> str:  # a part timed below zero is below the run-to-run noise
        return f"{1e3 * x:.1f} ms" if x > 0 else "below the noise"

    print(
        f"the overhead, {ms(result['overhead_s'])}, buys: the stop watch {ms(b['stop_watch_s'])}, the energies of "
        f"{n + 1} samples {ms(b['energies_s'])}, the set-up and the Trajectory {ms(b['set_up_and_trajectory_s'])}, "
        f"and the stepper, the records and the divergence checks {ms(b['stepper_records_and_checks_s'])} "
        "(each timed on its own)"
    )
    print(f"wrote {path}")
    return 0 if ratio < LIMIT else 1


if __name__ == "__main__":
    raise SystemExit(main())
