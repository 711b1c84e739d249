"""The house: no function outside the compiled kernels runs over MAX_FUNCTION_LINES lines of code.

A function that long does several things; split into named steps, its body reads as the pipeline
it is. Lines of code are the function's lines less blank lines, comment lines and its docstring
(a nested function counts in its parent too: it is read there).

Exempt, by path, are the modules of numba kernels: a kernel's helpers are closures over the
compiled functions built inside one factory (``_kernels``, ``stages``, ``kinematics``), compiled and
inlined as one unit, so the factory is as long as the algorithm it compiles. They all live in
``engine/`` (its ``tree/`` and ``cuda/`` included): :data:`KERNEL_MODULES`.
"""

from __future__ import annotations

import ast
from fnmatch import fnmatch
from pathlib import Path

import robodyn

MAX_FUNCTION_LINES = 80  # issue 40: "no function outside the kernels over 80 lines of code"
KERNEL_MODULES = ("engine/*", "engine/*/*")


def code_lines(text: str, node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """The function's lines less blank lines, comment lines and its docstring."""
    docstring: set[int] = set()
    first = node.body[0]
    if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
        docstring = set(range(first.lineno, (first.end_lineno or first.lineno) + 1))
    assert node.end_lineno is not None
    lines = text.splitlines()[node.lineno - 1 : node.end_lineno]
    return sum(
        1
        for number, line in enumerate(lines, start=node.lineno)
        if line.strip() and not line.strip().startswith("#") and number not in docstring
    )


def long_functions(root: Path, limit: int = MAX_FUNCTION_LINES) -> list[str]:
    """``path::name (n lines)`` of every function over ``limit`` lines of code outside the kernel modules."""
    found = []
    for path in sorted(root.rglob("*.py")):
        relative = path.relative_to(root).as_posix()
        if any(fnmatch(relative, pattern) for pattern in KERNEL_MODULES):
            continue
        text = path.read_text(encoding="utf-8")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = code_lines(text, node)
                if n > limit:
                    found.append(f"{relative}::{node.name} ({n} lines)")
    return found


def test_no_function_outside_the_kernels_is_over_80_lines_of_code():
    too_long = long_functions(Path(robodyn.__file__).parent)
    assert too_long == [], f"functions over {MAX_FUNCTION_LINES} lines of code: {too_long}"


def test_the_count_leaves_out_docstrings_comments_and_blank_lines_only(tmp_path):
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES))
    (tmp_path / "ok.py").write_text(
        f'def f():\n    """Doc\n\n    string."""\n    # note\n\n{body.rsplit(chr(10), 1)[0]}\n', encoding="utf-8"
    )
    assert long_functions(tmp_path) == []  # the def line and 79 statements: 80 lines, the limit
    (tmp_path / "ok.py").write_text(f"def f():\n{body}\n    return x0\n", encoding="utf-8")
    assert long_functions(tmp_path) == ["ok.py::f (82 lines)"]
    (tmp_path / "engine").mkdir()
    (tmp_path / "engine" / "closed_form.py").write_text(f"def f():\n{body}\n    return x0\n", encoding="utf-8")
    assert long_functions(tmp_path) == ["ok.py::f (82 lines)"]  # a kernel module is exempt
