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
from collections.abc import Callable
from contextlib import redirect_stdout
from pathlib import Path
from typing import Any

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


def _facts(data: dict[str, Any], name: str) -> str:
    run = data.get("run")
    if not isinstance(run, dict):
        machine = data.get("machine")
        shown = json.dumps(machine) if machine else "not recorded"
        return f"*`{name}` records no date or load (machine: {shown}); the git history of the file dates it.*\n"

    def load(key: str) -> str:
        value = run.get(key)
        return "not recorded" if not value else f"{value[0]:g} (1 min), {value[1]:g} (5 min)"

    versions = ", ".join(f"{k} {run[k]}" for k in ("robodyn", "pinocchio", "numpy", "python") if k in run)
    return (
        f"*Measured {run['date']} on {run['machine']} ({run.get('processor', '?')}, {run.get('cpus', '?')} CPUs); "
        f"load average before {load('load_before')}, after {load('load_after')}; {run.get('wall_time_s', '?')} s "
        f"of wall time; {versions}. Command: `{run.get('command', '?')}`.*\n"
    )


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
    return (
        f"`simulate` took {data['ratio']:.2f}× the time of a bare Python loop of `pin.aba` + RK4 on the same "
        f"problem ({data['model']}, RK4, dt = {data['dt_s']:g} s, {data['steps']} steps, best of {data['repeat']}: "
        f"{data['per_step_us']['simulate']:.1f} µs against {data['per_step_us']['bare_loop']:.1f} µs a step; the "
        f"states differ by at most {data['max_state_difference']:.1e}): {verdict} the limit of "
        f"{data['limit']:g}×.\n"
    )


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


def _mujoco(data: dict[str, Any]) -> str:
    single, batch = data["single"], data["batch"]
    names = {
        "mujoco_rk4_c_loop": "MuJoCo RK4, `mj_step` in its own C loop",
        "robodyn_fast_rk4": "robodyn fast path (compiled closed form + loop)",
        "robodyn_simulate_rk4_aba": "robodyn `simulate`, Python loop over Pinocchio ABA",
        "robodyn_simulate_rk4_formula": "robodyn `simulate`, NumPy formula backend",
    }
    out = [
        f"| Pendubot, torque-free, RK4, dt = {single['dt'] * 1e3:g} ms | per step [µs] | error at t = 2 s |",
        "|---|---:|---:|",
    ]
    for key, path in single["paths"].items():
        out.append(f"| {names.get(key, key)} | {path['us_per_step']:.3g} | {path['error_at_2s']:.2g} |")
    out += [
        "",
        f"| batch of {batch['states']} seeded states, {batch['steps']} RK4 steps, {batch['threads']} threads "
        "| per state-step [µs] |",
        "|---|---:|",
        f"| robodyn, Pinocchio `abaInParallel` inside RK4 | "
        f"{batch['robodyn_pinocchio_abaInParallel_rk4_us_per_state_step']:.3g} |",
        f"| `mujoco.rollout` | {batch['mujoco_rollout_us_per_state_step']:.3g} |",
        f"| robodyn fast path, one state after another | {batch['robodyn_fast_loop_us_per_state_step']:.3g} |",
        "",
        f"The model check before timing: mass matrices equal to {data['model_check']['mass_matrix_rel_diff']:.1g} and "
        f"bias forces to {data['model_check']['bias_rel_diff']:.1g} (relative) on {data['model_check']['states']} "
        f"states. The fast path is {single['speedup_fast_vs_mujoco']:.0f}× faster per step than MuJoCo's RK4 at "
        f"equal error; Pinocchio's batch path has {batch['throughput_ratio_pinocchio_vs_mujoco']:.1f}× the throughput "
        f"of `mujoco.rollout` (final states agree to {batch['max_final_state_difference_vs_mujoco']:.0e}). Both "
        "thread pools suffer when other processes share the cores.",
    ]
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
    return "\n".join(out) + "\n"


RENDERERS: dict[str, Callable[[dict[str, Any]], str]] = {
    "scaling": _scaling,
    "fidelity": _fidelity,
    "overhead": _overhead,
    "control": _control,
    "bench_mujoco": _mujoco,
    "fuzz": _fuzz,
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
