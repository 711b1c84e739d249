"""``robodyn check --explain``: name the wrong term of each mismatching entry, in the formula's own symbols.

For every entry of M, C, G (and V) that is out of tolerance, the difference formula - Pinocchio over
the sampled states is fitted sparsely in a basis of the terms rigid-body dynamics is made of
(:mod:`robodyn.checker.explain_basis`: cos(q2), sin(q1 + q2), q2*cos(q3), sin(q2)*v1, ...).

A coefficient is then named across parameter values, not at one set of them, where a coincidence
(0.8 * 0.25 = 0.5 * 0.4) would pass for a name: the fit's terms are refitted at the varied parameter
sets (:class:`Sets`, gathered by :mod:`robodyn.checker.explain_sets`), so that each coefficient is a
vector over the sets, and a product of the file's parameters (or a sum or difference of two) names it
only when it is the one that equals it at every set (:mod:`robodyn.checker.explain_names`). Each entry
comes out as an :class:`Explained`, of status ``named`` (every term has its one name), ``candidates``
(several fit: listed, with why they cannot be told apart), ``unnamed`` (none fits, or the terms change
form with the parameters: why) or ``no_fit`` (no sum of at most :data:`MAX_TERMS` terms is exact), and
as printed lines in the formula's own coordinates (``NAMES``: cos(phi1), phi1_dot).

The formula's own structure is read too: an M that is not symmetric, or not positive definite at a
sample; a C whose C v is right while dM/dt - 2C is not skew (a valid C v, not in Christoffel form).
Knock-on rows (C v + G, tau, the acceleration, T) say which mismatching entries they follow from.
Nothing here imports Pinocchio: it works on what the check gathered.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.checker.explain_basis import (
    MAX_TERMS,
    Basis,
    Fit,
    fit,
    fit_target,
    least_squares,
    q_basis,
    velocity_basis,
)
from robodyn.checker.explain_names import (
    MAX_FACTORS,
    NAME_RTOL,
    Dim,
    Name,
    Namer,
    entry_dimension,
    factors_of,
    sub,
    term_dimension,
)
from robodyn.checker.rows import Accumulator, CheckRow

Array = NDArray[np.float64]

QUANTITIES = {"M": "M", "C": "C", "G": "G", "V": "V - V(q0)"}
MAX_CANDIDATES = 4  # candidates listed for a term; past them, how many more


# ---------------------------------------------------------------------------------------- the parameter sets
@dataclass(frozen=True)
class Sets:
    """The formula's parameters and formula - Pinocchio at the parameter sets (:mod:`robodyn.checker.explain_sets`).

    ``params[0]`` is the check's own set; ``differences[key]`` (S - 1, k, *shape) and ``scales[key]`` (S - 1,)
    are at the varied sets, at the check's first k states; ``gravity`` (S,) [m/s^2]. ``followed``: constant
    parameter -> the per-link value it was varied as; ``held``: parameter -> why it could not be varied;
    ``advice``: what would let it; ``failure``: why no varied set could be built.
    """

    params: tuple[Mapping[str, float], ...]
    gravity: tuple[float, ...]
    differences: Mapping[str, Array]
    scales: Mapping[str, Array]
    followed: Mapping[str, str]
    held: Mapping[str, str]
    advice: str = ""
    failure: str = ""

    @property
    def count(self) -> int:
        """Number of parameter sets, the check's own included."""
        return len(self.params)


def one_set(params: Mapping[str, float], g: float, *, failure: str) -> Sets:
    """The check's own parameter set alone; ``failure``: why no other (a name is then only a candidate)."""
    return Sets((params,), (g,), {}, {}, {}, {}, failure=failure)


# ---------------------------------------------------------------------------------------- the explanation
@dataclass(frozen=True)
class Term:
    """One term of an entry's difference: its basis function, coefficient (the check's set), name and candidates."""

    basis: str
    coefficient: float
    name: str | None
    candidates: tuple[str, ...]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return {
            "basis": self.basis,
            "coefficient": self.coefficient,
            "name": self.name,
            "candidates": list(self.candidates),
        }


@dataclass(frozen=True)
class Explained:
    """An entry's difference formula - Pinocchio as named terms; ``status`` named, candidates, unnamed or no_fit."""

    quantity: str  # "M", "C", "G" or "V"
    entry: tuple[int, ...]
    label: str
    status: str
    terms: tuple[Term, ...]
    reason: str

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: the schema of ``check --json``'s ``explain_terms``."""
        return {
            "quantity": self.quantity,
            "entry": list(self.entry),
            "label": self.label,
            "status": self.status,
            "terms": [t.as_dict() for t in self.terms],
            "reason": self.reason,
        }


def _display(term: str, names: Sequence[str] | None) -> str:
    """A basis term in the formula's own names: q2 -> phi1, v2 -> phi1_dot (``NAMES``); q1, v1 ... without."""
    if not names:
        return term
    return re.sub(r"\b([qv])(\d+)\b", lambda m: names[int(m[2]) - 1] + ("_dot" if m[1] == "v" else ""), term)


def _coefficients(f: Fit, basis: Basis, sets: Sets, key: str, flat: int, tolerance: float) -> Array | None:
    """The fit's coefficients at every parameter set (S, J), its terms refitted at each; None where they do not fit."""
    out = [np.array(f.coefficients)]
    if sets.count == 1:
        return np.array(out)
    index = {name: j for j, name in enumerate(basis.names)}
    k = sets.differences[key].shape[1]
    Phi = basis.values[:k, [index[t] for t in f.terms]]
    for d_all, scale in zip(sets.differences[key], sets.scales[key], strict=True):
        d = d_all.reshape(k, -1)[:, flat]
        coef, left = least_squares(Phi, d)
        if left > fit_target(d, float(scale), tolerance):
            return None
        out.append(coef)
    return np.array(out)


def identify(
    key: str,
    entry: tuple[int, ...],
    label: str,
    f: Fit,
    vectors: Array | None,
    namer: Namer,
    sets: Sets,
    dims: Sequence[Dim | None],
    names: Sequence[str] | None,
) -> Explained:
    """Name each term of the fit ``f`` by what equals its coefficient at every parameter set (``vectors`` (S, J))."""
    shown = [_display(t, names) for t in f.terms]
    if not f.exact:
        reason = (
            f"no sum of at most {MAX_TERMS} terms of the basis fits (the best leaves {f.residual:.3g}): more than a "
            "term is wrong, or a term is outside the basis"
        )
        return Explained(key, entry, label, "no_fit", (), reason)
    if vectors is None:  # what fits at the check's own values is all there is: candidates at best, never a name
        own = Namer(sets.params[:1], sets.gravity[:1])
        bare = tuple(
            Term(b, c, None, tuple(n.text for n in own.candidates(c, dims[j])))
            for j, (b, c) in enumerate(zip(shown, f.coefficients, strict=True))
        )
        reason = (
            f"its terms do not keep their form when the parameters vary ({sets.count} parameter sets), so what "
            "fits at the check's values alone may be a coincidence: a parameter the model cannot vary"
            + (_held(sets) or ", or a number written where a parameter belongs")
        )
        status = "candidates" if all(t.candidates for t in bare) else "unnamed"
        return Explained(key, entry, label, status, bare, reason)
    terms: list[Term] = []
    for j, (b, c) in enumerate(zip(shown, f.coefficients, strict=True)):
        found = [n.text for n in namer.candidates(vectors[:, j], dims[j])]
        unique = found[0] if len(found) == 1 and sets.count > 1 else None
        terms.append(Term(b, c, unique, tuple(found)))
    if all(t.name is not None for t in terms):
        return Explained(key, entry, label, "named", tuple(terms), "")
    if any(not t.candidates for t in terms):
        reason = (
            f"no product of at most {MAX_FACTORS} parameters (times g, with a small rational factor), nor a sum or "
            f"difference of two, equals it at all {sets.count} parameter sets" + _held(sets)
        )
        return Explained(key, entry, label, "unnamed", tuple(terms), reason)
    return Explained(key, entry, label, "candidates", tuple(terms), _why_alike(terms, namer, sets))


def _held(sets: Sets) -> str:
    if not sets.held:
        return ""
    return "; " + "; ".join(sets.held.values()) + (f": {sets.advice}" if sets.advice else "")


def _why_alike(terms: Sequence[Term], namer: Namer, sets: Sets) -> str:
    """``cannot tell m2*l1 from m2*lc2: l1 = 0.5 did not change with the model ...; define parameters(robot) ...``."""
    if sets.count == 1:
        return f"a match at one parameter set may be a coincidence, and {sets.failure}"
    term = next(t for t in terms if t.name is None)
    involved: set[str] = set()
    for text in term.candidates:
        involved |= factors_of(text)
    parts = namer.alike(sorted(involved))
    said = " from ".join(term.candidates[:2])
    why = "; ".join(parts) if parts else f"both equal it at all {sets.count} parameter sets"
    held = [why_held for name, why_held in sets.held.items() if name in involved]
    if held:
        why = "; ".join(held)
    advice = sets.advice or "vary those values in the model (or in parameters(robot))"
    return f"cannot tell {said}: {why}; {advice}"


def _top_level_space(text: str) -> bool:
    """True when ``text`` has a space outside parentheses (``a - b``, not ``2*(a - b)``)."""
    depth = 0
    for ch in text:
        depth += {"(": 1, ")": -1}.get(ch, 0)
        if ch == " " and depth == 0:
            return True
    return False


def _term(coefficient: float, name: Name | None, atom: str) -> tuple[str, str]:
    """(sign, magnitude text) of one term: ``-``, ``m2*l1*lc2*cos(q2)``."""
    if name is not None:
        text = name.text
        negative = text.startswith("-") and not _top_level_space(text)
        sign = "-" if negative else "+"
        body = text[1:] if negative else text
        if _top_level_space(body) and atom != "1":
            body = f"({body})"
    else:
        sign = "-" if coefficient < 0 else "+"
        body = f"{abs(coefficient):.3g}"
    return sign, body if atom == "1" else f"{body}*{atom}"


def _expression(ex: Explained, order: Sequence[int]) -> str:
    expression = ""
    for position, j in enumerate(order):
        t = ex.terms[j]
        sign, body = _term(t.coefficient, None if t.name is None else Name(t.name, 0.0), t.basis)
        if position == 0:
            expression = body if sign == "+" else f"-{body}"
        else:
            expression += f" {sign} {body}"
    return expression


def describe(ex: Explained, unit: str, sets: Sets, vectors: Array | None = None) -> list[str]:
    """``M[0,1]: formula - Pinocchio = m2*(lc1 - l1)*cos(phi1)   (coefficient -0.2 = m2*(lc1 - l1) at 5 sets)``."""
    if ex.status == "no_fit":
        return [f"{ex.label}: formula - Pinocchio: {ex.reason} ({unit})"]
    coefficients = [t.coefficient for t in ex.terms]
    # largest first; of two equal ones, the formula's own (positive: formula - Pinocchio) first
    order = sorted(range(len(coefficients)), key=lambda j: (-float(f"{abs(coefficients[j]):.9g}"), coefficients[j] < 0))
    details = []
    for j in order:
        t = ex.terms[j]
        said = f"{t.coefficient:.3g}"
        if t.name is not None:
            said += f" = {t.name}"
        elif t.candidates:
            said += f", one of {', '.join(t.candidates[:MAX_CANDIDATES])}"
            if len(t.candidates) > MAX_CANDIDATES:
                said += f" and {len(t.candidates) - MAX_CANDIDATES} more"
        else:
            said += ", unnamed"
        details.append(said)
    word = "coefficient" if len(details) == 1 else "coefficients"
    at = f" at each of {sets.count} parameter sets" if ex.status == "named" else ""
    lines = [f"{ex.label}: formula - Pinocchio = {_expression(ex, order)}   ({word} {'; '.join(details)}{at})"]
    if ex.reason:
        lines.append(f"    {ex.reason}")
    swap = _swapped(ex, order, vectors)
    if swap:
        lines.append(f"    {swap}")
    return lines


def _swapped(ex: Explained, order: Sequence[int], vectors: Array | None) -> str:
    """``the formula has ... where Pinocchio has ...`` for two terms of equal and opposite coefficients at every set."""
    if len(ex.terms) != 2 or vectors is None:
        return ""
    a, b = order
    ca, cb = vectors[:, a], vectors[:, b]
    if np.any(np.abs(ca + cb) > NAME_RTOL * np.maximum(np.abs(ca), np.abs(cb)) * 1e3):
        return ""
    extra, missing = (a, b) if ex.terms[a].coefficient > 0 else (b, a)  # + what the formula has, - what it lacks
    own = ex.terms[extra]
    name = None if own.name is None else Name(own.name, 0.0)
    has = _term(own.coefficient, name, own.basis)[1]
    lacks = _term(own.coefficient, name, ex.terms[missing].basis)[1]
    what = "a term written wrong"
    if _sin_cos(own.basis, ex.terms[missing].basis):
        what = "a sine and a cosine swapped"
    elif re.sub(r"\d", "#", own.basis) == re.sub(r"\d", "#", ex.terms[missing].basis):
        what = "an index written wrong"
    return f"the formula has {has} where Pinocchio has {lacks}: {what}"


def _sin_cos(a: str, b: str) -> bool:
    return a.replace("sin", "#").replace("cos", "sin").replace("#", "cos") == b


def _entries(row: CheckRow) -> list[tuple[int, ...]]:
    return [m.entry for m in row.mismatches] or ([row.entry] if not row.passed else [])


def failing_keys(rows: Sequence[CheckRow]) -> tuple[str, ...]:
    """The formula rows (of M, C, G, V) --explain fits: those out of tolerance."""
    by_quantity = {r.quantity: r for r in rows}
    return tuple(k for k, q in QUANTITIES.items() if q in by_quantity and not by_quantity[q].passed)


def explain(
    rows: Sequence[CheckRow],
    acc: Mapping[str, Accumulator],
    samples: Sequence[Any],
    params: Mapping[str, float],
    *,
    prismatic: Sequence[bool],
    g: float,
    sets: Sets | None = None,
    names: Sequence[str] | None = None,
) -> tuple[tuple[str, ...], tuple[Explained, ...]]:
    """The explanation lines of a check and each mismatching entry's named terms.

    ``acc``: the formula rows' accumulators (key -> (Pinocchio, formula) per sample), ``samples``: the
    states (``.q``, ``.v`` in the formula's coordinates), ``prismatic[i]``: coordinate i is a length;
    ``sets``: the parameter sets (:mod:`robodyn.checker.explain_sets`; None: the check's own only, and then
    nothing is named, only candidates given); ``names``: the formula's coordinates (``NAMES``).
    """
    sets = sets if sets is not None else one_set(params, g, failure="no varied parameter set was asked for")
    by_quantity = {r.quantity: r for r in rows}
    q = np.array([s.q for s in samples])
    v = np.array([s.v for s in samples])
    base = q_basis(q, prismatic)
    namer = Namer(sets.params, sets.gravity)
    lines: list[str] = []
    explained: list[Explained] = []
    failing: dict[str, list[str]] = {}
    for key, quantity in QUANTITIES.items():
        row = by_quantity.get(quantity)
        if row is None or row.passed or key not in acc:
            continue
        basis = velocity_basis(base, v) if key == "C" else base
        refs = np.array([ref for ref, _ in acc[key].pairs])
        vals = np.array([val for _, val in acc[key].pairs])
        scale = float(np.max(np.abs(refs))) if refs.size else 1.0
        labels = []
        for entry in _entries(row):
            label = row.entry_label(entry) if key != "V" else "V"
            labels.append(label)
            flat = int(np.ravel_multi_index(entry, refs.shape[1:])) if entry else 0
            d = (vals - refs).reshape(len(samples), -1)[:, flat]
            found = fit(d, basis, scale, acc[key].tolerance)
            own = entry_dimension(key, entry, prismatic)
            dims = [sub(own, term_dimension(term, prismatic)) for term in found.terms]
            vectors = _coefficients(found, basis, sets, key, flat, acc[key].tolerance) if found.exact else None
            ex = identify(key, entry, label, found, vectors, namer, sets, dims, names)
            explained.append(ex)
            lines += describe(ex, row.unit, sets, vectors)
        failing[key] = labels
    lines += _structure(rows, acc, samples)
    lines += _knock_on(rows, failing)
    if lines:
        lines[:0] = _heading(sets)
    return tuple(lines), tuple(explained)


def _heading(sets: Sets) -> list[str]:
    head = "explain: each mismatching entry as formula - Pinocchio, fitted over the samples"
    if sets.count == 1:
        return [f"{head}, at the check's parameters only ({sets.failure}):"]
    head += f"; a coefficient is named by what equals it at all {sets.count} parameter sets (the model's values varied)"
    lines = [head + ":"]
    if sets.followed:
        lines.append("  the constant parameters followed " + ", ".join(f"{k} = {v}" for k, v in sets.followed.items()))
    if sets.held:
        advice = f": {sets.advice}" if sets.advice else ""
        lines.append("  could not be varied: " + "; ".join(sets.held.values()) + advice)
    return lines


def _structure(rows: Sequence[CheckRow], acc: Mapping[str, Accumulator], samples: Sequence[Any]) -> list[str]:
    """The formula's own M and C: symmetric, positive definite, Christoffel."""
    by_quantity = {r.quantity: r for r in rows}
    out = []
    sym = by_quantity.get("M = M^T (formula)")
    if sym is not None and not sym.passed:
        i, j = sym.entry
        out.append(
            f"the formula's M is not symmetric: M[{i},{j}] - M[{j},{i}] = {sym.got:.3g} {sym.unit.split(' (')[0]} "
            f"at sample {sym.worst_sample}"
        )
    if "M" in acc:
        for k, (_, M) in enumerate(acc["M"].pairs):
            eig = np.linalg.eigvalsh(0.5 * (M + M.T))
            if eig[0] <= 0:
                q = ", ".join(f"{x:.4g}" for x in samples[k].q)
                out.append(
                    f"the formula's M is not positive definite at sample {k}: q = [{q}], smallest eigenvalue "
                    f"{eig[0]:.3g} {acc['M'].unit}"
                )
                break
    skew = by_quantity.get("N = dM/dt - 2C skew (formula)")
    nle = by_quantity.get("nle = C v + G")
    mass = by_quantity.get("M")
    if skew is not None and not skew.passed and nle is not None and nle.passed and mass is not None and mass.passed:
        out.append(
            "the formula's C v is right but dM/dt - 2C is not skew: a valid C v written in a non-Christoffel form "
            "(C[i,j] = sum_k 1/2 (dM[i,j]/dq_k + dM[i,k]/dq_j - dM[j,k]/dq_i) v_k is the one that is)"
        )
    return out


KNOCK_ON = {
    "nle = C v + G": ("C", "G"),
    "tau (inverse dynamics)": ("M", "C", "G"),
    "a (forward dynamics)": ("M", "C", "G"),
    "T = 1/2 v^T M v": ("M",),
    "N = dM/dt - 2C skew (formula)": ("M", "C"),
    "G = dV/dq (formula)": ("G", "V"),
}


def _knock_on(rows: Sequence[CheckRow], failing: Mapping[str, list[str]]) -> list[str]:
    """``tau[1] follows from M[0,1], C[1,0]``: which mismatching entries each derived row's entries come from."""
    out = []
    for row in rows:
        sources = KNOCK_ON.get(row.quantity)
        if sources is None or row.passed:
            continue
        for entry in _entries(row):
            label = row.entry_label(entry)
            feeding = []
            for key in sources:
                for source in failing.get(key, []):
                    if key in ("C", "G") and row.quantity in ("nle = C v + G", "tau (inverse dynamics)") and entry:
                        if not source.startswith(f"{key}[{entry[0]}"):
                            continue
                    if row.quantity == "G = dV/dq (formula)" and key == "G" and source != f"G[{entry[0]}]":
                        continue
                    if key == "M" and row.quantity == "tau (inverse dynamics)" and entry:
                        if not source.startswith(f"M[{entry[0]},") and not source.endswith(f",{entry[0]}]"):
                            continue
                    feeding.append(source)
            if feeding:
                out.append(f"{label} ({row.quantity}) follows from {', '.join(dict.fromkeys(feeding))}")
            elif row.quantity == "G = dV/dq (formula)":
                out.append(f"{label} ({row.quantity}): the formula's G and V disagree with each other")
    return out
