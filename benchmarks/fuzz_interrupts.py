"""Interrupt robodyn at random moments: SIGINT and SIGKILL to simulate, run, bench and sweep.

    python benchmarks/fuzz_interrupts.py [--trials 60] [--seed 0] [--out DIR (default bench-out)]
                                         [--commands simulate,run,bench,sweep] [--minutes M]

A sibling of ``fuzz.py`` for issue 27. Each command is first run once without a signal (its
duration T calibrates the moments, its outputs are the good results of an "earlier run"). Each
trial then draws, from ``(seed, index)`` alone, a command, a signal (SIGINT to the command's
process group, as a terminal's Ctrl-C; or SIGKILL to the command alone) and a moment: uniform
over [0, 1.1 T] for half the trials, within the last 30 % of T (the final writes) for the other
half. Half the trials start with the earlier run's outputs in place. The command runs in a
session of its own; every 10 ms the trial notes its processes and the temporary files
(``.NAME.*.part``) that show a finished result being written.

Each trial is checked for:

* **lost result**: a finished result being written (a ``.part`` of it was seen) when Ctrl-C came
  that ends up nowhere (no new output, no ``.partial`` file, no partial folder; under SIGKILL no
  process can finish a write, so there only the next two rules apply); or an output (present, or
  named by the line) that does not load; or an earlier good output changed by a run stopped by
  Ctrl-C that does not say it wrote one (a killed run that finished a write leaves a whole file);
* **leftover process**: a process of the command still running 10 s after it ended;
* **traceback**: ``Traceback`` or ``Exception ignored`` on stderr through any robodyn file (its
  import included: ``robodyn.__main__`` ends a Ctrl-C that comes while the command line loads);
  counted apart as **start-up traceback** when no robodyn frame is in it: a Ctrl-C in the first
  ~0.1 s, while the interpreter starts (``site`` and the ``.pth`` files of the installed
  packages), before any robodyn code runs;
* **not one line**: an interrupted run (exit 130) whose stderr, less progress bars and notes, is
  not exactly one line; a killed one that printed anything but progress bars (e.g. ``leaked
  semaphore``); and a run after a killed sweep that says ``leaked``.

``--out`` gets ``fuzz_interrupts.json`` (the table and every finding) and the table is printed.
"""

from __future__ import annotations

import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = ("simulate", "run", "bench", "sweep")
# Seconds [s] the processes of a command get to be gone after it ended (the kernel kills at once).
GONE_WITHIN_S = 10.0
# Seconds [s] after which a trial's command is killed as hung.
HANG_S = 600.0
# The sweep of the sweep trials: 12 runs of 2 s in chunks of 2 on 2 workers.
SWEEP = """model = "pendubot"
duration = 2.0
dt = 1e-3
integrator = "rk4"
controller = "lqr"
measure = ["final_state"]
chunk = 2

[q0]
joint1 = { from = 1.45, to = 1.69, n = 6 }
joint2 = [-0.05, 0.05]
"""
SCENE = """[model]
name = "pendubot"

[simulate]
duration = 20.0
dt = 1e-3
integrator = "rk4"
"""


def command_line(name: str) -> list[str]:
    """The robodyn command of a trial, run in the trial's folder."""
    robodyn = [sys.executable, "-m", "robodyn"]
    if name == "simulate":
        return [*robodyn, "simulate", "pendubot", "--duration", "10", "--out", "x.npz", "--csv", "x.csv"]
    if name == "run":
        return [*robodyn, "run", "scene.toml", "--no-view", "--out", "scene-out"]
    if name == "bench":
        return [*robodyn, "bench", "cart_pole", "--quick", "--no-stability", "--out", "bench-out"]
    return [*robodyn, "sweep", "sweep.toml", "--out", "sweep-out", "--workers", "2"]


def prepare(folder: Path) -> None:
    """The input files of every command."""
    (folder / "scene.toml").write_text(SCENE)
    (folder / "sweep.toml").write_text(SWEEP)


@dataclass
class Outcome:
    """What one run did: exit code, stderr, processes and temporary files seen, wall time [s]."""

    code: int
    stderr: str
    seen_processes: list[Any] = field(default_factory=list)
    seen_parts: set[str] = field(default_factory=set)
    wall_s: float = 0.0


def execute(command: list[str], folder: Path, *, signum: int | None = None, delay: float = 0.0) -> Outcome:
    """Run ``command`` in ``folder`` in a session of its own; send ``signum`` after ``delay`` seconds."""
    import psutil

    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    env.pop("ROBODYN_TEST_PAUSE_AT", None)
    err_path = folder / f".stderr-{time.monotonic_ns()}"
    start = time.monotonic()
    with err_path.open("wb") as err:
        process = subprocess.Popen(
            command,
            cwd=folder,
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=err,
            start_new_session=True,
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        )
    seen: dict[int, Any] = {}
    parts: set[str] = set()
    sent = signum is None
    root = psutil.Process(process.pid)
    while process.poll() is None:
        now = time.monotonic() - start
        if not sent and now >= delay:
            if signum == signal.SIGKILL:
                os.kill(process.pid, signal.SIGKILL)
            else:
                os.killpg(process.pid, signal.SIGINT)
            sent = True
        if now > HANG_S:
            os.killpg(process.pid, signal.SIGKILL)
        try:
            for child in root.children(recursive=True):
                seen.setdefault(child.pid, child)
        except psutil.Error:
            pass
        try:
            for path in folder.rglob(".*.part"):
                parts.add(path.name.split(".")[1])  # .x.npz.abc.part -> x
        except OSError:  # a folder removed while it was listed (bench's partial folder)
            pass
        time.sleep(0.01)
    code = process.returncode
    wall = time.monotonic() - start
    time.sleep(0.05)
    stderr = err_path.read_text(errors="replace").replace("\r", "\n")
    err_path.unlink()
    return Outcome(code, stderr, list(seen.values()), parts, wall)


def leftovers(outcome: Outcome) -> list[int]:
    """Processes of the run still running ``GONE_WITHIN_S`` after it ended (killed then)."""
    import psutil

    _, alive = psutil.wait_procs(outcome.seen_processes, timeout=GONE_WITHIN_S)
    left = []
    for process in alive:
        try:
            if process.status() != psutil.STATUS_ZOMBIE:
                left.append(process.pid)
                process.kill()
        except psutil.Error:
            pass
    return left


def message_lines(stderr: str) -> list[str]:
    """stderr less progress bars (bench's ``[###...]``, the sweep's ``sweep [``), stage notes and notes."""
    out = []
    for line in stderr.splitlines():
        text = line.strip()
        if not text or text.startswith(("[", "sweep [", "robodyn bench: work-precision", "robodyn bench: stability")):
            continue
        if ": note: " in text:
            continue
        out.append(text)
    return out


def loads(path: Path) -> bool:
    """Whether an output file is whole: it loads as what it claims to be."""
    try:
        if path.suffix == ".npz":
            from robodyn.sim.trajectory import Trajectory

            Trajectory.load(path)
        elif path.suffix == ".csv":
            import numpy as np

            np.loadtxt(path, delimiter=",", skiprows=1)
        elif path.suffix == ".json":
            json.loads(path.read_text())
        elif path.suffix == ".parquet":
            import pyarrow.parquet as pq

            pq.read_table(path)
        return True
    except Exception:
        return False


def outputs_of(name: str, folder: Path) -> list[Path]:
    """Every output file a command may have left, partial ones included."""
    if name == "simulate":
        return sorted(folder.glob("x*.npz")) + sorted(folder.glob("x*.csv"))
    if name == "run":
        return sorted((folder / "scene-out").glob("*.npz")) + sorted((folder / "scene-out").glob("*.json"))
    if name == "bench":
        return sorted((folder / "bench-out").rglob("*.json"))
    return sorted((folder / "sweep-out").rglob("*.parquet")) + sorted((folder / "sweep-out").glob("*.json"))


def finals_of(name: str, folder: Path) -> list[Path]:
    """The complete outputs of a finished run (the earlier good results, when kept)."""
    return {
        "simulate": [folder / "x.npz", folder / "x.csv"],
        "run": [folder / "scene-out" / "scene.npz"],
        "bench": [folder / "bench-out" / "bench.json", folder / "bench-out" / "report.md"],
        "sweep": [folder / "sweep-out" / "manifest.json"],
    }[name]


def check(name: str, folder: Path, outcome: Outcome, signum: int, earlier: dict[Path, bytes]) -> dict[str, Any]:
    """The findings of one trial (see the module docstring)."""
    found: dict[str, Any] = {}
    broken = [str(p.relative_to(folder)) for p in outputs_of(name, folder) if not loads(p)]
    if broken:
        found["lost result"] = f"outputs that do not load: {broken}"
    lines = message_lines(outcome.stderr)
    finals = finals_of(name, folder)
    if outcome.code == 0:
        missing = [str(p.relative_to(folder)) for p in finals if not p.exists()]
        if missing:
            found["lost result"] = f"exit 0 without {missing}"
    else:
        said = " ".join(lines)
        changed = [
            str(p.relative_to(folder)) for p, data in earlier.items() if (p.read_bytes() if p.exists() else b"") != data
        ]
        saying = ("written to", "holds them all", "moved in")
        if changed and signum == signal.SIGINT and not any(words in said for words in saying):
            found["lost result"] = f"an interrupted run changed {changed} without saying so"
        stem = {"simulate": "x", "run": "scene"}.get(name)
        # a finished result was being written when Ctrl-C came (a SIGKILL cannot be answered by any
        # process: what holds then is that no output is half-written and an earlier one is whole)
        if stem is not None and stem in outcome.seen_parts and signum == signal.SIGINT:
            kept = list(folder.rglob(f"{stem}.npz")) + list(folder.rglob(f"{stem}.partial.npz"))
            new = [p for p in kept if p.read_bytes() != earlier.get(p, b"")]
            if not new:
                found["lost result"] = "a finished result was being written and is nowhere"
    if "Traceback" in outcome.stderr or "Exception ignored" in outcome.stderr:
        before_main = "/robodyn/" not in outcome.stderr  # no robodyn frame: Python's own start-up (site, .pth files)
        found["start-up traceback" if before_main else "traceback"] = outcome.stderr[-600:]
    if outcome.code == 130 and len(lines) != 1:
        found["not one line"] = lines[:6]
    if outcome.code == -signal.SIGKILL and lines:
        found["not one line"] = lines[:6]
    left = leftovers(outcome)
    if left:
        found["leftover process"] = left
    return found


def run_trial(index: int, seed: int, names: Sequence[str], calibration: dict[str, float], folder: Path) -> dict:
    """One trial, drawn from (seed, index); its record."""
    rng = random.Random(f"{seed}:{index}")
    name = rng.choice(list(names))
    signum = rng.choice([signal.SIGINT, signal.SIGKILL])
    span = calibration[name]
    late = rng.random() < 0.5
    delay = rng.uniform(0.7 * span, span) if late else rng.uniform(0.0, 1.1 * span)
    keep_earlier = rng.random() < 0.5 and name != "sweep"  # a sweep's earlier run would leave nothing to do
    trial = folder / f"trial-{index}"
    shutil.copytree(folder / f"good-{name}", trial) if keep_earlier else prepare_fresh(trial)
    earlier = {p: p.read_bytes() for p in finals_of(name, trial) if p.exists()}
    outcome = execute(command_line(name), trial, signum=signum, delay=delay)
    found = check(name, trial, outcome, signum, earlier)
    if name == "sweep" and signum == signal.SIGKILL:  # the next run must not print the tracker's warning
        after = execute(command_line(name), trial)
        if "leaked" in after.stderr:
            found["not one line"] = "the next run's stderr says leaked"
        if leftovers(after):
            found["leftover process"] = "after the next run"
    if not found:
        shutil.rmtree(trial, ignore_errors=True)
    else:  # kept for a look: what it said and what was found
        (trial / "stderr.txt").write_text(outcome.stderr)
        (trial / "findings.json").write_text(json.dumps(found, indent=1, default=str))
    return {
        "index": index,
        "command": name,
        "signal": signal.Signals(signum).name,
        "delay_s": round(delay, 3),
        "earlier_outputs": keep_earlier,
        "exit": outcome.code,
        "wall_s": round(outcome.wall_s, 2),
        "findings": found,
    }


def prepare_fresh(trial: Path) -> None:
    trial.mkdir()
    prepare(trial)


def main(argv: Sequence[str] | None = None) -> int:
    """Calibrate, run the trials, print and save the table."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import _common

    parser = _common.argument_parser(__doc__ or "")
    parser.add_argument("--trials", type=int, default=60, help="number of trials (default 60)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the draws (default 0)")
    parser.add_argument("--commands", default=",".join(COMMANDS), help="commands to interrupt, comma-separated")
    parser.add_argument(
        "--minutes", type=float, default=None, help="start no trial after this many minutes (default: no limit)"
    )
    args = parser.parse_args(argv)
    names = [n for n in args.commands.split(",") if n]
    unknown = sorted(set(names) - set(COMMANDS))
    if unknown:
        parser.error(f"--commands: unknown {unknown}; expected some of {', '.join(COMMANDS)}")
    out = _common.output_folder(Path(args.out), overwrite_committed=args.overwrite_committed).resolve()
    facts = _common.run_facts()
    work = Path(tempfile.mkdtemp(prefix="fuzz-interrupts-"))
    calibration: dict[str, float] = {}
    for name in names:  # one run each without a signal: its duration, and the good earlier outputs
        good = work / f"good-{name}"
        prepare_fresh(good)
        outcome = execute(command_line(name), good)
        if outcome.code != 0:
            print(f"fuzz_interrupts: {name} failed without a signal ({outcome.code}): {outcome.stderr[-400:]}")
            return 1
        calibration[name] = outcome.wall_s
        print(f"calibration: {name} takes {outcome.wall_s:.1f} s without a signal", flush=True)
    records = []
    deadline = time.monotonic() + 60.0 * args.minutes if args.minutes is not None else float("inf")
    for index in range(args.trials):
        if time.monotonic() > deadline:
            break
        record = run_trial(index, args.seed, names, calibration, work)
        records.append(record)
        flags = ", ".join(record["findings"]) or "ok"
        print(
            f"trial {index}: {record['command']} {record['signal']} at {record['delay_s']:.2f} s -> exit "
            f"{record['exit']}: {flags}",
            flush=True,
        )
    table = table_of(records, names)
    print_table(table)
    summary = {"trials": len(records), "calibration_s": calibration, "table": table, "records": records}
    path = _common.write_json(out, "fuzz_interrupts", summary, facts)
    print(f"wrote {path}; failing trials kept in {work}")
    if all(not r["findings"] for r in records):
        shutil.rmtree(work, ignore_errors=True)
    return 0


FINDINGS = ("lost result", "leftover process", "traceback", "not one line", "start-up traceback")


def table_of(records: list[dict], names: Sequence[str]) -> dict[str, dict[str, int]]:
    """Per command: trials, exits by code, and each finding's count."""
    table: dict[str, dict[str, int]] = {}
    for name in [*names, "all"]:
        rows = [r for r in records if name in ("all", r["command"])]
        counts: Counter[str] = Counter()
        counts["trials"] = len(rows)
        for r in rows:
            counts[f"exit {r['exit']}"] += 1
            for finding in r["findings"]:
                counts[finding] += 1
        table[name] = {"trials": counts["trials"], **{f: counts[f] for f in FINDINGS}}
        table[name] |= {k: v for k, v in sorted(counts.items()) if k.startswith("exit")}
    return table


def print_table(table: dict[str, dict[str, int]]) -> None:
    """The table: one row per command."""
    print(f"{'command':<10} {'trials':>6} " + " ".join(f"{f:>16}" for f in FINDINGS) + "  exits")
    for name, row in table.items():
        exits = ", ".join(f"{k.split()[1]}: {v}" for k, v in row.items() if k.startswith("exit"))
        print(f"{name:<10} {row['trials']:>6} " + " ".join(f"{row[f]:>16}" for f in FINDINGS) + f"  {exits}")


if __name__ == "__main__":
    sys.exit(main())
