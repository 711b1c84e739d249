"""The textbook's worked examples: each one's worst deviation from the book's closed form, through ``robodyn run``.

    python benchmarks/bench_textbook.py [--out DIR] [--samples N]

Runs every scene under ``examples/textbook/`` exactly as a user would (``robodyn run SCENE
--out <temporary folder> --no-view``: the library's own run path, nothing re-implemented here),
reads what each run wrote to its ``summary.json`` and prints, then saves as
``DIR/textbook.json`` (DIR defaults to ``bench-out/``; committed files only with ``--overwrite-committed``):

* for each scene, the worst deviation of the simulated motion from the closed form over the
  whole run, relative to the largest value of the quantity (19.1 rolling and sliding: v(b);
  19.2: b(v); 19.3: omega^2; Fig. 19.9: the spring's motion and V; 19.22-19.24: the power and
  the work; 6.1: the spin about the box's corner), against the scene's tolerance;
* for scenes with loops (19.3), the worst loop drift [m] along the run;
* for scenes whose ``[check] formula`` is a reduced Lagrangian (19.3), the reduced-Lagrangian
  check's worst relative error of each term (M, the bias C omega, G, the acceleration, V,
  on_the_loop) over ``--samples`` random states on the loop.

The machine's load (``os.getloadavg``) is recorded beside the wall times.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from robodyn.cli import main as robodyn_main

from _common import argument_parser, output_folder, run_facts, write_json

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples" / "textbook"
# The book's example behind each scene file.
EXAMPLE = {
    "rolling": "19.1 disk rolling down the incline",
    "sliding": "19.1 disk sliding (no coupling)",
    "motorcycle": "19.2 motorcycle",
    "linkage": "19.3 linkage (collar, spring)",
    "spring_bar": "Fig. 19.9 torsional spring",
    "power": "19.22-19.24 power",
    "box": "6.1 box about its corner",
}


def run_scene(scene: Path, out: Path, samples: int) -> dict[str, Any]:
    """``robodyn run scene --out out --no-view`` (with ``[check] samples`` set), and the summary it wrote."""
    text = scene.read_text(encoding="utf-8")
    if "\nformula = " in text and "\nsamples = " not in text:  # the reduced-Lagrangian check: as many samples as asked
        text = text.replace("[check]\n", f"[check]\nsamples = {samples}\n", 1)
    copy = out / scene.name
    copy.parent.mkdir(parents=True, exist_ok=True)
    for name in ("urdf", "closed_form.py", "reduced_formula.py"):  # relative paths: read from the example folder
        for path in scene.parent.glob(f"*{name}" if name == "urdf" else name):
            text = text.replace(f'"{path.name}"', json.dumps(str(path)))
    copy.write_text(text, encoding="utf-8")
    captured = io.StringIO()
    start = time.perf_counter()
    with contextlib.redirect_stdout(captured):
        code = robodyn_main(["run", str(copy), "--out", str(out), "--no-view"])
    wall = time.perf_counter() - start
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    return {"exit_code": code, "wall_time_s": wall, "summary": summary, "printed": captured.getvalue()}


def figures(name: str, run: dict[str, Any]) -> dict[str, Any]:
    """The figures of one scene's run, as its summary states them."""
    s = run["summary"]
    closed = s["closed_form"]
    row: dict[str, Any] = {
        "scene": name,
        "example": EXAMPLE.get(name, name),
        "exit_code": run["exit_code"],
        "passed": closed["passed"],
        "worst_deviation": closed["worst_deviation"],
        "worst": closed["worst"],
        "tolerance": closed["tolerance"],
        "steps": s["simulate"]["steps"],
        "wall_time_s": run["wall_time_s"],
        "loop_drift_m": s["simulate"].get("loop_drift"),
    }
    check = s.get("check")
    if check is not None and "worst_relative_error" in check:
        row["reduced_lagrangian"] = {"passed": check["passed"], "worst_relative_error": check["worst_relative_error"]}
    return row


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--samples", type=int, default=1000, help="random states of the reduced-Lagrangian check")
    args = parser.parse_args()
    output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    rows = []
    errors = {}
    runs = Path(tempfile.mkdtemp(prefix="bench-textbook-"))  # each run's own files: read, then removed
    for scene in sorted(EXAMPLES.glob("*/*.toml")):
        try:
            run = run_scene(scene, runs / scene.stem, args.samples)
        except Exception as exc:  # a crash is a finding: report it, and measure the other scenes
            errors[scene.stem] = f"{type(exc).__name__}: {exc}"
            print(f"ERROR: robodyn run {scene.relative_to(ROOT)} raised {errors[scene.stem]}")
            continue
        rows.append(figures(scene.stem, run))
    load = os.getloadavg()
    print(f"textbook examples through robodyn run (load average {load[0]:.2f}, {os.cpu_count()} CPUs):")
    print(f"  {'example':<36}{'quantity':<22}{'worst deviation':>16}{'tolerance':>11}  result  wall")
    for r in rows:
        for quantity, deviation in r["worst_deviation"].items():
            verdict = "pass" if deviation <= r["tolerance"] else "FAIL"
            print(
                f"  {r['example']:<36}{quantity:<22}{deviation:>16.3e}{r['tolerance']:>11.0e}  {verdict:<6}  "
                f"{r['wall_time_s']:.2f} s"
            )
        if r["loop_drift_m"] is not None:
            print(f"  {r['example']:<36}{'loop drift [m]':<22}{r['loop_drift_m']:>16.3e}{1e-9:>11.0e}")
    for r in rows:
        reduced = r.get("reduced_lagrangian")
        if reduced is None:
            continue
        print(f"reduced-Lagrangian check of {r['example']} ({args.samples} states on the loop, rtol 1e-9):")
        for term, error in reduced["worst_relative_error"].items():
            print(f"  {term:<56}{error:>11.3e}")
    result = {
        "samples": args.samples,
        "scenes": rows,
        "errors": errors,
    }
    shutil.rmtree(runs, ignore_errors=True)
    print(f"wrote {write_json(args.out, 'textbook', result, facts)}")


if __name__ == "__main__":
    main()
