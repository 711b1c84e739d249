"""What it costs to run a controller file safely: the watched child per run, the guards per call, a pipe per call.

A controller file runs, from the CLI, inside a forked child that robodyn watches
(:mod:`robodyn.control.supervised`); each call gets read-only copies of q and v and a time limit.
Measured here on the Pendubot with a plain NumPy controller (tau = [-k q1 - d v1, 0]):

* per run: a watched child that does nothing (the fork, its exit, the wait); the same simulation
  (RK4, dt = 1 ms, the Python loop of the aba backend) in robodyn's
  process and in the watched child, for DURATIONS seconds of motion: the difference is the fork,
  the trajectory's way back through the pipe and the child's exit;
* per call: the user's function alone, with robodyn's checks of its torques, with the read-only
  copies of q and v, and with the time limit's deadline set and cleared (as in the child), best of
  REPEAT batches of CALLS calls;
* the alternative the module's docstring weighs: one round trip per call to a process of its own
  through pipes (a forked echo of q and v, 32 bytes each way), the floor of any per-call sandbox.

    python benchmarks/bench_controller_file.py --out bench-out

prints the figures and writes controller_file.json (with the date, machine and load of the run).
"""

from __future__ import annotations

import os
import struct
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import robodyn
from robodyn import control
from robodyn.control import supervised

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _common

DURATIONS = (0.1, 1.0, 5.0)  # [s] of simulated motion per run
DT = 1e-3  # [s]
REPEAT = 5  # best of, on a shared machine
CALLS = 20_000  # calls per batch in the per-call figures
CONTROLLER = """import numpy as np

def make(robot, **gains):
    def tau(t, q, v):
        return np.array([-2.0 * q[0] - 0.1 * v[0], 0.0])
    return tau
"""


def per_run(robot: Any, path: Path) -> list[dict[str, float]]:
    """Wall time [s] of one run in-process and in the watched child, per duration."""
    rows = []
    for duration in DURATIONS:

        def job(duration: float = duration) -> Any:
            fn = control.make(str(path), robot)
            return robodyn.simulate(robot, [0.3, 0.2], [0.0, 0.0], duration=duration, dt=DT, torque=fn, backend="aba")

        here, run = _common.best_of(job, REPEAT)
        child, _ = _common.best_of(lambda job=job: supervised.run_supervised(job, source=str(path)), REPEAT)
        calls = 4 * run.n_steps  # RK4: four stages a step
        rows.append({"duration_s": duration, "calls": calls, "in_process_s": here, "watched_child_s": child,
                     "overhead_s": child - here, "overhead_per_call_us": (child - here) / calls * 1e6})  # fmt: skip
        print(
            f"run of {duration:g} s ({calls:,} controller calls): in process {here:.3f} s, in the watched child "
            f"{child:.3f} s, + {1e3 * (child - here):.1f} ms"
        )
    return rows


def per_call(robot: Any, path: Path) -> dict[str, float]:
    """Cost of one call [us]: the function; checked without and with read-only copies; with the watchdog's deadline."""
    from robodyn.control import user_controller as user

    wrapped = control.make(str(path), robot)
    q, v = np.array([0.3, 0.2]), np.array([0.0, 0.1])

    def batch(fn: Any) -> None:
        for k in range(CALLS):
            fn(k * 1e-3, q, v)

    bare, _ = _common.best_of(lambda: batch(wrapped.fn), REPEAT)
    copies = user._read_only
    user._read_only = lambda x: x  # type: ignore[assignment]  # the checks of before, without the copies
    try:
        checked, _ = _common.best_of(lambda: batch(wrapped), REPEAT)
    finally:
        user._read_only = copies  # type: ignore[assignment]
    guarded, _ = _common.best_of(lambda: batch(wrapped), REPEAT)
    with open(os.devnull, "wb") as sink:
        supervised.watch = supervised.Watchdog(sink.fileno())  # as in the child: a deadline set and cleared a call
        try:
            timed, _ = _common.best_of(lambda: batch(wrapped), REPEAT)
        finally:
            supervised.watch = None
    out = {
        "function_us": bare / CALLS * 1e6,
        "checked_us": checked / CALLS * 1e6,
        "checked_read_only_copies_us": guarded / CALLS * 1e6,
        "checked_copies_deadline_us": timed / CALLS * 1e6,
    }
    print(
        f"one call: the function {out['function_us']:.2f} us; with robodyn's checks of the torques "
        f"{out['checked_us']:.2f} us; + read-only copies of q and v "
        f"{out['checked_read_only_copies_us'] - out['checked_us']:+.2f} us; + the time limit "
        f"{out['checked_copies_deadline_us'] - out['checked_read_only_copies_us']:+.2f} us"
    )
    return out


def pipe_round_trip() -> float:
    """One round trip [us] of q and v (4 float64) to a forked echo process and back, best of REPEAT batches."""
    up_r, up_w = os.pipe()
    down_r, down_w = os.pipe()
    message = struct.pack("<4d", 0.3, 0.2, 0.0, 0.1)
    pid = os.fork()
    if pid == 0:  # the echo
        os.close(up_w)
        os.close(down_r)
        while data := os.read(up_r, 32):
            os.write(down_w, data)
        os._exit(0)
    os.close(up_r)
    os.close(down_w)

    def batch() -> None:
        for _ in range(CALLS):
            os.write(up_w, message)
            os.read(down_r, 32)

    best, _ = _common.best_of(batch, REPEAT)
    os.close(up_w)
    os.waitpid(pid, 0)
    os.close(down_r)
    per = best / CALLS * 1e6
    print(f"a pipe round trip per call (the floor of a per-call sandbox): {per:.2f} us")
    return per


def main() -> int:
    args = _common.argument_parser(__doc__ or "").parse_args()
    out = _common.output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = _common.run_facts()
    robot = robodyn.load("pendubot")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "ctl.py"
        path.write_text(CONTROLLER)
        empty, _ = _common.best_of(lambda: supervised.run_supervised(lambda: 0, source=str(path)), REPEAT)
        print(f"a watched child that does nothing: {1e3 * empty:.1f} ms (the fork, the exit and the wait)")
        runs = per_run(robot, path)
        calls = per_call(robot, path)
    pipe = pipe_round_trip()
    longest = runs[-1]
    print(
        f"a pipe per call would add {pipe * longest['calls'] / 1e3:.0f} ms to the {longest['duration_s']:g} s run; "
        f"the watched child adds {1e3 * longest['overhead_s']:.1f} ms"
    )
    result = {
        "empty_child_s": empty,
        "runs": runs,
        "per_call": calls,
        "pipe_round_trip_us": pipe,
        "dt": DT,
        "repeat": REPEAT,
    }
    print(f"saved {_common.write_json(out, 'controller_file', result, facts)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
