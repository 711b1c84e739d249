"""Ctrl-C at the worst moment: a finished result is kept, and the interpreter's exit stays quiet.

* :func:`held`: around the writing of a finished result. The first Ctrl-C (SIGINT) is noted and
  the write goes on; the caller then says in its one line where the result is and exits 130. A
  second Ctrl-C raises KeyboardInterrupt: the user insists, the write is abandoned (an atomic write
  leaves no partial file, :func:`robodyn.fileio.write_atomically`).
* :func:`install`: for the ``robodyn`` program (not for ``main([...])`` called in-process). A
  Ctrl-C that arrives while a finalizer runs (a weakref callback, a ``__del__``) would be printed as
  ``Exception ignored in: ... KeyboardInterrupt`` and then lost: it is delivered again 50 ms later,
  outside the finalizer.
* :func:`quiet_exit`: once the command has returned its exit code, Ctrl-C is ignored while the
  interpreter shuts down (nothing is left to interrupt, and a finalizer must not print a traceback).
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Callable, Iterator
from types import FrameType

# Seconds [s] after which a Ctrl-C that came during a finalizer is delivered again.
REDELIVER_AFTER_S = 0.05
# Frames [count] looked through, from the interrupted one outwards, for a finalizer.
FINALIZER_DEPTH = 8


@contextlib.contextmanager
def held(*, abandoned: Callable[[], str] | None = None) -> Iterator[list[int]]:
    """Hold Ctrl-C for the block: the list it yields is non-empty when one came; a second one raises.

    The second one's KeyboardInterrupt carries ``abandoned()``, the line saying what is lost.
    Outside the main thread, or where Ctrl-C is ignored (a background job), nothing changes.
    """
    caught: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield caught
        return
    previous = signal.getsignal(signal.SIGINT)
    if previous is signal.SIG_IGN or previous is None:
        yield caught
        return

    def note(signum: int, frame: FrameType | None) -> None:
        caught.append(signum)
        if len(caught) > 1:
            raise KeyboardInterrupt(abandoned() if abandoned is not None else "interrupted twice")

    signal.signal(signal.SIGINT, note)
    try:
        yield caught
    finally:
        signal.signal(signal.SIGINT, previous)


def install() -> None:
    """Make Ctrl-C raise KeyboardInterrupt as usual, except inside a finalizer (delivered again just after)."""
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _interrupt)


def quiet_exit() -> None:
    """Ignore Ctrl-C from now on: the command has finished, the interpreter is shutting down.

    Also clears CPython's note of a KeyboardInterrupt seen by a nested ``PyRun_String`` (a
    library's call into the interpreter during the run): with it set, the interpreter ends the
    process with SIGINT at exit instead of the exit code the command returned. Running an empty
    statement through ``PyRun_SimpleString`` resets that note, as every such run does.
    """
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    with contextlib.suppress(AttributeError, OSError, ImportError):
        import ctypes

        ctypes.pythonapi.PyRun_SimpleString(b"pass")


def _interrupt(signum: int, frame: FrameType | None) -> None:
    if _in_finalizer(frame):
        timer = threading.Timer(REDELIVER_AFTER_S, os.kill, (os.getpid(), signal.SIGINT))
        timer.daemon = True
        timer.start()
        return
    raise KeyboardInterrupt


def _in_finalizer(frame: FrameType | None) -> bool:
    """Whether ``frame`` or one of its callers is a weakref callback or a ``__del__``."""
    for _ in range(FINALIZER_DEPTH):
        if frame is None:
            return False
        code = frame.f_code
        if code.co_name == "__del__" or code.co_filename.endswith(("weakref.py", "_weakrefset.py")):
            return True
        frame = frame.f_back
    return False
