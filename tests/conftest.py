"""pytest's set-up for every test of robodyn."""

import os
import signal
from collections.abc import Iterator

import pytest

# The suite tests the compiled loop wherever it applies, whatever numba's cache holds and in whatever
# order the tests run: a run compiles its kernels the first time (ROBODYN_COMPILE=always), as every
# command a test starts does too (they inherit it). The default choice, the Python loop while the
# kernels are not built and compiling would cost more, is tested in test_compile_choice.py.
os.environ["ROBODYN_COMPILE"] = "always"


@pytest.fixture(autouse=True)
def _ctrl_c_as_a_terminal_gives_it() -> Iterator[None]:
    """Each test starts with Python's own Ctrl-C handler, as under a user's terminal.

    A test run started in the background by a shell without job control (``cmd &`` in a
    script, as some CI runners do) inherits SIGINT ignored, and so would every command a test
    starts: a test of what Ctrl-C does would then see nothing happen (a ``robodyn view`` server
    that never stops, a bench that never sees its Ctrl-C). Python's handler here gives the
    commands a test starts SIGINT at its default.
    """
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
