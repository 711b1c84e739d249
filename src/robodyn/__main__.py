"""The ``robodyn`` program and ``python -m robodyn``: the command line of :mod:`robodyn.cli`.

:func:`program` is the console script's entry point. A Ctrl-C while the command line's modules
load (the first ~0.1 s) ends the program with robodyn's one line and exit code 130, as a Ctrl-C
later does, instead of a traceback through the import machinery.
"""

import os
import signal
import sys
from types import FrameType


def _interrupted_while_loading(signum: int, frame: FrameType | None) -> None:
    """Nothing has begun yet: say so in one line and end at once (no finalizer, no traceback)."""
    os.write(2, b"robodyn: interrupted\n")
    os._exit(130)


def program() -> int:
    """Load the command line with Ctrl-C ending the program quietly, then run it; the exit code."""
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _interrupted_while_loading)
        from robodyn.cli import main

        signal.signal(signal.SIGINT, signal.default_int_handler)
    else:  # Ctrl-C ignored (a background job) or handled by whoever started us: left as it is
        from robodyn.cli import main
    return main()


if __name__ == "__main__":
    sys.exit(program())
