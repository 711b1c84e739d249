"""``robodyn sweep``: many independent runs from one sweep file, in chunks on Dask, into a Parquet dataset.

A sweep file that names a scene is read with :func:`robodyn.scene.read_scene`, handed down to
:func:`robodyn.sweep.run` (the scene package sits above the sweep in robodyn's layers).

Exit codes: 0 every chunk is written; 2 bad input (a bad sweep file, an unknown name, an
unwritable --out); 4 Dask or pyarrow missing; 5 no scheduler at --scheduler; 130 interrupted
(the chunks written so far stay, and the same command resumes from them).
"""

from __future__ import annotations

import sys
from typing import Any

from robodyn.cli._common import add_physics_argument, file_path, physics_checked, positive_int
from robodyn.cli._output import check_output_folder


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "sweep",
        help="run many independent runs described by a sweep file, on Dask, into Parquet",
        description="Cross the axes of a sweep file (initial states, parameters, integrators, dt, controllers) over "
        "its model or scene file (which supplies what the sweep leaves out) into runs, group them into chunks, "
        "run each chunk as one Dask task (a local cluster, or --scheduler), and "
        "write each finished chunk to DIR/results/ as Parquet with DIR/manifest.json. Run again to resume: "
        "chunks already written are skipped. Exit 0: done; 2: bad input; 4: Dask or pyarrow missing; 5: no "
        "scheduler there; 130: interrupted.",
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
    p.add_argument("--workers", type=positive_int, help="local worker processes (default: one per CPU)")
    p.add_argument("--plots", action="store_true", help="also draw maps and sensitivity charts into DIR/plots/")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_physics_argument(p)
    p.set_defaults(handler=run)


def run(args: Any) -> int:
    """Run the sweep and print one summary line."""
    import dataclasses

    import robodyn.sweep as sweep
    from robodyn.scene import read_scene
    from robodyn.sweep.spec import load

    check_output_folder(args.out)
    spec = load(args.sweep)
    if not physics_checked(args):
        spec = dataclasses.replace(spec, physics_check=False)
    if not spec.physics_check:
        print(_as_written(spec.model or spec.scene), file=sys.stderr)

    def reader(path: Any) -> Any:
        scene = read_scene(path)
        if spec.physics_check and scene.model.get("physics_check") is False:  # the scene's own [model] setting
            print(_as_written(str(scene.model.get("urdf") or scene.model.get("name"))), file=sys.stderr)
        return scene

    result = sweep.run(
        spec,
        out=args.out,
        scheduler=args.scheduler,
        workers=args.workers,
        progress=None if args.quiet else sys.stderr,
        read_scene=reader,
    )
    table = result.table()
    print(
        f"{table.num_rows} runs in {len(result.plan.chunks)} chunks ({result.computed} computed, "
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
