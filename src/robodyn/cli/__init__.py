"""The ``robodyn`` command line.

Each subcommand lives in its own module of this package, exposing
``add_parser(subparsers)`` and ``run(args) -> int``; heavy imports happen inside ``run``.
Only the command line prints, writes files and picks exit codes: library code raises
:class:`robodyn.RobodynError`, whose ``exit_code`` is returned here after one line on
stderr. Exit codes: 0 ok, 1 check mismatch, 2 bad input, 3 diverged, 4 missing optional
dependency, 5 resource unavailable (e.g. a port in use), 130 interrupted.

numpy's floating-point RuntimeWarnings (overflow, invalid value) are counted, not printed:
a run that ends 0 or 1 says how many in one note line; a failure's own line says enough.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import reprlib
import sys
import warnings
from collections import Counter
from collections.abc import Iterator, Sequence
from typing import TextIO

from robodyn import __version__
from robodyn.errors import EXIT_BAD_INPUT, CompileNotice, ModelWarning, RobodynError
from robodyn.fileio import pause_for_test

DESCRIPTION = "robodyn: rigid-body robot dynamics checked against Pinocchio, simulated and replayed."
"""What ``robodyn --help`` says first: plain text (the module docstring's reST markup would show as written)."""

EXIT_INTERRUPTED = 130

pause_for_test("loading")  # tests send Ctrl-C here: while the command line loads (robodyn.__main__)


class _Parser(argparse.ArgumentParser):
    """argparse whose usage errors are one line on stderr, exit code 2, like every other bad input."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def get_argument_parser() -> argparse.ArgumentParser:
    """Build the parser with every available subcommand."""
    parser = _Parser(prog="robodyn", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"robodyn {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    # Each subcommand module is light to import (its heavy imports happen inside its ``run``);
    # plain imports, in the order --help shows them, so that import-linter sees every edge.
    from robodyn.cli import bench, check, derive, grade, info, params, portrait, run, simulate, sweep, view, warmup

    for module in (info, params, check, derive, simulate, view, portrait, bench, run, sweep, grade, warmup):
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
    """Run the command line; return the process exit code.

    As the ``robodyn`` program (``argv`` None), Ctrl-C is held off finalizers and ignored once the
    command has returned (:mod:`robodyn.cli._interrupts`): the interpreter's exit prints nothing.
    """
    from robodyn.cli import _interrupts

    if argv is None:
        _interrupts.install()
    try:
        parser = get_argument_parser()
        args = parser.parse_args(_attach_negative_values(sys.argv[1:] if argv is None else argv))
    except KeyboardInterrupt:  # while the subcommands' modules load: nothing began
        print("robodyn: interrupted", file=sys.stderr)
        if argv is None:
            _interrupts.quiet_exit()
        return EXIT_INTERRUPTED
    with _numeric_warnings(args.command) as counts:
        code = _run(args)
    if counts and code in (0, 1):  # a refusal or a failure says what went wrong in its own one line
        print(f"robodyn {args.command}: note: {_describe_warnings(counts)}", file=sys.stderr)
    if argv is None:
        _interrupts.quiet_exit()
        pause_for_test("exit")
    return code


def _run(args: argparse.Namespace) -> int:
    """Call the subcommand; turn robodyn's errors, Ctrl-C and a closed pipe into an exit code."""
    try:
        return int(args.handler(args))
    except RobodynError as exc:
        one_line = str(exc).replace("\r", "\\r").replace("\n", "\\n")  # a name from a hostile file may hold one
        print(f"robodyn {args.command}: error: {one_line}", file=sys.stderr)
        return exc.exit_code
    except RecursionError:
        # The last net under hostile input: a reader given a file nested thousands deep (JSON,
        # TOML, XML) that does not catch it itself. Each reader should name its file.
        print(
            f"robodyn {args.command}: error: an input file is nested too deeply to read "
            f"(more than about {sys.getrecursionlimit()} levels); expected a flat file",
            file=sys.stderr,
        )
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as exc:
        print(f"robodyn {args.command}: {str(exc) or 'interrupted'}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # The reader of our output went away (e.g. `robodyn info talos | head`): not an error.
        # Point stdout at /dev/null so that the interpreter's final flush stays quiet.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except OSError as exc:
        # The net under a path the system refuses outright (a name too long, a file that is
        # unreadable for permissions) that no reader caught itself: one line naming it.
        name = reprlib.repr(exc.filename) if exc.filename is not None else "a path"
        print(
            f"robodyn {args.command}: error: {name}: {exc.strerror or exc} (expected a path the system can open)",
            file=sys.stderr,
        )
        return EXIT_BAD_INPUT


@contextlib.contextmanager
def _numeric_warnings(command: str) -> Iterator[Counter[str]]:
    """Count numpy's floating-point RuntimeWarnings (overflow, invalid value...) instead of printing them.

    They would break the one-line promise (a warning and its source line in the middle of a
    progress bar); :func:`main` folds their count into one note. robodyn's own
    :class:`~robodyn.errors.ModelWarning` is one line ``robodyn COMMAND: warning: ...`` (each
    message once), a :class:`~robodyn.errors.CompileNotice` one line ``robodyn COMMAND: note: ...``
    (said once per process by :mod:`robodyn.engine.jit`; ``PYTHONWARNINGS=ignore`` silences it, as the
    test suite does). Other warnings pass through.
    """
    counts: Counter[str] = Counter()
    shown_once: set[str] = set()
    with warnings.catch_warnings():
        warnings.simplefilter("always", RuntimeWarning)
        warnings.simplefilter("always", ModelWarning)  # deduplicated below, by message
        show = warnings.showwarning

        def count(
            message: Warning | str,
            category: type[Warning],
            filename: str,
            lineno: int,
            file: TextIO | None = None,
            line: str | None = None,
        ) -> None:
            if issubclass(category, RuntimeWarning):
                counts[str(message)] += 1
            elif issubclass(category, ModelWarning):
                if str(message) not in shown_once:  # the file is read more than once by some commands
                    shown_once.add(str(message))
                    print(f"robodyn {command}: warning: {message}", file=sys.stderr)
            elif issubclass(category, CompileNotice):
                print(f"robodyn {command}: note: {message}", file=sys.stderr, flush=True)
            else:
                show(message, category, filename, lineno, file, line)

        warnings.showwarning = count
        yield counts


def _describe_warnings(counts: Counter[str]) -> str:
    """``numpy reported 12 floating-point warnings: overflow encountered in add (10), ...``."""
    total = sum(counts.values())
    common = ", ".join(f"{message} ({n})" for message, n in counts.most_common(3))
    more = f" and {len(counts) - 3} other kinds" if len(counts) > 3 else ""
    what = "warning" if total == 1 else "warnings"
    return f"numpy reported {total} floating-point {what} during the run: {common}{more}"


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
