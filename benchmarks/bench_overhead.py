"""Overhead of robodyn.simulate over a bare Python loop of pin.aba + RK4 on the same problem.

    python benchmarks/bench_overhead.py [--model pendubot] [--duration 2] [--dt 1e-4] [--repeat 5]
                                        [--out bench-out]

Both sides integrate the same model from the same state with classic RK4 at the same dt, over
Pinocchio's ABA (``backend="aba"``: simulate's compiled default would compare another loop), and
keep every step. The bare loop is what one would write by hand: four ``pin.aba`` calls and
the RK4 combinations in NumPy, storing q and v. ``simulate`` does that plus everything it
promises: the system layer, energies (CRBA + potential) at every sample, the ledger,
divergence checks and the Trajectory. The figure is the ratio of the best-of-``repeat``
wall times (simulate / bare loop), held to at most 1.3 (exit 1 above it). It prints the ratio and
writes overhead.json (with the date, machine and load of the run) to --out.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin

import robodyn
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


def best_of_interleaved(
    repeat: int, first: Callable[[], Any], second: Callable[[], Any]
) -> tuple[float, Any, float, Any]:
    """Best wall times [s] of ``repeat`` alternating calls of first() and second(), and their results.

    Alternating the two spreads the load of a shared machine evenly over both.
    """
    best = [np.inf, np.inf]
    results: list[Any] = [None, None]
    for _ in range(repeat):
        for i, fn in enumerate((first, second)):
            start = time.perf_counter()
            results[i] = fn()
            best[i] = min(best[i], time.perf_counter() - start)
    return best[0], results[0], best[1], results[1]


def main(argv: list[str] | None = None) -> int:
    parser = argument_parser(__doc__)
    parser.add_argument("--model", default="pendubot")
    parser.add_argument("--duration", type=float, default=2.0)
    parser.add_argument("--dt", type=float, default=1e-4)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()

    robot = robodyn.load(args.model)
    rng = np.random.default_rng(0)
    q0, v0 = robot.random_state(rng, speed=1.0)
    n = round(args.duration / args.dt)

    t_bare, states, t_sim, traj = best_of_interleaved(
        args.repeat,
        lambda: bare_rk4(robot.model, robot.model.createData(), q0, v0, args.dt, n),
        lambda: simulate(robot, q0, v0, duration=args.duration, dt=args.dt, integrator="rk4", backend="aba"),
    )
    assert isinstance(states, np.ndarray) and isinstance(traj, robodyn.Trajectory)
    same = float(np.max(np.abs(states - np.hstack([traj.q, traj.v]))))
    ratio = t_sim / t_bare
    result = {
        "model": args.model,
        "integrator": "rk4",
        "duration_s": args.duration,
        "dt_s": args.dt,
        "steps": n,
        "repeat": args.repeat,
        "bare_loop_s": t_bare,
        "simulate_s": t_sim,
        "ratio": ratio,
        "limit": LIMIT,
        "within_limit": ratio < LIMIT,
        "max_state_difference": same,
        "per_step_us": {"bare_loop": 1e6 * t_bare / n, "simulate": 1e6 * t_sim / n},
    }
    path = write_json(args.out, "overhead", result, facts)
    print(
        f"{args.model}, RK4, dt = {args.dt:g} s, {n} steps: bare pin.aba loop {t_bare:.3f} s, "
        f"simulate {t_sim:.3f} s -> ratio {ratio:.2f}, {'within' if ratio < LIMIT else 'OVER'} the limit "
        f"{LIMIT}; max state difference {same:.1e}"
    )
    print(f"wrote {path}")
    return 0 if ratio < LIMIT else 1


if __name__ == "__main__":
    raise SystemExit(main())
