"""``robodyn bench``: work--precision charts, stability limits and a report, written to a folder.

Everything is written into a fresh private folder inside ``--out`` (``bench.partial.XXXX``,
made by ``tempfile.mkdtemp``) and moved into ``--out`` only once the report is written: the
old ``report.md`` goes first and the new one comes last, so the folder never holds a report
beside results it does not describe. Ctrl-C keeps the results so far in that partial folder
and leaves ``--out`` as it was; a Ctrl-C during the moves themselves is held until they are
done (the folder then holds the new run whole) and honoured after.

``--view`` then replays, as ``robodyn view`` does (a meshcat server until Ctrl-C, or one
``--html`` file), the fastest run that meets ``--accuracy`` beside the cheapest one that does
not, as two ghosts named by integrator, step, error and cost
(:mod:`robodyn.studies.replay_pair`). The accuracy and the two runs are printed; when no run
meets it, or every run does, one line says so and the one run that exists is replayed.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from robodyn.cli._common import (
    _json_default,
    add_physics_argument,
    file_path,
    number_in,
    physics_checked,
    warn_unchecked,
)
from robodyn.cli._interrupts import held
from robodyn.cli.view import add_ground_argument, port_number
from robodyn.errors import InputError
from robodyn.fileio import pause_for_test, write_text_atomically
from robodyn.wording import count

BUILTINS = ("pendubot", "cart_pole", "geared_arm")

# Files every run writes under these names (the charts of each model are named after it): a
# run that does not write one of them (e.g. --no-stability) removes the old one, which
# would describe another run.
FIXED_OUTPUTS = ("bench.json", "stability.json", "stability.png", "stability.svg", "lyapunov.png", "lyapunov.svg")
REPORT = "report.md"


def add_parser(sub: Any) -> None:
    """Register ``robodyn bench``."""
    p = sub.add_parser(
        "bench",
        help="work-precision charts, stability limits and a report for one or more models",
        description="Run every integrator over a ladder of steps (and tolerances) on every dynamics backend, "
        "measure error against a DOP853 reference, cost and energy drift; find where each method "
        "becomes unstable; write bench.json, stability.json, charts (PNG + SVG) and report.md. With --view, then "
        "replay the fastest run that meets --accuracy beside the cheapest run that does not. Exit codes: 0 ok, "
        "2 bad input, 130 interrupted (the folder is left as it was; the results so far are in a "
        "bench.partial.* folder inside it).",
    )
    p.add_argument(
        "models",
        nargs="*",
        metavar="MODEL",
        help=f"built-in name or URDF path (default: {', '.join(BUILTINS)})",
    )
    p.add_argument("--out", type=file_path, required=True, metavar="DIR", help="output folder (created if needed)")
    p.add_argument("--quick", action="store_true", help="a CI-sized subset (under a minute)")
    p.add_argument("--no-stability", action="store_true", help="skip the stability study (stability.json)")
    p.add_argument("--no-progress", action="store_true", help="do not draw the progress bar on stderr")
    add_physics_argument(p)
    view = p.add_argument_group("replay of two runs (one model)")
    view.add_argument(
        "--view",
        action="store_true",
        help="after the bench, replay the fastest run that meets --accuracy beside the cheapest one that does not, "
        "as two ghosts in a meshcat server until Ctrl-C (or in the --html file); one MODEL only",
    )
    view.add_argument(
        "--accuracy",
        type=accuracy_value,
        default=None,
        metavar="RTOL",
        help="the accuracy of --view: largest relative state error against the DOP853 reference over the error "
        "horizon (default 1e-6)",
    )
    view.add_argument(
        "--html",
        type=file_path,
        default=None,
        metavar="OUT.html",
        help="write the replay to this file (implies --view)",
    )
    view.add_argument("--open", action="store_true", help="open the replay (page or file) in the web browser")
    add_ground_argument(view)
    view.add_argument(
        "--port", type=port_number, default=None, help="web port of the replay's meshcat server (default: free)"
    )
    p.set_defaults(handler=run)


accuracy_value = number_in(low=0.0, high=1.0, noun="relative error")
"""Argparse type: an accuracy, a relative error > 0 and <= 1."""


class ProgressBar:
    """A one-line progress bar on stderr, redrawn only when it changes."""

    WIDTH = 30

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.last = ""

    def __call__(self, done: int, total: int, label: str) -> None:
        """Draw ``done`` of ``total`` with ``label``."""
        if not self.enabled:
            return
        filled = int(self.WIDTH * done / max(total, 1))
        line = f"\r[{'#' * filled}{'.' * (self.WIDTH - filled)}] {done}/{total} {label}"[:110]
        if line != self.last:
            sys.stderr.write(line.ljust(len(self.last)))
            sys.stderr.flush()
            self.last = line
        if done == total:
            sys.stderr.write("\n")
            self.last = ""

    def end_line(self) -> None:
        """End a bar left mid-line (a Ctrl-C), so that the next line starts on a line of its own."""
        if self.enabled and self.last:
            sys.stderr.write("\n")
            sys.stderr.flush()
            self.last = ""

    def note(self, text: str) -> None:
        """A line of status (e.g. the stage starting)."""
        if self.enabled:
            sys.stderr.write(f"{text}\n")
            sys.stderr.flush()


def _write_json(path: Path, obj: Any) -> None:
    text = json.dumps(obj, indent=1, default=_json_default, allow_nan=False) + "\n"
    write_text_atomically(path, text)


def _clean(obj: Any) -> Any:
    """JSON-ready copy with inf and nan as None (JSON has no such numbers)."""
    from robodyn.studies.stability import as_dict

    out = as_dict(obj)
    return _none_for_text_numbers(out)


def _none_for_text_numbers(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _none_for_text_numbers(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_none_for_text_numbers(v) for v in obj]
    if isinstance(obj, str) and obj in ("inf", "-inf", "nan"):
        return None
    return obj


def run(args: argparse.Namespace) -> int:
    """Run the sweeps, then the stability study; write everything under ``--out``; replay if asked."""
    from robodyn.cli._output import refuse_clobbering, writable_path
    from robodyn.model.load import load

    out: Path = args.out
    _check_view_options(args)
    writable_path(out / "bench.json")
    names = args.models or list(BUILTINS)
    if args.view and len(names) != 1:
        raise InputError(
            f"--view replays the runs of one model; {len(names)} given ({', '.join(names)}): name one MODEL"
        )
    robots = [load(name, check_physics=physics_checked(args)) for name in names]  # bad names fail here, before any work
    for robot in robots if not physics_checked(args) else ():
        warn_unchecked(robot, command="bench")
    written = [("the output", out / name) for name in (*FIXED_OUTPUTS, REPORT)]
    written += [("the output", out / f"{stem}_{r.name}.{ext}") for r in robots for stem, ext in _CHART_FILES]
    written.append(("--html", args.html))
    for robot in robots:
        inputs = [(f"the URDF of {robot.name}", robot.urdf_path), (f"the SRDF of {robot.name}", robot.srdf_path)]
        refuse_clobbering(written, inputs)
    stage = Path(tempfile.mkdtemp(prefix="bench.partial.", dir=out))
    progress = ProgressBar(not args.no_progress)
    try:
        sweeps = _bench(args, robots, stage, progress)
    except KeyboardInterrupt:
        progress.end_line()  # the one line below on a line of its own
        raise KeyboardInterrupt(_kept(stage, out)) from None
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    abandoned = (
        f"interrupted twice while the results were being moved in; the moves were abandoned: the new files are "
        f"in {stage} or {out}, the earlier ones in {stage / '.old'} or {out}"
    )
    with held(abandoned=lambda: abandoned) as ctrl_c:
        published = _publish(stage, out, ctrl_c)
    if not published:  # a Ctrl-C during the moves: they were undone
        raise KeyboardInterrupt(
            f"interrupted while the results were being moved in; they are in {stage} ({out} is left as it was)"
        )
    runs = sum(len(s.results) for s in sweeps)
    print(f"wrote {out / 'bench.json'} ({count(runs, 'run')}), charts and {out / REPORT}")
    if ctrl_c:  # after the last move: the folder holds the new run whole
        raise KeyboardInterrupt(f"interrupted after the results were moved in; {out} holds them all")
    if args.view:
        return _replay(args, robots[0], sweeps[0])
    return 0


_CHART_FILES = (
    *((stem, ext) for stem in ("work_precision", "error_vs_dt", "energy") for ext in ("png", "svg")),
    ("energy", "json"),
)
"""The per-model files of a sweep, ``STEM_MODEL.EXT`` (the energy chart's data beside it)."""


def _check_view_options(args: argparse.Namespace) -> None:
    """``--html`` implies ``--view``; the other replay options need it. Checks the --html path before the work."""
    from robodyn.cli._output import check_output_file

    if args.html is not None:
        args.view = True
        if args.port is not None:
            raise InputError("--html writes a file and starts no server; leave out --port")
        check_output_file(args.html)
    if not args.view:
        replay_only = (
            ("--accuracy", args.accuracy),
            ("--open", args.open or None),
            ("--port", args.port),
            ("--ground", args.ground or None),
        )
        for flag, given in replay_only:
            if given is not None:
                raise InputError(f"{flag} is an option of the replay; add --view (or --html OUT.html)")


def _kept(stage: Path, out: Path) -> str:
    """``interrupted; the results so far are in STAGE (OUT is left as it was)``; the stage goes if it is empty."""
    if stage.is_dir() and any(stage.iterdir()):
        return f"interrupted; the results so far are in {stage} ({out} is left as it was)"
    shutil.rmtree(stage, ignore_errors=True)
    return f"interrupted before any result; {out} is left as it was"


def _replay(args: argparse.Namespace, robot: Any, sweep: Any) -> int:
    """Replay the fastest run that meets the accuracy beside the cheapest that does not; the exit code."""
    from robodyn import viewer
    from robodyn.cli.view import check_frame_count, serve_playback, write_html
    from robodyn.studies.replay_pair import DEFAULT_ACCURACY, pick_pair, rerun

    accuracy = DEFAULT_ACCURACY if args.accuracy is None else args.accuracy
    pair = pick_pair(sweep.model, sweep.results, accuracy, horizon=sweep.plan.error_horizon)
    print(f"replay of {pair.describe()}", flush=True)
    if not pair.runs:
        return 0
    replayed = [rerun(robot, sweep, result) for result in pair.runs]
    for run in replayed:
        recorded, again = run.result.error, run.error
        if not (recorded == again or (math.isinf(recorded) and math.isinf(again))):
            print(
                f"robodyn bench: note: {run.result.label} measured again gives error {again:.3g}, "
                f"the sweep {recorded:.3g}",
                file=sys.stderr,
            )
    span = max(float(r.trajectory.t[-1]) for r in replayed) - min(float(r.trajectory.t[0]) for r in replayed)
    check_frame_count(span, speed=1.0, fps=None, what="the replay", hint="a shorter energy horizon")
    playback = viewer.build(
        robot,
        [r.trajectory for r in replayed],
        names=[pair.name(r.result) for r in replayed],
        ground=args.ground,
    )
    print(
        f"{playback.robot_name}: {count(playback.n_frames, 'frame')}, {playback.duration:.2f} s of playback, "
        f"{count(len(playback.runs), 'run')}, camera {playback.camera_mode}",
        flush=True,
    )
    if args.html is not None:
        write_html(playback, args.html, open_browser=args.open)
        return 0
    return serve_playback(playback, open_browser=args.open, zmq_url=None, port=args.port)


def _load() -> float:
    """The 1-minute load average (NaN where the platform has none): the report states it with its timings."""
    try:
        return os.getloadavg()[0]
    except OSError:  # pragma: no cover - platforms without a load average
        return float("nan")


def _bench(args: argparse.Namespace, robots: list[Any], out: Path, progress: ProgressBar) -> list[Any]:
    """Write the results of the sweeps, the stability study and the report into ``out``; return the sweeps.

    A Ctrl-C during a sweep first writes the runs finished so far to ``out``/bench.json.
    """
    from robodyn import charts
    from robodyn.errors import BenchInterrupted
    from robodyn.studies import bench, report

    plan = bench.default_plan(quick=args.quick)
    sweeps: list[bench.Sweep] = []
    figures: dict[str, list[str]] = {}
    started, load_start = time.perf_counter(), _load()
    for robot in robots:
        progress.note(f"robodyn bench: work-precision sweep of {robot.name}")
        try:
            result = bench.sweep(robot, plan=plan, progress=progress)
        except BenchInterrupted as exc:
            finished = [*sweeps, exc.sweep] if exc.sweep.results else sweeps
            if finished:
                with held():
                    _write_json(out / "bench.json", bench.records(finished))
            raise
        sweeps.append(result)
        _write_json(out / "bench.json", bench.records(sweeps))  # partial results first
        figures[robot.name] = _sweep_charts(result, out, charts)
    findings = None
    if not args.no_stability:
        progress.note("robodyn bench: stability study")
        findings = _stability(robots, out, quick=args.quick, progress=progress)
    seconds, load = time.perf_counter() - started, (load_start, _load(), os.cpu_count() or 1)
    text = report.bench_report(sweeps, figures, findings, quick=args.quick, seconds=seconds, load=load)
    write_text_atomically(out / REPORT, text)
    return sweeps


def _publish(stage: Path, out: Path, ctrl_c: list[int]) -> bool:
    """Move the files of ``stage`` into ``out``, or, if a Ctrl-C came meanwhile, none: True when moved.

    The old files this run replaces, and the fixed-name results of an earlier run that it did not
    write, first go into ``stage``/.old; the new report comes last. A Ctrl-C noted in ``ctrl_c``
    (the list of :func:`robodyn.cli._interrupts.held`) before the last move undoes the moves:
    ``out`` is as it was and ``stage`` holds the new results. Only then is .old removed.
    """
    produced = sorted(path.name for path in stage.iterdir())
    new = [name for name in produced if name != REPORT] + [REPORT]
    old_names = [REPORT, *(x for x in FIXED_OUTPUTS if x not in produced), *new[:-1]]
    backup = stage / ".old"
    backup.mkdir()
    moved_out: list[str] = []
    moved_in: list[str] = []
    for name in dict.fromkeys(old_names):
        old = out / name
        if old.is_symlink() or old.is_file():
            os.replace(old, backup / name)
            moved_out.append(name)
    for name in new:
        if ctrl_c:
            break
        os.replace(stage / name, out / name)
        moved_in.append(name)
        pause_for_test("publish")
    if ctrl_c:  # undo: the new files back into the stage, the old ones back into out
        for name in moved_in:
            os.replace(out / name, stage / name)
        for name in moved_out:
            os.replace(backup / name, out / name)
        backup.rmdir()
        return False
    shutil.rmtree(backup, ignore_errors=True)
    stage.rmdir()
    return True


def _sweep_charts(result: Any, out: Path, charts: Any) -> list[str]:
    from robodyn.studies import bench

    name = result.model
    orders = {m: bench.measured_order(result.results, m) for m in (*result.plan.fixed,)}
    files = []
    files += charts.work_precision(result.results, out / f"work_precision_{name}", title=f"{name}: work-precision")
    files += charts.error_vs_dt(
        result.results, out / f"error_vs_dt_{name}", orders=orders, title=f"{name}: error vs dt"
    )
    files += charts.energy_error(result.energy, out / f"energy_{name}", title=f"{name}: energy error vs time")
    _write_json(
        out / f"energy_{name}.json",
        [
            {"integrator": s.integrator, "backend": s.backend, "dt": s.dt, "t": s.t, "energy_error": s.error}
            for s in result.energy
        ],
    )
    return [Path(f).name for f in files]


def _stability(robots: list[Any], out: Path, *, quick: bool, progress: ProgressBar) -> Any:
    """Run the stability study, write stability.json and its charts; return its findings for the report.

    The limits are measured on the benched robots. The built-in models' own studies (the stiff
    arm, which also gets its limits, the Pendubot's chaos and the light-tip Pendubot's near-singular
    mass matrix) run only in a bench of at least one built-in kind: a report about other robots
    says nothing of robots it did not bench.
    """
    import numpy as np

    from robodyn import charts
    from robodyn.errors import RobodynError
    from robodyn.kinds.params import detect_kind
    from robodyn.model.load import load
    from robodyn.studies import stability
    from robodyn.studies.report import StabilityFindings

    methods = stability.QUICK_FIXED_METHODS if quick else stability.FIXED_METHODS
    steps = 300 if quick else 2000
    builtin = any(detect_kind(robot) is not None for robot in robots)
    stiff = load(stability.variant_path(stability.STIFF_VARIANT)) if builtin else None
    light = load(stability.variant_path(stability.LIGHT_VARIANT)) if builtin else None
    cases = [*([stiff] if stiff is not None else []), *(robots[:1] if quick else robots)]
    if light is not None and not quick:
        cases.append(light)
    summary: dict[str, Any] = {"quick": quick, "steps_per_trial": steps, "limits": [], "notes": []}
    limits: list[Any] = []
    for k, robot in enumerate(cases, start=1):
        progress(k - 1, len(cases), f"limits of {robot.name}")
        try:
            found = stability.limits(robot, methods=methods, steps=steps, rtol=0.03 if quick else 0.01)
        except RobodynError as exc:
            summary["notes"].append(f"{robot.name}: no stability limits ({exc})")
            continue
        limits += found
        summary["limits"] += [{**_clean(x), "ratio": _clean(x.ratio)} for x in found]
        _write_json(out / "stability.json", summary)
    progress(len(cases), len(cases), "limits done")
    studies: dict[str, Any] = {}
    if stiff is not None and light is not None:
        studies = _builtin_studies(stiff, light, summary, quick=quick, progress=progress)
    n = 31 if quick else 71
    re = np.linspace(-3.5, 1.0, n)
    im = np.linspace(-3.5, 3.5, n)
    regions = {m: (re, im, stability.region_grid(m, re, im)) for m in methods}
    summary["regions"] = {
        m: {
            "real_axis_limit": _clean(stability.region_radius(m, np.pi)),
            "imaginary_axis_limit": _clean(stability.region_radius(m, np.pi / 2)),
        }
        for m in methods
    }
    _write_json(out / "stability.json", summary)
    files = list(charts.stability(summary["limits"], regions, out / "stability"))
    chaos = studies.get("chaos")
    if chaos is not None:
        lyap = chaos.lyapunov
        t_run = lyap.interval * np.arange(1, lyap.renormalisations + 1)
        files += charts.lyapunov(t_run, lyap.running, chaos.gap_t, chaos.gap, out / "lyapunov")
    summary["figures"] = [Path(f).name for f in files]
    _write_json(out / "stability.json", summary)
    return StabilityFindings(limits=tuple(limits), steps_per_trial=steps, notes=tuple(summary["notes"]), **studies)


def _builtin_studies(stiff: Any, light: Any, summary: dict[str, Any], *, quick: bool, progress: ProgressBar) -> Any:
    """The stiff arm's runs, the Pendubot's chaos, the light tip's conditioning: StabilityFindings' fields."""
    from robodyn.model.load import load
    from robodyn.studies import stability
    from robodyn.studies.bench import start_state
    from robodyn.studies.report import time_constants

    progress.note("robodyn bench: stiff runs, chaos, near-singular mass matrix")
    eigenvalues = stability.linearise(stiff, stability.hanging_equilibrium(stiff)).eigenvalues
    runs = stability.stiff_runs(stiff, dt=0.01, duration=0.2 if quick else 1.0, quick=quick)
    taus = time_constants(eigenvalues)
    summary["stiff"] = {
        "model": stiff.name,
        "eigenvalues": _clean(eigenvalues),
        "time_constant_s": _clean(taus[0] if taus else float("nan")),
        "runs": _clean(runs),
    }
    pendubot = load("pendubot")
    q0, v0 = start_state(pendubot)
    found_chaos = stability.chaos(pendubot, q0, v0, duration=30.0 if quick else 60.0)
    summary["chaos"] = _clean(found_chaos)
    near = stability.near_singular(light, pendubot, duration=1.0 if quick else 2.0)
    summary["near_singular"] = _clean(near)
    return {
        "stiff_model": stiff.name,
        "stiff_eigenvalues": eigenvalues,
        "stiff_runs": tuple(runs),
        "chaos": found_chaos,
        "near_singular": near,
        "tip_masses": {r.name: _distal_mass(r) for r in (light, pendubot)},
    }


def _distal_mass(robot: Any) -> float:
    """Mass [kg] of the body carried by the robot's last joint."""
    model = robot.model
    return float(model.inertias[model.njoints - 1].mass)
