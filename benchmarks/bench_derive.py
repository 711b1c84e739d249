"""robodyn derive on every robot it accepts: time per robot, and its self-check against Pinocchio.

Every built-in and every distinct example-robot-data URDF is loaded on a fixed base; those with at
most 6 moving joints, all revolute, continuous or prismatic, are derived (the exact Fourier-form
derivation), written out by sympy (the grouped expressions, then the text ``robodyn derive`` prints)
and checked against Pinocchio at 20 seeded states (the printed text compiled), as the command does
by default. Printed and saved as ``derive.json``:

    python benchmarks/bench_derive.py --out bench-out
"""

from __future__ import annotations

import os
import time
from typing import Any

from robodyn.errors import RobodynError
from robodyn.lagrange.derivation import MAX_JOINTS, derive
from robodyn.lagrange.render import text
from robodyn.lagrange.selfcheck import self_check
from robodyn.lagrange.symbolic import symbolic
from robodyn.model.links import link_table
from robodyn.model.load import load
from robodyn.model.sources import BUILTIN_NAMES, distinct_robots

from _common import argument_parser, output_folder, run_facts, write_json


def measure(name: str, samples: int) -> dict[str, Any]:
    """One robot: load, derive, sympy, self-check, each timed [s]; or why it is not taken."""
    start = time.perf_counter()
    try:
        robot = load(name)
    except RobodynError as exc:  # robodyn refuses the file (an impossible inertia...): not a derivation's
        return {"robot": name, "skipped": f"not loadable: {exc}"}
    loaded = time.perf_counter()
    if len(robot.joints) > MAX_JOINTS:
        return {"robot": name, "joints": len(robot.joints), "skipped": f"{len(robot.joints)} moving joints"}
    try:
        table = link_table(robot)
    except RobodynError as exc:
        return {"robot": name, "joints": len(robot.joints), "skipped": str(exc)}
    t0 = time.perf_counter()
    derivation = derive(table)
    t1 = time.perf_counter()
    expressions = symbolic(derivation)
    text(expressions)
    t2 = time.perf_counter()
    check = self_check(expressions, robot, samples=samples, text=True)
    t3 = time.perf_counter()
    return {
        "robot": name,
        "joints": len(robot.joints),
        "joint_types": sorted({link.joint_type for link in table.links}),
        "parameters": len(derivation.params),
        "load_s": round(loaded - start, 4),
        "derive_s": round(t1 - t0, 4),
        "sympy_s": round(t2 - t1, 4),
        "self_check_s": round(t3 - t2, 4),
        "total_s": round(t3 - t0, 4),
        "samples": samples,
        "max_relative_difference": check.max_relative,
        "passed": check.passed,
    }


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--samples", type=int, default=20, help="self-check states per robot (default 20)")
    args = parser.parse_args()
    output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    symbolic(derive(link_table(load("geared_arm"))))  # sympy's first import is not any robot's cost
    rows, errors = [], {}
    for name in (*sorted(BUILTIN_NAMES), *distinct_robots()):
        try:
            rows.append(measure(name, args.samples))
        except Exception as exc:  # a crash is a finding: report it, and measure the others
            errors[name] = f"{type(exc).__name__}: {exc}"
            print(f"ERROR: {name}: {errors[name]}")
    taken = [r for r in rows if "skipped" not in r]
    load_avg = os.getloadavg()
    print(f"robodyn derive per robot (load average {load_avg[0]:.2f}, {os.cpu_count()} CPUs), {args.samples} states:")
    print(f"  {'robot':<28}{'joints':>7}{'params':>7}{'derive':>9}{'sympy':>9}{'check':>9}{'total':>9}  max rel diff")
    for r in taken:
        verdict = "" if r["passed"] else "  FAIL"
        print(
            f"  {r['robot']:<28}{r['joints']:>7}{r['parameters']:>7}{r['derive_s']:>8.3f}s{r['sympy_s']:>8.3f}s"
            f"{r['self_check_s']:>8.3f}s{r['total_s']:>8.3f}s  {r['max_relative_difference']:.1e}{verdict}"
        )
    skipped = [r for r in rows if "skipped" in r]
    print(
        f"{len(taken)} robots derived, {sum(r['passed'] for r in taken)} agree with Pinocchio; {len(skipped)} skipped"
    )
    if taken:
        slowest = max(taken, key=lambda r: r["total_s"])
        print(f"slowest: {slowest['robot']} ({slowest['joints']} joints) in {slowest['total_s']:.2f} s")
    result = {"samples": args.samples, "robots": taken, "skipped": skipped, "errors": errors}
    print(f"wrote {write_json(args.out, 'derive', result, facts)}")


if __name__ == "__main__":
    main()
