"""MkDocs hooks: the pages' generated parts, so that nothing in them is typed by hand.

A page asks for a generated part with an HTML comment on a line of its own:

* ``<!-- generated: cli-reference -->``: ``robodyn --help`` and every subcommand's help, rendered
  from the argparse parsers themselves;
* ``<!-- generated: layout -->``: every package and module of ``src/robodyn`` with the first line
  of its docstring;
* ``<!-- generated: bench PATH -->``: a table and the sentences read from a saved benchmark JSON
  (PATH relative to ``docs/``), with the date, machine and load of its run, and the JSON itself;
* ``<!-- generated: include PATH -->``: a Markdown file (e.g. a ``robodyn bench`` report), its
  headings moved two levels down and its relative links made relative to the page.

An unknown part, a missing file or a JSON without the keys its table needs fails the build.
"""

from __future__ import annotations

import ast
import io
import json
import os
import posixpath
import re
import sys
from collections import Counter
from collections.abc import Callable
from contextlib import redirect_stdout
from pathlib import Path
from typing import Any, NamedTuple

from mkdocs.exceptions import PluginError

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
MARKER = re.compile(r"^<!-- generated: (?P<what>[\w-]+)(?: (?P<arg>\S+))? -->$", re.MULTILINE)
INLINE_JSON_LIMIT = 20_000  # characters: larger files are linked, not shown


class GeneratedPartError(PluginError):
    """A page asked for a generated part that cannot be made."""


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """Replace every ``<!-- generated: ... -->`` line of a page by what it names."""
    page_dir = posixpath.dirname(page.file.src_uri)

    def replace(match: re.Match[str]) -> str:
        what, arg = match.group("what"), match.group("arg")
        maker = PARTS.get(what)
        if maker is None:
            raise GeneratedPartError(f"{page.file.src_uri}: unknown generated part {what!r}; expected {sorted(PARTS)}")
        return maker(arg, page_dir)

    return MARKER.sub(replace, markdown)


# -- the CLI reference -------------------------------------------------------------------------


def cli_reference(_arg: str | None, _page_dir: str) -> str:
    """``robodyn --help`` and each subcommand's ``--help``, as argparse formats them at 100 columns."""
    import argparse

    from robodyn.cli import get_argument_parser

    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"
    try:
        parser = get_argument_parser()
        parts = ["## robodyn", "", "```text", parser.format_help().rstrip(), "```", ""]
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    parts += [f"## robodyn {name}", "", "```text", sub.format_help().rstrip(), "```", ""]
    finally:
        if previous is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = previous
    return "\n".join(parts)


# -- the source layout -------------------------------------------------------------------------


def _first_line(path: Path) -> str:
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")))
    if not doc:
        raise GeneratedPartError(f"{path.relative_to(ROOT)} has no module docstring")
    return doc.strip().splitlines()[0]


def layout(_arg: str | None, _page_dir: str) -> str:
    """A table of every package and module of ``src/robodyn`` with its docstring's first line."""
    src = ROOT / "src" / "robodyn"
    rows = ["| module | what it is |", "|---|---|"]
    for path in sorted(src.rglob("*.py")):
        if "__pycache__" in path.parts or "assets" in path.parts:
            continue
        relative = path.relative_to(src.parent).with_suffix("")
        parts = list(relative.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        name = ".".join(parts)
        text = _first_line(path).replace("|", "\\|")
        rows.append(f"| `{name}` | {text} |")
    return "\n".join(rows) + "\n"


# -- benchmark JSON ----------------------------------------------------------------------------


def _num(x: float | None, digits: int = 3) -> str:
    if x is None:
        return "–"
    return f"{x:.{digits}g}"


def _run_record(data: dict[str, Any]) -> dict[str, Any] | None:
    """The run's facts (date, machine, load, command) wherever a benchmark put them, or None."""
    run = data.get("run")
    if isinstance(run, dict):
        return run
    if "date" not in data and "load_average_before" not in data and "load_average" not in data:
        return None
    machine = data.get("machine")
    record: dict[str, Any] = {
        "date": data.get("date"),
        "load_before": data.get("load_average_before"),
        "load_after": data.get("load_average_after"),
        "load_end": data.get("load_average"),
        "command": data.get("command"),
    }
    if isinstance(machine, dict):
        record.update(machine=machine.get("platform", "?"), cpus=machine.get("cpus"))
        record.update({k: machine[k] for k in ("robodyn", "mujoco", "python") if k in machine})
    else:
        record["machine"] = machine or "?"
    return record


def _facts(data: dict[str, Any], name: str) -> str:
    """One sentence: when, where, under what load and by what command the file was measured."""
    run = _run_record(data)
    if run is None:
        machine = data.get("machine")
        shown = json.dumps(machine) if machine else "not recorded"
        return f"*`{name}` records no date or load (machine: {shown}); the git history of the file dates it.*\n"

    def load(value: list[float]) -> str:
        return f"{value[0]:.2f} (1 min), {value[1]:.2f} (5 min)"

    when = (
        f"Measured {run['date']}" if run.get("date") else "Measured on a date the file does not record (git dates it)"
    )
    details = [x for x in (run.get("processor"), f"{run['cpus']} CPUs" if run.get("cpus") else None) if x]
    parts = [f"{when} on {run.get('machine', '?')}" + (f" ({', '.join(details)})" if details else "")]
    loads = [
        f"{label} {load(run[key])}"
        for key, label in (("load_before", "before"), ("load_after", "after"), ("load_end", "at the end of the run"))
        if run.get(key)
    ]
    parts.append("load average " + (", ".join(loads) if loads else "not recorded"))
    if run.get("wall_time_s") is not None:
        parts.append(f"{run['wall_time_s']} s of wall time")
    versions = ", ".join(f"{k} {run[k]}" for k in ("robodyn", "pinocchio", "mujoco", "numpy", "python") if k in run)
    if versions:
        parts.append(versions)
    if run.get("command"):
        parts.append(f"command: `{run['command']}`")
    text = "; ".join(parts) + "."
    cpus, before = run.get("cpus"), run.get("load_before")
    if cpus and before and before[0] > cpus:
        text += (
            f" The 1-minute load before the run ({before[0]:.2f}) already exceeded the {cpus} CPUs: other work "
            "shared the cores, so its speed figures are those of a busy machine."
        )
    return f"*{text}*\n"


def _scaling(data: dict[str, Any]) -> str:
    rows = data["rows"]
    out = [
        "| model | nv | M [µs] | C [µs] | G [µs] | ABA [µs] | wall s per simulated s (RK4, 1 ms) "
        "| load [ms] | load + meshes [ms] |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        c = r["per_call_s"]
        out.append(
            f"| {r['label']} | {r['nv']} | {c['M'] * 1e6:.2f} | {c['C'] * 1e6:.2f} | {c['G'] * 1e6:.2f} | "
            f"{c['ABA'] * 1e6:.2f} | {r['per_simulated_second_s']:.3g} | {r['load_dynamics_s'] * 1e3:.3g} | "
            f"{r['load_with_geometry_s'] * 1e3:.3g} |"
        )
    out.append("")
    sentences = []
    by_nv = sorted(rows, key=lambda r: (r["nv"], r["per_call_s"]["M"]))
    low, high = by_nv[0], by_nv[-1]
    m = [r["per_call_s"]["M"] * 1e6 for r in rows]
    sentences.append(
        f"M (robodyn's `mass_matrix`: CRBA, then the copy and symmetrisation) costs {min(m):.2f} to {max(m):.2f} µs "
        f"per call here: {low['per_call_s']['M'] * 1e6:.2f} µs at nv = {low['nv']} ({low['label']}) and "
        f"{high['per_call_s']['M'] * 1e6:.2f} µs at nv = {high['nv']} ({high['label']})."
    )
    label = {r["label"]: r for r in rows}
    if "talos" in label and "talos keep 7 (left arm)" in label:
        full, kept = label["talos"]["per_call_s"], label["talos keep 7 (left arm)"]["per_call_s"]
        sentences.append(
            f"Keeping Talos's 7 left-arm joints makes C {full['C'] / kept['C']:.1f}× and ABA "
            f"{full['ABA'] / kept['ABA']:.1f}× cheaper per call than the 32-DoF model."
        )
    for name, shown in (("talos", "Talos"), ("panda", "The Panda")):
        if name in label:
            r = label[name]
            sentences.append(
                f"{shown} loads for dynamics in {r['load_dynamics_s'] * 1e3:.3g} ms, against "
                f"{r['load_with_geometry_s'] * 1e3:.3g} ms with its visual meshes "
                f"({r['load_with_geometry_s'] / r['load_dynamics_s']:.0f}×)."
            )
    sims = sorted(rows, key=lambda r: r["per_simulated_second_s"])
    sentences.append(
        f"Per simulated second the runs cost from {sims[0]['per_simulated_second_s']:.3g} s ({sims[0]['label']}) to "
        f"{sims[-1]['per_simulated_second_s']:.3g} s ({sims[-1]['label']})."
    )
    return "\n".join(out) + "\n" + " ".join(sentences) + "\n"


def _fidelity(data: dict[str, Any]) -> str:
    out = [
        "| system | minimal model | richer model | max trajectory error | wall s per simulated s (minimal / richer) |",
        "|---|---|---|---:|---:|",
    ]
    for p in data["pairs"]:
        s, r = p["simple"], p["rich"]
        out.append(
            f"| {p['system']} | {s['model']} ({s['backend']}) | {r['model']} ({r['backend']}) | "
            f"{p['max_q_error']:.3g} | {s['per_simulated_second_s']:.3g} / {r['per_simulated_second_s']:.3g} "
            f"({100 * p['time_saved_fraction']:.0f} % saved) |"
        )
    return "\n".join(out) + "\n"


def _overhead(data: dict[str, Any]) -> str:
    verdict = "within" if data["ratio"] < data["limit"] else "**over**"
    statistic = "best" if data.get("statistic", "min") == "min" else data["statistic"]
    text = (
        f"`simulate` took {data['ratio']:.2f}× the time of a bare Python loop of `pin.aba` + RK4 on the same "
        f"problem ({data['model']}, RK4, dt = {data['dt_s']:g} s, {data['steps']} steps, {statistic} of "
        f"{data['repeat']}: {data['per_step_us']['simulate']:.1f} µs against {data['per_step_us']['bare_loop']:.1f} µs "
        f"a step; the states differ by at most {data['max_state_difference']:.1e}): {verdict} the limit of "
        f"{data['limit']:g}×."
    )
    if "ratio_cpu" in data:
        text += f" In CPU time (without the waits for a core on a loaded machine): {data['ratio_cpu']:.2f}×."
    buys = data.get("overhead_buys")
    if buys is not None:

        def ms(x: float) -> str:  # a part timed below zero is below the run-to-run noise
            return f"{1e3 * x:.1f} ms" if x > 0 else "below the noise"

        text += (
            f" The {ms(data['overhead_s'])} it adds buy the watch on the joint stops "
            f"({ms(buys['stop_watch_s'])}: the same call with `limits=False` took {data['ratio_limits_off']:.2f}×), "
            f"the energies of every sample for the ledger ({ms(buys['energies_s'])}, computed alone), the set-up and "
            f"the Trajectory ({ms(buys['set_up_and_trajectory_s'])}, a two-step call) and the rest: the stepper's "
            f"layers, the records and the divergence checks ({ms(buys['stepper_records_and_checks_s'])}). Each part "
            "is timed on its own, so on a loaded machine they need not add up exactly."
        )
    return text + "\n"


def _api(data: dict[str, Any]) -> str:
    out = ["| call | robodyn [µs] | Pinocchio [µs] | ratio | limit [µs] | |", "|---|---:|---:|---:|---:|---|"]
    for row in data["rows"]:
        verdict = "within" if row["within_limit"] else "**over**"
        out.append(
            f"| `robot.{row['call']}` | {row['robodyn_us']:.2f} | {row['pinocchio_us']:.2f} | {row['ratio']:.2f} | "
            f"{row['limit_us']:.2f} | {verdict} |"
        )
    over = [row["call"] for row in data["rows"] if not row["within_limit"]]
    worst = max(data["rows"], key=lambda row: row["robodyn_us"] - row["limit_us"])
    reading = (
        f"{data['model']} (nv = {data['nv']}), best of {data['repeat']} loops of {data['calls']} calls each; the "
        f"limit is {data['ratio_limit']:g}× the Pinocchio call + {data['slack_us']:g} µs. "
        + (
            f"Every call is within it; the closest, `robot.{worst['call']}`, by "
            f"{worst['limit_us'] - worst['robodyn_us']:.2f} µs."
            if not over
            else f"Over it: {', '.join(f'`robot.{c}`' for c in over)}."
        )
    )
    return "\n".join(out) + "\n\n" + reading + "\n"


def _control(data: dict[str, Any]) -> str:
    out = [
        "| system | swing-up: upright from | peak torque / limit | LQR basin balanced | hand-over region | "
        "mass errors: swing-ups that succeed |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name in ("cart_pole", "pendubot"):
        if name not in data:
            continue
        d = data[name]
        s, b, r = d["swing_up"], d["basin"], d["robustness"]
        upright = "never" if s["time_to_upright_s"] is None else f"{s['time_to_upright_s']:.2f} s"
        out.append(
            f"| {name} | {upright} | {s['peak_torque']:.3g} / {s['effort_limit']:g} | "
            f"{100 * b['fraction_balanced']:.1f} % of a {len(b['balanced'])} × {len(b['balanced'])} grid | "
            f"{100 * b['fraction_in_region']:.1f} % of the grid | {r['successes']} |"
        )
    note = " (a `--quick` run: not figures to quote)" if data.get("quick") else ""
    reading = f"RK4 at dt = {data['dt_s']:g} s; upright means within {data['settle_tol_rad']:g} rad, staying{note}."
    return "\n".join(out) + "\n\n" + reading + "\n"


# The goals of the comparison with MuJoCo, as ratios measured in one run: (label, system, kind, threads, bound,
# at_least). kind "single": MuJoCo's RK4 time over robodyn's with the joint stops off in both (closed form for the
# built-in kinds, else robodyn.simulate), "single_on": the same with the stops on (robodyn.simulate's stops against
# MuJoCo's limits from the same URDF), "batch": mujoco.rollout over robodyn's batch.rollout (no stops), "overhead":
# robodyn.simulate's whole call over its own compiled loop (at most the bound; stops off). A bound of None: shown,
# with no target.
SEED_KINDS = ("pendubot", "cart_pole", "geared_arm")
STOPS_OF_KIND = {"single": "off", "single_on": "on", "batch": "off", "overhead": "off"}
MUJOCO_GOALS: tuple[tuple[str, str, str, str | None, float | None, bool], ...] = (
    ("Pendubot batch of 1000 vs `mujoco.rollout`, 1 thread each", "pendubot", "batch", "1", 5.0, True),
    ("Pendubot batch of 1000 vs `mujoco.rollout`, 2 threads each", "pendubot", "batch", "2", 5.0, True),
    ("Panda single trajectory vs MuJoCo RK4 with its limits", "panda", "single_on", None, 2.0, True),
    ("Panda single trajectory vs MuJoCo RK4, equal error", "panda", "single", None, 2.0, True),
    ("Talos, fixed base, single trajectory vs MuJoCo RK4 with its limits", "talos", "single_on", None, 1.5, True),
    ("Talos, fixed base, single trajectory vs MuJoCo RK4, equal error", "talos", "single", None, 1.5, True),
    ("Panda batch of 1000 vs `mujoco.rollout`, 1 thread each", "panda", "batch", "1", 2.0, True),
    ("Panda batch of 1000 vs `mujoco.rollout`, 2 threads each", "panda", "batch", "2", 2.0, True),
    *(
        row
        for name in SEED_KINDS
        for row in (
            (
                f"{name} single trajectory vs MuJoCo RK4 with its limits (`robodyn.simulate`)",
                name,
                "single_on",
                None,
                None,
                True,
            ),
            (f"{name} single trajectory vs MuJoCo RK4 (compiled closed form)", name, "single", None, 10.0, True),
        )
    ),
    *(
        (f"{name}: `robodyn.simulate` with the ledger vs its own compiled loop", name, "overhead", None, 1.3, False)
        for name in ("pendubot", "cart_pole", "geared_arm", "panda", "talos")
    ),
)
MUJOCO_PATHS = {
    "mujoco_rk4_c_loop": "MuJoCo RK4",
    "robodyn_simulate_compiled": "`robodyn.simulate`",
    "robodyn_fast_closed_form": "closed form",
    "robodyn_simulate_python_aba": "Python loop over ABA",
}


def _us(x: float | None) -> str:
    return "–" if x is None else f"{x:.3g}"


def _mujoco_single_ratio(system: dict[str, Any]) -> tuple[float, str]:
    """MuJoCo's RK4 µs per step over robodyn's best, stops off: the closed form where there is one, else simulate."""
    paths = system["single"]["paths"]
    fast = paths.get("robodyn_fast_closed_form")
    mine = fast if fast is not None else paths["robodyn_simulate_compiled"]
    return paths["mujoco_rk4_c_loop"]["us_per_step"] / mine["us_per_step"], (
        "closed form" if fast is not None else "`robodyn.simulate`"
    )


def _stops_on_ratio(system: dict[str, Any]) -> float:
    """MuJoCo's RK4 µs per step, with its limits, over robodyn.simulate's with its stops."""
    paths = system["single_stops_on"]["paths"]
    return paths["mujoco_rk4_c_loop"]["us_per_step"] / paths["robodyn_simulate_compiled"]["us_per_step"]


class Goal(NamedTuple):
    """One goal of the comparison with MuJoCo, as the README and the benchmarks page show it.

    ``stops``: "on" | "off"; ``impacts``: "robodyn's impacts / MuJoCo's limit activations" of a stops-on run;
    ``bound``: None for none; ``value``: the measured ratio, None when the file lacks the measurement.
    """

    label: str
    stops: str
    impacts: str
    bound: float | None
    at_least: bool
    value: float | None

    def met(self) -> bool | None:
        """Whether the ratio meets its bound (None without a bound or a ratio)."""
        if self.bound is None or self.value is None:
            return None
        return self.value >= self.bound if self.at_least else self.value <= self.bound

    @property
    def target(self) -> str:
        """The bound as the tables write it ("≥ 2×", or "–" without one)."""
        return "–" if self.bound is None else f"{'≥' if self.at_least else '≤'} {self.bound:g}×"


def mujoco_goals(data: dict[str, Any]) -> list[Goal]:
    """Every goal of a system the run measured; a stops-on goal of a file without that measurement has no value."""
    systems = data["systems"]
    goals = []
    for label, name, kind, threads, bound, at_least in MUJOCO_GOALS:
        r = systems.get(name)
        if r is None:
            continue
        value: float | None
        impacts = "–"
        if kind == "single":
            if at_least and name in SEED_KINDS and "robodyn_fast_closed_form" not in r["single"]["paths"]:
                continue
            value, _ = _mujoco_single_ratio(r)
        elif kind == "single_on":
            on = r.get("single_stops_on")
            value = None if on is None else _stops_on_ratio(r)
            if on is not None:
                impacts = f"{on['impacts']} / {on['mujoco_limit_activations']}"
        elif kind == "batch":
            t = r["batch"]["threads"].get(threads)
            if t is None:
                continue
            value = t["mujoco_rollout_us_per_state_step"] / t["robodyn_us_per_state_step"]
        else:
            value = r["single"]["simulate_call_over_compiled_loop"]
        goals.append(
            Goal(label, STOPS_OF_KIND[kind], impacts, bound, at_least, None if value is None else float(value))
        )
    return goals


def readme_speed(normal: dict[str, Any], busy: dict[str, Any]) -> str:
    """The README's speed table: the goals against MuJoCo, measured on a quiet machine and under ``--busy``."""
    got = {goal.label: goal.value for goal in mujoco_goals(busy)}
    lines = [
        "| goal (ratios measured side by side in one run) | joint stops | impacts: robodyn / MuJoCo's limit "
        "activations | target | measured | with a CPU-bound process competing |",
        "|---|---|---:|---:|---:|---:|",
    ]
    verdicts = {True: 0, False: 0}
    missing = 0

    def shown(goal: Goal, x: float | None) -> str:
        nonlocal missing
        if x is None:
            missing += 1
            return "not measured"
        ok = Goal(goal.label, goal.stops, goal.impacts, goal.bound, goal.at_least, x).met()
        if ok is not None:
            verdicts[ok] += 1
        return f"{x:.3g}×" + ("" if ok is not False else " (**not met**)")

    for goal in mujoco_goals(normal):
        lines.append(
            f"| {goal.label} | {goal.stops} | {goal.impacts} | {goal.target} | {shown(goal, goal.value)} "
            f"| {shown(goal, got.get(goal.label))} |"
        )

    def when(data: dict[str, Any]) -> str:
        run = _run_record(data) or {}
        before, after = run.get("load_before"), run.get("load_after")
        loads = f"load {before[0]:.2f} before, {after[0]:.2f} after" if before and after else "load not recorded"
        return f"{run.get('date', 'undated')}, {run.get('cpus', '?')} CPUs, {loads}"

    missed = verdicts[False]
    judged = sum(verdicts.values())
    lines += [
        "",
        f"From `docs/benchmarks/bench_mujoco.json` ({when(normal)}) and `bench_mujoco_busy.json` "
        f"({when(busy)}), as `python benchmarks/bench_mujoco.py [--busy]` saved them. Stops on: robodyn's default "
        "(exact impacts and holds at the URDF's limits) against MuJoCo's soft limits read from the same URDF; stops "
        "off: no limit in either engine; contacts off in both. "
        + (
            f"{missed} of the {judged} figures with a target miss it"
            if missed
            else "Every figure with a target meets it"
        )
        + (f"; {missing} figures are not in these files (measured by a later bench_mujoco.py)." if missing else "."),
    ]
    return "\n".join(lines) + "\n"


def _mujoco_stops_on(systems: dict[str, Any]) -> list[str]:
    """The single trajectories with the joint stops on, as table lines (none when the file lacks them)."""
    rows = [(name, r["single_stops_on"]) for name, r in systems.items() if "single_stops_on" in r]
    if not rows:
        return []
    out = [
        "| system | MuJoCo RK4 with its limits [µs/step] | `robodyn.simulate` with its stops [µs/step] | robodyn: "
        "impacts (steps with an event) | MuJoCo: limit activations | MuJoCo over robodyn |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, on in rows:
        mj, sim = on["paths"]["mujoco_rk4_c_loop"], on["paths"]["robodyn_simulate_compiled"]
        events = sim.get("event_steps")
        out.append(
            f"| {name} | {_us(mj['us_per_step'])} | {_us(sim['us_per_step'])} ({sim.get('loop', '?')}) | "
            f"{on['impacts']} ({'–' if events is None else events}) | {on['mujoco_limit_activations']} | "
            f"{mj['us_per_step'] / sim['us_per_step']:.3g}× |"
        )
    return [
        *out,
        "",
        "The same trajectories with the joint stops on: robodyn's default (exact impacts and holds at the URDF's "
        "limits) against MuJoCo's soft limits read from the same URDF, contacts off in both. The engines model a "
        "stop differently, so no error is compared.",
        "",
    ]


def _mujoco(data: dict[str, Any]) -> str:
    systems = data["systems"]
    out = [
        "| system | nv | MuJoCo RK4 [µs/step] | `robodyn.simulate`, compiled loop with the ledger [µs/step] "
        "| compiled closed form [µs/step] | Python loop over ABA [µs/step] | error at t, MuJoCo / robodyn [rad, m] "
        "| MuJoCo over robodyn |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    worst_error_gap = (0.0, "")
    for name, r in systems.items():
        single = r["single"]
        paths = single["paths"]
        mj, sim = paths["mujoco_rk4_c_loop"], paths["robodyn_simulate_compiled"]
        fast = paths.get("robodyn_fast_closed_form")
        python = paths.get("robodyn_simulate_python_aba")
        ratio, which = _mujoco_single_ratio(r)
        gap = abs(mj["error"] - sim["error"]) / max(abs(mj["error"]), abs(sim["error"]), 1e-300)
        if gap >= worst_error_gap[0]:
            worst_error_gap = (gap, name)
        out.append(
            f"| {name} | {r['nv']} | {_us(mj['us_per_step'])} | {_us(sim['us_per_step'])} "
            f"({sim.get('backend', '?')}, {sim.get('loop', '?')}) | {_us(fast['us_per_step'] if fast else None)} | "
            f"{_us(python['us_per_step'] if python else None)} | t = {single['error_at_s']:g} s: "
            f"{mj['error']:.2g} / {sim['error']:.2g} | {ratio:.3g}× ({which}) |"
        )
    dt = next(iter(systems.values()))["single"]["dt"]
    out += [
        "",
        f"Single torque-free trajectories, RK4 at dt = {dt * 1e3:g} ms; errors against robodyn's compiled RK4 at "
        f"dt / 20. At equal method and step the errors are equal: MuJoCo's and robodyn's differ by at most "
        f"{100 * worst_error_gap[0]:.2g} % of the larger ({worst_error_gap[1]}).",
        "",
        *_mujoco_stops_on(systems),
        "| system | batch | threads | robodyn `batch.rollout` [µs per state-step] | `mujoco.rollout` "
        "[µs per state-step] | `mujoco.rollout` over robodyn | final states differ by |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for name, r in systems.items():
        b = r["batch"]
        for threads, t in b["threads"].items():
            ratio = t["mujoco_rollout_us_per_state_step"] / t["robodyn_us_per_state_step"]
            out.append(
                f"| {name} | {b['states']} states × {b['steps']} steps | {threads} | "
                f"{t['robodyn_us_per_state_step']:.3g} ({t['robodyn_path']}) | "
                f"{t['mujoco_rollout_us_per_state_step']:.3g} | {ratio:.3g}× | {t['max_final_state_difference']:.1g} |"
            )
    slower = [
        f"{name} ({b['threads']['2']['robodyn_us_per_state_step']:.3g} against "
        f"{b['threads']['1']['robodyn_us_per_state_step']:.3g} µs)"
        for name, r in systems.items()
        if {"1", "2"} <= set((b := r["batch"])["threads"])
        and b["threads"]["2"]["robodyn_us_per_state_step"] > b["threads"]["1"]["robodyn_us_per_state_step"]
    ]
    defaults = sorted({r["batch"].get("default_threads_now") for r in systems.values()} - {None})
    sentence = (
        "robodyn's batch on 2 threads was slower than on 1 for " + ", ".join(slower) + "; "
        if slower
        else "robodyn's batch on 2 threads was never slower than on 1; "
    )
    out += [
        "",
        sentence + f"the default thread count (the cores idle by the load average) was "
        f"{' or '.join(str(d) for d in defaults) or 'not recorded'} during this run.",
        "",
        "| goal | joint stops | impacts: robodyn / MuJoCo's limit activations | target | measured | |",
        "|---|---|---:|---:|---:|---|",
    ]
    met, missed = 0, []
    for goal in mujoco_goals(data):
        ok = goal.met()
        met += ok is True
        if ok is False:
            missed.append(f"{goal.label} ({goal.value:.3g}×, target {goal.target})")
        verdict = {True: "met", False: "**not met**", None: "no target" if goal.value is not None else ""}[ok]
        value = "not measured" if goal.value is None else f"{goal.value:.3g}×"
        out.append(f"| {goal.label} | {goal.stops} | {goal.impacts} | {goal.target} | {value} | {verdict} |")
    total = met + len(missed)
    reading = f"{met} of the {total} goals above with a target were met in this run"
    reading += "; not met: " + "; ".join(missed) + "." if missed else "."
    out += ["", reading]
    return "\n".join(out) + "\n"


def _sweep(data: dict[str, Any]) -> str:
    phases = (
        ("batch_alone", "batch path alone (the same chunks in one process, no Dask)"),
        ("dask_1_worker", "Dask, 1 worker"),
        ("dask_2_workers", "Dask, 2 workers"),
    )
    out = [
        "| phase | runs | wall [s] | runs per s | CPU [s] | load, 1-min mean (max) | contended |",
        "|---|---:|---:|---:|---:|---:|---|",
    ]
    for key, label in phases:
        p = data[key]
        wall = p.get("wall_s", p.get("sweep_s"))
        cpu = p.get("cpu_s")
        if cpu is None and "workers_cpu_s" in p:
            cpu = p["workers_cpu_s"] + p.get("scheduler_and_client_cpu_s", 0.0)
        start = f" (+ {p['cluster_start_s']:.1f} s cluster start)" if "cluster_start_s" in p else ""
        load = p["load"]
        out.append(
            f"| {label} | {p['runs']:,} in {p['chunks']} chunks | {wall:.1f}{start} | {p['runs'] / wall:.0f} | "
            f"{_num(cpu)} | {load['load_1min_mean']:.2f} ({load['load_1min_max']:.2f}) | "
            f"{'**yes**' if load['contended'] else 'no'} |"
        )
    chaos, swing = data["chaos_run"], data["swing_up"]
    out.append(
        f"| chaos run, `{chaos['path']}` path: {chaos['samples']} runs timed | {chaos['samples']} | "
        f"{chaos['seconds_per_run'] * chaos['samples']:.2f} | {1 / chaos['seconds_per_run']:.1f} | "
        f"{chaos['cpu_seconds_per_run'] * chaos['samples']:.2f} | {chaos['load']['load_1min_mean']:.2f} "
        f"({chaos['load']['load_1min_max']:.2f}) | {'**yes**' if chaos['load']['contended'] else 'no'} |"
    )
    batch, one, two = data["batch_alone"], data["dask_1_worker"], data["dask_2_workers"]
    rate1, rate2 = one["runs"] / one["sweep_s"], two["runs"] / two["sweep_s"]
    efficiency = rate2 / (2 * rate1)
    overhead = one["sweep_s"] / batch["wall_s"] - 1
    cpu_overhead = (one["workers_cpu_s"] + one["scheduler_and_client_cpu_s"]) / batch["cpu_s"] - 1
    proj = data["projection"]
    per_run = chaos["cpu_seconds_per_run"]
    used = proj.get("efficiency", efficiency)
    seconds = proj["states"] * per_run / (proj["cores"] * used)
    if abs(used - efficiency) > 1e-6:
        basis = (
            f"an assumed efficiency of {used:.3g}, since the measured {efficiency:.3g} came from phases whose load "
            "exceeded the CPUs (not representative)"
        )
    else:
        basis = "the measured efficiency"
    speedup = swing["simulate_seconds_per_run"] / swing["chunk_seconds_per_run"]
    contended = [label for key, label in phases if data[key]["load"]["contended"]]
    out += [
        "",
        f"The basin run: {data['basin_run']}. Going from 1 to 2 workers, the scaling efficiency is "
        f"{rate2:.0f} / (2 × {rate1:.0f}) = {100 * efficiency:.0f} %. Against the batch path alone on the same "
        f"runs, Dask on 1 worker costs {100 * overhead:+.1f} % of wall time and {100 * cpu_overhead:+.1f} % of CPU "
        f"time (workers, scheduler and client). The cart-pole swing-up, one `{'/'.join(swing['path'])}` chunk of "
        f"{swing['runs']} runs, took {1e3 * swing['chunk_seconds_per_run']:.3g} ms a run against "
        f"{1e3 * swing['simulate_seconds_per_run']:.3g} ms for `robodyn.simulate` run by run "
        f"({swing['simulate_runs']} runs): {speedup:.0f}× faster.",
        "",
        f"A chaos map of {proj['states']:,} states on {proj['cores']} cores, projected from the measured CPU time "
        f"per chaos run and {basis}: {proj['states']:,} × {per_run:.4g} s / ({proj['cores']} × "
        f"{used:.3g}) = {seconds:.0f} s ≈ {seconds / 3600:.2g} h, for cores as fast as these, plus the "
        "cluster's start.",
        "",
        (
            "Phases whose mean 1-minute load exceeded the CPUs + 0.5 (contended, not figures to quote): "
            + "; ".join(contended)
            + "."
        )
        if contended
        else "No phase's mean 1-minute load exceeded the CPUs + 0.5: none was contended.",
    ]
    return "\n".join(out) + "\n"


TEXTBOOK_ORDER = ("rolling", "sliding", "motorcycle", "linkage", "spring_bar", "power", "box")
LOOP_DRIFT_BOUND = 1e-9  # [m]: the linkage's loop must stay closed to this along the whole motion


def _textbook(data: dict[str, Any]) -> str:
    rank = {name: i for i, name in enumerate(TEXTBOOK_ORDER)}
    scenes = sorted(data["scenes"], key=lambda r: rank.get(r["scene"], len(rank)))
    out = [
        "| example | quantity | worst deviation from the closed form (relative to its largest value) | tolerance | |",
        "|---|---|---:|---:|---|",
    ]
    worst = (0.0, "")
    failed = []
    for r in scenes:
        for quantity, deviation in r["worst_deviation"].items():
            ok = deviation <= r["tolerance"]
            if not ok:
                failed.append(f"{r['example']} ({quantity})")
            share = deviation / r["tolerance"]
            if share >= worst[0]:
                worst = (share, f"{r['example']}, {quantity}")
            out.append(
                f"| {r['example']} | `{quantity}` | {deviation:.2g} | {r['tolerance']:.0e} | "
                f"{'within' if ok else '**over**'} |"
            )
        if r.get("loop_drift_m") is not None:
            ok = r["loop_drift_m"] <= LOOP_DRIFT_BOUND
            if not ok:
                failed.append(f"{r['example']} (loop drift)")
            out.append(
                f"| {r['example']} | loop drift [m] | {r['loop_drift_m']:.2g} m | {LOOP_DRIFT_BOUND:.0e} m | "
                f"{'within' if ok else '**over**'} |"
            )
    if data.get("errors"):
        failed += [f"{name} (the run raised: {error})" for name, error in data["errors"].items()]
    out += [
        "",
        (
            f"Every example stayed within its tolerance; the closest to it is {worst[1]}, at "
            f"{100 * worst[0]:.2g} % of its tolerance."
        )
        if not failed
        else "**Over their tolerance:** " + "; ".join(failed) + ".",
    ]
    for r in scenes:
        reduced = r.get("reduced_lagrangian")
        if reduced is None:
            continue
        errors = reduced["worst_relative_error"]
        top = max(errors, key=lambda k: errors[k])
        out += [
            "",
            f"The reduced-Lagrangian check of {r['example']}, {data.get('samples', '?')} random states on the loop "
            f"({'passed' if reduced['passed'] else '**failed**'}; the largest error is {errors[top]:.2g}, {top}):",
            "",
            "| term | worst relative error |",
            "|---|---:|",
        ]
        out += [f"| {term.replace('|', chr(92) + '|')} | {error:.2g} |" for term, error in errors.items()]
    return "\n".join(out) + "\n"


def _fuzz(data: dict[str, Any]) -> str:
    out = [
        f"{data['cases']} cases in {data['wall_time_s']} s ({data['cases_per_s']} cases/s). Exit codes: "
        + ", ".join(f"{k}: {v}" for k, v in data["exits"].items())
        + ".",
        "",
        "| violation | cases |",
        "|---|---:|",
    ]
    out += [f"| {name} | {count} |" for name, count in data["violations"].items()]
    out += ["", "| kind of case | cases | with a problem |", "|---|---:|---:|"]
    out += [f"| {kind} | {v['cases']} | {v['problems']} |" for kind, v in data["by_kind"].items()]
    table = data.get("table") or {}
    if table:  # one row per family of files, as the campaign prints it
        columns = list(next(iter(table.values())))
        out += ["", "| family | " + " | ".join(columns) + " |", "|---|" + "---:|" * len(columns)]
        out += [f"| {family} | " + " | ".join(str(row[c]) for c in columns) + " |" for family, row in table.items()]
    return "\n".join(out) + "\n"


def _fuzz_interrupts(data: dict[str, Any]) -> str:
    """Per command: trials, what was found, and how the trials ended."""
    table = data["table"]
    findings = ("lost result", "leftover process", "traceback", "not one line", "start-up traceback")
    exits = sorted({k for row in table.values() for k in row if k.startswith("exit ")}, key=lambda k: int(k[5:]))
    out = [
        "| command | trials | " + " | ".join(findings) + " | " + " | ".join(exits) + " |",
        "|---|---:|" + "---:|" * (len(findings) + len(exits)),
    ]
    out += [
        f"| {name} | {row['trials']} | "
        + " | ".join(str(row[f]) for f in findings)
        + " | "
        + " | ".join(str(row.get(e, 0)) for e in exits)
        + " |"
        for name, row in table.items()
    ]
    found = sum(table["all"][f] for f in findings)
    out += [
        "",
        f"{table['all']['trials']} trials; {found} with a finding"
        + (": see the data below." if found else " (exit -9: ended by the SIGKILL itself)."),
    ]
    return "\n".join(out) + "\n"


_WORLD_SETS = {
    "erd-file": "example-robot-data, every URDF file by path",
    "erd-name": "example-robot-data, every name robodyn's model sources give (loader names with their SRDF)",
    "pybullet": "pybullet_data, every URDF outside random_urdfs/",
    "pybullet-random": "pybullet_data, the generated random_urdfs/",
}


def _exits(counts: dict[str, int]) -> str:
    return ", ".join(f"{code}: {n}" for code, n in counts.items()) or "–"


def _arrow(old: int | None, new: int) -> str:
    """``"1 → 0"`` when the exit code changed, else ``"0"``."""
    return f"{old} → {new}" if old is not None and old != new else f"{new}"


def _against(data: dict[str, Any]) -> str:
    """benchmarks/against.py: per engine and reading, files compared, agree, differ by cause, refused, unexplained."""
    rows = data["rows"]
    tallies: dict[tuple[str, str], Counter[str]] = {}
    causes: dict[tuple[str, str], Counter[str]] = {}
    for row in rows:
        for r in row.get("readings", []):
            key = (r["engine"], r["reading"])
            tallies.setdefault(key, Counter())[r["status"]] += 1
            tallies[key]["unexplained"] += r["unexplained"]
            causes.setdefault(key, Counter()).update(r["causes"])
    lines = [
        "| engine | reading | files | agree | differ | causes (files) | refused | unexplained |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for (engine, reading), t in tallies.items():
        named = "; ".join(f"{c} ({n})" for c, n in causes[(engine, reading)].most_common()) or "–"
        files = t["agree"] + t["differ"] + t["refused"]
        lines.append(
            f"| {engine} | {reading} | {files} | {t['agree']} | {t['differ']} | {named} | {t['refused']} | "
            f"{t['unexplained']} |"
        )
    skipped = [row for row in rows if "skipped" in row]
    crashed = [row for row in rows if "crashed" in row]
    seconds = [row["seconds"] for row in rows if "seconds" in row]
    total = f"{sum(seconds):.1f} s in all, {max(seconds):.2f} s at most" if seconds else "none compared"
    meant = int(data.get("files", len(rows)))
    stopped = f" (the survey was stopped after {len(rows)} of its {meant} files)" if len(rows) < meant else ""
    lines.append("")
    lines.append(
        f"{len(rows)} files{stopped}; {len(crashed)} crashed the comparison or ran past the survey's timeout; "
        f"{len(skipped)} not compared (robodyn refuses them, or a joint that is not 1-DoF, or none moves); "
        f"robodyn's time, engines included: {total}."
    )
    return "\n".join(lines) + "\n"


def _world_urdfs(data: dict[str, Any]) -> str:
    """Per set: exit codes of info and check before and after; then every file's, with the reason of a refusal."""
    before = data.get("before", {}).get("summary", {})
    out = [
        "| set | files | info exits before | info exits after | check exits before | check exits after | "
        "tracebacks after | check FAIL after | refusals of more than one error line after |",
        "|---|---:|---|---|---|---|---:|---:|---:|",
    ]
    for name, s in data["summary"].items():
        b = before.get(name, {})
        out.append(
            f"| {_WORLD_SETS.get(name, name)} | {s['files']} | {_exits(b.get('info_exits', {}))} | "
            f"{_exits(s['info_exits'])} | {_exits(b.get('check_exits', {}))} | {_exits(s['check_exits'])} | "
            f"{s['tracebacks']} | {s['check_fail']} | {s['refusals_not_one_line']} |"
        )
    out += [
        "",
        "Every file of the first three sets (exit codes before → after; the reason is the first line "
        "`robodyn check` wrote on stderr after, when it did not exit 0):",
        "",
        "| set | file or name | info | check | why check did not exit 0 |",
        "|---|---|---|---|---|",
    ]
    for row in data["rows"]:
        if row["set"] == "pybullet-random":
            continue
        b = row.get("before") or {}
        info, check = row["info"], row["check"]
        why = check["stderr_first"].split("error: ", 1)[-1] if check["exit"] != 0 else ""
        if b.get("fail_rows") and check["exit"] == 0:
            why = f"before: {b['fail_rows'][0]}"
        why = why.replace("|", "\\|")
        out.append(
            f"| {row['set']} | `{row['target']}` | {_arrow(b.get('info'), info['exit'])} | "
            f"{_arrow(b.get('check'), check['exit'])} | {why} |"
        )
    return "\n".join(out) + "\n"


def _handback_kind(sim: dict[str, Any]) -> str:
    if sim.get("fallback"):
        return "**fallback**"
    if sim.get("stiff_handback"):
        return "stiff losses (warned)"
    return "diverged" if sim["exit"] == 3 else "structural"


def _world_corpora(data: dict[str, Any]) -> str:
    """Per corpus: files, tracebacks, hangs, silences, fallbacks, divergences; then every refusal with its reason."""
    out = [
        "| corpus | files | tracebacks | hangs | runs silent over 60 s (longest silence) | check FAIL | "
        "fallbacks from the compiled loop | hand-backs for the stiff losses of a warning | simulate diverged | "
        "refusals not one line |",
        "|---|---:|---:|---:|---|---:|---:|---:|---:|---:|",
    ]
    for name, s in data["summary"].items():
        if not s["files"]:
            continue
        out.append(
            f"| {name} | {s['files']} | {s['tracebacks']} | {s['hangs']} | {s['silent_over_limit']} "
            f"({s['longest_silence_s']:.0f} s) | {s['check_fail']} | {s['fallbacks']} | {s['stiff_handbacks']} | "
            f"{s['diverged']} | "
            f"{s['refusals_not_one_line']} |"
        )
    for name, how in data.get("absent", {}).items():
        out.append(f"| {name} | not installed (`{how}`) | | | | | | | | |")
    out += ["", "Every refusal and divergence, with its reason (the number of files that gave it):", ""]
    out += ["| corpus | command: reason | files |", "|---|---|---:|"]
    for name, s in data["summary"].items():
        for reason, n in s["refusals"].items():
            out.append(f"| {name} | {reason.replace('|', chr(92) + '|')} | {n} |")
    out += ["", "Every run the Python loop took, with the reason the summary gave:", ""]
    out += ["| file | command | exit | kind | why the Python loop |", "|---|---|---:|---|---|"]
    for r in data["rows"]:
        for command in ("simulate", "simulate --no-physics-check"):
            sim = r.get(command, {})
            if sim.get("why_python"):
                out.append(
                    f"| `{r['target']}` | {command} | {sim['exit']} | {_handback_kind(sim)} | "
                    f"{sim['why_python'].replace('|', chr(92) + '|')} |"
                )
    return "\n".join(out) + "\n"


_EXPLAIN_WORDS = {
    "named_right": "named right",
    "candidates": "candidates incl. the truth",
    "cannot_name": "cannot name",
    "wrong_name": "**WRONG NAME**",
    "missing": "missing",
    "convention": "(a convention slip: its hint)",
    "convention_wrong_name": "**WRONG NAME** (convention slip)",
    "not_run": "not run",
}


def _explain_summary(s: dict[str, Any]) -> list[str]:
    return [
        f"| cases with a true term | {s['term_cases']} |",
        f"| named right | {s['named_right']} ({s['named_right_pct']} %) |",
        f"| candidates including the truth | {s['candidates']} |",
        f"| honest cannot-name | {s['cannot_name']} |",
        f"| **wrong name** (cases; entries over all cases) | {s['wrong_name']}; {s['entries_wrong_name']} |",
        f"| missing (a differing entry not explained) | {s['missing']} |",
        f"| convention cases: hint right / wrong / missing | {s['hints_right']} / {s['hints_wrong']} / "
        f"{s['hints_missing']} |",
        f"| hints where none was due | {s['spurious_hints']} |",
        f"| cases not run (the correct file does not pass) | {s['not_run']} |",
    ]


def _explain_times(robots: list[dict[str, Any]], before: dict[str, Any]) -> list[str]:
    def cell(t: dict[str, Any] | None) -> str:
        if not t:
            return "–"
        if t.get("exit") not in (0, 1):
            return f"exit {t['exit']}"
        return f"{t['first_s']:.2f} / {t['median_s']:.2f}" if "median_s" in t else f"{t['first_s']:.2f}"

    out = [
        "| robot | cases | check | check --explain | derive | before: check, check --explain, derive |",
        "|---|---:|---:|---:|---:|---|",
    ]
    for r in robots:
        t, b = r["times"], before.get(r["robot"], {})
        old = ", ".join(cell(b.get(k)) for k in ("check", "check_explain", "derive")) if b else "–"
        note = f" (correct file: exit {r['correct_exit']})" if r["correct_exit"] != 0 else ""
        out.append(
            f"| {r['robot']}{note} | {r['cases']} | {cell(t.get('check'))} | {cell(t.get('check_explain'))} | "
            f"{cell(t.get('derive'))} | {old} |"
        )
    return out


def _explain_truth(row: dict[str, Any]) -> str:
    """The first true entry (``M[0,1] = m2*(lc1 - l1)*cos(phi1)``, and how many more), or the hint's fix."""
    truth = row.get("truth") or {}
    if truth:
        label, text = next(iter(truth.items()))
        more = f" (+{len(truth) - 1} more)" if len(truth) > 1 else ""
        return f"`{label} = {text}`{more}"
    hint = row.get("hint_expected") or {}
    return f"hint: `{hint.get('fix', '')}`" if hint else ""


def _explain(data: dict[str, Any]) -> str:
    """Totals (before beside them when saved), times per robot, then every case's outcome and hint."""
    before = data.get("before", {})
    out = ["| | this run |" + (" before |" if before else ""), "|---|---|" + ("---|" if before else "")]
    rows = _explain_summary(data["summary"])
    if before:
        old_rows = _explain_summary(before["summary"])
        rows = [f"{a} {b.split('|')[2].strip()} |" for a, b in zip(rows, old_rows, strict=True)]
    out += rows
    out += ["", "Wall time of each command [s]: the first run / the median of the runs after it.", ""]
    out += _explain_times(data["robots"], before.get("robots", {}))
    out += ["", "| case | slip | true term | outcome | hint | wrong entries |", "|---|---|---|---|---|---|"]
    old = before.get("cases", {})
    for r in data["cases"]:
        outcome = _EXPLAIN_WORDS.get(r["outcome"], r["outcome"])
        if r["id"] in old and old[r["id"]]["outcome"] != r["outcome"]:
            outcome = f"{_EXPLAIN_WORDS.get(old[r['id']]['outcome'], old[r['id']]['outcome'])} → {outcome}"
        hint = r["hint"] if r.get("hint_expected") or r["hint"] == "spurious" else ""
        wrong = ", ".join(e["label"] for e in r["entries"] if e["outcome"] == "wrong_name")
        out.append(f"| `{r['id']}` | {r['slip']} | {_explain_truth(r)} | {outcome} | {hint} | {wrong} |")
    return "\n".join(out) + "\n"


def _first_run(data: dict[str, Any]) -> str:
    """benchmarks/bench_first_run.py: robodyn simulate, empty numba cache (the default, then compiling), cached."""
    out = [
        f"`robodyn simulate MODEL --duration {data['duration_s']:g}`, each run a fresh process:",
        "",
        "| model | first run (empty cache): loop | wall | CPU | goal (quiet 2 cores, judged by the CPU) "
        "| the compile (`ROBODYN_COMPILE=always`, empty cache): wall | CPU | later runs (cached): loop | wall | CPU "
        "| load average (1 min) before and after the first run |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    notes = []
    for model, row in data["runs"].items():
        first, compiled, cached = row["first"], row["first_compiled"], row["cached"]
        goal = "–"
        if row.get("goal_s"):  # judged by the CPU time: a quiet machine's wall time, near enough
            goal = f"{row['goal_s']:g} s: " + ("met" if first["cpu_s"] <= row["goal_s"] else "**not met**")
        load = " → ".join(f"{x[0]:.1f}" for x in (first.get("load_before"), first.get("load_after")) if x) or "–"
        out.append(
            f"| {model} | {first['loop']} | {first['wall_s']:.1f} s | {first['cpu_s']:.1f} s | {goal} | "
            f"{compiled['wall_s']:.1f} s | {compiled['cpu_s']:.1f} s | {cached['loop']} | {cached['wall_s']:.1f} s | "
            f"{cached['cpu_s']:.1f} s | {load} |"
        )
        if compiled.get("compile_note"):
            notes.append(compiled["compile_note"])
    if notes:
        out += ["", f"The compile's first line on stderr: `{notes[0]}`"]
    return "\n".join(out) + "\n"


def _swing_up(data: dict[str, Any]) -> str:
    out = [
        "| family | start | runs | balanced | balanced where the effort allows it | did not, with a reason | "
        "time to balance median / max | peak torque / effort limit (max) |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for label, family in data["families"].items():
        for start, s in family["starts"].items():
            times = "-" if s["time_median_s"] is None else f"{s['time_median_s']:.1f} s / {s['time_max_s']:.1f} s"
            out.append(
                f"| {label} | {start} | {family['n']} | {100 * s['balanced']:.0f} % | "
                f"{100 * s['able_balanced']:.0f} % of {s['able']} | {100 * s['failed_with_reason']:.0f} % | {times} | "
                f"{s['peak_over_effort_max']:.3g} |"
            )
    first = next(iter(data["families"].values()))
    reading = (
        f"Each run {first['duration_s']:g} s, RK4 at dt = {data['dt_s']:g} s; balanced means upright within "
        f"{data['balance_tol_rad']:g} rad over the whole last {data['hold_s']:g} s with the torque within its limit "
        "(`robodyn.control.outcome`); the effort allows it where it is at least what the swing is said to need."
    )
    return "\n".join(out) + "\n\n" + reading + "\n"


def _acrobot_pump(data: dict[str, Any]) -> str:
    """benchmarks/acrobot_pump.py: how fast two published Acrobot laws start the swing from hanging."""
    out = [
        "| family | systems | law | best swing growth / w, median | max | 0.01 to 1 rad, median | fastest |",
        "|---|---:|---|---:|---:|---:|---:|",
    ]
    names = {"spong": "Spong 1995's pump", "xin_kaneda": "Xin and Kaneda's energy law"}
    for family in data["families"]:
        for law, name in names.items():
            s = family[law]
            g, sec = s["swing_growth_per_omega"], s["seconds_0.01_to_1_rad"]
            out.append(
                f"| {family['label']} | {len(family['systems'])} | {name} | {g['median']:.3f} | {g['max']:.3f} | "
                f"{sec['median']:.3g} s | {sec['min']:.3g} s |"
            )
    reading = (
        "Each law linearised at the hanging rest on the model's own M and h, the best of its scanned gains per "
        "system; w = sqrt(|G1| / M11) with the arm straight and horizontal. The seconds are ln(100) over the "
        "growth rate: how long a 0.01 rad disturbance takes to become a 1 rad swing."
    )
    return "\n".join(out) + "\n\n" + reading + "\n"


def _acrobot_family(data: dict[str, Any]) -> str:
    """benchmarks/acrobot_family.py: drawn Acrobots swung up from hanging by robodyn.control.acrobot."""
    out = [
        "| family | systems | balanced | time to balance median / max | peak elbow torque / hold torque (max) "
        "| did not, with its coupling κ and reason |",
        "|---|---:|---:|---:|---:|---|",
    ]
    for label, s in data["families"].items():
        times = "-" if s["time_median_s"] is None else f"{s['time_median_s']:.1f} s / {s['time_max_s']:.1f} s"
        failed = "; ".join(
            f"#{f['system']} (κ {f['kappa']:.3f}): {f['reason'].split(':')[0]}" for f in s["not_balanced"]
        )
        peak = f"{s['peak_over_hold_max']:.2f}"
        out.append(f"| {label} | {s['systems']} | {s['balanced']} | {times} | {peak} | {failed or '-'} |")
    reading = (
        f"Each run {data['duration_s']:g} s from the hanging rest at zero velocity, RK4 at dt = {data['dt_s']:g} s, "
        f"the elbow's limit {data['elbow_effort_n_m']:g} N m; balanced as `robodyn.control.outcome` judges it."
    )
    return "\n".join(out) + "\n\n" + reading + "\n"


RENDERERS: dict[str, Callable[[dict[str, Any]], str]] = {
    "explain": _explain,
    "explain_before": _explain,
    "swing_up": _swing_up,
    "scaling": _scaling,
    "fidelity": _fidelity,
    "overhead": _overhead,
    "overhead_busy": _overhead,
    "bench_api": _api,
    "control": _control,
    "bench_mujoco": _mujoco,
    "bench_mujoco_busy": _mujoco,
    "sweep": _sweep,
    "textbook": _textbook,
    "fuzz": _fuzz,
    "fuzz_interrupts": _fuzz_interrupts,
    "world_urdfs": _world_urdfs,
    "world_urdfs_corpora": _world_corpora,
    "against": _against,
    "against_free_flyer": _against,
    "first_run": _first_run,
    "acrobot_pump": _acrobot_pump,
    "acrobot_family": _acrobot_family,
}


def bench(arg: str | None, page_dir: str) -> str:
    """The table, the sentences, the run's facts and the JSON of one saved benchmark file."""
    if arg is None:
        raise GeneratedPartError("generated: bench needs the path of a JSON file")
    path = DOCS / arg
    if not path.is_file():
        raise GeneratedPartError(f"generated: bench {arg}: no such file under docs/")
    text = path.read_text(encoding="utf-8")
    data = json.loads(text)
    renderer = RENDERERS.get(path.stem)
    if renderer is None:
        raise GeneratedPartError(f"generated: bench {arg}: no table for {path.stem!r}; expected {sorted(RENDERERS)}")
    try:
        body = renderer(data)
    except (KeyError, TypeError, ValueError, ZeroDivisionError) as exc:
        raise GeneratedPartError(f"generated: bench {arg}: cannot read {exc!r} from it") from exc
    link = posixpath.relpath(arg, page_dir or ".")
    if len(text) <= INLINE_JSON_LIMIT:
        shown = "\n".join("    " + line for line in ["```json", *text.rstrip().splitlines(), "```"])
        data_part = f'??? note "{path.name}: the data above, as saved"\n\n{shown}\n'
    else:
        data_part = f"The data: [{path.name}]({link}) ({len(text) // 1000} kB).\n"
    return f"{_facts(data, path.name)}\n{body}\n{data_part}"


# -- included Markdown ---------------------------------------------------------------------------

_LINK = re.compile(r"(!?\[[^\]]*\]\()([^)\s]+)(\))")


def include(arg: str | None, page_dir: str) -> str:
    """A Markdown file's text, headings two levels down, relative links rebased onto the page."""
    if arg is None:
        raise GeneratedPartError("generated: include needs a path")
    path = DOCS / arg
    if not path.is_file():
        raise GeneratedPartError(f"generated: include {arg}: no such file under docs/")
    base = posixpath.relpath(posixpath.dirname(arg) or ".", page_dir or ".")

    def rebase(match: re.Match[str]) -> str:
        target = match.group(2)
        if re.match(r"^[a-z]+:|^#|^/", target):
            return match.group(0)
        return f"{match.group(1)}{posixpath.normpath(posixpath.join(base, target))}{match.group(3)}"

    lines = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("#"):
            line = "##" + line
        lines.append(_LINK.sub(rebase, line))
    return "\n".join(lines) + "\n"


PARTS: dict[str, Callable[[str | None, str], str]] = {
    "cli-reference": cli_reference,
    "layout": layout,
    "bench": bench,
    "include": include,
}


def render_page(markdown: str, page_dir: str = "") -> str:
    """The page text with its generated parts (for the tests, without MkDocs)."""

    class _File:
        src_uri = posixpath.join(page_dir, "page.md")

    class _Page:
        file = _File()

    with redirect_stdout(io.StringIO()):
        return on_page_markdown(markdown, _Page(), None, None)


# -- the README's speed table ----------------------------------------------------------------------

README = ROOT / "README.md"
README_SPEED = re.compile(r"(<!-- speed-table: begin -->\n)(.*?)(<!-- speed-table: end -->)", re.S)


def readme_speed_block() -> str:
    """The README's speed table as the saved MuJoCo comparisons give it today."""
    normal = json.loads((DOCS / "benchmarks" / "bench_mujoco.json").read_text(encoding="utf-8"))
    busy = json.loads((DOCS / "benchmarks" / "bench_mujoco_busy.json").read_text(encoding="utf-8"))
    return readme_speed(normal, busy)


if __name__ == "__main__":  # python docs/hooks/robodyn_docs.py readme-speed: rewrite the README's table
    if sys.argv[1:] != ["readme-speed"]:
        sys.exit("usage: python docs/hooks/robodyn_docs.py readme-speed")
    text = README.read_text(encoding="utf-8")
    if not README_SPEED.search(text):
        sys.exit("README.md has no <!-- speed-table: begin --> ... <!-- speed-table: end --> block")
    block = readme_speed_block()
    README.write_text(README_SPEED.sub(lambda m: m.group(1) + block + m.group(3), text), encoding="utf-8")
    print("README.md: speed table rewritten from docs/benchmarks/bench_mujoco.json and bench_mujoco_busy.json")
