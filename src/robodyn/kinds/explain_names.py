"""--explain's names: a coefficient as a product of a formula's parameters, and the dimensions that pick one.

A fitted coefficient (:mod:`robodyn.kinds.explain`) is named, when one does, by a product of the
file's parameters (up to :data:`MAX_FACTORS` of them, times g) with a small rational factor
(:data:`RATIONALS`), or a sum or difference of two such products, equal to it to :data:`NAME_RTOL`.
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
    """A coefficient's name (``-m2*l1*lc2``) and how closely it equals it (relative)."""

    text: str
    error: float


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
    """Names numbers by products of parameters (up to :data:`MAX_FACTORS`, times g) with a small rational factor.

    Where every factor's dimension is known (:func:`parameter_dimension`) a product must have the
    coefficient's dimension; products of known dimension are preferred, then a rational factor of 1,
    then fewer factors.
    """

    def __init__(self, params: Mapping[str, float], g: float) -> None:
        names = [k for k, x in params.items() if math.isfinite(x) and x != 0 and k != "g"]
        names.sort(key=_factor_rank)  # masses, lengths, inertias, others: m2*l1*lc2, in the file's order within each
        gravity = params.get("g", g)
        products: list[tuple[str, float, int, Dim | None]] = []  # (text, value, factors, dimension)
        for size in range(1, MAX_FACTORS + 1):
            for combo in itertools.combinations_with_replacement(names, size):
                value = math.prod(params[k] for k in combo)
                products.append((_product_text(combo), value, size, _dimension(combo)))
        if gravity:
            products += [
                (f"{text}*g", value * gravity, size + 1, None if dim is None else _add(dim, GRAVITY))
                for text, value, size, dim in products
            ]
            products.append(("g", gravity, 1, GRAVITY))
        self.products = products
        values = np.array([abs(p[1]) for p in products])
        order = np.argsort(values, kind="stable")
        self.sorted_values = values[order]
        self.sorted_index = order

    def _matches(self, target: float, tol: float) -> list[int]:
        lo = np.searchsorted(self.sorted_values, abs(target) - tol, side="left")
        hi = np.searchsorted(self.sorted_values, abs(target) + tol, side="right")
        return [int(i) for i in self.sorted_index[lo:hi]]

    def name(self, c: float, dim: Dim | None = None) -> Name | None:
        """The simplest r * product equal to ``c`` (of dimension ``dim``) to NAME_RTOL, or +-P1 +- P2; else None."""
        if c == 0:
            return None
        best: tuple[tuple[int, int, int, int, int], str, float] | None = None
        for r_index, r in enumerate(RATIONALS):
            for i in self._matches(c / float(r), NAME_RTOL * abs(c / float(r))):
                text, value, size, own = self.products[i]
                if dim is not None and own is not None and own != dim:
                    continue
                key = (int(dim is None or own is None), int(r_index > 0), size, r_index, i)
                if best is None or key < best[0]:
                    err = abs(float(r) * abs(value) - abs(c)) / abs(c)
                    sign = "-" if (c < 0) != (value < 0) else ""
                    best = (key, f"{sign}{_scaled(text, r)}", err)
        if best is not None:
            return Name(best[1], best[2])
        return self._pair(c, dim)

    def _pair(self, c: float, dim: Dim | None) -> Name | None:
        """``c`` = r (+-P1 +- P2) for two products of dimension ``dim`` (r 1, 2 or 1/2), the simplest; else None."""
        for r in RATIONALS[:PAIR_RATIONALS]:
            found = self._plain_pair(c / float(r), dim)
            if found is not None:
                text = found.text if r == 1 else f"{_scaled('(' + found.text + ')', r)}"
                return Name(text, found.error)
        return None

    def _plain_pair(self, c: float, dim: Dim | None) -> Name | None:
        """``c`` = +-P1 +- P2 for two products of dimension ``dim``, the simplest pair; None if none."""
        best: tuple[tuple[int, int, int], str, float] | None = None
        for i, (text1, value1, size1, dim1) in enumerate(self.products):
            if dim is not None and dim1 is not None and dim1 != dim:
                continue
            for s1 in (1.0, -1.0):
                rest = c - s1 * value1
                if abs(rest) < NAME_RTOL * abs(c):
                    continue
                for j in self._matches(rest, NAME_RTOL * abs(c)):
                    text2, value2, size2, dim2 = self.products[j]
                    if j == i or (dim is not None and dim2 is not None and dim2 != dim):
                        continue
                    s2 = 1.0 if (rest > 0) == (value2 > 0) else -1.0
                    key = (size1 + size2, min(i, j), max(i, j))
                    if best is None or key < best[0]:
                        first, second = (s1, text1), (s2, text2)
                        if s1 < 0 < s2:
                            first, second = second, first
                        if first[0] < 0:  # both negative: -(a + b)
                            text = f"-({first[1]} + {second[1]})"
                        else:
                            text = f"{first[1]} {'-' if second[0] < 0 else '+'} {second[1]}"
                        err = abs(s1 * value1 + s2 * value2 - c) / abs(c)
                        best = (key, text, err)
        return None if best is None else Name(best[1], best[2])


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
