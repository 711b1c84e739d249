"""``robodyn warmup``: compile every numba kernel ahead, for a classroom or a CI image.

The first run on a machine compiles the kernels it needs (20 s to a minute and a half) and caches them
(:mod:`robodyn.engine.jit`); ``robodyn warmup`` does it for all of them at once, group by group,
printing each group's time and the total. ``--only`` takes some groups. Exit codes: 0 done;
2 an unknown group.
"""

from __future__ import annotations

import argparse
import time
import warnings
from typing import Any

from robodyn.errors import EXIT_OK, CompileNotice


def add_parser(sub: Any) -> None:
    """Register ``robodyn warmup``."""
    from robodyn.sim.warmup import GROUPS

    names = ", ".join(g.name for g in GROUPS)
    p = sub.add_parser(
        "warmup",
        help="compile every numba kernel now (once per machine and robodyn version), for a classroom or CI image",
        description="Compile (or load from numba's cache) every compiled kernel robodyn runs, group by group, so "
        "that no later run on this machine waits for a compile. Prints each group's time and the total. "
        f"Groups: {names}.",
    )
    p.add_argument(
        "--only",
        metavar="GROUP,...",
        default=None,
        type=lambda text: [name.strip() for name in text.split(",") if name.strip()],
        help=f"compile only these groups (of: {names})",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Load or compile each group, one line each, then the total."""
    from robodyn.sim import warmup

    chosen = warmup.groups(args.only)
    total = time.perf_counter()
    for group in chosen:
        print(f"{group.name}: {group.serves} ...", end="", flush=True)
        with warnings.catch_warnings():  # this line says it already
            warnings.simplefilter("ignore", CompileNotice)
            seconds = warmup.warm(group)
        print(f" {seconds:.1f} s", flush=True)
    what = "group" if len(chosen) == 1 else "groups"
    print(f"warmup: {len(chosen)} {what} compiled or loaded in {time.perf_counter() - total:.1f} s")
    return EXIT_OK
