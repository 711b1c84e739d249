"""A user's own Python file (formula, controller, measure, closed form), imported with one-line errors.

:func:`import_user_file` is the one way robodyn imports such a file: a missing file, a syntax
error, ``sys.exit`` at import or any exception becomes one :class:`~robodyn.errors.RobodynError`
line that names the file and, where the failure passed through it, the user's line. The
helpers :func:`exit_call`, :func:`user_line` and :func:`at_line` serve the callers' own messages
about the functions they later call from the file.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType, TracebackType
from typing import IO

from robodyn.errors import InputError, RobodynError


def import_user_file(
    path: Path,
    *,
    what: str,
    expected: str,
    source: str | None = None,
    error: type[RobodynError] = InputError,
) -> ModuleType:
    """Import the Python file ``path`` as a fresh module (never left in ``sys.modules``).

    Args:
        path: the file.
        what: what the file is, for messages ("formula", "controller", "measure").
        expected: what it should define, for the missing-file message.
        source: how to name the file in messages (default: the path as given).
        error: the exception class raised (its constructor takes the one-line message).

    Raises:
        ``error``: no such file, not importable, a syntax error, ``sys.exit`` or any exception at import.
    """
    source = str(path) if source is None else source
    if not path.is_file():
        broken = " (a symbolic link to nothing, or a loop of links)" if path.is_symlink() else ""
        raise error(f"{source}: no such {what} file{broken} (expected a .py file defining {expected})")
    name = f"robodyn_user_{what.replace(' ', '_')}_{abs(hash(str(real_path(path))))}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise error(f"{source}: cannot be imported as a Python module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        with _robodyn_streams_kept():
            spec.loader.exec_module(module)
    except SyntaxError as exc:
        raise error(f"{source}:{exc.lineno}: the {what} file has a syntax error: {exc.msg}") from None
    except SystemExit as exc:  # a user's file defines things; it does not decide robodyn's exit code
        raise error(f"{source}: the {what} file called {exit_call(exc)} at import{at_line(exc, path)}") from None
    except Exception as exc:  # a user's file can raise anything on import
        raise error(
            f"{source}: the {what} file failed to import: {type(exc).__name__}: {exc}{at_line(exc, path)}"
        ) from None
    finally:
        sys.modules.pop(name, None)
    return module


@contextmanager
def _robodyn_streams_kept() -> Iterator[None]:
    """Keep robodyn's ``sys.stdout`` and ``sys.stderr`` as they were, whatever a user's file does to them at import.

    A file that closes or replaces them (``sys.stdout.close()``) would otherwise break robodyn's own
    report: a closed one is opened again on its file descriptor (which closing ``sys.stdout`` leaves open).
    """
    saved = {"stdout": sys.stdout, "stderr": sys.stderr}
    fds = {name: _descriptor(stream) for name, stream in saved.items()}
    try:
        yield
    finally:
        for name, stream in saved.items():
            fd = fds[name]
            if stream is not None and stream.closed:
                stream = None if fd is None else open(os.dup(fd), "w", buffering=1, encoding="utf-8", errors="replace")
            setattr(sys, name, stream if stream is not None else open(os.devnull, "w", encoding="utf-8"))


def _descriptor(stream: IO[str] | None) -> int | None:
    try:
        return stream.fileno() if stream is not None else None
    except (AttributeError, OSError, ValueError):  # a stream without one (pytest's capture, io.StringIO)
        return None


def real_path(path: Path) -> Path:
    """``path`` with its links followed, never raising: a loop of links stays a path that is no file.

    ``Path.resolve`` raises ``RuntimeError`` on a loop in Python 3.11 (``OSError`` from 3.13).
    """
    return Path(os.path.realpath(path))


def exit_call(exc: SystemExit) -> str:
    """``sys.exit(0)``, ``sys.exit()`` or ``sys.exit('bye')``: the call as the user would have written it."""
    return "sys.exit()" if exc.code is None else f"sys.exit({exc.code!r})"


def user_line(tb: TracebackType | None, user_file: Path) -> int | None:
    """The line of the deepest frame of ``tb`` in ``user_file`` (not in numpy or robodyn), or None."""
    target = real_path(user_file)
    line = None
    while tb is not None:
        if real_path(Path(tb.tb_frame.f_code.co_filename)) == target:
            line = tb.tb_lineno
        tb = tb.tb_next
    return line


def at_line(exc: BaseException, user_file: Path) -> str:
    """`` (line 17)`` when the exception passed through the user's file, else ``""``."""
    line = user_line(exc.__traceback__, user_file)
    return f" (line {line})" if line is not None else ""
