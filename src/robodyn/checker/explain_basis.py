"""``--explain``'s basis and fit: the terms rigid-body dynamics is made of, and the sparsest exact sum of them.

* of q: 1; cos and sin of each revolute coordinate, of the sums and differences of two, of the sums
  of consecutive runs (cos(q2), sin(q1 + q2), cos(q1 - q3), cos(q1 + q2 + q3)) and, on three revolutes,
  of every signed sum of the three (cos(q1 - q2 + q3)); products of two of these (cos(q2)**2,
  sin(q2)*cos(q2 + q3)); a prismatic coordinate's monomials (q2, q2**2) and their products with the
  trigonometric terms (q2*cos(q3));
* for C, each of those times one velocity (sin(q2)*v1).

The sparsest exact fit is taken (:func:`fit`): every single term first, then every pair among the
best-correlated terms, then orthogonal matching pursuit up to :data:`MAX_TERMS` terms. A fit is exact
when what it leaves is round-off (:data:`FIT_RTOL` of the difference, or :data:`ROUNDOFF` of the
entry's scale). Terms are named q1, q2, ..., v1, v2, ... here; :mod:`robodyn.checker.explain` shows them
in the formula's own names.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

MAX_TERMS = 6  # the most terms a correction may have: more is not "a wrong term" but a wrong derivation
FIT_RTOL = 1e-9  # an exact fit leaves at most this fraction of the difference (its round-off is ~1e-13)
ROUNDOFF = 1e-12  # ... or this fraction of the entry's own scale (a difference near the tolerance)
BELOW_CHECK = 0.1  # ... or this fraction of the check's own tolerance (times the entry's scale): not a mismatch
PAIR_CANDIDATES = 40  # pairs of terms are searched among this many best-correlated ones
SIGNED_TRIPLES = 3  # on at most this many revolutes, every signed sum of three angles is a term (q1 - q2 + q3)


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
    if len(revolute) <= SIGNED_TRIPLES:
        for i, j, k in itertools.combinations(revolute, 3):
            for sj, sk in ((1, -1), (-1, 1), (-1, -1)):
                name = f"q{i + 1} {'+' if sj > 0 else '-'} q{j + 1} {'+' if sk > 0 else '-'} q{k + 1}"
                out.append((name, vec({i: 1, j: sj, k: sk})))
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


def fit_target(d: Array, scale: float, tolerance: float = 0.0) -> float:
    """The largest |d - fit| an exact fit may leave: round-off of ``d`` or of the entry (see :func:`fit`)."""
    return max(FIT_RTOL * float(np.max(np.abs(d))), ROUNDOFF * scale, BELOW_CHECK * tolerance * scale)


def fit(d: Array, basis: Basis, scale: float, tolerance: float = 0.0) -> Fit:
    """The sparsest exact fit of ``d`` (k,) in ``basis``; ``scale``: the entry's own magnitude (for round-off).

    ``tolerance``: the check's own relative tolerance; a fit may leave :data:`BELOW_CHECK` of it (times
    ``scale``), a part of the difference the check would not count as a mismatch on its own (a URDF's
    rounded rpy that tilts an arm out of its plane by 1e-10 leaves such a term, which is no slip of the
    formula's).
    """
    target = fit_target(d, scale, tolerance)
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
        coef, left = least_squares(Phi[:, [a, b]], d)
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
        coef, left = least_squares(Phi[:, support], d)
        residual = d - Phi[:, support] @ coef
        if left <= target:
            break
    return Fit(tuple(basis.names[j] for j in support), tuple(float(c) for c in coef), left, left <= target)


def least_squares(A: Array, d: Array) -> tuple[Array, float]:
    """Least-squares coefficients of ``d`` in the columns of ``A``, and the largest |residual|."""
    coef = np.asarray(np.linalg.lstsq(A, d, rcond=None)[0], dtype=np.float64)
    return coef, float(np.max(np.abs(d - A @ coef)))
