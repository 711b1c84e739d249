"""--explain's names: a coefficient as a product of a formula's parameters, and the dimensions that pick one.

A fitted coefficient (:mod:`robodyn.checker.explain`) is a vector over the parameter sets (the check's
own and the varied ones). It is named by a product of the file's parameters (up to :data:`MAX_FACTORS`
of them, times g) with a small rational factor (:data:`RATIONALS`), or a sum or difference of two such
products with their common factors taken out (``m2*(lc1 - l1)``), that equals it to :data:`NAME_RTOL`
at every set: :meth:`Namer.candidates` lists each that does, and :meth:`Namer.alike` says why several
cannot be told apart (a parameter that did not vary, two in a fixed ratio).
Where every factor's dimension is known (guessed from its name, :func:`parameter_dimension`) a product
must have the dimension the coefficient has in its entry (:func:`entry_dimension`, :func:`term_dimension`).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

NAME_RTOL = 1e-9  # a coefficient is named by a product of parameters that equals it to this (fits give ~1e-13)
MAX_FACTORS = 3  # parameters in a product (g comes on top)
PAIR_RATIONALS = 3  # a sum or difference of two products is tried with the first three rationals: 1, 2, 1/2
RATIONALS = tuple(
    Fraction(x) for x in ("1", "2", "1/2", "3", "1/3", "4", "1/4", "3/2", "2/3", "3/4", "4/3", "1/12", "1/6", "1/8")
)


@dataclass(frozen=True)
class Name:
    """A coefficient's name (``-m2*l1*lc2``), how closely it equals it (relative, the worst set), and its rank."""

    text: str
    error: float
    known: bool = True  # every factor's dimension is known (and is the coefficient's)
    rank: tuple[int, ...] = ()  # simpler first: a rational of 1, fewer factors


Dim = tuple[int, int, int]  # exponents of kg, m, s
GRAVITY: Dim = (0, 1, -2)


def parameter_dimension(name: str) -> Dim | None:
    """A parameter's dimension guessed from its name: m/M a mass, I/J an inertia, l/L/d/r/a/h/b/w a length, g."""
    if name == "g":
        return GRAVITY
    head = name[:1]
    if head in "mM":
        return (1, 0, 0)
    if head in "IJ":
        return (1, 2, 0)
    if head in "lLdrahbw":
        return (0, 1, 0)
    return None


class Namer:
    """Names coefficients by products of parameters (up to :data:`MAX_FACTORS`, times g) with a small rational factor.

    ``params`` is one parameter set or several (the check's own first, then the varied ones, see
    :mod:`robodyn.checker.explain_sets`); a coefficient is then a vector over the sets, and a name must equal
    it at every set. Where every factor's dimension is known (:func:`parameter_dimension`) a product must
    have the coefficient's dimension; one of unknown dimension is kept only when none of known dimension fits.
    """

    def __init__(self, params: Mapping[str, float] | Sequence[Mapping[str, float]], g: float | Sequence[float]) -> None:
        sets = [params] if isinstance(params, Mapping) else list(params)
        gs = [float(g)] * len(sets) if isinstance(g, (int, float)) else [float(x) for x in g]
        first = sets[0]
        names = [
            k
            for k, x in first.items()
            if k != "g" and all(math.isfinite(s.get(k, math.nan)) and s.get(k, 0.0) != 0 for s in sets)
        ]
        names.sort(key=_factor_rank)  # masses, lengths, inertias, others: m2*l1*lc2, in the file's order within each
        self.sets = len(sets)
        self.parameters = {k: np.array([s[k] for s in sets], dtype=np.float64) for k in names}
        gravity = np.array([s.get("g", gk) for s, gk in zip(sets, gs, strict=True)], dtype=np.float64)
        if "g" in first and np.all(np.isfinite(gravity)):
            self.parameters["g"] = gravity
        # what did not change over the sets (everything, with one set): a match resting on it may be a coincidence
        self.constant = {k for k, x in self.parameters.items() if np.ptp(x) <= 1e-12 * np.max(np.abs(x))}
        products: list[tuple[tuple[str, ...], int, Dim | None]] = []  # (factors, size, dimension)
        vectors = []
        for size in range(1, MAX_FACTORS + 1):
            for combo in itertools.combinations_with_replacement(names, size):
                products.append((combo, size, _dimension(combo)))
                vectors.append(np.prod([self.parameters[k] for k in combo], axis=0))
        if np.all(gravity != 0) and np.all(np.isfinite(gravity)):
            for (combo, size, dim), vec in list(zip(products, vectors, strict=True)):
                products.append(((*combo, "g"), size + 1, None if dim is None else _add(dim, GRAVITY)))
                vectors.append(vec * gravity)
            products.append((("g",), 1, GRAVITY))
            vectors.append(gravity)
        self.products = products
        self.values = np.array(vectors, dtype=np.float64).reshape(len(products), self.sets)
        first_values = np.abs(self.values[:, 0])
        order = np.argsort(first_values, kind="stable")
        self.sorted_values = first_values[order]
        self.sorted_index = order

    def _matches(self, target: float, tol: float) -> list[int]:
        lo = np.searchsorted(self.sorted_values, abs(target) - tol, side="left")
        hi = np.searchsorted(self.sorted_values, abs(target) + tol, side="right")
        return [int(i) for i in self.sorted_index[lo:hi]]

    def name(self, c: float | Sequence[float] | np.ndarray, dim: Dim | None = None) -> Name | None:
        """The one name that equals ``c`` at every set (None if none, or several)."""
        found = self.candidates(c, dim)
        return found[0] if len(found) == 1 else None

    def candidates(self, c: float | Sequence[float] | np.ndarray, dim: Dim | None = None) -> list[Name]:
        """Every r * product, else every r (+-P1 +- P2), equal to ``c`` (a value per set) at every set, simplest first.

        Of dimension ``dim`` where known: those of unknown dimension only when none of known dimension fits.
        """
        vec = np.atleast_1d(np.asarray(c, dtype=np.float64))
        if vec.shape != (self.sets,) or not np.all(np.isfinite(vec)) or np.any(vec == 0):
            return []
        found = self._singles(vec, dim)
        # a lone product is the simplest name; where it is not alone, or rests on a value that did not vary, the
        # sums and differences of two are candidates too
        if len({n.text for n in found}) != 1 or factors_of(found[0].text) & self.constant:
            found += self._pairs(vec, dim)
        known = [name for name in found if name.known]
        found = known or found
        unique: dict[str, Name] = {}
        for name in sorted(found, key=lambda n: n.rank):
            unique.setdefault(name.text, name)
        return list(unique.values())

    def _fits(self, vec: np.ndarray, target: np.ndarray) -> float | None:
        """Largest relative error of ``vec`` against ``target`` over the sets, when within NAME_RTOL at each."""
        err = np.abs(vec - target) / np.abs(target)
        worst = float(np.max(err))
        return worst if worst <= NAME_RTOL else None

    def _allowed(self, own: Dim | None, dim: Dim | None) -> bool:
        return dim is None or own is None or own == dim

    def _singles(self, vec: np.ndarray, dim: Dim | None) -> list[Name]:
        out = []
        for r_index, r in enumerate(RATIONALS):
            for i in self._matches(vec[0] / float(r), NAME_RTOL * abs(vec[0] / float(r))):
                combo, size, own = self.products[i]
                if not self._allowed(own, dim):
                    continue
                sign = 1.0 if (vec[0] > 0) == (self.values[i, 0] > 0) else -1.0
                err = self._fits(sign * float(r) * self.values[i], vec)
                if err is None:
                    continue
                text = ("-" if sign < 0 else "") + _scaled(_product_text(combo), r)
                known = dim is not None and own is not None
                out.append(Name(text, err, known, (int(r_index > 0), size, r_index, i)))
        return out

    def _pairs(self, vec: np.ndarray, dim: Dim | None) -> list[Name]:
        """``c`` = r (+-P1 +- P2) for two products of dimension ``dim`` (r 1, 2 or 1/2)."""
        out = []
        allowed = np.array([self._allowed(d, dim) for _, _, d in self.products], dtype=bool)
        for r_index, r in enumerate(RATIONALS[:PAIR_RATIONALS]):
            target = vec / float(r)
            tol = NAME_RTOL * abs(target[0])
            for s1 in (1.0, -1.0):
                # what the second product must be at the first set, for every first product at once
                rest0 = np.abs(target[0] - s1 * self.values[:, 0])
                lo = np.searchsorted(self.sorted_values, rest0 - tol, side="left")
                hi = np.searchsorted(self.sorted_values, rest0 + tol, side="right")
                for i in np.nonzero((hi > lo) & allowed & (rest0 >= tol))[0].tolist():
                    combo1, size1, dim1 = self.products[i]
                    rest = target - s1 * self.values[i]
                    for j in self.sorted_index[lo[i] : hi[i]].tolist():
                        combo2, size2, dim2 = self.products[j]
                        if j == i or not self._allowed(dim2, dim):
                            continue
                        s2 = 1.0 if (rest[0] > 0) == (self.values[j, 0] > 0) else -1.0
                        total = float(r) * (s1 * self.values[i] + s2 * self.values[j])
                        err = self._fits(total, vec)
                        if err is None:
                            continue
                        pair = ((s1, combo1), (s2, combo2)) if (s1, -i) >= (s2, -j) else ((s2, combo2), (s1, combo1))
                        text = _factored(pair, r)
                        known = dim is not None and dim1 is not None and dim2 is not None
                        out.append(Name(text, err, known, (1, size1 + size2, r_index, min(i, j), max(i, j))))
        return out

    def alike(self, names: Sequence[str]) -> list[str]:
        """Why ``names`` (parameters) cannot be told apart over the sets: held constant, or in a fixed ratio."""
        involved = [k for k in self.parameters if k in names]
        out: list[str] = []
        if self.sets == 1:
            return out
        for k in involved:
            x = self.parameters[k]
            if np.ptp(x) <= 1e-12 * np.max(np.abs(x)):
                out.append(f"{k} = {x[0]:.6g} did not change with the model")
        for a, b in itertools.combinations(involved, 2):
            ratio = self.parameters[a] / self.parameters[b]
            if np.ptp(ratio) <= 1e-12 * np.max(np.abs(ratio)) and not (
                np.ptp(self.parameters[a]) <= 1e-12 * np.max(np.abs(self.parameters[a]))
            ):
                out.append(f"{a} / {b} = {ratio[0]:.6g} at every parameter set")
        return out


def factors_of(text: str) -> set[str]:
    """The parameter names a name uses (``m2*(lc1 - l1)`` -> {m2, lc1, l1})."""
    return set(re.findall(r"[A-Za-z_][A-Za-z_0-9]*", text))


def _factored(terms: Sequence[tuple[float, tuple[str, ...]]], r: Fraction) -> str:
    """R (s1 P1 + s2 P2) with the factors both products share taken out (g last): ``m2*(lc1 - l1)``."""
    (s1, a), (s2, b) = terms
    common: list[str] = []
    rest_a, rest_b = list(a), list(b)
    for factor in a:
        if factor in rest_a and factor in rest_b:
            common.append(factor)
            rest_a.remove(factor)
            rest_b.remove(factor)
    if not rest_a or not rest_b:  # one product divides the other: nothing to take out that reads better
        common, rest_a, rest_b = [], list(a), list(b)
    if s1 < 0 < s2:
        (s1, rest_a), (s2, rest_b) = (s2, rest_b), (s1, rest_a)
    negative = s1 < 0  # both negative (the positive one comes first): -(a + b)
    inner = f"{_product_text(rest_a)} {'-' if s1 * s2 < 0 else '+'} {_product_text(rest_b)}"
    outside = [f for f in common if f != "g"]
    gravity = ["g"] * common.count("g")
    body = "*".join([*([_product_text(outside)] if outside else []), f"({inner})", *gravity])
    if not common:
        body = f"({inner})" if negative or r != 1 else inner
    text = _scaled(body, r) if r != 1 else body
    return f"-{text}" if negative else text


def _factor_rank(name: str) -> int:
    dim = parameter_dimension(name)
    return {(1, 0, 0): 0, (0, 1, 0): 1, (1, 2, 0): 2}.get(dim, 3) if dim is not None else 3


def _add(a: Dim, b: Dim) -> Dim:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a: Dim, b: Dim) -> Dim:
    """The dimension ``a / b``."""
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _dimension(combo: Sequence[str]) -> Dim | None:
    out: Dim = (0, 0, 0)
    for name in combo:
        dim = parameter_dimension(name)
        if dim is None:
            return None
        out = _add(out, dim)
    return out


def _product_text(combo: Sequence[str]) -> str:
    parts = []
    for name, group in itertools.groupby(combo):
        power = len(list(group))
        parts.append(name if power == 1 else f"{name}**{power}")
    return "*".join(parts)


def _scaled(text: str, r: Fraction) -> str:
    if r == 1:
        return text
    if r.denominator == 1:
        return f"{r.numerator}*{text}"
    if r.numerator == 1:
        return f"{text}/{r.denominator}"
    return f"{r.numerator}*{text}/{r.denominator}"


def entry_dimension(key: str, entry: tuple[int, ...], prismatic: Sequence[bool]) -> Dim:
    """The dimension of an entry of M, C, G or V (a prismatic coordinate's rows and columns lose a metre)."""
    rev = [0 if p else 1 for p in prismatic]
    if key == "M":
        return (1, rev[entry[0]] + rev[entry[1]], 0)
    if key == "C":
        return (1, rev[entry[0]] + rev[entry[1]], -1)
    if key == "G":
        return (1, 1 + rev[entry[0]], -2)
    return (1, 2, -2)


def term_dimension(term: str, prismatic: Sequence[bool]) -> Dim:
    """The dimension of a basis term: a prismatic q is a metre, a velocity 1/s (a prismatic one m/s)."""
    bare = re.sub(r"\([^)]*\)", "", term)  # the arguments of cos and sin are dimensionless
    metres, seconds = 0, 0
    for letter, index, power in re.findall(r"([qv])(\d+)(?:\*\*(\d+))?", bare):
        k = int(power or 1)
        if prismatic[int(index) - 1]:
            metres += k
        if letter == "v":
            seconds -= k
    return (0, metres, seconds)
