"""The teacher's check of an assignment: the solution gets full marks, and each planted slip loses points.

A mutant is the solution with one change inside ``mass_matrix``, ``coriolis_matrix``,
``coriolis_vector``, ``gravity`` or ``potential_energy`` (by the syntax tree, not the text): a ``+``
made ``-`` (or back), a term dropped (``a + b`` -> ``a``), a sine made a cosine (or back). A mutant
that still gets full marks is a slip the assignment would not catch: fewer samples than it needs, a
quantity not asked, or an equivalent rewrite.
"""

from __future__ import annotations

import ast
import copy
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

FUNCTIONS = ("mass_matrix", "coriolis_matrix", "coriolis_vector", "gravity", "potential_energy")
SWAP = {"sin": "cos", "cos": "sin"}


@dataclass(frozen=True)
class Mutant:
    """One planted slip: its description (``gravity line 42: '+' -> '-'``) and the mutated source."""

    description: str
    source: str


def _sites(tree: ast.Module) -> Iterator[tuple[str, ast.AST]]:
    for fn in tree.body:
        if isinstance(fn, ast.FunctionDef) and fn.name in FUNCTIONS:
            for node in ast.walk(fn):
                yield fn.name, node


def _changes(node: ast.AST) -> list[tuple[str, str]]:
    """(kind, description) of each mutation this node admits."""
    out = []
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
        sign = "+" if isinstance(node.op, ast.Add) else "-"
        out.append(("flip", f"'{sign}' -> '{'-' if sign == '+' else '+'}'"))
        out.append(("drop", f"dropped the term {ast.unparse(node.right)!r}"))
    if isinstance(node, ast.Call):
        f = node.func
        name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""
        if name in SWAP:
            out.append(("swap", f"{name} -> {SWAP[name]}"))
    return out


def _mutated(node: ast.AST, kind: str) -> ast.AST:
    """``node`` with one change of ``kind`` (the node itself is changed, or its replacement returned)."""
    if kind == "drop" and isinstance(node, ast.BinOp):
        return node.left
    if kind == "flip" and isinstance(node, ast.BinOp):
        node.op = ast.Sub() if isinstance(node.op, ast.Add) else ast.Add()
    elif kind == "swap" and isinstance(node, ast.Call):
        if isinstance(node.func, ast.Attribute):
            node.func.attr = SWAP[node.func.attr]
        elif isinstance(node.func, ast.Name):
            node.func.id = SWAP[node.func.id]
    return node


def mutants(source: str, *, limit: int = 24) -> list[Mutant]:
    """At most ``limit`` single-change mutants of ``source``, spread evenly over every possible one."""
    tree = ast.parse(source)
    order = {id(n): i for i, n in enumerate(ast.walk(tree))}  # _walk_apply finds a node by this index
    found = []
    for fn, node in _sites(tree):
        for kind, what in _changes(node):
            found.append((order[id(node)], kind, f"{fn} line {getattr(node, 'lineno', '?')}: {what}"))
    if len(found) > limit:
        step = len(found) / limit
        found = [found[int(i * step)] for i in range(limit)]
    out = []
    for index, kind, what in found:
        mutated = _walk_apply(copy.deepcopy(tree), index, kind)
        out.append(Mutant(what, ast.unparse(ast.fix_missing_locations(mutated)) + "\n"))
    return out


def _walk_apply(tree: ast.Module, index: int, kind: str) -> ast.AST:
    """Apply one change to the ``index``-th node of ``ast.walk(tree)``."""
    nodes = list(ast.walk(tree))
    target = nodes[index]
    for parent in nodes:
        for name, value in ast.iter_fields(parent):
            if value is target:
                setattr(parent, name, _mutated(target, kind))
                return tree
            if isinstance(value, list) and any(v is target for v in value):
                value[next(i for i, v in enumerate(value) if v is target)] = _mutated(target, kind)
                return tree
    return tree


def write_mutants(solution: Path, folder: Path, *, limit: int = 24) -> list[tuple[Path, str]]:
    """The mutants as files ``folder/mutant_NN/<solution's name>``, each with its description."""
    out = []
    for k, m in enumerate(mutants(solution.read_text(encoding="utf-8"), limit=limit)):
        path = folder / f"mutant_{k:02d}" / solution.name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(m.source, encoding="utf-8")
        out.append((path, m.description))
    return out
