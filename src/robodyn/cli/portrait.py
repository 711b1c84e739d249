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
    runs = []
    for path in args.trajectory:
        traj = Trajectory.load(path)
        runs.append((Path(path).name, traj.q, traj.v))
    region = None
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
    png, svg = charts.portrait(p, out / "portrait")
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
    kinds = ", ".join(f"{'stable' if e.stable else 'unstable'} at {e.q:.4g} {p.q_unit}" for e in p.equilibria)
    print(f"{robot.name}: phase portrait of {p.joint}; equilibria: {kinds or 'none'}")
    if p.separatrix_energy is not None:
        print(f"separatrix energy {p.separatrix_energy:.6g} J")
    if p.region is not None:
        print(f"LQR region slice: e^T P e < {p.region.rho:.4g}")
    for path in (png, svg, csv, record):
        print(f"wrote {path}")
    return 0
