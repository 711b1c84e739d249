"""A long run's progress lines on stderr: how far it got, every 10 s, even while one step takes long."""

from __future__ import annotations

import math
import threading
import time
from typing import Any

from robodyn.engine import jit

# A long run says how far it got on stderr this often [s] (so no run is silent for a minute).
PROGRESS_EVERY = 10.0


class ProgressLines:
    """``robodyn simulate: t = 0.12 s of 0.5 s (24 %), 10 s after its first steps`` on ``stream``, every 10 s.

    A run's progress hook (:func:`robodyn.simulate`'s ``progress``); a run shorter than
    PROGRESS_EVERY prints nothing. The clock starts at the hook's first call, when the run is
    about to take its first step: what came before (a first compile of the kernels, which can take
    minutes) is the compile notice's to say. The hook is called after each step (each block of the
    compiled loop); a step that takes long (a robot whose stops chatter, a slow controller) calls
    it late, so with the real clock a watch thread prints the last time reached every
    ``every`` seconds while the calls stop, until :meth:`close`. ``clock`` [s] is ``time.monotonic``
    (a test gives its own, and no thread runs then).
    """

    def __init__(self, stream: Any, duration: float, *, clock: Any = None, every: float = PROGRESS_EVERY) -> None:
        self.stream, self.duration, self.every = stream, float(duration), float(every)
        self.clock = clock if clock is not None else time.monotonic
        self.start: float | None = None
        self.next = math.inf
        self.t = 0.0  # the last time reached [s]
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self._watch = clock is None

    def __call__(self, t: float) -> None:
        """The run has reached ``t`` [s] from its start."""
        now = self.clock()
        with self._lock:
            self.t = t
            if self.start is None:
                self.start, self.next = now, now + self.every
                if self._watch:
                    threading.Thread(target=self._beat, name="robodyn-progress", daemon=True).start()
                return
            self._print_if_due(now)

    def _beat(self) -> None:
        """The watch thread: between the hook's calls, print when a line is due (every ``every`` s)."""
        while not self._closed.wait(min(1.0, self.every / 4.0)):
            with self._lock:
                if not self._closed.is_set():
                    self._print_if_due(self.clock())

    def _print_if_due(self, now: float) -> None:
        if now < self.next or self.start is None:
            return
        self.next = now + self.every
        if jit.compiling():  # a compile inside the run (the stop events, met late): its notes speak
            return
        share = 100.0 * self.t / self.duration if self.duration > 0 else 100.0
        print(
            f"robodyn simulate: t = {self.t:.6g} s of {self.duration:g} s ({share:.3g} %), "
            f"{now - self.start:.0f} s after its first steps",
            file=self.stream,
            flush=True,
        )

    def close(self) -> None:
        """The run is over: the watch thread prints no more."""
        with self._lock:
            self._closed.set()
