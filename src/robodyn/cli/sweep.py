"""``robodyn sweep``: many independent runs from one sweep file, in chunks on Dask, into a Parquet dataset.

A sweep file that names a scene is read with :func:`robodyn.scene.read_scene`, handed down to
:func:`robodyn.sweep.run` (the scene package sits above the sweep in robodyn's layers).

Exit codes: 0 every chunk is written; 2 bad input (a bad sweep file, an unknown name, a sweep past
the bounds, an unwritable --out, a setting ``--device cuda`` cannot run) or a run that failed in its
worker; 4 Dask or pyarrow missing, or numba's CUDA target for ``--device cuda``; 5 no scheduler at
--scheduler, the scheduler went away mid-sweep, or no CUDA GPU for ``--device cuda``; 130 interrupted
(in the cases of a scheduler gone and of an interrupt the chunks written so far stay, and the same
command resumes from them).
"""

from __future__ import annotations

import sys
from typing import Any

from robodyn.cli._common import add_passive_argument, add_physics_argument, file_path, physics_checked, positive_int
from robodyn.cli._output import check_output_folder
from robodyn.errors import SweepInterrupted
from robodyn.wording import count


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "sweep",
        help="run many independent runs described by a sweep file, on Dask, into Parquet",
        description="Cross the axes of a sweep file (initial states, parameters, integrators, dt, controllers) over "
        "its model or scene file (which supplies what the sweep leaves out) into runs, group them into chunks, "
        "run each chunk as one Dask task (a local cluster, or --scheduler), and "
        "write each finished chunk to DIR/results/ as Parquet with DIR/manifest.json. Run again to resume: "
        "chunks already written are skipped. Exit 0: done; 2: bad input; 4: Dask or pyarrow missing (or numba's "
        "CUDA target, with --device cuda); 5: no scheduler there, or it went away mid-sweep (run again to resume), "
        "or no CUDA GPU for --device cuda; 130: interrupted.",
    )
    p.add_argument(
        "sweep",
        type=file_path,
        metavar="SWEEP.toml",
        help="the sweep file: a model or a scene file, the axes and the measures (see examples/sweeps/)",
    )
    p.add_argument(
        "--out", type=file_path, required=True, metavar="DIR", help="results folder (created; reused to resume)"
    )
    p.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler, e.g. tcp://127.0.0.1:8786")
    p.add_argument(
        "--workers", type=positive_int, help="local worker processes (default: one per CPU; at most 4 per CPU)"
    )
    p.add_argument(
        "--device",
        choices=("cpu", "cuda"),
        help="where the runs are computed (default: the sweep file's device, else cpu); cuda: an NVIDIA GPU, "
        "without controller: a built-in kind with rk4, or any robot the compiled tree path takes (rk4, heun, "
        "euler); measures final_state, energy_drift, wall_time (and lyapunov for a built-in kind); with the "
        "controller lqr or swing_up: the Pendubot or the cart-pole, rk4, and time_to_balance too",
    )
    p.add_argument(
        "--precision",
        choices=("float64", "float32"),
        help="what the runs compute in (default: the sweep file's precision, else float64); float32 with "
        "--device cuda only, without lyapunov",
    )
    p.add_argument("--plots", action="store_true", help="also draw maps and sensitivity charts into DIR/plots/")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_physics_argument(p)
    add_passive_argument(p, what="the sweep's model or scene (added to its passive list)")
    p.set_defaults(handler=run)


def run(args: Any) -> int:
    """Run the sweep and print one summary line."""
    import dataclasses
    import logging

    import robodyn.sweep as sweep
    from robodyn.scene import read_scene
    from robodyn.sweep.spec import load

    # Dask's loggers (the client's reconnection tracebacks, a worker's "Compute Failed") never reach stderr, even
    # from its threads after the sweep gave up: what went wrong is robodyn's one line.
    logging.disable(logging.CRITICAL)
    check_output_folder(args.out)
    spec = load(args.sweep)
    if not physics_checked(args):
        spec = dataclasses.replace(spec, physics_check=False)
    if args.device is not None:
        spec = dataclasses.replace(spec, device=args.device)
    if args.precision is not None:
        spec = dataclasses.replace(spec, precision=args.precision)
    if args.passive:
        spec = dataclasses.replace(spec, passive=tuple(dict.fromkeys((*spec.passive, *args.passive))))
    if not spec.physics_check:
        print(_as_written(spec.model or spec.scene), file=sys.stderr)

    def reader(path: Any) -> Any:
        scene = read_scene(path)
        if spec.physics_check and scene.model.get("physics_check") is False:  # the scene's own [model] setting
            print(_as_written(str(scene.model.get("urdf") or scene.model.get("name"))), file=sys.stderr)
        return scene

    try:
        result = sweep.run(
            spec,
            out=args.out,
            scheduler=args.scheduler,
            workers=args.workers,
            progress=None if args.quiet else sys.stderr,
            read_scene=reader,
        )
    except SweepInterrupted as exc:
        raise KeyboardInterrupt(f"{exc}; run the same command again to resume from them") from None
    table = result.table()
    print(
        f"{count(table.num_rows, 'run')} in {count(len(result.plan.chunks), 'chunk')} ({result.computed} computed, "
        f"{result.skipped} already written) -> {args.out / 'results'}"
    )
    if args.plots:
        from robodyn.sweep import plots

        written = plots.draw(table, result.plan.axes, args.out / "plots")
        print(f"{len(written)} picture files -> {args.out / 'plots'}")
    return 0


def _as_written(model: str) -> str:
    """The one warning line of a sweep whose model is loaded with its file's numbers as written."""
    return (
        f"robodyn sweep: warning: physics check off (--no-physics-check or physics_check = false): {model} is "
        "loaded with its file's masses and inertias as written (robodyn info lists any physically impossible ones)"
    )
