"""``robodyn check --explain``: name the wrong term of each mismatching entry, in the formula's own symbols.

For every entry of M, C, G (and V) that is out of tolerance, the difference formula - Pinocchio over
the sampled states is fitted against a basis of the terms rigid-body dynamics is made of:

* of q: 1; cos and sin of each revolute coordinate, of the sums and differences of two and of the
  sums of consecutive runs (cos(q2), sin(q1 + q2), cos(q1 - q3), cos(q1 + q2 + q3)); products of two
  of these (cos(q2)**2, sin(q2)*cos(q2 + q3)); a prismatic coordinate's monomials (q2, q2**2) and their
  products with the trigonometric terms (q2*cos(q3));
* for C, each of those times one velocity (sin(q2)*v1).

The sparsest exact fit is taken: every single term first, then every pair among the best-correlated
terms, then orthogonal matching pursuit up to :data:`MAX_TERMS` terms. A fit is exact when what it
leaves is round-off (:data:`FIT_RTOL` of the difference, or :data:`ROUNDOFF` of the entry's scale).
Each coefficient is then named, when one does, by a product of the file's parameters with a small
rational factor (and g where gravity is), or a sum or difference of two such
products (``lc1`` written for ``l1`` leaves m2*lc1*lc2 - m2*l1*lc2): :mod:`robodyn.kinds.explain_names`.

The formula's own structure is read too: an M that is not symmetric, or not positive definite at a
sample; a C whose C v is right while dM/dt - 2C is not skew (a valid C v, not in Christoffel form).
Knock-on rows (C v + G, tau, the acceleration, T) say which mismatching entries they follow from.
Nothing here imports Pinocchio: it works on what the check gathered.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.kinds.check_rows import Accumulator, CheckRow
from robodyn.kinds.explain_names import (
    NAME_RTOL,
    Dim,
    Name,
    Namer,
    entry_dimension,
    sub,
    term_dimension,
)

Array = NDArray[np.float64]

MAX_TERMS = 6  # the most terms a correction may have: more is not "a wrong term" but a wrong derivation
FIT_RTOL = 1e-9  # an exact fit leaves at most this fraction of the difference (its round-off is ~1e-13)
ROUNDOFF = 1e-12  # ... or this fraction of the entry's own scale (a difference near the tolerance)
PAIR_CANDIDATES = 40  # pairs of terms are searched among this many best-correlated ones
QUANTITIES = {"M": "M", "C": "C", "G": "G", "V": "V - V(q0)"}


@dataclass(frozen=True)
class Basis:
    """Candidate terms evaluated at the samples: ``values`` (k, D), ``names`` (D,), simplest first."""

    values: Array
    names: tuple[str, ...]


def _angle_combinations(revolute: Sequence[int]) -> list[tuple[str, Array]]:
    """(name, coefficient vector over q) of q_i, q_i +- q_j and runs q_i + ... + q_j of consecutive revolutes."""
    n = max(revolute) + 1 if revolute else 0
    out: list[tuple[str, Array]] = []

    def vec(signs: Mapping[int, int]) -> Array:
        w = np.zeros(n)
        for i, s in signs.items():
            w[i] = s
        return w

    for i in revolute:
        out.append((f"q{i + 1}", vec({i: 1})))
    for i, j in itertools.combinations(revolute, 2):
        out.append((f"q{i + 1} + q{j + 1}", vec({i: 1, j: 1})))
        out.append((f"q{i + 1} - q{j + 1}", vec({i: 1, j: -1})))
    for length in range(3, len(revolute) + 1):
        for start in range(len(revolute) - length + 1):
            run = revolute[start : start + length]
            out.append((" + ".join(f"q{i + 1}" for i in run), vec(dict.fromkeys(run, 1))))
    return out


def q_basis(q: Array, prismatic: Sequence[bool]) -> Basis:
    """The terms of q (k samples, n coordinates): trigonometric of the revolutes, monomials of the prismatics."""
    k, n = q.shape
    revolute = [i for i in range(n) if not prismatic[i]]
    slides = [i for i in range(n) if prismatic[i]]
    trig: list[tuple[str, Array]] = []
    for name, w in _angle_combinations(revolute):
        angle = q[:, : len(w)] @ w if len(w) else np.zeros(k)
        trig.append((f"cos({name})", np.cos(angle)))
        trig.append((f"sin({name})", np.sin(angle)))
    poly: list[tuple[str, Array, int]] = [(f"q{i + 1}", q[:, i], 1) for i in slides]
    poly += [
        (f"q{i + 1}**2" if i == j else f"q{i + 1}*q{j + 1}", q[:, i] * q[:, j], 2)
        for i, j in itertools.combinations_with_replacement(slides, 2)
    ]
    names: list[str] = ["1"]
    values: list[Array] = [np.ones(k)]
    # degree by degree, so that the simplest term comes first
    for name, x, _ in poly:
        names.append(name)
        values.append(x)
    for name, x in trig:
        names.append(name)
        values.append(x)
    for name, x, _ in poly:
        for tname, t in trig:
            names.append(f"{name}*{tname}")
            values.append(x * t)
    for (a, x), (b, y) in itertools.combinations_with_replacement(trig, 2):
        names.append(f"{a}**2" if a == b else f"{a}*{b}")
        values.append(x * y)
    for name, x, degree in poly:
        if degree == 1:
            for (a, t), (b, u) in itertools.combinations_with_replacement(trig, 2):
                names.append(f"{name}*{a}**2" if a == b else f"{name}*{a}*{b}")
                values.append(x * t * u)
    return _distinct(Basis(np.column_stack(values), tuple(names)))


def _distinct(basis: Basis) -> Basis:
    """Drop terms that are (to round-off) a multiple of an earlier one (sin(q1)**2 against ..., zero columns)."""
    norms = np.linalg.norm(basis.values, axis=0)
    keep: list[int] = []
    unit = basis.values / np.where(norms > 0, norms, 1.0)
    parallel = np.abs(unit.T @ unit) > 1 - 1e-12  # (D, D): term j is a multiple of term i
    for j in range(unit.shape[1]):
        if norms[j] <= 1e-12 * math.sqrt(len(unit)):
            continue
        if keep and parallel[j, keep].any():
            continue
        keep.append(j)
    return Basis(basis.values[:, keep], tuple(basis.names[j] for j in keep))


def velocity_basis(base: Basis, v: Array) -> Basis:
    """Each term of ``base`` times one velocity v1 ... vn (C is linear in v)."""
    names, values = [], []
    for i in range(v.shape[1]):
        for name, column in zip(base.names, base.values.T, strict=True):
            names.append(f"v{i + 1}" if name == "1" else f"{name}*v{i + 1}")
            values.append(column * v[:, i])
    return Basis(np.column_stack(values), tuple(names))


@dataclass(frozen=True)
class Fit:
    """A sparse fit d = sum c_j phi_j: the chosen terms, their coefficients, and what is left (max abs)."""

    terms: tuple[str, ...]
    coefficients: tuple[float, ...]
    residual: float
    exact: bool


def fit(d: Array, basis: Basis, scale: float) -> Fit:
    """The sparsest exact fit of ``d`` (k,) in ``basis``; ``scale``: the entry's own magnitude (for round-off)."""
    target = max(FIT_RTOL * float(np.max(np.abs(d))), ROUNDOFF * scale)
    Phi = basis.values
    norms = np.linalg.norm(Phi, axis=0)
    unit = Phi / norms
    corr = np.abs(unit.T @ d)
    # every single term
    c1 = (unit.T @ d) / norms
    left1 = np.max(np.abs(d[:, None] - Phi * c1[None, :]), axis=0)
    exact = np.nonzero(left1 <= target)[0]
    if exact.size:
        j = int(exact[0])
        return Fit((basis.names[j],), (float(c1[j]),), float(left1[j]), True)
    # every pair among the best-correlated
    best = np.argsort(-corr, kind="stable")[:PAIR_CANDIDATES]
    found: tuple[tuple[int, ...], Array, float] | None = None
    for a, b in itertools.combinations(sorted(best.tolist()), 2):
        coef, left = _least_squares(Phi[:, [a, b]], d)
        if left <= target and (found is None or (a, b) < found[0]):
            found = ((a, b), coef, left)
    if found is not None:
        idx, coef, left = found
        return Fit(tuple(basis.names[j] for j in idx), tuple(float(c) for c in coef), left, True)
    # orthogonal matching pursuit
    support: list[int] = []
    coef, left = np.zeros(0), float(np.max(np.abs(d)))
    residual = d.copy()
    for _ in range(MAX_TERMS):
        j = int(np.argmax(np.abs(unit.T @ residual)))
        if j in support:
            break
        support.append(j)
        coef, left = _least_squares(Phi[:, support], d)
        residual = d - Phi[:, support] @ coef
        if left <= target:
            break
    return Fit(tuple(basis.names[j] for j in support), tuple(float(c) for c in coef), left, left <= target)


def _least_squares(A: Array, d: Array) -> tuple[Array, float]:
    coef = np.asarray(np.linalg.lstsq(A, d, rcond=None)[0], dtype=np.float64)
    return coef, float(np.max(np.abs(d - A @ coef)))


# ---------------------------------------------------------------------------------------- the explanation
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


def _power_of_ten(x: float) -> str:
    return f"1e{math.ceil(math.log10(max(x, 1e-16))):d}"


def describe_fit(label: str, f: Fit, namer: Namer, unit: str, dims: Sequence[Dim | None] | None = None) -> list[str]:
    """``M[0,1]: formula - Pinocchio = -m2*l1*lc2*cos(q2)   (coefficient -0.00945, = -m2*l1*lc2 to 1e-15)``."""
    if not f.exact:
        return [
            f"{label}: formula - Pinocchio is no sum of at most {MAX_TERMS} terms of the basis (the best such leaves "
            f"{f.residual:.3g} {unit}): more than a term is wrong, or a term is outside the basis"
        ]
    named = [namer.name(c, None if dims is None else dims[j]) for j, c in enumerate(f.coefficients)]
    # largest first; of two equal ones, the formula's own (positive: formula - Pinocchio) first
    order = sorted(range(len(f.terms)), key=lambda j: (-float(f"{abs(f.coefficients[j]):.9g}"), f.coefficients[j] < 0))
    expression = ""
    details = []
    for position, j in enumerate(order):
        sign, body = _term(f.coefficients[j], named[j], f.terms[j])
        if position == 0:
            expression = body if sign == "+" else f"-{body}"
        else:
            expression += f" {sign} {body}"
        name = named[j]
        said = f"{f.coefficients[j]:.3g}"
        if name is not None:
            said += f", = {name.text} to {_power_of_ten(name.error)}"
        details.append(said)
    word = "coefficient" if len(details) == 1 else "coefficients"
    lines = [f"{label}: formula - Pinocchio = {expression}   ({word} {'; '.join(details)})"]
    swap = _swapped(f, named, order)
    if swap:
        lines.append(f"    {swap}")
    return lines


def _swapped(f: Fit, named: Sequence[Name | None], order: Sequence[int]) -> str:
    """``the formula has ... where Pinocchio has ...`` for two terms of equal and opposite coefficients."""
    if len(f.terms) != 2:
        return ""
    a, b = order
    ca, cb = f.coefficients[a], f.coefficients[b]
    if abs(ca + cb) > NAME_RTOL * max(abs(ca), abs(cb)) * 1e3:
        return ""
    extra, missing = (a, b) if ca > 0 else (b, a)  # formula - Pinocchio: + what the formula has, - what it lacks
    has = _term(f.coefficients[extra], named[extra], f.terms[extra])[1]
    lacks = _term(f.coefficients[extra], named[extra], f.terms[missing])[1]
    what = "a term written wrong"
    if _sin_cos(f.terms[extra], f.terms[missing]):
        what = "a sine and a cosine swapped"
    elif re.sub(r"\d", "#", f.terms[extra]) == re.sub(r"\d", "#", f.terms[missing]):
        what = "an index written wrong"
    return f"the formula has {has} where Pinocchio has {lacks}: {what}"


def _sin_cos(a: str, b: str) -> bool:
    return a.replace("sin", "#").replace("cos", "sin").replace("#", "cos") == b


def _entries(row: CheckRow) -> list[tuple[int, ...]]:
    return [m.entry for m in row.mismatches] or ([row.entry] if not row.passed else [])


def explain(
    rows: Sequence[CheckRow],
    acc: Mapping[str, Accumulator],
    samples: Sequence[Any],
    params: Mapping[str, float],
    *,
    prismatic: Sequence[bool],
    g: float,
) -> tuple[str, ...]:
    """The explanation lines of a check: each mismatching entry's wrong term, the formula's structure, knock-ons.

    ``acc``: the formula rows' accumulators (key -> (Pinocchio, formula) per sample), ``samples``: the
    states (``.q``, ``.v`` in the formula's coordinates), ``prismatic[i]``: coordinate i is a length.
    """
    by_quantity = {r.quantity: r for r in rows}
    q = np.array([s.q for s in samples])
    v = np.array([s.v for s in samples])
    base = q_basis(q, prismatic)
    namer = Namer(params, g)
    lines: list[str] = []
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
            found = fit(d, basis, scale)
            own = entry_dimension(key, entry, prismatic)
            dims = [sub(own, term_dimension(term, prismatic)) for term in found.terms]
            lines += describe_fit(label, found, namer, row.unit, dims)
        failing[key] = labels
    lines += _structure(rows, acc, samples)
    lines += _knock_on(rows, failing)
    if lines:
        lines.insert(0, "explain: each mismatching entry as formula - Pinocchio, fitted over the samples:")
    return tuple(lines)


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
