"""A run with a user's controller file, in a forked child that robodyn's process watches.

A controller file is code that robodyn calls at every integrator stage (four times a step with
RK4), so it runs in the simulation's own process: a process of its own with a pipe round trip
per call would cost more than the dynamics. But the file could end that process (``os._exit(0)``
at import or inside ``tau``: robodyn would exit 0 with no run done, a faked pass) or loop for
ever. So :func:`run_supervised` forks: the child imports the file, builds the controller and runs
the whole simulation (the controller stays in-process and fast), then sends the trajectory, or
the error, back through a pipe, as JSON and raw float64 arrays (never a pickle), and exits. The
parent (robodyn's process, which never imports the file) rebuilds the result, or says in one
line how the child ended when it sent none. In the child each call of the controller, its
import and its ``make`` get a time limit (:data:`CALL_TIMEOUT`, :data:`LOAD_TIMEOUT`), kept by a
watchdog thread (:class:`Watchdog`).

Cost (``python benchmarks/bench_controller_file.py``): one fork and the trajectory's way back,
a few milliseconds per run, whatever the run's length; the per-call guards (read-only copies of
q and v, the alarm set and cleared) a few microseconds per call.

Where ``os.fork`` does not exist (Windows) the run stays in robodyn's process, unsupervised.
Not a security boundary: the file runs with the user's rights.
"""

from __future__ import annotations

import contextlib
import io
import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

import numpy as np

from robodyn.errors import DivergenceError, InputError, RobodynError, SimulationInterrupted, UnknownNameError
from robodyn.sim.trajectory import Trajectory

CALL_TIMEOUT = 10.0
"""Seconds one call of a controller file's ``tau(t, q, v)`` may take: a plain NumPy controller takes ~10 us, so
a call that runs 10 s is a loop that will not end (the run is refused, naming the file and the time t)."""
LOAD_TIMEOUT = 30.0
"""Seconds a controller file's import and its ``make(robot, **gains)`` may take: room for a file that imports a large
library, while a loop at import ends the run within half a minute."""

_ARRAYS = ("t", "q", "v", "a", "tau", "kinetic", "potential", "work_input", "work_damping", "work_limits")
_BUILTIN_ERRORS: dict[str, type[Exception]] = {
    cls.__name__: cls for cls in (RuntimeError, ValueError, TypeError, MemoryError, OSError)
}
T = TypeVar("T")


class OutOfTime(BaseException):
    """Raised in the child by SIGALRM; a BaseException, so that a controller's ``except Exception`` lets it by."""


def supervision_available() -> bool:
    """Whether runs can be forked and watched (POSIX)."""
    return hasattr(os, "fork") and hasattr(signal, "pthread_kill")


GRACE = 2.0
"""Seconds after a time limit's SIGALRM before the watchdog ends the child itself (a controller that catches it)."""


class Watchdog:
    """The child's timer of the user's code: a thread that interrupts a call past its deadline.

    A call sets :attr:`deadline` (a ``time.monotonic()`` value) and clears it after: two attribute
    writes, where an interval timer would cost two system calls per call. Past the deadline the
    thread sends SIGALRM, whose handler raises :class:`OutOfTime` in the call; if the user's code
    swallows it and goes on, the thread sends robodyn the refusal itself ``GRACE`` seconds later and
    ends the child.
    """

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.deadline: float | None = None
        self.seconds = 0.0
        self.what = ""
        threading.Thread(target=self._watch, daemon=True).start()

    def _watch(self) -> None:  # pragma: no cover - runs in the forked child
        fired: float | None = None
        while True:
            time.sleep(0.05)
            deadline = self.deadline
            if deadline is None or time.monotonic() < deadline:
                fired = None
                continue
            if fired is None or fired != deadline:
                fired = deadline
                signal.pthread_kill(threading.main_thread().ident or 0, signal.SIGALRM)
            elif time.monotonic() > deadline + GRACE:
                message = f"{self.what} did not return within {self.seconds:g} s (and caught the interruption)"
                _send(self.fd, _encode({"kind": "InputError", "message": message, "exit_code": InputError.exit_code}))
                os._exit(0)


watch: Watchdog | None = None
"""The watchdog of :func:`run_supervised`'s child; None elsewhere (no limit: the Python API runs unwatched)."""


def in_supervised_child() -> bool:
    """True inside :func:`run_supervised`'s child: the controller's calls are then timed."""
    return watch is not None


@contextlib.contextmanager
def time_limit(seconds: float, what: str) -> Iterator[None]:
    """Raise :class:`OutOfTime` in the body after ``seconds`` (in a supervised child only; elsewhere no limit).

    ``what`` names the code for the watchdog's own message (``"ctl.py: make(robot, **gains)"``).
    """
    if watch is None:
        yield
        return
    watch.seconds, watch.what = seconds, what
    watch.deadline = time.monotonic() + seconds
    try:
        yield
    finally:
        watch.deadline = None


def _alarm(signum: int, frame: Any) -> None:
    if watch is not None and watch.deadline is not None:  # still inside the user's code
        raise OutOfTime


def run_supervised(job: Callable[[], T], *, source: str) -> T:
    """``job()`` (build the controller of file ``source`` and simulate) in a forked child; its result here.

    ``job`` returns a :class:`Trajectory` (sent back whole) or an exit code (a whole command run
    in the child, which printed and wrote its own results). The errors ``job`` raises in the
    child are raised here again (InputError, DivergenceError and SimulationInterrupted with
    their partial trajectory, UnknownNameError, any RobodynError with its exit code).

    Raises:
        InputError: the child ended without a result (``os._exit`` in the file, a crash: how it ended is said).
    """
    if not supervision_available():
        return job()
    read_end, write_end = os.pipe()
    parent = os.getpid()
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child (its coverage is not collected)
        os.close(read_end)
        _child(job, write_end, parent)
    os.close(write_end)
    data, interrupted = _read_all(read_end)
    _, status = os.waitpid(pid, 0)
    reply = _decode(data)
    if reply is None:
        if interrupted:
            raise KeyboardInterrupt
        raise InputError(f"{source}: the controller file ended the simulation's process ({_how(status)}); no run done")
    return _rebuild(reply)  # type: ignore[return-value]


def _child(job: Callable[[], Any], fd: int, parent: int) -> None:  # pragma: no cover - runs in the forked child
    global watch
    _die_with_parent(parent)
    signal.signal(signal.SIGALRM, _alarm)
    watch = Watchdog(fd)
    code = 0
    try:
        try:
            result = job()
            if isinstance(result, int):
                message = _encode({"kind": "code", "code": result})
            else:
                message = _trajectory_message({"kind": "trajectory"}, result)
        except (DivergenceError, SimulationInterrupted) as exc:
            header: dict[str, Any] = {"kind": type(exc).__name__, "message": str(exc)}
            if isinstance(exc, DivergenceError):
                header.update(step=exc.step, time=exc.time)
            message = _trajectory_message(header, exc.trajectory)
        except UnknownNameError as exc:
            message = _encode({"kind": "UnknownNameError", "what": exc.what, "name": exc.name, "choices": exc.choices})
        except KeyboardInterrupt:
            message = _encode({"kind": "KeyboardInterrupt"})
        except BaseException as exc:  # any error goes back to robodyn's process, which raises it
            kind = type(exc).__name__
            exit_code = getattr(exc, "exit_code", None) if isinstance(exc, RobodynError) else None
            if exit_code is None:
                traceback.print_exc()  # not robodyn's own error: where it came from, as in-process
            message = _encode({"kind": kind, "message": str(exc), "exit_code": exit_code})
        watch.deadline = None
        _send(fd, message)
    except BaseException:
        code = 1
    finally:
        with contextlib.suppress(BaseException):
            sys.stdout.flush()
            sys.stderr.flush()
        os._exit(code)


def _send(fd: int, message: bytes) -> None:
    view = memoryview(message)
    while view:
        view = view[os.write(fd, view) :]


def _die_with_parent(parent: int) -> None:  # pragma: no cover - runs in the forked child
    """On Linux, ask for SIGKILL when robodyn's process ends (killed, or past a harness's time limit): no orphan."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:  # the parent ended before the request took hold
        os._exit(1)


def _trajectory_message(header: dict[str, Any], trajectory: Trajectory | None) -> bytes:
    if trajectory is None:
        return _encode({**header, "trajectory": None})
    arrays = {name: getattr(trajectory, name) for name in _ARRAYS}
    if trajectory.constraint_drift is not None:
        arrays["constraint_drift"] = trajectory.constraint_drift
    info = {
        "wall_time_s": trajectory.wall_time_s,
        "evaluations": trajectory.evaluations,
        "status": trajectory.status,
        "message": trajectory.message,
        "meta": trajectory.meta,
    }
    return _encode({**header, "trajectory": info}, arrays)


def _encode(header: dict[str, Any], arrays: dict[str, Any] | None = None) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, header=np.array(_json(header)), **(arrays or {}))
    return buffer.getvalue()


def _json(header: dict[str, Any]) -> str:
    import json

    return json.dumps(header, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))


def _read_all(fd: int) -> tuple[bytes, bool]:
    """Everything the child writes, to its end; Ctrl-C meanwhile is noted (the child gets it too and answers)."""
    chunks: list[bytes] = []
    interrupted = False
    while True:
        try:
            chunk = os.read(fd, 1 << 20)
        except KeyboardInterrupt:
            interrupted = True
            continue
        if not chunk:
            break
        chunks.append(chunk)
    os.close(fd)
    return b"".join(chunks), interrupted


def _decode(data: bytes) -> tuple[dict[str, Any], dict[str, Any]] | None:
    import json

    if not data:
        return None
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            header = json.loads(str(npz["header"]))
            arrays = {name: np.array(npz[name], dtype=np.float64) for name in npz.files if name != "header"}
    except (ValueError, OSError, KeyError, EOFError):
        return None
    return (header, arrays) if isinstance(header, dict) else None


def _rebuild(reply: tuple[dict[str, Any], dict[str, Any]]) -> Trajectory | int:
    header, arrays = reply
    kind = header.get("kind")
    if kind == "code":
        return int(header["code"])
    if kind == "trajectory":
        return _trajectory(header, arrays)  # type: ignore[return-value]
    if kind == "DivergenceError":
        raise DivergenceError(
            str(header["message"]),
            step=int(header["step"]),
            time=float(header["time"]),
            trajectory=_trajectory(header, arrays),
        )
    if kind == "SimulationInterrupted":
        raise SimulationInterrupted(str(header["message"]), trajectory=_trajectory(header, arrays))
    if kind == "KeyboardInterrupt":
        raise KeyboardInterrupt
    if kind == "UnknownNameError":
        raise UnknownNameError(str(header["what"]), str(header["name"]), [str(c) for c in header["choices"]])
    message = str(header.get("message"))
    exit_code = header.get("exit_code")
    if isinstance(exit_code, int):
        error = InputError(message) if exit_code == InputError.exit_code else RobodynError(message)
        error.exit_code = exit_code
        raise error
    raise _BUILTIN_ERRORS.get(str(kind), RuntimeError)(message)


def _trajectory(header: dict[str, Any], arrays: dict[str, Any]) -> Trajectory | None:
    info = header.get("trajectory")
    if not isinstance(info, dict):
        return None
    return Trajectory(**{name: arrays[name] for name in arrays}, **info)


def _how(status: int) -> str:
    if os.WIFSIGNALED(status):
        number = os.WTERMSIG(status)
        try:
            name = signal.Signals(number).name
        except ValueError:
            name = str(number)
        return f"killed by signal {name}"
    return f"exit code {os.WEXITSTATUS(status)}: os._exit in the file, or a crash?"
