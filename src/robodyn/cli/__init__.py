"""The ``robodyn`` command line.

Each subcommand lives in its own module of this package, exposing
``add_parser(subparsers)`` and ``run(args) -> int``; heavy imports happen inside ``run``.
Only the command line prints, writes files and picks exit codes: library code raises
:class:`robodyn.RobodynError`, whose ``exit_code`` is returned here after one line on
stderr. Exit codes: 0 ok, 1 check mismatch, 2 bad input, 3 diverged, 4 missing optional
dependency, 5 resource unavailable (e.g. a port in use), 130 interrupted.
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import sys
from collections.abc import Sequence

from robodyn import __version__
from robodyn.errors import RobodynError

# Subcommand -> module in robodyn.cli, in the order shown by --help.
SUBCOMMANDS = {
    "info": "info",
    "params": "params",
    "check": "check",
    "simulate": "simulate",
    "view": "view",
    "bench": "bench",
    "run": "run",
}


class _Parser(argparse.ArgumentParser):
    """argparse whose usage errors are one line on stderr, exit code 2, like every other bad input."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def get_argument_parser() -> argparse.ArgumentParser:
    """Build the parser with every available subcommand."""
    parser = _Parser(prog="robodyn", description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--version", action="version", version=f"robodyn {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for module_name in SUBCOMMANDS.values():
        try:
            module = importlib.import_module(f"robodyn.cli.{module_name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"robodyn.cli.{module_name}":
                continue  # subcommand not built in this version
            raise
        module.add_parser(sub)
    return parser


_NEGATIVE_VALUE = re.compile(r"^-(\d|\.\d)")


def _attach_negative_values(argv: Sequence[str]) -> list[str]:
    """``--q0 -1.2,0.3`` -> ``--q0=-1.2,0.3``: argparse would take ``-1.2,0.3`` for an option."""
    out: list[str] = []
    for token in argv:
        if out and out[-1].startswith("--") and "=" not in out[-1] and _NEGATIVE_VALUE.match(token):
            out[-1] = f"{out[-1]}={token}"
        else:
            out.append(token)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the process exit code."""
    parser = get_argument_parser()
    args = parser.parse_args(_attach_negative_values(sys.argv[1:] if argv is None else argv))
    try:
        return int(args.handler(args))
    except RobodynError as exc:
        print(f"robodyn {args.command}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print(f"robodyn {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # The reader of our output went away (e.g. `robodyn info talos | head`): not an error.
        # Point stdout at /dev/null so that the interpreter's final flush stays quiet.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
