"""Every notebook in ``notebooks/`` runs from top to bottom (nbclient), and is stored without outputs.

The notebooks assert what they show (the check passes, the energy is kept...), and every figure or
verdict their text states is checked against the value it comes from (see ``claims_of``), so a
change that breaks the story, or a sentence its own numbers contradict, fails here. Each notebook gets NOTEBOOK_TIMEOUT_S in all, shared by its cells.
"""

from __future__ import annotations

import re
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


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_and_its_text_matches_its_numbers(path: Path) -> None:
    nbformat = pytest.importorskip("nbformat")
    book = nbformat.read(path, as_version=4)
    assert not execute(with_claim_checks(book), path.parent)


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
    exercises = [c for c in book.cells[headings[0] :] if c.cell_type == "markdown" and "**Exercise" in c.source]
    assert len(exercises) >= 2, f"{path.name}: {len(exercises)} exercise(s), want two or three"
    for cell in exercises:
        assert claims_of(cell.source), f"{path.name}: an exercise whose answer is not checked: {cell.source[:60]!r}"


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
