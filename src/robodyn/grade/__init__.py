"""``robodyn grade``: a class's derivations graded by their equations of motion, with feedback in each student's names.

The assignment (:mod:`robodyn.grade.assignment`), one submission's grade (:mod:`robodyn.grade.grading`),
a class's outputs (:mod:`robodyn.grade.outputs`, :mod:`robodyn.grade.report`), the teacher's mutants
(:mod:`robodyn.grade.mutate`) and the notebook helper (:mod:`robodyn.grade.notebook`). Only robodyn's
public ``check`` and ``load`` are used.
"""

from __future__ import annotations

from robodyn.grade.assignment import Assignment, load_assignment
from robodyn.grade.grading import QuantityScore, SubmissionResult, grade_file
from robodyn.grade.notebook import NotebookResult, notebook_check

__all__ = [
    "Assignment",
    "NotebookResult",
    "QuantityScore",
    "SubmissionResult",
    "grade_file",
    "load_assignment",
    "notebook_check",
]
