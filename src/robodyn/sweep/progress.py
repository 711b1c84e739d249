"""The sweep's progress bar: chunks done, runs per second and time left, as one updating line on a stream."""

from __future__ import annotations

import time
from typing import TextIO

BAR_WIDTH = 24


class Progress:
    """Counts finished chunks and runs; :meth:`update` redraws the line (a carriage return), :meth:`close` ends it."""

    def __init__(
        self, stream: TextIO | None, *, chunks: int, runs: int, skipped_chunks: int, skipped_runs: int
    ) -> None:
        self.stream = stream
        self.chunks, self.runs = chunks, runs
        self.done_chunks, self.done_runs = skipped_chunks, skipped_runs
        self.new_runs = 0
        self.start = time.perf_counter()
        self.draw()

    def update(self, runs: int) -> None:
        """One more chunk of ``runs`` runs is written."""
        self.done_chunks += 1
        self.done_runs += runs
        self.new_runs += runs
        self.draw()

    def line(self) -> str:
        """The bar's text."""
        elapsed = max(time.perf_counter() - self.start, 1e-9)
        rate = self.new_runs / elapsed
        left = (self.runs - self.done_runs) / rate if rate > 0 else float("nan")
        filled = int(BAR_WIDTH * self.done_chunks / max(self.chunks, 1))
        bar = "#" * filled + "." * (BAR_WIDTH - filled)
        eta = "--:--" if left != left else f"{int(left) // 60:02d}:{int(left) % 60:02d}"
        return f"sweep [{bar}] {self.done_chunks}/{self.chunks} chunks, {rate:,.0f} runs/s, {eta} left"

    def draw(self) -> None:
        """Redraw the line over the previous one."""
        if self.stream is not None:
            self.stream.write("\r" + self.line())
            self.stream.flush()

    def close(self) -> None:
        """End the line."""
        if self.stream is not None:
            self.stream.write("\n")
            self.stream.flush()
