"""The helper a notebook's hidden test cell calls (nbgrader, Otter): the same score and feedback as ``robodyn grade``.

    from robodyn.grade import notebook_check
    result = notebook_check("pendubot.toml", globals())
    print(result.feedback)
    result.score            # nbgrader: a test cell whose last value is a number is given that many points

``result`` is a :class:`NotebookResult` ``(score, max_score, feedback)``, which unpacks as a tuple.

``functions_or_module`` is a formula file's path, a module (its file is graded), or a namespace
(``globals()`` of the notebook, or a dict): its formula functions' source and its constants
(``KIND``, ``JOINTS``, ``COORDINATES``, ``OFFSETS``, ``LOCKED``, ``NAMES``, ``PARAMETERS``) are
written to a file, which is graded exactly as ``robodyn grade`` grades a file.
"""

from __future__ import annotations

import inspect
import tempfile
import types
from collections.abc import Mapping
from pathlib import Path
from typing import Any, NamedTuple

from robodyn.errors import InputError
from robodyn.grade.assignment import load_assignment
from robodyn.grade.grading import grade_file

CONSTANTS = ("KIND", "JOINTS", "COORDINATES", "OFFSETS", "LOCKED", "NAMES", "PARAMETERS")
FUNCTIONS = ("parameters", "mass_matrix", "coriolis_matrix", "coriolis_vector", "gravity", "potential_energy")
HEADER = "import math\n\nimport numpy as np\n\n"


def formula_source(namespace: Mapping[str, Any]) -> str:
    """A formula file's text from a namespace's constants and functions (each function's own source)."""
    lines = [HEADER]
    lines += [f"{name} = {namespace[name]!r}\n" for name in CONSTANTS if name in namespace]
    for name in FUNCTIONS:
        fn = namespace.get(name)
        if fn is None:
            continue
        try:
            lines.append("\n\n" + inspect.getsource(fn))
        except (OSError, TypeError):
            raise InputError(f"{name}: its source cannot be read; define it with def in a cell or a file") from None
    return "".join(lines)


class NotebookResult(NamedTuple):
    """A notebook answer's grade: the points earned, the points asked, the feedback text (as ``robodyn grade``'s)."""

    score: float
    max_score: float
    feedback: str

    @property
    def passed(self) -> bool:
        """Full marks."""
        return self.score == self.max_score


def notebook_check(
    assignment_path: str | Path,
    functions_or_module: str | Path | types.ModuleType | Mapping[str, Any],
    *,
    student: str = "notebook",
) -> NotebookResult:
    """Grade a notebook's answer exactly as ``robodyn grade`` grades a file: same score, same feedback.

    Args:
        assignment_path: the assignment (TOML, :mod:`robodyn.grade.assignment`); its model, points,
            tolerance, feedback level, time and memory limits apply.
        functions_or_module: the answer. ``globals()`` of the notebook (or any dict): the functions
            ``mass_matrix``, ``coriolis_matrix`` (or ``coriolis_vector``), ``gravity``, ``potential_energy`` and
            ``parameters`` found there, each by its source (define them with ``def`` in a cell), and the
            constants ``KIND``, ``JOINTS``, ``COORDINATES``, ``OFFSETS``, ``LOCKED``, ``NAMES``, ``PARAMETERS``;
            or a formula file's path; or an imported module (its file).
        student: the name the feedback and a saved result carry.

    Returns:
        ``NotebookResult(score, max_score, feedback)``; it unpacks as a 3-tuple. The answer runs in robodyn's
        formula sandbox with the assignment's limits: one that loops, exits or imports what it must not gets 0
        and a one-line reason in ``feedback``, and the notebook's kernel is unaffected.

    Raises:
        InputError: an unreadable assignment, a module without a file, or a function whose source cannot be read
            (one defined by ``exec`` or a lambda), each in one line.
    """
    assignment = load_assignment(assignment_path)
    answer = functions_or_module
    if isinstance(answer, types.ModuleType):
        if not getattr(answer, "__file__", None):
            raise InputError(f"module {answer.__name__} has no file to grade")
        answer = Path(str(answer.__file__))
    if isinstance(answer, (str, Path)):
        result = grade_file(assignment, Path(answer), student=student)
        return NotebookResult(result.score, result.max_score, result.feedback)
    with tempfile.TemporaryDirectory(prefix="robodyn-notebook-") as tmp:
        path = Path(tmp) / f"{student}.py"
        path.write_text(formula_source(answer), encoding="utf-8")
        result = grade_file(assignment, path, student=student)
    return NotebookResult(result.score, result.max_score, result.feedback)
