"""Scoring ``robodyn check --explain --json`` against the explain corpus's truth (benchmarks/bench_explain.py).

What a check said about each entry is read from its JSON: the ``explain_terms`` list when the check
writes one (``quantity``, ``entry``, ``label``, ``status`` named | candidates | unnamed | no_fit, and
``terms`` of ``basis``, ``coefficient``, ``name``, ``candidates``) and its ``hints``; otherwise from
the printed lines of ``explanation`` (``M[0,1]: formula - Pinocchio = <expr>   (coefficient c, = name
to 1e-15)``, or ``... is no sum of at most 6 terms ...``), as robodyn printed them before.

The truth is computed, not read: at seeded random parameter values and states, the planted file minus
the correct one carried into the planted file's coordinates (``verify.difference``; the corpus's
verifier proves it equals the written truth). A printed expression is evaluated with the same values
(its q1, v1 or the file's own coordinate names and ``<name>_dot``; a symbol that is neither a
parameter nor a coordinate draws a value of its own, so it cannot be right by chance). Per entry:

* ``named_right``: every term named and the printed sum is the truth at every draw;
* ``candidates``: candidates listed, the truth among them for every term;
* ``cannot_name``: nothing named (``unnamed``, ``no_fit``), or only terms that are right;
* ``wrong_name``: a printed name (or a candidate list) that is not the truth at some draw;
* ``missing``: the entry differs but the explanation does not mention it.

A case takes its worst entry's outcome (wrong_name, missing, cannot_name, candidates, named_right).
A convention case's hint is ``right`` when a hint line mentions every word of the case's hint,
``wrong`` when hints were given but none does, ``missing`` when none was given.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent / "explain_corpus"))

from verify import (
    Case,
    RandomParameters,
    Robot,
    coordinate_names,
    difference,
    draw_state,
    evaluate,
    load_corpus,
    load_module,
    numeric,
    planted_text,
)

__all__ = ["OUTCOMES", "Case", "Robot", "load_corpus", "planted_text", "score_case"]

OUTCOMES = ("wrong_name", "missing", "cannot_name", "candidates", "named_right")  # worst first
PARAMETER_DRAWS = 6  # parameter sets a printed name must hold at (a coincidence holds at one)
STATES = 30  # states per parameter set: enough to fit a handful of terms by least squares
NAME_RTOL = 1e-6  # a name is the truth when it agrees to this (both are exact; round-off is ~1e-13)
ZERO = 1e-9  # an entry whose difference stays below this fraction of the scale is not a true entry

_LINE = re.compile(r"^(?P<label>[MCGV](?:\[\d+(?:,\d+)?\])?): formula - Pinocchio (?P<rest>.*)$")
_DETAIL = re.compile(r"^(?P<c>[-+0-9.e]+)(?:, = (?P<name>.+) to 1e-?\d+)?$")


@dataclass
class Term:
    """One fitted term as the check reported it."""

    basis: str
    coefficient: float | None = None
    name: str | None = None
    candidates: list[str] = field(default_factory=list)


@dataclass
class Entry:
    """What the check said about one entry."""

    label: str
    status: str  # named | candidates | unnamed | no_fit | partial
    terms: list[Term]
    text: str = ""  # the line (or the JSON reason)


# ------------------------------------------------------------------------------ reading a check's JSON
def label_of(quantity: str, entry: Sequence[int]) -> str:
    """``("M", [0, 1])`` -> ``"M[0,1]"``."""
    return quantity + (f"[{','.join(str(int(i)) for i in entry)}]" if len(entry) else "")


def read_entries(report: Mapping[str, Any]) -> dict[str, Entry]:
    """Every explained entry of a check's JSON, by label (the new schema when present, else the lines)."""
    if "explain_terms" in report:
        return _from_schema(report["explain_terms"])
    out: dict[str, Entry] = {}
    for line in report.get("explanation") or []:
        entry = parse_line(line)
        if entry is not None:
            out.setdefault(entry.label, entry)
    return out


def _from_schema(items: Sequence[Mapping[str, Any]]) -> dict[str, Entry]:
    out = {}
    for item in items:
        label = item.get("label") or label_of(item["quantity"], item.get("entry", []))
        terms = []
        for t in item.get("terms", []):
            candidates = [c if isinstance(c, str) else str(c.get("name")) for c in t.get("candidates") or []]
            terms.append(Term(str(t.get("basis", "1")), t.get("coefficient"), t.get("name"), candidates))
        status = str(item.get("status", "unnamed"))
        out[label] = Entry(label, status, terms, f"{label}: {status}: {_shown(terms)} {item.get('reason', '')}".strip())
    return out


def _shown(terms: Sequence[Term]) -> str:
    """The terms as text: ``name*basis`` each, the coefficient where unnamed, candidates in brackets."""
    parts = []
    for t in terms:
        what = t.name or (f"[{' | '.join(t.candidates)}]" if t.candidates else f"{t.coefficient:.3g}")
        parts.append(f"({what})*{t.basis}")
    return " + ".join(parts)


def parse_line(line: str) -> Entry | None:
    """One printed explanation line (robodyn's text before the JSON schema); None for other lines."""
    match = _LINE.match(line.strip())
    if match is None:
        return None
    label, rest = match.group("label"), match.group("rest")
    if not rest.startswith("= "):
        return Entry(label, "no_fit", [], line)
    expr, _, details = rest[2:].rpartition("   (")
    details = re.sub(r"^coefficients? ", "", details.rstrip(")"))
    parsed = [_DETAIL.match(d.strip()) for d in details.split("; ")]
    if not expr or any(p is None for p in parsed):
        return Entry(label, "unnamed", [], line)
    terms = _terms(expr, [(float(p.group("c")), p.group("name")) for p in parsed if p is not None])
    if terms is None:
        return Entry(label, "unnamed", [], line)
    named = sum(t.name is not None for t in terms)
    status = "named" if named == len(terms) else "partial" if named else "unnamed"
    return Entry(label, status, terms, line)


def _top_level_end(text: str, start: int) -> int:
    """The index of the first space outside parentheses at or after ``start`` (or the end)."""
    depth = 0
    for i in range(start, len(text)):
        depth += {"(": 1, ")": -1}.get(text[i], 0)
        if text[i] == " " and depth == 0:
            return i
    return len(text)


def _terms(expr: str, details: Sequence[tuple[float, str | None]]) -> list[Term] | None:
    """The printed sum cut into its terms, guided by each term's coefficient and name (in the printed order)."""
    pos, terms = 0, []
    for k, (c, name) in enumerate(details):
        if k == 0:
            pos += expr.startswith("-")
        elif expr[pos : pos + 3] in (" + ", " - "):
            pos += 3
        else:
            return None
        bodies = [f"{abs(c):.3g}"] if name is None else [name, name.lstrip("-"), f"({name})", f"({name.lstrip('-')})"]
        body = max((b for b in bodies if expr.startswith(b, pos)), key=len, default=None)
        if body is None:
            return None
        pos += len(body)
        if expr.startswith("*", pos):
            end = _top_level_end(expr, pos + 1)
            basis, pos = expr[pos + 1 : end], end
        else:
            basis = "1"
        terms.append(Term(basis, c, name))
    return terms if pos == len(expr) else None


def read_hints(report: Mapping[str, Any]) -> list[str]:
    """The check's one-line convention hints: ``hints``, else explanation lines that are not about an entry."""
    if "hints" in report:
        return [str(h) for h in report["hints"]]
    lines = report.get("explanation") or []
    return [
        line
        for line in lines[1:]
        if _LINE.match(line.strip()) is None
        and "follows from" not in line
        and not line.startswith("    ")
        and not line.startswith("the formula's")
    ]


# ------------------------------------------------------------------------------ the truth, numerically
class Truth:
    """The true difference of a case at seeded random parameter sets and states, and the printed text's values."""

    def __init__(self, robot: Robot, case: Case, *, seed: int = 0) -> None:
        self.correct = load_module(robot.correct_text(), f"{robot.name}_correct")
        self.planted = load_module(planted_text(robot, case), f"{case.id}_planted")
        self.names = coordinate_names(self.correct)
        rng = np.random.default_rng(seed)
        self.draws = []  # per parameter set: (envs per state, differences per state)
        for _ in range(PARAMETER_DRAWS):
            p = RandomParameters(rng)
            envs, diffs = [], []
            for _ in range(STATES):
                q, v = draw_state(rng, len(self.names))
                diffs.append(difference(self.correct, self.planted, p, q, v))
                scale = max(float(np.max(np.abs(x))) for x in evaluate(self.correct, p, q, v).values())
                envs.append((self._env(p, q, v), scale))
            self.draws.append((envs, diffs))

    def _env(self, p: RandomParameters, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        env = RandomParameters(p.rng)
        env.update(p)
        for i, name in enumerate(self.names):
            for alias in (name, f"q{i + 1}"):
                env[alias] = float(q[i])
            for alias in (f"{name}_dot", f"v{i + 1}"):
                env[alias] = float(v[i])
        return env

    def entries(self) -> list[str]:
        """The labels of the entries that differ (M's upper triangle when its difference is symmetric)."""
        out = []
        diffs = [d for _, ds in self.draws for d in ds]
        scale = max(s for envs, _ in self.draws for _, s in envs)
        for key in diffs[0]:
            stack = np.array([d[key] for d in diffs])
            symmetric = key == "M" and np.allclose(stack, np.swapaxes(stack, 1, 2), atol=ZERO * (1 + scale))
            for idx in np.ndindex(stack.shape[1:]):
                if symmetric and idx[0] > idx[1]:
                    continue
                if np.max(np.abs(stack[(slice(None), *idx)])) > ZERO * (1 + scale):
                    out.append(label_of(key, idx))
        return out

    def values(self, label: str) -> list[np.ndarray]:
        """The true difference of ``label`` per parameter set, over its states (V up to a constant: centred)."""
        key, idx = _key(label)
        return [_centred(label, np.array([d[key][idx] for d in diffs])) for _, diffs in self.draws]

    def printed(self, text: str) -> list[np.ndarray]:
        """A printed expression's values per parameter set, over the same states (NaN when it does not parse)."""
        try:
            fn = numeric(text)
        except Exception:
            return [np.full(STATES, np.nan) for _ in self.draws]
        return [np.array([_safe(fn, env) for env, _ in envs]) for envs, _ in self.draws]


def _centred(label: str, x: np.ndarray) -> np.ndarray:
    """``x`` less its mean for V (the check compares V - V(q0): a constant is not a term), else ``x``."""
    return x - np.mean(x) if label == "V" else x


def _safe(fn: Any, env: Mapping[str, float]) -> float:
    try:
        return float(fn(env))
    except Exception:
        return float("nan")


def _key(label: str) -> tuple[str, tuple[int, ...]]:
    match = re.fullmatch(r"([MCGV])(?:\[(\d+)(?:,(\d+))?\])?", label)
    if match is None:
        raise ValueError(f"label {label!r}")
    return match.group(1), tuple(int(x) for x in match.groups()[1:] if x is not None)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    scale = max(float(np.max(np.abs(b))), 1e-12)
    return bool(np.all(np.isfinite(a)) and np.max(np.abs(a - b)) <= NAME_RTOL * scale)


# ------------------------------------------------------------------------------ scoring
def score_entry(truth: Truth, label: str, said: Entry | None) -> str:
    """One true entry's outcome (see the module docstring)."""
    if said is None:
        return "missing"
    if said.status in ("unnamed", "no_fit") or not said.terms:
        return "cannot_name"
    want = truth.values(label)
    if said.status == "named":
        whole = " + ".join(f"({t.name})*({t.basis})" for t in said.terms)
        got = [_centred(label, g) for g in truth.printed(whole)]
        return "named_right" if all(_same(g, w) for g, w in zip(got, want, strict=True)) else "wrong_name"
    coefficients = _true_coefficients(truth, said.terms, want)
    for term, true in zip(said.terms, coefficients, strict=True):
        names = [term.name] if term.name else term.candidates
        if not names or (label == "V" and term.basis == "1"):
            continue
        if not any(_same(np.array([g[0] for g in truth.printed(n)]), true) for n in names):
            return "wrong_name"
    if said.status == "candidates":
        return "candidates"
    return "cannot_name"


def _true_coefficients(truth: Truth, terms: Sequence[Term], want: Sequence[np.ndarray]) -> list[np.ndarray]:
    """Each printed basis term's true coefficient per parameter set (least squares of the truth on the basis)."""
    bases = [truth.printed(t.basis) for t in terms]
    out = np.zeros((len(terms), len(want)))
    for k, w in enumerate(want):
        A = np.column_stack([b[k] for b in bases])
        if np.all(np.isfinite(A)):
            out[:, k] = np.linalg.lstsq(A, w, rcond=None)[0]
        else:
            out[:, k] = np.nan
    return [out[j] for j in range(len(terms))]


def score_hint(case: Case, hints: Sequence[str]) -> str:
    """``right``, ``wrong`` or ``missing`` for a convention case; ``spurious`` or ``none`` for another."""
    if case.hint is None:
        return "spurious" if hints else "none"
    words = [str(w) for w in case.hint.get("words", [])]
    for hint in hints:
        if all((w in hint) if w != w.lower() else (w in hint.lower()) for w in words):
            return "right"
    return "wrong" if hints else "missing"


def worst(outcomes: Sequence[str]) -> str:
    """The worst of entry outcomes (OUTCOMES is worst first); ``none`` when there are none."""
    for outcome in OUTCOMES:
        if outcome in outcomes:
            return outcome
    return "none"


def score_case(robot: Robot, case: Case, report: Mapping[str, Any]) -> dict[str, Any]:
    """Per entry and for the whole case: what the check said, and its outcome."""
    truth = Truth(robot, case)
    said = read_entries(report)
    entries = []
    for label in truth.entries():
        entry = said.get(label)
        if entry is None and label.startswith("M[") and "," in label:  # M[j,i] stands for M[i,j]
            i, j = _key(label)[1]
            entry = said.get(f"M[{j},{i}]")
        entries.append(
            {
                "label": label,
                "truth": case.truth.get(label, ""),
                "said": entry.text if entry is not None else "",
                "status": entry.status if entry is not None else "absent",
                "outcome": score_entry(truth, label, entry),
            }
        )
    hints = read_hints(report)
    term_outcome = worst([e["outcome"] for e in entries]) if case.truth or case.hint is None else "convention"
    if term_outcome == "convention" and any(e["outcome"] == "wrong_name" for e in entries):
        term_outcome = "convention_wrong_name"
    return {"entries": entries, "outcome": term_outcome, "hint": score_hint(case, hints), "hints": hints}
