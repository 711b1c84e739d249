"""A local cluster's processes live and die with the ``robodyn sweep`` that started them.

Three ties, each for a way the sweep can end:

* Ctrl-C: the worker processes start with SIGINT blocked (:func:`sigint_blocked` around the
  cluster's start: the threads that spawn them, and so the processes, inherit the mask), so the
  terminal's Ctrl-C, sent to the whole process group, reaches only the sweep, which kills them
  (:func:`kill_local_workers`) before it says its one line: no worker prints a traceback or a log.
* SIGTERM, SIGKILL: each worker asks Linux for SIGKILL when its parent goes
  (``prctl(PR_SET_PDEATHSIG)``, from this module loaded as a Dask preload,
  ``LocalCluster(preload=[__name__])``), and exits at once if the parent is already gone.
  Dask's own watchdog (a thread reading a pipe from the parent) needs the GIL, which a
  compiled chunk holds for seconds; the kernel's signal does not.
* The semaphores of a killed sweep: :func:`quiet_resource_tracker` starts multiprocessing's
  resource tracker with its stderr on /dev/null. It still unlinks what a killed sweep leaves,
  but its ``There appear to be N leaked semaphore objects`` no longer lands on a later prompt.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
from collections.abc import Iterator
from typing import Any

PARENT_VARIABLE = "ROBODYN_SWEEP_PARENT"
"""Environment variable giving the workers the sweep's process id (see :func:`tie_to_parent`)."""

# prctl(2) option number of PR_SET_PDEATHSIG (linux/prctl.h).
PR_SET_PDEATHSIG = 1


def tie_to_parent() -> None:
    """In a worker: be killed (SIGKILL) when the parent process dies; exit now if it already has (Linux only)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):
        return
    parent = os.environ.get(PARENT_VARIABLE, "")
    if parent.isdigit() and os.getppid() != int(parent):  # the sweep died before the prctl
        os._exit(1)


def dask_setup(worker: Any) -> None:
    """Dask's preload entry point, called in each worker process as it starts."""
    tie_to_parent()


@contextlib.contextmanager
def sigint_blocked() -> Iterator[None]:
    """Block SIGINT in this thread for the block: threads (and processes) started meanwhile inherit the mask.

    A Ctrl-C that comes meanwhile stays pending and is delivered when the block ends.
    """
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


@contextlib.contextmanager
def sigint_ignored() -> Iterator[None]:
    """Ignore Ctrl-C for the block (the main thread only): a second one must not cut a teardown short."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@contextlib.contextmanager
def logging_off() -> Iterator[None]:
    """No log record of any logger for the block (Dask's warnings while a killed cluster closes)."""
    import logging

    previous = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    try:
        yield
    finally:
        logging.disable(previous)


def quiet_resource_tracker() -> None:
    """Start multiprocessing's resource tracker (if not yet running) with its stderr on /dev/null."""
    from multiprocessing import resource_tracker

    try:
        saved = os.dup(2)
    except OSError:
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        sys.stderr.flush()
        os.dup2(devnull, 2)
        resource_tracker.ensure_running()
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


def kill_local_workers() -> int:
    """SIGKILL the worker processes this process started (a local cluster's); return how many.

    Every child process but multiprocessing's resource tracker, which stays to clean up after
    them. They are not waited for here: Dask's own thread reaps each one.
    """
    from multiprocessing import resource_tracker

    import psutil  # a dependency of distributed

    tracker = getattr(resource_tracker._resource_tracker, "_pid", None)
    children = [c for c in psutil.Process().children() if c.pid != tracker]
    for child in children:
        with contextlib.suppress(psutil.Error):
            child.kill()
    return len(children)
