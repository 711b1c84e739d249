"""A user's formula file runs in a process of its own, under a time limit, talking to robodyn only through a pipe.

A formula file is code: it could call ``sys.exit(0)`` or ``os._exit(0)`` (robodyn would end with
exit 0 and no output, a faked pass), loop for ever (a hung check), or print (a faked report).
So :class:`FormulaProcess` starts a fresh Python (``subprocess``, in its own process group), which imports
the file and evaluates it (:func:`serve`); robodyn's process never runs a line of it.

* The child's stdout and stderr are pipes robodyn reads and keeps to itself: what the formula
  prints never reaches robodyn's stdout or stderr (the last line is quoted only when the
  process dies, where it may say why). Its stdin is ``/dev/null`` from its start (whatever robodyn's
  own stdin is, and whatever ran in robodyn's process before), and is reset before each import:
  ``input()`` in a formula always raises EOFError.
* Requests travel on a pipe of their own (passed as an extra descriptor, never as stdin); replies
  on a private copy of the child's original stdout as JSON headers with raw
  float64 arrays, never pickles: nothing the child sends can run code in robodyn.
* Each request (import the file; evaluate a batch of points) gets ``timeout`` seconds of the
  formula's own time. The child interrupts itself at the limit (SIGALRM) to say which function
  and line it was in; robodyn kills its process group ``GRACE`` seconds later in any case.
  Every wait on robodyn's side has its own deadline (the child's start, each reply, its exit
  after the kill): a child that never answers is an error, never a hang.
* A ``SystemExit`` is caught where it is raised (:mod:`robodyn.checker.file_contract`); a process that
  ends anyway (``os._exit``, a crash) is an error naming the file, never a result.

Not a security boundary: the file still runs with the user's rights. It is a boundary against
accidents, and against a result that a file forges rather than computes.
"""

from __future__ import annotations

import json
import math
import os
import queue
import signal
import subprocess
import sys
import threading
import time
import weakref
from collections.abc import Callable, Mapping
from pathlib import Path
from types import FrameType
from typing import IO, Any

from robodyn.checker import any_kind, constrained_kind
from robodyn.checker.evaluation import FUNCTIONS, Points, Values, evaluate, value_shape
from robodyn.checker.file_contract import load_in_process, renamed_notes
from robodyn.checker.wire import encode, read_message
from robodyn.errors import FormulaError, InputError
from robodyn.kinds.formula import Array, Formula
from robodyn.user_import import real_path, user_line

DEFAULT_TIMEOUT = 60.0
"""Seconds of the formula's own time per request (its import; then one check's whole batch).

Measured with ``examples/formulas/pendubot_mine.py`` (plain NumPy): ~6 us a call, 0.01 s for a
default check (100 samples, ~1,000 calls) and 6 s for the largest (100,000 samples, 10^6 calls).
60 s is ten times that, room for a slower but honest formula, while a hang still ends within a minute."""
MAX_TIMEOUT = 86400.0  # [s] a day: the longest time limit accepted (the limit must be a real bound)
GRACE = 2.0  # [s] after the limit, robodyn waits this long for the child's own report, then kills it
STARTUP_TIMEOUT = 120.0  # [s] for a fresh Python with NumPy and robodyn to start (no user code runs yet)
SETTLE = 5.0  # [s] a process whose pipe closed gets this long to exit before it is killed
OUTPUT_TAIL = 4096  # [bytes] of the child's printed output kept, for the last line of a dead process

# The child imports this very robodyn: its folder goes on sys.path unless it is there already.
# Its requests come on the descriptor named by sys.argv[2] (on POSIX; on Windows, its stdin).
_CHILD = (
    "import sys; sys.argv[1] in sys.path or sys.path.insert(0, sys.argv[1]); "
    "import robodyn.checker.sandbox as s; s.serve(int(sys.argv[2]))"
)
_OWN_PIPE = os.name == "posix"  # a pipe passed to the child besides stdin (subprocess's pass_fds)
_SRC = str(Path(__file__).resolve().parents[2])


def _points_arrays(points: Points) -> dict[str, Array]:
    return {
        "mass": points.mass,
        "coriolis_q": points.coriolis_q,
        "coriolis_v": points.coriolis_v,
        "gravity": points.gravity,
        "potential": points.potential,
    }


# ---------------------------------------------------------------------------------------- the child
class _OutOfTime(BaseException):
    """Raised in the child by SIGALRM; a BaseException so that a formula's ``except Exception`` lets it by."""


def serve(request_fd: int = 0) -> None:
    """The formula's process: import the file, evaluate batches, until robodyn closes its end of the pipe.

    Args:
        request_fd: the descriptor robodyn's requests come on (0, stdin, where no other pipe could be passed).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is robodyn's to handle (it kills this process)
    requests, replies = os.fdopen(os.dup(request_fd), "rb"), os.dup(1)
    if request_fd != 0:
        os.close(request_fd)
    os.dup2(os.open(os.devnull, os.O_RDONLY), 0)  # input() in a formula reads nothing (already so on POSIX)
    _empty_stdin()
    os.dup2(2, 1)  # print() in a formula goes to the captured stderr, never to robodyn's stdout
    inbox: queue.Queue[tuple[dict[str, Any], dict[str, Array]]] = queue.Queue()
    threading.Thread(target=_receive, args=(requests, inbox), daemon=True).start()
    child = _Child(replies)
    child.send({"op": "ready"})
    while True:
        header, arrays = inbox.get()
        child.handle(header, arrays)


def _empty_stdin() -> None:
    """``sys.stdin`` on ``/dev/null`` again: whatever an earlier import put there, ``input()`` raises EOFError."""
    sys.stdin = open(os.devnull, encoding="utf-8")  # lives as long as the process


def _receive(requests: IO[bytes], inbox: queue.Queue[tuple[dict[str, Any], dict[str, Array]]]) -> None:
    """Hand robodyn's requests to the main thread; when robodyn is gone, end at once (even mid-loop)."""
    try:
        while (message := read_message(requests)) is not None:
            inbox.put(message)
    finally:
        os._exit(0)


class _Child:
    """The child's state: the loaded formula, its time limit, and what it is running now."""

    def __init__(self, replies: int) -> None:
        self.replies = replies
        self.formula: Formula | None = None
        self.path = Path()
        self.source = ""
        self.timeout = DEFAULT_TIMEOUT
        self.running = "import"

    def send(self, header: Mapping[str, Any], arrays: Mapping[str, Array] | None = None) -> None:
        """One whole message to robodyn; the time limit's alarm waits until it is written."""
        data = memoryview(encode(header, arrays))
        blocking = hasattr(signal, "pthread_sigmask")
        if blocking:
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})
        try:
            while data:
                data = data[os.write(self.replies, data) :]
        finally:
            if blocking:
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGALRM})

    def started(self, function: str) -> None:
        self.running = function
        self.send({"op": "progress", "function": function})

    def handle(self, header: dict[str, Any], arrays: dict[str, Array]) -> None:
        try:
            if header["op"] == "load":
                self.path, self.source, self.timeout = Path(header["path"]), header["source"], header["timeout"]
                self.running = "import"
                _empty_stdin()
                formula = self.formula = _limited(self.timeout, lambda: load_in_process(self.path, self.source))
                self.send(
                    {
                        "op": "loaded",
                        "kind": formula.kind,
                        "dof": formula.dof,
                        "param_names": list(formula.param_names),
                        "potential": formula.potential_energy is not None,
                        "coriolis": formula.coriolis_form,
                        "independent": list(getattr(formula, "independent", ())),
                        **any_kind.loaded_header(formula),
                    }
                )
            elif header["op"] == "evaluate" and self.formula is not None:
                formula, p = self.formula, header["params"]
                self.running = FUNCTIONS[0]
                points = Points(*(arrays[k] for k in ("mass", "coriolis_q", "coriolis_v", "gravity", "potential")))
                values = _limited(self.timeout, lambda: evaluate(formula, p, points, on_start=self.started))
                renamed = renamed_notes(formula)  # the earlier parameter names the file read (p["M"])
                self.send({"op": "values", "renamed": renamed}, {name: values.of(name) for name in FUNCTIONS})
            elif header["op"] == "call" and self.formula is not None:  # a constrained file's parameters, on_the_loop
                formula, self.running = self.formula, str(header.get("function"))
                serve_call = any_kind.serve if formula.kind == any_kind.KIND else constrained_kind.serve
                self.send(*_limited(self.timeout, lambda: serve_call(formula, header, arrays)))
            else:
                self.send({"op": "error", "message": f"{self.source}: robodyn sent a request out of order"})
        except FormulaError as exc:
            self.send({"op": "error", "message": str(exc)})
        except _OutOfTime as exc:
            line = user_line(exc.__traceback__, self.path)
            where = f"; it was running line {line}" if line is not None else ""
            self.send({"op": "error", "message": out_of_time(self.source, self.running, self.timeout) + where})
        except BaseException as exc:  # anything else a formula raises past the wrappers (KeyboardInterrupt...)
            line = user_line(exc.__traceback__, self.path)
            at = f" (line {line})" if line is not None else ""
            what = "the formula file" if self.running == "import" else self.running
            raised = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
            self.send({"op": "error", "message": f"{self.source}: {what} raised {raised}{at}"})


def _limited(timeout: float, job: Callable[[], Any]) -> Any:
    """``job()``, interrupted by :class:`_OutOfTime` after ``timeout`` seconds where SIGALRM exists."""
    if not hasattr(signal, "setitimer"):
        return job()  # robodyn's own limit still holds

    def alarm(signum: int, frame: FrameType | None) -> None:
        raise _OutOfTime

    signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    try:
        return job()
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)


def out_of_time(source: str, running: str, timeout: float) -> str:
    """``x.py: mass_matrix did not return within 60 s (--formula-timeout)``."""
    what = "the formula file did not finish its import" if running == "import" else f"{running} did not return"
    return f"{source}: {what} within {timeout:g} s (--formula-timeout)"


# ---------------------------------------------------------------------------------------- robodyn's side
class FormulaProcess:
    """robodyn's handle on the process that runs one formula file.

    The process starts with this object and is started afresh after a request that failed (a
    timeout or a process that ended). :meth:`close` (or garbage collection, or the end of
    robodyn) kills it.
    """

    def __init__(self, path: Path, source: str, *, timeout: float = DEFAULT_TIMEOUT) -> None:
        """Start the process now (it imports NumPy and robodyn while the caller goes on); no user code runs yet."""
        try:
            seconds = float(timeout)
        except (TypeError, ValueError):
            seconds = math.nan
        if not 0 < seconds <= MAX_TIMEOUT:  # NaN fails too
            raise InputError(f"the formula time limit must be > 0 and <= {MAX_TIMEOUT:g} s, got {timeout!r}")
        self.path, self.source, self.timeout = real_path(path), source, seconds
        self.renamed: dict[str, None] = {}  # notes on the earlier parameter names the file read, in order
        self._child: _Running | None = _Running(source)

    def load(self) -> dict[str, Any]:
        """Import the file in the process: its kind, dof, parameter names and whether it has a potential."""
        header, _ = self._request(self._load_header())
        return header

    def evaluate(self, p: Mapping[str, float], points: Points, dof: int) -> Values:
        """The formula's values at ``points`` with parameters ``p``: one round trip for the whole batch."""
        try:
            params = {str(k): float(v) for k, v in p.items()}
        except (TypeError, ValueError):
            raise InputError(f"formula parameters must be numbers, got {dict(p)!r}") from None
        reply, arrays = self._request({"op": "evaluate", "params": params}, _points_arrays(points))
        renamed = reply.get("renamed", [])
        self.renamed.update(dict.fromkeys(str(note) for note in renamed if isinstance(renamed, list)))
        values = []
        for name in FUNCTIONS:
            got = arrays.get(name)
            expected = (points.count(name), *value_shape(name, dof))
            if got is None or got.shape != expected:
                self.close()
                raise FormulaError(f"{self.source}: the formula's process sent {name} values robodyn did not ask for")
            values.append(got)
        return Values(*values)

    def call(
        self, header: dict[str, Any], arrays: Mapping[str, Array] | None = None
    ) -> tuple[dict[str, Any], dict[str, Array]]:
        """One of a constrained file's own functions (``header["function"]``): the reply (robodyn checks it)."""
        return self._request({"op": "call", **header}, arrays)

    def close(self) -> None:
        """End the process (and anything it started)."""
        if self._child is not None:
            self._child.kill()
            self._child = None

    def _request(
        self, header: dict[str, Any], arrays: Mapping[str, Array] | None = None
    ) -> tuple[dict[str, Any], dict[str, Array]]:
        child = self._child
        if child is None:  # after a failure: a fresh process
            child = self._child = _Running(self.source)
        if header["op"] != "load" and not child.loaded:
            self._exchange(child, self._load_header(), None)
        return self._exchange(child, header, arrays)

    def _exchange(
        self, child: _Running, header: dict[str, Any], arrays: Mapping[str, Array] | None
    ) -> tuple[dict[str, Any], dict[str, Array]]:
        running = {"load": "import", "call": str(header.get("function"))}.get(header["op"], FUNCTIONS[0])
        try:
            reply, values = child.exchange(header, arrays, self.timeout, running)
        except BaseException:  # a timeout, a process that ended, or Ctrl-C: the process goes too
            self.close()
            raise
        if reply.get("op") == "error":
            if header["op"] == "load":
                self.close()
            raise FormulaError(str(reply.get("message")))
        child.loaded = child.loaded or header["op"] == "load"
        return reply, values

    def _load_header(self) -> dict[str, Any]:
        return {"op": "load", "path": str(self.path), "source": self.source, "timeout": self.timeout}


class _Running:
    """One started child: the process, the threads that drain its pipes, and the limit on each exchange.

    It is started at once and waited for on the first exchange, so that its start (a fresh Python
    importing NumPy, ~0.25 s) can overlap robodyn's own work (loading the models).
    """

    def __init__(self, source: str) -> None:
        self.source = source
        flags = ["-u", "-P"] if sys.version_info >= (3, 11) else ["-u"]  # -P: no cwd on sys.path
        theirs, ours = os.pipe() if _OWN_PIPE else (0, -1)
        try:
            self.process = subprocess.Popen(
                [sys.executable, *flags, "-c", _CHILD, _SRC, str(theirs)],
                stdin=subprocess.DEVNULL if _OWN_PIPE else subprocess.PIPE,  # never robodyn's own stdin
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                pass_fds=(theirs,) if _OWN_PIPE else (),
                start_new_session=True,  # its own process group: killed whole, and Ctrl-C stays robodyn's
            )
        except OSError as exc:
            if _OWN_PIPE:
                os.close(ours)
            raise FormulaError(f"{source}: cannot start a Python process for the formula: {exc}") from None
        finally:
            if _OWN_PIPE:
                os.close(theirs)
        self.requests = os.fdopen(ours, "wb") if _OWN_PIPE else self.process.stdin
        self._finalizer = weakref.finalize(self, _kill, self.process, self.requests)
        self.inbox: queue.Queue[tuple[dict[str, Any], dict[str, Array]] | Exception | None] = queue.Queue()
        self.output = _Tail()
        threading.Thread(target=_replies, args=(self.process.stdout, self.inbox), daemon=True).start()
        threading.Thread(target=_drain, args=(self.process.stderr, self.output), daemon=True).start()
        self.ready = False  # it said so: no user code has run, the time limit can start
        self.loaded = False  # the formula file is imported in it

    def _wait_until_ready(self) -> None:
        if self.ready:
            return
        first = self._next(time.monotonic() + STARTUP_TIMEOUT, "start")
        if first is None or first[0].get("op") != "ready":
            self.kill()
            raise FormulaError(
                f"{self.source}: the Python process for the formula did not start{self.output.last_line_quoted()}"
            )
        self.ready = True

    def exchange(
        self, header: dict[str, Any], arrays: Mapping[str, Array] | None, limit: float, running: str
    ) -> tuple[dict[str, Any], dict[str, Array]]:
        """Send one request; wait for its reply (progress notes along the way) ``limit + GRACE`` seconds at most."""
        self._wait_until_ready()
        message = encode(header, arrays)
        threading.Thread(target=_write, args=(self.requests, message), daemon=True).start()
        deadline = time.monotonic() + limit + GRACE
        while True:
            reply = self._next(deadline, running)
            if reply is None:
                self.kill()
                raise FormulaError(out_of_time(self.source, running, limit))
            if reply[0].get("op") != "progress":
                return reply
            running = str(reply[0].get("function"))

    def _next(self, deadline: float, running: str) -> tuple[dict[str, Any], dict[str, Array]] | None:
        """The next reply; None when ``deadline`` passes; FormulaError when the process ends or talks nonsense."""
        try:
            item = self.inbox.get(timeout=max(0.0, deadline - time.monotonic()))
        except queue.Empty:
            return None
        if isinstance(item, tuple):
            return item
        _wait_without_reaping(self.process, SETTLE)  # its pipe closed: let it finish exiting, to read its code
        self.kill()
        if isinstance(item, Exception):
            raise FormulaError(f"{self.source}: the formula's process sent something robodyn cannot read ({item})")
        code = self.process.returncode
        if code is not None and code < 0:
            how = f"killed by signal {_signal_name(-code)}"
        else:
            how = f"exit code {code}: os._exit, or a crash?"
        what = {
            "start": "the Python process for the formula ended as it started",
            "import": "the formula file ended its process at import",
        }.get(running, f"{running} ended the formula's process")
        raise FormulaError(f"{self.source}: {what} ({how}){self.output.last_line_quoted()}")

    def kill(self) -> None:
        """Kill the process group and reap the process."""
        self._finalizer()


def _kill(process: subprocess.Popen[bytes], requests: IO[bytes] | None) -> None:
    if process.returncode is None:  # not reaped yet: its pid (the group's id) cannot have been reused
        if hasattr(os, "killpg"):
            try:
                os.killpg(process.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
        else:  # pragma: no cover - Windows
            process.kill()
        try:
            process.wait(
                timeout=SETTLE
            )  # SIGKILL cannot be refused; a process stuck in the kernel is left, not waited for
        except subprocess.TimeoutExpired:
            pass
    for stream in (requests, process.stdin, process.stdout, process.stderr):
        try:
            if stream is not None:
                stream.close()
        except OSError:
            pass


def _wait_without_reaping(process: subprocess.Popen[bytes], seconds: float) -> None:
    """Wait up to ``seconds`` for ``process`` to exit, leaving it a zombie so its pid stays reserved."""
    if not hasattr(os, "waitid"):
        return
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            if os.waitid(os.P_PID, process.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None:
                return
        except ChildProcessError:
            return
        time.sleep(0.005)


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return str(number)


def _write(stream: IO[bytes] | None, data: bytes) -> None:
    try:
        if stream is not None:
            stream.write(data)
            stream.flush()
    except (OSError, ValueError):  # the process is gone: its reader reports how
        pass


def _replies(stream: IO[bytes] | None, inbox: queue.Queue[Any]) -> None:
    """Decoded replies into ``inbox``; then None at the end of the stream, or the decoding error."""
    try:
        while stream is not None and (message := read_message(stream)) is not None:
            inbox.put(message)
        inbox.put(None)
    except (OSError, ValueError, TypeError) as exc:
        inbox.put(exc)


class _Tail:
    """The last OUTPUT_TAIL bytes the formula printed."""

    def __init__(self) -> None:
        self.data = b""
        self.lock = threading.Lock()

    def add(self, chunk: bytes) -> None:
        with self.lock:
            self.data = (self.data + chunk)[-OUTPUT_TAIL:]

    def last_line_quoted(self) -> str:
        """``; its last output: "..."`` (at most 120 characters), or ``""`` when it printed nothing."""
        with self.lock:
            lines = [line.strip() for line in self.data.decode("utf-8", "replace").splitlines() if line.strip()]
        if not lines:
            return ""
        last = lines[-1] if len(lines[-1]) <= 120 else lines[-1][:117] + "..."
        return f"; its last output: {json.dumps(last, ensure_ascii=False)}"


def _drain(stream: IO[bytes] | None, tail: _Tail) -> None:
    try:
        while stream is not None and (chunk := stream.read1(65536)):  # type: ignore[attr-defined]
            tail.add(chunk)
    except (OSError, ValueError):
        pass
