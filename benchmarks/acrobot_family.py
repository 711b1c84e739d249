"""Drawn Acrobots swung up from hanging: how many balance within 30 s, how fast, and why the others do not.

The swing-up benchmark's two Pendubot families (``bench_swing_up.draw`` over 0.3x to 3x of the built-in
and of Spong and Block's parameters, the same seeds) with the shoulder passive and the elbow driven
(elbow limit 1000 N m), each run by ``robodyn.simulate`` with ``control.make("swing_up", robot)``
(:mod:`robodyn.control.acrobot`, the Python law: the Acrobot has no compiled law) from the hanging rest
at zero velocity, RK4 at 1 ms, and judged by :mod:`robodyn.control.outcome`. Each system's coupling
kappa (:func:`robodyn.control.acrobot.scales`) is saved beside its outcome.

Run: ``python benchmarks/acrobot_family.py --out DIR [--n 10] [--jobs 2]``; saves ``acrobot_family.json``.
"""

from __future__ import annotations

import multiprocessing
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_swing_up import BASES, FAMILY_SEED, PENDUBOT, SCALE, draw

from _common import argument_parser, output_folder, run_facts, write_json

FAMILIES = ("pendubot (Spong-Block)", "pendubot (built-in)")
DURATION_S = 30.0  # [s] the swing-up benchmark's run
DT = 1e-3  # [s]
ELBOW_EFFORT = 1000.0  # [N m]


def one(job: tuple[str, int, dict[str, float], str]) -> dict[str, Any]:
    """Swing up one drawn Acrobot (its URDF written into ``folder``) and judge it."""
    import robodyn
    from robodyn import control
    from robodyn.control import acrobot, outcome

    label, k, p, folder = job
    text = PENDUBOT.format(effort="0", **{n: repr(v) for n, v in p.items()})
    head, _, tail = text.rpartition('effort="0"')  # the template's last effort is the elbow's
    path = Path(folder) / f"acrobot_{label.split('(')[1][:-1]}_{k}.urdf"
    path.write_text(head + f'effort="{ELBOW_EFFORT:g}"' + tail, encoding="utf-8")
    robot = robodyn.load(path, passive=["joint1"])
    controller = control.make("swing_up", robot)
    plant = controller.lqr.plant
    run = robodyn.simulate(robot, plant.hanging(), [0.0, 0.0], duration=DURATION_S, dt=DT, torque=controller)
    verdict = outcome.judge(controller, run.t, run.q, run.v, run.tau)
    weight, _omega, kappa = acrobot.scales(plant)
    return {"family": label, "system": k, "params": p, "kappa": kappa, "hold_torque_n_m": weight,
            **verdict.as_record()}  # fmt: skip


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    balanced = [r for r in rows if r["balanced"]]
    times = np.array([r["time_to_balance_s"] for r in balanced])
    return {
        "systems": len(rows),
        "balanced": len(balanced),
        "time_median_s": float(np.median(times)) if times.size else None,
        "time_max_s": float(np.max(times)) if times.size else None,
        "peak_over_hold_max": max(r["peak_torque"] / r["hold_torque_n_m"] for r in rows),
        "not_balanced": [
            {"system": r["system"], "kappa": r["kappa"], "reason": r["reason"]} for r in rows if not r["balanced"]
        ],
    }


def main() -> None:
    parser = argument_parser(__doc__ or "")
    parser.add_argument("--n", type=int, default=10, help="systems per family (default 10)")
    parser.add_argument("--jobs", type=int, default=1, help="systems run at once, one process each (default 1)")
    args = parser.parse_args()
    out = output_folder(args.out, overwrite_committed=args.overwrite_committed)
    facts = run_facts()
    with tempfile.TemporaryDirectory() as tmp:
        jobs = []
        for label in FAMILIES:
            rng = np.random.default_rng(FAMILY_SEED[label])
            jobs += [(label, k, draw(BASES[label][1], "pendubot", rng), tmp) for k in range(args.n)]
        with multiprocessing.get_context("fork").Pool(max(1, args.jobs)) as pool:
            rows = []
            for row in pool.imap(one, jobs):
                rows.append(row)
                said = f"balanced from {row['time_to_balance_s']:.2f} s" if row["balanced"] else row["reason"]
                print(f"{row['family']} #{row['system']} (kappa {row['kappa']:.3f}): {said}", flush=True)
    result = {
        "duration_s": DURATION_S,
        "dt_s": DT,
        "elbow_effort_n_m": ELBOW_EFFORT,
        "scale": list(SCALE),
        "families": {label: {**summary([r for r in rows if r["family"] == label])} for label in FAMILIES},
        "rows": rows,
    }
    path = write_json(out, "acrobot_family", result, facts)
    for label, s in result["families"].items():
        print(f"{label}: {s['balanced']} of {s['systems']} balanced, median {s['time_median_s']} s")
    print(f"saved {path}")


if __name__ == "__main__":
    main()
