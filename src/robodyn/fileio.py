"""Writing a file safely: it appears complete or not at all, and never through a planted link.

:func:`write_atomically` writes to a fresh temporary file in the target's folder, created with
``tempfile.mkstemp`` (``O_CREAT | O_EXCL``, an unpredictable name, so an existing file or a
symbolic link planted under that name is never followed), then renames it over the target. A
rename replaces a link at the target itself, not the file the link points to.

:func:`pause_for_test` is the one test hook of the package: with ``ROBODYN_TEST_PAUSE_AT=WINDOW:FILE``
in the environment, the command stops at the named window (``write``: a temporary file written and
not yet renamed; ``exit``: the command has returned its exit code; ``publish``, ``chunk``: see their
callers) until ``FILE`` exists, having created
``FILE.waiting``. A test then sends its signal inside that window, deterministically.
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO


def write_atomically(path: Path, write: Callable[[IO[bytes]], None]) -> Path:
    """Call ``write`` on a new temporary file next to ``path``, then rename it to ``path``.

    An interrupted or failed write leaves no partial or empty file behind, and a previous file
    at ``path`` stays as it was until the rename.
    """
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    tmp = Path(name)
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
        pause_for_test("write")
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def write_text_atomically(path: Path, text: str) -> Path:
    """Write ``text`` as UTF-8 to ``path`` through :func:`write_atomically`; return the path."""
    data = text.encode("utf-8")

    def write(fh: IO[bytes]) -> None:
        fh.write(data)

    return write_atomically(path, write)


PAUSE_VARIABLE = "ROBODYN_TEST_PAUSE_AT"
# A paused command gives up waiting after this many seconds [s] (a test that died leaves no process).
PAUSE_LIMIT_S = 120.0


def pause_for_test(window: str) -> None:
    """Test hook: wait at ``window`` while ``ROBODYN_TEST_PAUSE_AT=window:FILE`` is set and FILE does not exist.

    Creates ``FILE.waiting`` first (the test's cue to send its signal), then polls every 10 ms.
    Without the variable, or for another window, it returns at once.
    """
    where, _, go = os.environ.get(PAUSE_VARIABLE, "").partition(":")
    if where != window or not go:
        return
    Path(f"{go}.waiting").touch()
    deadline = time.monotonic() + PAUSE_LIMIT_S
    while not os.path.exists(go) and time.monotonic() < deadline:
        time.sleep(0.01)


def _umask() -> int:
    """The process's umask (mkstemp creates files 0600; a saved result is as readable as any other file)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask
