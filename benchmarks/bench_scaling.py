"""Cost against nv, from the 1-DoF geared arm up to Talos, with and without reduction.

Measured side by side in one run, for every model:

* per dynamics call: M (CRBA), C, G and ABA, mean over seeded random states [s];
* per simulated second: wall time of robodyn.simulate for 1 s (RK4, dt = 1 ms) [s];
* load time: dynamics only (robodyn.load: no mesh is read) against dynamics plus visual
  geometry (robodyn.model.load.load_geometry parses every mesh) [s].

    python benchmarks/bench_scaling.py --out bench-out

prints a table and writes bench-out/scaling.json (with the date, machine and load of the run),
scaling.png and scaling.svg. The documentation's figure is refreshed with
``--out docs/benchmarks --overwrite-committed``.
"""

from __future__ import annotations

import platform
from pathlib import Path

import numpy as np

import robodyn
from robodyn.model.load import load, load_geometry
from robodyn.sim.simulation import simulate
from robodyn.studies.exactness import time_calls

from _common import argument_parser, best_of, output_folder, pyplot, run_facts, save_figure, write_json

# (label, model, load options). Reduced entries keep the joints a scene would move.
CASES = [
    ("geared_arm", "geared_arm", {}),
    ("cart_pole", "cart_pole", {}),
    ("pendubot", "pendubot", {}),
    ("panda keep 3", "panda", {"keep": ["panda_joint2", "panda_joint4", "panda_joint6"], "reference": "default"}),
    ("ur5", "ur5", {}),
    ("talos_arm", "talos_arm", {}),
    ("panda", "panda", {}),
    (
        "talos keep 7 (left arm)",
        "talos",
        {"keep": [f"arm_left_{i}_joint" for i in range(1, 8)], "reference": "half_sitting"},
    ),
    ("solo12 free flyer", "solo12", {"free_flyer": True}),
    ("talos", "talos", {}),
    ("talos free flyer", "talos", {"free_flyer": True}),
]


def measure(label: str, name: str, options: dict, *, calls: int, sim_seconds: float, load_repeat: int) -> dict:
    robot = load(name, **options)
    runs = [time_calls(robot, repeat=calls, seed=0) for _ in range(3)]  # best of 3: a shared machine is noisy
    per_call = {what: min(run[what] for run in runs) for what in runs[0]}
    q0 = robot.neutral()
    if "reference" in options:
        from robodyn.model.files import reference_configurations

        q0 = reference_configurations(robot).get(options["reference"], q0)
    traj = simulate(
        robot, q0, np.zeros(robot.nv), duration=sim_seconds, dt=1e-3, integrator="rk4", max_energy_growth=None
    )
    load_dynamics, _ = best_of(lambda: load(name, **options), load_repeat)
    load_full, _ = best_of(lambda: load_geometry(load(name, **options)), load_repeat)
    row = {
        "label": label,
        "model": name,
        "nv": robot.nv,
        "per_call_s": per_call,
        "per_simulated_second_s": traj.wall_time_s / sim_seconds,
        "simulate_status": traj.status,
        "load_dynamics_s": load_dynamics,
        "load_with_geometry_s": load_full,
    }
    return row


def chart(rows: list[dict], out: Path) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8))
    nv = np.array([r["nv"] for r in rows])
    order = np.argsort(nv, kind="stable")
    ax = axes[0]
    for what, marker in (("M", "o"), ("C", "s"), ("G", "^"), ("ABA", "D")):
        ax.plot(
            nv[order], [rows[i]["per_call_s"][what] * 1e6 for i in order], marker=marker, linestyle="none", label=what
        )
    ax.set(
        xscale="log",
        yscale="log",
        xlabel="nv (degrees of freedom)",
        ylabel="time per call [us]",
        title="per dynamics call",
    )
    ax.legend()
    ax = axes[1]
    ax.plot(nv[order], [rows[i]["per_simulated_second_s"] for i in order], marker="o", linestyle="none")
    for i in order:
        ax.annotate(rows[i]["label"], (nv[i], rows[i]["per_simulated_second_s"]), fontsize=7, rotation=20)
    ax.set(
        xscale="log",
        yscale="log",
        xlabel="nv",
        ylabel="wall time per simulated second [s]",
        title="simulate (RK4, dt = 1 ms)",
    )
    ax = axes[2]
    for key, marker, label in (("load_dynamics_s", "o", "dynamics only"), ("load_with_geometry_s", "s", "with meshes")):
        ax.plot(nv[order], [rows[i][key] * 1e3 for i in order], marker=marker, linestyle="none", label=label)
    ax.set(xscale="log", yscale="log", xlabel="nv", ylabel="load time [ms]", title="load")
    ax.legend()
    fig.suptitle(f"robodyn {robodyn.__version__}: cost against nv ({platform.processor() or platform.machine()})")
    fig.tight_layout()
    save_figure(fig, out, "scaling")


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--calls", type=int, default=2000, help="random states per dynamics call timing")
    parser.add_argument("--sim-seconds", type=float, default=1.0, help="simulated time per model [s]")
    parser.add_argument("--load-repeat", type=int, default=3, help="loads per model (best kept)")
    parser.add_argument(
        "--only",
        default=None,
        help="comma-separated labels of the rows to measure (default: all: "
        + ", ".join(label for label, _, _ in CASES)
        + ")",
    )
    args = parser.parse_args()
    cases = CASES
    if args.only is not None:
        wanted = [label.strip() for label in args.only.split(",")]
        unknown = sorted(set(wanted) - {label for label, _, _ in CASES})
        if unknown:
            parser.error(f"--only: unknown rows {unknown}; expected labels among {[label for label, _, _ in CASES]}")
        cases = [case for case in CASES if case[0] in wanted]
    output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    rows = []
    header = (
        f"{'model':26s} {'nv':>4s} {'M us':>8s} {'C us':>8s} {'G us':>8s} {'ABA us':>8s} "
        f"{'sim s/s':>8s} {'load ms':>8s} {'+mesh ms':>9s}"
    )
    print(header)
    for label, name, options in cases:
        row = measure(
            label, name, options, calls=args.calls, sim_seconds=args.sim_seconds, load_repeat=args.load_repeat
        )
        rows.append(row)
        c = row["per_call_s"]
        print(
            f"{label:26s} {row['nv']:4d} {c['M'] * 1e6:8.2f} {c['C'] * 1e6:8.2f} {c['G'] * 1e6:8.2f} "
            f"{c['ABA'] * 1e6:8.2f} {row['per_simulated_second_s']:8.4f} {row['load_dynamics_s'] * 1e3:8.2f} "
            f"{row['load_with_geometry_s'] * 1e3:9.2f}"
        )
    result = {
        "calls": args.calls,
        "sim_seconds": args.sim_seconds,
        "rows": rows,
    }
    path = write_json(args.out, "scaling", result, facts)
    chart(rows, args.out)
    print(f"wrote {path}, scaling.png, scaling.svg")


if __name__ == "__main__":
    main()
