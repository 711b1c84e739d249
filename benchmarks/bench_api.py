"""The cost of robodyn's per-state calls (robot.M, C, G, ...) against the Pinocchio call each one wraps.

    python benchmarks/bench_api.py [--model panda] [--calls 200] [--repeat 300] [--out bench-out]

Each ``Robot`` method validates its input (shape, dtype, finiteness), calls Pinocchio and returns
a fresh array; the Pinocchio side is the bare call on the same model, data and state, with
arrays already of the right type. Both are timed in short loops of ``--calls`` calls, alternating,
and the best of ``--repeat`` loops gives each a cost per call [us] (short loops, many of them:
on a shared machine some run unpreempted). robodyn holds itself to at most
2x the Pinocchio call plus 1 us (``RATIO``, ``SLACK_US``): exit 1 when a call costs more. It prints
the table and writes bench_api.json (with the date, machine and load of the run) to --out.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin

import robodyn

from _common import argument_parser, output_folder, run_facts, write_json

RATIO = 2.0  # robodyn's call may cost this many times the Pinocchio call ...
SLACK_US = 1.0  # ... plus this much [us]: the validation and the copy of the result


def cases(
    robot: Any, q: np.ndarray, v: np.ndarray, tau: np.ndarray
) -> dict[str, tuple[Callable[[], Any], Callable[[], Any]]]:
    """Call name -> (robodyn's call, the Pinocchio call it wraps) on one state."""
    m, d = robot.model, robot.data
    return {
        "M(q)": (lambda: robot.M(q), lambda: pin.crba(m, d, q)),
        "C(q, v)": (lambda: robot.C(q, v), lambda: pin.computeCoriolisMatrix(m, d, q, v)),
        "G(q)": (lambda: robot.G(q), lambda: pin.computeGeneralizedGravity(m, d, q)),
        "nle(q, v)": (lambda: robot.nle(q, v), lambda: pin.nonLinearEffects(m, d, q, v)),
        "inverse_dynamics(q, v, a)": (lambda: robot.inverse_dynamics(q, v, tau), lambda: pin.rnea(m, d, q, v, tau)),
        "forward_dynamics(q, v, tau)": (lambda: robot.forward_dynamics(q, v, tau), lambda: pin.aba(m, d, q, v, tau)),
        "kinetic_energy(q, v)": (lambda: robot.kinetic_energy(q, v), lambda: pin.crba(m, d, q)),
        "potential_energy(q)": (lambda: robot.potential_energy(q), lambda: pin.computePotentialEnergy(m, d, q)),
        "integrate(q, dq)": (lambda: robot.integrate(q, v), lambda: pin.integrate(m, q, v)),
    }


def per_call(fn: Callable[[], Any], calls: int) -> float:
    """Wall time of ``calls`` calls of ``fn`` [s], divided by ``calls``."""
    start = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - start) / calls


def main(argv: list[str] | None = None) -> int:
    parser = argument_parser(__doc__)
    parser.add_argument("--model", default="panda", help="a built-in or example-robot-data name (default panda)")
    parser.add_argument("--calls", type=int, default=200, help="calls per timed loop (default 200)")
    parser.add_argument("--repeat", type=int, default=300, help="timed loops per call, the best kept (default 300)")
    args = parser.parse_args(argv)
    output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    robot = robodyn.load(args.model)
    q, v = robot.random_state(np.random.default_rng(0))
    tau = np.random.default_rng(1).normal(size=robot.nv)
    rows = []
    print(f"{robot.name} (nq = {robot.nq}, nv = {robot.nv}): cost per call, best of {args.repeat} loops of "
          f"{args.calls} calls")  # fmt: skip
    print(f"{'call':30s} {'robodyn [us]':>12s} {'Pinocchio [us]':>15s} {'ratio':>6s} {'limit [us]':>11s}  verdict")
    for name, (ours, theirs) in cases(robot, q, v, tau).items():
        ours(), theirs()  # warm: caches filled, first-use work done
        best = [np.inf, np.inf]
        for _ in range(args.repeat):
            best[0] = min(best[0], per_call(ours, args.calls))
            best[1] = min(best[1], per_call(theirs, args.calls))
        us, pin_us = best[0] * 1e6, best[1] * 1e6
        limit = RATIO * pin_us + SLACK_US
        ok = us <= limit
        rows.append({"call": name, "robodyn_us": us, "pinocchio_us": pin_us, "ratio": us / pin_us,
                     "limit_us": limit, "within_limit": ok})  # fmt: skip
        print(f"{name:30s} {us:12.2f} {pin_us:15.2f} {us / pin_us:6.2f} {limit:11.2f}  {'ok' if ok else 'OVER'}")
    over = [r["call"] for r in rows if not r["within_limit"]]
    verdict = (
        f"every call within {RATIO:g}x Pinocchio's + {SLACK_US:g} us"
        if not over
        else f"over {RATIO:g}x Pinocchio's + {SLACK_US:g} us: {', '.join(over)}"
    )
    print(verdict)
    result = {"model": robot.name, "nq": robot.nq, "nv": robot.nv, "calls": args.calls, "repeat": args.repeat,
              "ratio_limit": RATIO, "slack_us": SLACK_US, "rows": rows, "verdict": verdict}  # fmt: skip
    path = write_json(args.out, "bench_api", result, facts)
    print(f"wrote {path}")
    return 1 if over else 0


if __name__ == "__main__":
    raise SystemExit(main())
