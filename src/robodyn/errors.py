"""Exceptions raised by robodyn.

Every error derives from :class:`RobodynError` and carries an ``exit_code`` that the
command line returns. Messages are one line: what was wrong, and what was expected.

Exit codes (documented in the README):

* 0 -- success;
* 1 -- a check found a mismatch (returned by ``robodyn check``, not raised);
* 2 -- bad input: a missing or malformed file, wrong vector lengths, an unknown name;
* 3 -- a simulation diverged (partial results are written first);
* 4 -- an optional dependency is missing;
* 5 -- a resource is unavailable (e.g. a port in use);
* 6 -- a controller did not reach its goal (``simulate --controller swing_up`` ended not balanced).
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from typing import Any

EXIT_OK = 0
EXIT_MISMATCH = 1
EXIT_BAD_INPUT = 2
EXIT_DIVERGED = 3
EXIT_MISSING_DEPENDENCY = 4
EXIT_UNAVAILABLE = 5
EXIT_NOT_BALANCED = 6


class RobodynError(Exception):
    """Base class of every robodyn error."""

    exit_code = EXIT_BAD_INPUT


class ModelError(RobodynError):
    """A URDF/SRDF is missing, malformed or physically impossible."""

    def __init__(self, message: str, *, path: object = None) -> None:
        self.path = path
        super().__init__(f"{path}: {message}" if path is not None else message)


class ModelWarning(UserWarning):
    """A file robodyn reads, but not quite as written: the message says what it skipped or read how.

    Only what cannot touch the dynamics is read this way (a blank line before the XML declaration,
    a visual mesh scale with a fourth number 1); the command line prints it as one warning line.
    """


class CompileNotice(UserWarning):
    """A kernel compiles now, once per machine and robodyn version: the message says what and about how long.

    Library code never prints; the command line shows it as one ``note:`` line on stderr, and a
    notebook under the cell that waits (Python shows a warning once per place it is raised).
    """


class InputError(RobodynError, ValueError):
    """A value given by the user has the wrong shape, sign or type."""


# A name longer than this is shown by its start and its length: a 5,000-character typo is no one-line message.
SHOWN_NAME_CHARS = 60


def shown_name(name: str) -> str:
    """``name`` quoted, or its first characters quoted with its length when it is long."""
    if len(name) <= SHOWN_NAME_CHARS:
        return repr(name)
    return f"{name[: SHOWN_NAME_CHARS // 2]!r}... ({len(name):,} characters)"


class UnknownNameError(RobodynError, KeyError):
    """A name does not resolve in a registry; the message lists what exists."""

    def __init__(self, what: str, name: str, choices: Iterable[str]) -> None:
        self.what = what
        self.name = name
        self.choices = tuple(sorted(choices))
        close = difflib.get_close_matches(name, self.choices, n=3, cutoff=0.6)
        hint = f"did you mean {' or '.join(repr(c) for c in close)}? " if close else ""
        super().__init__(f"unknown {what} {shown_name(name)}; {hint}expected one of: {', '.join(self.choices)}")

    def __str__(self) -> str:  # KeyError would quote the message otherwise
        return str(self.args[0])


class AssumptionError(ModelError):
    """A model breaks an assumption of a hand-derived formula (joint type, axis, COM line...)."""


class FormulaError(RobodynError):
    """A user's formula file fails to import or returns values of the wrong shape."""


class DivergenceError(RobodynError):
    """A simulation diverged. ``trajectory`` holds the states up to the failing step."""

    exit_code = EXIT_DIVERGED

    def __init__(self, message: str, *, step: int, time: float, trajectory: Any = None) -> None:
        self.step = step
        self.time = time
        self.trajectory = trajectory
        super().__init__(message)


class StepError(RobodynError, ArithmeticError):
    """A step could not be taken (Newton did not converge, the step size underflowed).

    ``str(exc)`` is the whole story (where, what, what to try); ``reason`` only what failed,
    for callers such as :func:`robodyn.simulate` that say where and what to try themselves.
    """

    exit_code = EXIT_DIVERGED

    def __init__(self, message: str, *, time: float, reason: str | None = None) -> None:
        self.time = time
        self.reason = reason if reason is not None else message
        super().__init__(message)


class SimulationInterrupted(KeyboardInterrupt):
    """The run was interrupted (Ctrl-C); ``trajectory`` holds it up to the last step taken."""

    def __init__(self, message: str, *, trajectory: Any) -> None:
        self.trajectory = trajectory
        super().__init__(message)


class SweepInterrupted(KeyboardInterrupt):
    """A sweep stopped by Ctrl-C: ``written`` of its ``chunks`` chunks are in ``folder``; running it again resumes."""

    def __init__(self, message: str, *, written: int, chunks: int, folder: Any) -> None:
        self.written = written
        self.chunks = chunks
        self.folder = folder
        super().__init__(message)


class BenchInterrupted(KeyboardInterrupt):
    """A work-precision sweep stopped by Ctrl-C; ``sweep`` holds the runs it finished (None before the first)."""

    def __init__(self, message: str, *, sweep: Any) -> None:
        self.sweep = sweep
        super().__init__(message)


class SceneError(InputError):
    """A scene file is missing, malformed or says something impossible."""


class EngineRefusedError(ModelError):
    """Another engine (MuJoCo, PyBullet, Drake) refuses a file; the message is the engine's own, on one line."""


class MissingDependencyError(RobodynError, ImportError):
    """An optional dependency is not installed; the message says how to install it."""

    exit_code = EXIT_MISSING_DEPENDENCY


class UnavailableError(RobodynError):
    """A resource such as a network port cannot be used."""

    exit_code = EXIT_UNAVAILABLE


class UnknownModelError(UnknownNameError):
    """A model name that is neither built in nor in example-robot-data: the close names first."""

    def __init__(self, name: str, choices: Iterable[str]) -> None:
        super().__init__("model", name, choices)
        close = difflib.get_close_matches(name, self.choices, n=5, cutoff=0.6)
        hint = f"did you mean {', '.join(close)}? " if close else ""
        self.args = (
            f"unknown model {shown_name(name)}; {hint}'robodyn info --list' names all {len(self.choices)} models "
            "(or give a path to a .urdf file)",
        )
