"""Fidelity against cost for the simplifications the textbook's systems make.

1. Geared arm: the rotor as armature (the minimal model, 1 body, ABA) against the rotor as
   its own body coupled by a mimic joint (2 bodies; ABA refuses mimic joints, so CRBA +
   Cholesky). Released from 1 rad, 5 s, RK4 at dt = 1 ms.
2. Cart-pole: the textbook's point bob against the distributed (uniform rod) pole, same mass
   and centre of mass. Pole released 0.1 rad off upright, cart free, 2 s, RK4 at dt = 1 ms.

Both models of a pair run through the same RK4 loop (robodyn.integrators.solve), without
torque or damping.

For each pair: the largest difference of the trajectories (the error the simplification
makes) and the wall time per simulated second of each (the time it saves).

    python benchmarks/bench_fidelity.py --out bench-out

prints a table and writes bench-out/fidelity.json (with the date, machine and load of the run),
fidelity.png and fidelity.svg.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import robodyn
from robodyn import integrators
from robodyn.model.load import load

from _common import argument_parser, best_of, output_folder, pyplot, run_facts, save_figure, write_json

DT = 1e-3


def run(robot, q0, *, duration: float, backend: str, repeat: int):
    """RK4 at DT on robot.forward_dynamics(backend): the same loop for every model.

    (robodyn.simulate's energy cross-check calls computePotentialEnergy, which Pinocchio
    refuses on mimic joints, so the integrator is driven directly here.)
    """
    n_steps = round(duration / DT)
    best, sol = best_of(
        lambda: integrators.solve(
            lambda t, q, v: robot.forward_dynamics(q, v, np.zeros(robot.nv), backend=backend),
            np.asarray(q0, dtype=np.float64),
            np.zeros(robot.nv),
            dt=DT,
            n_steps=n_steps,
            method="rk4",
        ),
        repeat,
    )
    return sol, best / duration


def pair(title: str, simple, simple_backend: str, rich, rich_backend: str, q0, duration: float, repeat: int) -> dict:
    ts, cost_simple = run(simple, q0, duration=duration, backend=simple_backend, repeat=repeat)
    tr, cost_rich = run(rich, q0, duration=duration, backend=rich_backend, repeat=repeat)
    dq = np.abs(ts.q - tr.q)
    return {
        "system": title,
        "simple": {
            "model": simple.name,
            "backend": simple_backend,
            "nbodies": simple.model.nbodies,
            "per_simulated_second_s": cost_simple,
        },
        "rich": {
            "model": rich.name,
            "backend": rich_backend,
            "nbodies": rich.model.nbodies,
            "per_simulated_second_s": cost_rich,
        },
        "duration_s": duration,
        "max_q_error": float(dq.max()),
        "q_error_by_joint": dq.max(axis=0).tolist(),
        "t": ts.t.tolist(),
        "q_error_t": dq.max(axis=1).tolist(),
        "time_saved_fraction": 1.0 - cost_simple / cost_rich,
    }


def chart(results: list[dict], out: Path) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    ax = axes[0]
    for r, colour in zip(results, ("C0", "C1"), strict=True):
        err = max(r["max_q_error"], 1e-17)
        ax.scatter(
            [r["rich"]["per_simulated_second_s"]],
            [1e-17],
            marker="o",
            color=colour,
            label=f"{r['system']}: {r['rich']['model']} (reference)",
        )
        ax.scatter(
            [r["simple"]["per_simulated_second_s"]],
            [err],
            marker="D",
            color=colour,
            label=f"{r['system']}: {r['simple']['model']}",
        )
    ax.set(
        xscale="log",
        yscale="log",
        xlabel="wall time per simulated second [s]",
        ylabel="max trajectory error against the richer model [rad | m]",
        title="accuracy against cost",
    )
    ax.legend(fontsize=7)
    ax = axes[1]
    for r in results:
        ax.plot(r["t"], np.maximum(r["q_error_t"], 1e-17), label=f"{r['system']}: {r['simple']['model']}")
    ax.set(yscale="log", xlabel="t [s]", ylabel="max |q_simple - q_rich| [rad | m]", title="error over time")
    ax.legend(fontsize=8)
    fig.suptitle(f"robodyn {robodyn.__version__}: what each simplification costs (RK4, dt = {DT} s)")
    fig.tight_layout()
    save_figure(fig, out, "fidelity")


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--repeat", type=int, default=3, help="runs per model (best kept)")
    args = parser.parse_args()
    output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    results = [
        pair(
            "geared arm",
            load("geared_arm"),
            "aba",
            load("geared_arm_rotor", mimic=True),
            "crba",
            np.array([1.0]),
            5.0,
            args.repeat,
        ),
        pair(
            "cart-pole",
            load("cart_pole_point_bob"),
            "aba",
            load("cart_pole"),
            "aba",
            np.array([0.0, 0.1]),
            2.0,
            args.repeat,
        ),
    ]
    print(
        f"{'system':12s} {'simple model':22s} {'rich model':18s} {'max error':>10s} "
        f"{'simple s/s':>11s} {'rich s/s':>9s} {'saved':>6s}"
    )
    for r in results:
        print(
            f"{r['system']:12s} {r['simple']['model'] + ' (' + r['simple']['backend'] + ')':22s} "
            f"{r['rich']['model'] + ' (' + r['rich']['backend'] + ')':18s} {r['max_q_error']:10.2e} "
            f"{r['simple']['per_simulated_second_s']:11.4f} {r['rich']['per_simulated_second_s']:9.4f} "
            f"{100 * r['time_saved_fraction']:5.0f}%"
        )
    path = write_json(args.out, "fidelity", {"dt": DT, "pairs": results}, facts)
    chart(results, args.out)
    print(f"wrote {path}, fidelity.png, fidelity.svg")


if __name__ == "__main__":
    main()
