"""Files a user hands robodyn and files robodyn writes: read bounded, written whole.

:func:`read_user_file` is the one way to read a file a user names (a scene, a sweep, parameters,
constraints): it looks at the path first (``os.stat``, which opens nothing) and refuses, in one
line, anything but a regular file (a FIFO, a device, a socket would block or never end; a folder
is no file), then reads at most a stated number of bytes. :func:`is_number` is the one test of a
number read from such a file: a float that is finite, or a whole number that fits 64 bits (what
TOML allows; Python would read 400 digits and overflow the first float conversion), within the
caller's bounds.

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

import math
import numbers
import os
import stat
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

from robodyn.errors import InputError, RobodynError

# The whole numbers a file may give: signed 64-bit, TOML's own range.
MIN_WHOLE, MAX_WHOLE = -(2**63), 2**63 - 1


def is_number(value: Any, *, integer: bool = False, low: float = -math.inf, high: float = math.inf) -> bool:
    """True when ``value`` is a number a file may give, within ``low <= value <= high``; never raises.

    A number is a finite float (not with ``integer``) or a whole number of 64 bits; ``bool`` is neither.
    """
    if isinstance(value, bool) or type(value).__name__ == "bool_":  # numpy's bool is no Integral, but say so
        return False
    if isinstance(value, numbers.Integral):  # int, numpy's integers
        return MIN_WHOLE <= int(value) <= MAX_WHOLE and low <= int(value) <= high
    if isinstance(value, numbers.Real) and not integer:  # float, numpy's floats
        return math.isfinite(float(value)) and low <= float(value) <= high
    return False


_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def read_user_file(
    path: Path, *, what: str, expected: str, limit: int, error: type[RobodynError] = InputError
) -> bytes:
    """The bytes of the file ``path`` that a user named, refused in one line unless it is a regular file.

    The path is looked at before it is opened, so a FIFO, a device or a socket is never opened for reading
    (it could block for ever or never end); the file is then opened without blocking and checked again.

    Args:
        path: the file.
        what: what it is, for messages ("scene", "sweep", "parameter", "constraints").
        expected: what was expected, for messages ("a .toml scene file").
        limit: the most bytes such a file may hold.
        error: the exception class raised (its constructor takes the one-line message).

    Raises:
        ``error``: no such file, a folder or another non-regular file, unreadable, or larger than ``limit``.
    """
    try:
        info = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        raise error(f"{path}: no such {what} file (expected {expected})") from None
    except (OSError, ValueError) as exc:  # a name too long, a NUL byte in it, no permission
        raise error(f"{path}: cannot read the {what} file: {getattr(exc, 'strerror', None) or exc}") from None
    _regular(path, info.st_mode, what, expected, error)
    if info.st_size > limit:
        raise error(f"{path}: larger than {_size(limit)} (expected {expected})")
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise error(f"{path}: cannot read the {what} file: {exc.strerror or exc}") from None
    with os.fdopen(fd, "rb") as fh:
        _regular(path, os.fstat(fh.fileno()).st_mode, what, expected, error)  # replaced since the look: look again
        try:
            raw = fh.read(limit + 1)
        except OSError as exc:
            raise error(f"{path}: cannot read the {what} file: {exc.strerror or exc}") from None
    if len(raw) > limit:
        raise error(f"{path}: larger than {_size(limit)} (expected {expected})")
    return raw


def _regular(path: Path, mode: int, what: str, expected: str, error: type[RobodynError]) -> None:
    if stat.S_ISDIR(mode):
        raise error(f"{path}: is a folder (expected {expected})")
    if not stat.S_ISREG(mode):
        kind = next((name for test, name in _KINDS if test(mode)), "not a regular file")
        raise error(f"{path}: is {kind}, not a regular file (expected {expected}); robodyn reads {what} files only")


def _size(limit: int) -> str:
    return f"{limit // 2**20} MiB" if limit % 2**20 == 0 else f"{limit // 1024} KiB"


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


def toml_module(files: str) -> Any:
    """The TOML reader: the stdlib's tomllib (Python >= 3.11), or tomli on Python 3.10.

    Raises:
        MissingDependencyError: neither is there (``files``, e.g. "scene files", names what needed it).
    """
    try:
        import tomllib

        return tomllib
    except ModuleNotFoundError:
        try:
            import tomli  # type: ignore[import-not-found]

            return tomli
        except ModuleNotFoundError:
            from robodyn.errors import MissingDependencyError

            raise MissingDependencyError(f"{files} need tomllib (Python >= 3.11) or tomli: pip install tomli") from None
