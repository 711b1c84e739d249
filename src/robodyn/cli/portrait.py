"""``robodyn portrait``: the phase portrait of one joint, as a chart with the numbers beside it.

Writes DIR/portrait.png and .svg (the chart), DIR/portrait.csv (the energy grid: one row per
(q, v) point, with units in the header) and DIR/portrait.json (equilibria, separatrix energy,
the LQR region's slice, the reference pose). Exit codes: 0 written; 2 bad input.
"""

from __future__ import annotations

import argparse
import io
import json
from pathlib import Path
from typing import Any

import numpy as np

from robodyn.cli._common import add_model_arguments, file_path, float_list, load_robot
from robodyn.cli._output import check_output_folder
from robodyn.errors import InputError


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "portrait",
        help="phase portrait of one joint: energy contours, equilibria, separatrix, runs, the LQR's region",
        description="Draw the (q, v) plane of one joint with the other joints held at a reference pose: the "
        "contours of E = 1/2 M_jj v^2 + V, the equilibria (filled: stable, open: unstable), the separatrix "
        "through the highest unstable one, any saved trajectories, and with --lqr the slice of the LQR's "
        "estimated region of attraction. Writes DIR/portrait.png, .svg, .csv (the grid) and .json. "
        "Exit 0: written; 2: bad input.",
    )
    add_model_arguments(p)
    p.add_argument("--joint", metavar="NAME", help="the joint of the plane (default: the first passive joint)")
    p.add_argument(
        "--at",
        type=float_list,
        metavar="Q",
        help="the reference pose the other joints are held at, comma-separated (default: neutral, "
        "or the upright equilibrium with --lqr)",
    )
    p.add_argument(
        "--trajectory",
        type=file_path,
        action="append",
        default=[],
        metavar="FILE.npz",
        help="a trajectory saved by 'robodyn simulate --out' to draw (repeatable)",
    )
    p.add_argument("--lqr", action="store_true", help="draw the LQR's estimated region of attraction (built-in kinds)")
    p.add_argument(
        "--basin",
        type=int,
        metavar="SIDE",
        help="with --lqr: also simulate the LQR from SIDE x SIDE starts in the plane (2 to 201; on the CPU, "
        "about 20 ms a start at 3 s each) and dot those it balances",
    )
    p.add_argument("--resolution", type=int, default=121, help="grid points per axis, 11 to 2001 (default: 121)")
    p.add_argument("--out", type=file_path, required=True, metavar="DIR", help="folder for the chart and its numbers")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Compute the portrait, write the chart, CSV and JSON, print one line per file."""
    from robodyn import charts
    from robodyn.fileio import write_text_atomically
    from robodyn.sim.trajectory import Trajectory
    from robodyn.studies import portrait

    check_output_folder(args.out)
    robot = load_robot(args)
    if args.basin is not None and not args.lqr:
        raise InputError("--basin SIDE simulates the LQR's basin: give --lqr with it")
    runs: list[tuple[str, Any, Any]] = []
    for path in args.trajectory:
        traj = Trajectory.load(path)
        runs.append((_run_name(traj, Path(path), [label for label, _, _ in runs]), traj.q, traj.v))
    region, lqr = None, None
    reference = args.at
    if args.lqr:
        import robodyn.control as control

        lqr = control.design(robot)
        estimate = control.estimate(lqr)
        region = (lqr.q_eq, lqr.P, estimate.rho)
        reference = lqr.q_eq if reference is None else reference
    p = portrait.compute(
        robot, joint=args.joint, reference=reference, resolution=args.resolution, trajectories=runs, region=region
    )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    simulated = None
    if args.basin is not None:
        from robodyn.control import basin

        simulated = basin.simulate(robot, lqr=lqr, joint=p.joint, side=args.basin, reference=p.reference)
    png, svg = charts.portrait(p, out / "portrait", basin=simulated)
    grid = io.StringIO()
    qq, vv = np.meshgrid(p.q, p.v)
    np.savetxt(
        grid,
        np.column_stack([qq.ravel(), vv.ravel(), p.energy.ravel()]),
        delimiter=",",
        header=f"{p.joint} [{p.q_unit}],{p.joint} velocity [{p.v_unit}],energy [J]",
        comments="",
        fmt="%.10g",
    )
    csv = write_text_atomically(out / "portrait.csv", grid.getvalue())
    record = write_text_atomically(out / "portrait.json", json.dumps(p.as_record(), indent=2) + "\n")
    kinds = ", ".join(f"{'stable' if e.stable else 'unstable'} at {_value(e.q)} {p.q_unit}" for e in p.equilibria)
    print(f"{robot.name}: phase portrait of {p.joint}; equilibria: {kinds or 'none'}")
    if p.held:
        print(f"other joints held at {p.held}")
    if p.separatrix_energy is not None:
        print(f"separatrix energy {p.separatrix_energy:.6g} J")
    if p.region is not None:
        print(f"LQR region slice: e^T P e < {p.region.rho:.4g}")
    if simulated is not None:
        print(simulated.describe())
    for path in (png, svg, csv, record):
        print(f"wrote {path}")
    return 0


ZERO_TOLERANCE = 1e-9
"""An equilibrium this close to 0 [rad | m] prints as 0: Brent's root of G_j lands within round-off
(4.4e-16 rad) of an exact zero, and "unstable at 4.441e-16 rad" would show the round-off as a value."""


def _value(x: float) -> str:
    """``x`` to 4 significant digits, 0 within ZERO_TOLERANCE."""
    return "0" if abs(x) < ZERO_TOLERANCE else f"{x:.4g}"


def _run_name(trajectory: Any, path: Path, taken: list[str]) -> str:
    """A trajectory's name on the chart: its controller, start and outcome.

    For example "lqr from q(0) = (1.6, 0.05), balanced from t = 0.42 s".

    The outcome is the one ``robodyn simulate`` judged and saved with the run (:mod:`robodyn.control.outcome`,
    the decision of its summary and of a sweep's ``time_to_balance``); a run saved without one names none.
    The file's name is added when two runs would read the same.
    """
    meta = trajectory.meta if isinstance(trajectory.meta, dict) else {}
    controller = meta.get("controller")
    law = str(controller.get("name")) if isinstance(controller, dict) and controller.get("name") else "free motion"
    start = ", ".join(f"{x:.3g}" for x in np.asarray(trajectory.q[0], dtype=np.float64))
    name = f"{law} from q(0) = ({start}){_outcome_words(meta.get('outcome'))}"
    return f"{name} [{path.name}]" if name in taken else name


def _outcome_words(judged: Any) -> str:
    """The words a saved outcome record adds to a run's name (", balanced from t = 2.06 s"); none without one."""
    if not isinstance(judged, dict) or "balanced" not in judged:
        return ""
    time = judged.get("time_to_balance_s")
    if judged["balanced"] and isinstance(time, (int, float)):
        return f", balanced from t = {time:.3g} s"
    return ", did not balance"
