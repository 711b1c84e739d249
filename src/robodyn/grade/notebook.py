"""The helper a notebook's hidden test cell calls (nbgrader, Otter): the same score and feedback as ``robodyn grade``.

    from robodyn.grade import notebook_check
    score, max_score, feedback = notebook_check("pendubot.toml", globals())

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
from typing import Any

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


def notebook_check(
    assignment_path: str | Path,
    functions_or_module: str | Path | types.ModuleType | Mapping[str, Any],
    *,
    student: str = "notebook",
) -> tuple[float, float, str]:
    """Grade a notebook's answer: ``(score, max_score, feedback)``, as ``robodyn grade`` would."""
    assignment = load_assignment(assignment_path)
    answer = functions_or_module
    if isinstance(answer, types.ModuleType):
        if not getattr(answer, "__file__", None):
            raise InputError(f"module {answer.__name__} has no file to grade")
        answer = Path(str(answer.__file__))
    if isinstance(answer, (str, Path)):
        result = grade_file(assignment, Path(answer), student=student)
        return result.score, result.max_score, result.feedback
    with tempfile.TemporaryDirectory(prefix="robodyn-notebook-") as tmp:
        path = Path(tmp) / f"{student}.py"
        path.write_text(formula_source(answer), encoding="utf-8")
        result = grade_file(assignment, path, student=student)
    return result.score, result.max_score, result.feedback
