"""Running ``robodyn view`` as a real process: shared by the viewer and browser tests."""

from __future__ import annotations

import contextlib
import re
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

SERVER_WAIT_S = 60.0  # generous: the machine is shared; nothing here measures time


@contextlib.contextmanager
def view_process(trajectory_file: Path, port: int) -> Iterator[tuple[subprocess.Popen[str], str]]:
    """``python -m robodyn view pendubot FILE --port PORT`` and the URL it printed; killed on exit if still up."""
    process = subprocess.Popen(
        [sys.executable, "-m", "robodyn", "view", "pendubot", str(trajectory_file), "--port", str(port)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        yield process, wait_for_url(process)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


def interrupt(process: subprocess.Popen[str]) -> str:
    """Ctrl-C the process, wait for it to end and return its stderr."""
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=SERVER_WAIT_S)
    return err


def wait_for_url(process: subprocess.Popen[str]) -> str:
    """The URL of the ``meshcat: open URL`` line the process prints on stdout."""
    deadline = time.monotonic() + SERVER_WAIT_S
    assert process.stdout is not None
    while time.monotonic() < deadline:
        ready, _, _ = select.select([process.stdout], [], [], 0.5)
        if ready:
            line = process.stdout.readline()
            match = re.match(r"meshcat: open (\S+)", line)
            if match:
                return match.group(1)
            if line == "" and process.poll() is not None:
                break
    raise AssertionError(f"robodyn view printed no URL: {process.stderr.read() if process.stderr else ''}")
