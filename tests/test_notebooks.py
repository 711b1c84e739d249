"""Every notebook in ``notebooks/`` runs from top to bottom (nbclient), alone in an empty folder, stored without outputs.

The notebooks assert what they show (the check passes, the energy is kept...), and every figure or
verdict their text states is checked against the value it comes from (see ``claims_of``), so a
change that breaks the story, or a sentence its own numbers contradict, fails here. Each notebook gets NOTEBOOK_TIMEOUT_S in all, shared by its cells.
"""

from __future__ import annotations

import re
import shutil
import time
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))
NOTEBOOK_TIMEOUT_S = 240.0  # a guard against a hung kernel, far above the ~10 s each one takes


def test_there_is_a_notebook_per_seed_system() -> None:
    names = {path.stem for path in NOTEBOOKS}
    assert {"pendubot", "cart_pole", "geared_arm"} <= names


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_is_stored_without_outputs(path: Path) -> None:
    nbformat = pytest.importorskip("nbformat")
    book = nbformat.read(path, as_version=4)
    nbformat.validate(book)
    for cell in book.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, f"{path.name}: clear the outputs before commit"


# --- Sentences true to their numbers -------------------------------------------------------------
#
# A markdown cell states a computed figure as the number followed by an HTML comment naming the
# expression it comes from, ``1.9e-7<!-- = traj.relative_energy_drift -->``, and a verdict as
# ``<!-- holds: expression -->`` (the comment is invisible where the notebook is rendered). The
# test inserts, after the first code cell that follows such a markdown cell, a cell that
# evaluates each expression in the kernel and fails when the figure, rounded as written, is not
# the computed value (or ``~ RTOL`` in the comment gives a relative tolerance), or when a verdict
# is false. A figure in scientific notation with no such comment is refused outright: it can
# only have been copied from a run.

FIGURE = re.compile(r"([-+−]?\d[\d,]*(?:\.\d+)?(?:[eE][-+−]?\d+)?)<!--\s*=\s*(.+?)\s*-->", re.S)
VERDICT = re.compile(r"<!--\s*holds:\s*(.+?)\s*-->", re.S)
BARE_SCIENTIFIC = re.compile(r"(?<![\w.])\d(?:\.\d+)?[eE][-+−]?\d+")
CODE_SPAN = re.compile(r"`[^`]*`")

CLAIM_CHECK = """
def _robodyn_check_claims(claims, namespace):
    import math
    failures = []
    for kind, text, expression, rtol in claims:
        value = eval(expression, namespace)
        if kind == "holds":
            if not value:
                failures.append(f"the verdict <!-- holds: {expression} --> is false")
            continue
        stated = float(text.replace(",", "").replace("\\u2212", "-"))
        if rtol is not None:
            ok = abs(value - stated) <= float(rtol) * abs(value)
        else:
            mantissa = text.lower().split("e")[0]
            exponent = int(text.lower().split("e")[1].replace("\\u2212", "-")) if "e" in text.lower() else 0
            decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
            ok = abs(value - stated) <= 0.5 * 10.0 ** (exponent - decimals) * (1 + 1e-9)
        if not ok:
            failures.append(f"the text says {text} for {expression}, which is {value!r}")
    assert not failures, "; ".join(failures)
"""


def claims_of(source: str) -> list[tuple[str, str, str, str | None]]:
    """The (kind, stated text, expression, rtol) of each figure and verdict in a markdown cell."""
    found: list[tuple[str, str, str, str | None]] = []
    for number, body in FIGURE.findall(source):
        expression, _, rtol = body.partition("~")
        found.append(("figure", number, expression.strip(), rtol.strip() or None))
    found += [("holds", "", expression, None) for expression in VERDICT.findall(source)]
    return found


def with_claim_checks(book):
    """A copy of ``book`` with a claim-checking cell after the code cell that follows each claim."""
    nbformat = pytest.importorskip("nbformat")
    cells, pending = [], []
    for cell in book.cells:
        cells.append(cell)
        if cell.cell_type == "markdown":
            pending += claims_of(cell.source)
        elif pending:
            cells.append(nbformat.v4.new_code_cell(f"{CLAIM_CHECK}\n_robodyn_check_claims({pending!r}, globals())"))
            pending = []
    if pending:
        cells.append(nbformat.v4.new_code_cell(f"{CLAIM_CHECK}\n_robodyn_check_claims({pending!r}, globals())"))
    copy = nbformat.from_dict(book)
    copy.cells = cells
    return copy


def execute(book, folder: Path):
    """Run ``book`` in a fresh kernel, sharing NOTEBOOK_TIMEOUT_S among its cells; return its error outputs."""
    nbclient = pytest.importorskip("nbclient")
    deadline = time.monotonic() + NOTEBOOK_TIMEOUT_S
    client = nbclient.NotebookClient(
        book,
        kernel_name="python3",
        resources={"metadata": {"path": str(folder)}},
        timeout_func=lambda cell: max(1, int(deadline - time.monotonic())),
    )
    try:
        client.execute()
    except nbclient.exceptions.CellExecutionError as error:
        return [str(error)]
    return [o for cell in book.cells if cell.cell_type == "code" for o in cell.outputs if o.output_type == "error"]


def alone(path: Path, folder: Path) -> Path:
    """``path`` copied into ``folder``, empty but for it: a student's download, or a hosted notebook service."""
    assert not any(folder.iterdir()), f"{folder} is not empty"
    return Path(shutil.copy(path, folder / path.name))


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_alone_and_its_text_matches_its_numbers(path: Path, tmp_path: Path) -> None:
    """Each notebook runs copied alone into an empty folder (the kernel's working folder), hidden tests included."""
    nbformat = pytest.importorskip("nbformat")
    copy = alone(path, tmp_path)
    book = nbformat.read(copy, as_version=4)
    assert not execute(with_claim_checks(book), tmp_path)


# --- Notebooks that run anywhere ------------------------------------------------------------------
#
# A notebook reads nothing beside itself: the examples it needs ship inside the package
# (pyproject's force-include, examples -> robodyn/examples) and are found by robodyn.example().

OUTSIDE = re.compile(r"""(Path\(\s*["']\.\.["']\s*\)|["']\.\./|["']examples/)""")
EXAMPLE_CALL = re.compile(r"""robodyn\.example\(\s*["']([^"']+)["']\s*\)""")


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_reads_no_path_outside_itself(path: Path) -> None:
    nbformat = pytest.importorskip("nbformat")
    book = nbformat.read(path, as_version=4)
    for index, cell in enumerate(book.cells):
        if cell.cell_type == "code":
            assert not OUTSIDE.search(cell.source), f"{path.name} cell {index} reads a path beside the notebook"


def test_the_examples_the_notebooks_name_ship_with_the_package() -> None:
    import robodyn

    root = Path(__file__).resolve().parents[1]
    from robodyn.fileio import toml_module

    pyproject = toml_module("pyproject.toml").loads((root / "pyproject.toml").read_text(encoding="utf-8"))
    shipped = pyproject["tool"]["hatch"]["build"]["targets"]["wheel"]["force-include"]
    assert shipped.get("examples") == "robodyn/examples", "the wheel must carry examples/ as robodyn/examples"
    nbformat = pytest.importorskip("nbformat")
    sources = [cell.source for path in NOTEBOOKS for cell in nbformat.read(path, as_version=4).cells]
    named = {m for source in sources for m in EXAMPLE_CALL.findall(source)}
    assert named, "no notebook names a shipped example"
    for relative in sorted(named):
        assert robodyn.example(relative).exists(), relative
        assert (root / "examples" / relative).exists(), f"{relative} is not under examples/, which the wheel ships"
    with pytest.raises(robodyn.InputError, match="expected a path under one of"):
        robodyn.example("textbook/no_such_example")
    with pytest.raises(robodyn.InputError):
        robodyn.example("../pyproject.toml")


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_no_figure_is_copied_into_the_text(path: Path) -> None:
    """A number in scientific notation in a markdown cell must name the expression it comes from."""
    nbformat = pytest.importorskip("nbformat")
    book = nbformat.read(path, as_version=4)
    for index, cell in enumerate(book.cells):
        if cell.cell_type == "markdown":
            bare = BARE_SCIENTIFIC.findall(VERDICT.sub("", FIGURE.sub("", CODE_SPAN.sub("", cell.source))))
            assert not bare, f"{path.name} cell {index}: {bare} stated without <!-- = expression -->"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_each_notebook_states_checked_figures_and_ends_with_exercises(path: Path) -> None:
    nbformat = pytest.importorskip("nbformat")
    book = nbformat.read(path, as_version=4)
    claims = [claim for cell in book.cells if cell.cell_type == "markdown" for claim in claims_of(cell.source)]
    assert claims, f"{path.name}: no figure or verdict of its text is checked"
    headings = [
        i for i, cell in enumerate(book.cells) if cell.cell_type == "markdown" and "## Exercises" in cell.source
    ]
    assert headings, f"{path.name}: no '## Exercises' section"
    cells = book.cells[headings[0] :]
    exercises = [i for i, c in enumerate(cells) if c.cell_type == "markdown" and "**Exercise" in c.source]
    assert len(exercises) >= 2, f"{path.name}: {len(exercises)} exercise(s), want two or three"
    for i in exercises:
        question = cells[i].source
        assert not claims_of(question) and "Answer" not in question, f"{path.name}: an answer in {question[:60]!r}"
        assert i + 2 < len(cells), f"{path.name}: {question[:40]!r} has no solution and test cells after it"
        assert role(cells[i + 1]) == "solution", f"{path.name}: {question[:40]!r} is not followed by a solution cell"
        assert role(cells[i + 2]) == "test", f"{path.name}: {question[:40]!r}'s solution has no hidden-test cell"


# --- Exercises a teacher can set (nbgrader's conventions) -------------------------------------------
#
# After each "**Exercise N.**" question: a solution cell (metadata nbgrader.solution, tag "solution")
# whose answer lies between "### BEGIN SOLUTION" and "### END SOLUTION", then an autograded test cell
# (nbgrader.grade with points, tag "hidden-test") whose checks lie between "### BEGIN HIDDEN TESTS" and
# "### END HIDDEN TESTS". nbgrader's generate_assignment makes the student's copy; student_copy does
# the same here.

SOLUTION = re.compile(r"### BEGIN SOLUTION\n(.*?)### END SOLUTION\n?", re.S)
HIDDEN = re.compile(r"### BEGIN HIDDEN TESTS\n(.*?)### END HIDDEN TESTS\n?", re.S)
STUB = "# YOUR CODE HERE\nraise NotImplementedError()\n"


def role(cell) -> str | None:
    """ "solution" or "test" as nbgrader's metadata and the cell's markers both say; else None."""
    meta = cell.metadata.get("nbgrader", {})
    if cell.cell_type != "code":
        return None
    if meta.get("solution") and not meta.get("grade") and SOLUTION.search(cell.source):
        return "solution"
    if meta.get("grade") and meta.get("points", 0) > 0 and meta.get("locked") and HIDDEN.search(cell.source):
        return "test"
    return None


def student_copy(book):
    """What nbgrader hands out: each solution replaced by a stub, each hidden test removed."""
    nbformat = pytest.importorskip("nbformat")
    copy = nbformat.from_dict(book)
    for cell in copy.cells:
        if role(cell) == "solution":
            cell.source = SOLUTION.sub(STUB, cell.source)
        elif role(cell) == "test":
            cell.source = HIDDEN.sub("", cell.source)
    return copy


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_the_students_copy_holds_no_answer_and_no_hidden_test(path: Path) -> None:
    nbformat = pytest.importorskip("nbformat")
    book = nbformat.read(path, as_version=4)
    solutions = [c for c in book.cells if role(c) == "solution"]
    tests = [c for c in book.cells if role(c) == "test"]
    assert len(solutions) >= 2 and len(tests) == len(solutions), (
        f"{path.name}: solutions {len(solutions)}, tests {len(tests)}"
    )
    ids = [c.metadata["nbgrader"]["grade_id"] for c in solutions + tests]
    assert len(set(ids)) == len(ids), f"{path.name}: nbgrader grade_ids must be unique"
    for cell in tests:
        assert "assert" in HIDDEN.search(cell.source).group(1), f"{path.name}: a hidden test that checks nothing"
    handed_out = "\n".join(c.source for c in student_copy(book).cells)
    for cell in solutions:
        answer = [line for line in SOLUTION.search(cell.source).group(1).splitlines() if line.strip()]
        assert answer and not any(line in handed_out for line in answer if "=" in line), f"{path.name}: an answer leaks"
    assert "BEGIN HIDDEN TESTS" not in handed_out


def test_a_planted_contradiction_fails(tmp_path: Path) -> None:
    """The claim check catches a figure changed in the text, and a verdict its numbers contradict."""
    nbformat = pytest.importorskip("nbformat")
    path = next(p for p in NOTEBOOKS if p.stem == "geared_arm")
    book = nbformat.read(path, as_version=4)
    index, cell = next(
        (i, c) for i, c in enumerate(book.cells) if c.cell_type == "markdown" and FIGURE.search(c.source)
    )
    number = FIGURE.search(cell.source).group(1)
    wrong = str(float(number.replace(",", "")) * 1.5)
    planted = nbformat.from_dict(book)
    planted.cells[index].source = cell.source.replace(f"{number}<!--", f"{wrong}<!--", 1)
    errors = execute(with_claim_checks(planted), path.parent)
    assert errors and f"the text says {wrong}" in str(errors)
    verdict = nbformat.from_dict(book)
    verdict.cells[index].source = cell.source + "\n\nThe run diverges.<!-- holds: False -->"
    errors = execute(with_claim_checks(verdict), path.parent)
    assert errors and "is false" in str(errors)


def test_a_wrong_answer_fails_its_hidden_test(tmp_path: Path) -> None:
    """A solution cell whose answer is off by half fails the hidden test after it, in the exercise it belongs to."""
    nbformat = pytest.importorskip("nbformat")
    path = next(p for p in NOTEBOOKS if p.stem == "geared_arm")
    book = nbformat.read(path, as_version=4)
    index = next(i for i, c in enumerate(book.cells) if role(c) == "solution")
    name = re.search(r"np\.ndim\((\w+)\)", book.cells[index + 1].source).group(1)  # the answer the test reads
    planted = nbformat.from_dict(book)
    planted.cells[index].source = book.cells[index].source.replace(
        "### END SOLUTION", f"{name} = {name} * 1.5\n### END SOLUTION"
    )
    errors = execute(planted, tmp_path)
    assert errors and "AssertionError" in str(errors)
    assert book.cells[index + 1].source in "\n".join(errors), (
        "the error must come from the hidden test after the solution"
    )
