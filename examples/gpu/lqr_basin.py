"""The Pendubot's LQR basin on a GPU: a grid of starts around the upright, one GPU thread a run.

    python examples/gpu/lqr_basin.py                 # 101 x 101 starts, 5 s at dt = 1 ms
    NUMBA_ENABLE_CUDASIM=1 python examples/gpu/lqr_basin.py --side 2 --duration 0.1   # no GPU: numba's simulator

``robodyn.control.rollout.closed_loop(..., backend="cuda")`` runs the controller that
``robodyn.control.make`` built (its law compiled for the GPU) from every start, and returns the
final states; the script prints how many runs end within 0.05 rad of the upright.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import robodyn
import robodyn.control
from robodyn.control import rollout
from robodyn.errors import RobodynError

UP = np.pi / 2
TOL = 0.05  # [rad]: within this of the upright counts as balanced


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--side", type=int, default=101, help="starts per angle (default 101)")
    parser.add_argument("--duration", type=float, default=5.0, help="seconds of each run (default 5)")
    args = parser.parse_args()
    robot = robodyn.load("pendubot")
    lqr = robodyn.control.make("lqr", robot)
    a, b = np.meshgrid(np.linspace(UP - 0.5, UP + 0.5, args.side), np.linspace(-0.5, 0.5, args.side))
    q0 = np.column_stack([a.ravel(), b.ravel()])
    try:
        run = rollout.closed_loop(robot, lqr, q0, np.zeros_like(q0), duration=args.duration, dt=1e-3, backend="cuda")
    except RobodynError as exc:
        print(f"lqr_basin: error: {exc}", file=sys.stderr)
        return exc.exit_code
    error = (run.q - np.array([UP, 0.0]) + np.pi) % (2 * np.pi) - np.pi
    caught = int(np.sum(np.all(np.abs(error) < TOL, axis=1)))
    print(f"{caught} of {q0.shape[0]} runs within {TOL} rad of the upright after {args.duration:g} s")
    print(f"GPU kernel: {run.wall_time_s:.3g} s for {q0.shape[0] * run.steps:,} state-steps")
    return 0


if __name__ == "__main__":
    sys.exit(main())
