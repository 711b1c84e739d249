"""Trigonometric polynomials in canonical Fourier form: the algebra the symbolic derivation runs in.

A :class:`Trig` is a finite sum of terms ``c * x^e * cos(n . q)`` or ``c * x^e * sin(n . q)``: ``q``
the angles (revolute coordinates), ``x`` the polynomial variables (prismatic coordinates and the
named parameters), ``n`` a vector of whole frequencies, ``c`` a float. Products are turned into
sums at once (``cos a cos b = (cos(a - b) + cos(a + b)) / 2`` and its three siblings) and the sign
of ``n`` is fixed (its first non-zero entry positive), so every trigonometric polynomial has one
form: ``cos(q1)cos(q2) - sin(q1)sin(q2)`` *is* ``cos(q1 + q2)`` here, and ``sin^2 + cos^2`` is 1.
No simplifier is called; identities hold by construction.

Keys are three integers, so that a product is a few integer additions:

* the kind, 0 for cos and 1 for sin;
* the frequencies, each stored as ``n_k + OFFSET`` in 8 bits, the first angle in the most
  significant byte (then "first non-zero entry positive" is "code > BASE");
* the monomial, each variable's exponent in 8 bits (a product adds the codes).

Imports nothing but the standard library.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

BITS = 8
MASK = (1 << BITS) - 1
OFFSET = 1 << (BITS - 1)  # frequencies from -128 to 127; a derivation of 6 joints reaches a few

# A coefficient below this is cancellation round-off and is dropped: the numbers multiplying the
# parameter monomials are products of rotation entries (0, +-1, +-1/2 or floats of order 1).
DROP = 1e-12

Key = tuple[int, int, int]


class Trig:
    """A trigonometric polynomial over ``n_angles`` angles; see the module docstring."""

    __slots__ = ("base", "n_angles", "terms")

    def __init__(self, n_angles: int, terms: Mapping[Key, float] | None = None) -> None:
        self.n_angles = n_angles
        self.base = sum(OFFSET << (BITS * k) for k in range(n_angles))
        self.terms: dict[Key, float] = dict(terms or {})

    # ------------------------------------------------------------------ construction
    def _new(self, terms: dict[Key, float]) -> Trig:
        out = Trig.__new__(Trig)
        out.n_angles, out.base, out.terms = self.n_angles, self.base, terms
        return out

    @classmethod
    def constant(cls, n_angles: int, value: float) -> Trig:
        """The constant ``value``."""
        out = cls(n_angles)
        if value != 0:
            out.terms[(0, out.base, 0)] = float(value)
        return out

    @classmethod
    def cos(cls, n_angles: int, k: int) -> Trig:
        """cos(q_k), k from 0."""
        out = cls(n_angles)
        out.terms[(0, out.base + _unit(n_angles, k), 0)] = 1.0
        return out

    @classmethod
    def sin(cls, n_angles: int, k: int) -> Trig:
        """sin(q_k), k from 0."""
        out = cls(n_angles)
        out.terms[(1, out.base + _unit(n_angles, k), 0)] = 1.0
        return out

    @classmethod
    def variable(cls, n_angles: int, i: int) -> Trig:
        """The polynomial variable x_i, i from 0."""
        out = cls(n_angles)
        out.terms[(0, out.base, 1 << (BITS * i))] = 1.0
        return out

    # ------------------------------------------------------------------ arithmetic
    def __add__(self, other: Trig) -> Trig:
        terms = dict(self.terms)
        for key, c in other.terms.items():
            s = terms.get(key, 0.0) + c
            if abs(s) > DROP:
                terms[key] = s
            else:
                terms.pop(key, None)
        return self._new(terms)

    def __neg__(self) -> Trig:
        return self._new({key: -c for key, c in self.terms.items()})

    def __sub__(self, other: Trig) -> Trig:
        return self + (-other)

    def scale(self, factor: float) -> Trig:
        """``factor * self``."""
        if factor == 0:
            return self._new({})
        return self._new({key: c * factor for key, c in self.terms.items()})

    def __mul__(self, other: Trig) -> Trig:
        base, two_base = self.base, 2 * self.base
        out: dict[Key, float] = {}

        def put(kind: int, code: int, mono: int, c: float) -> None:
            if code < base:  # first frequency negative: cos is even, sin odd
                code = two_base - code
                if kind:
                    c = -c
            elif code == base and kind:
                return  # sin(0)
            key = (kind, code, mono)
            out[key] = out.get(key, 0.0) + c

        for (ka, fa, ma), ca in self.terms.items():
            for (kb, fb, mb), cb in other.terms.items():
                c, mono = ca * cb, ma + mb
                if fb == base:  # times a pure polynomial term (cos 0 = 1)
                    put(ka, fa, mono, c)
                    continue
                if fa == base:
                    put(kb, fb, mono, c)
                    continue
                half = 0.5 * c
                plus, minus = fa + fb - base, fa - fb + base
                if ka == 0 and kb == 0:  # cos a cos b
                    put(0, minus, mono, half)
                    put(0, plus, mono, half)
                elif ka == 1 and kb == 1:  # sin a sin b
                    put(0, minus, mono, half)
                    put(0, plus, mono, -half)
                elif ka == 1:  # sin a cos b
                    put(1, plus, mono, half)
                    put(1, minus, mono, half)
                else:  # cos a sin b
                    put(1, plus, mono, half)
                    put(1, minus, mono, -half)
        return self._new({key: c for key, c in out.items() if abs(c) > DROP})

    # ------------------------------------------------------------------ calculus
    def d_angle(self, k: int) -> Trig:
        """The partial derivative with respect to the angle q_k."""
        shift = BITS * (self.n_angles - 1 - k)
        out: dict[Key, float] = {}
        for (kind, code, mono), c in self.terms.items():
            n = ((code >> shift) & MASK) - OFFSET
            if n:
                out[(1 - kind, code, mono)] = -n * c if kind == 0 else n * c
        return self._new(out)

    def d_variable(self, i: int) -> Trig:
        """The partial derivative with respect to the polynomial variable x_i."""
        shift = BITS * i
        out: dict[Key, float] = {}
        for (kind, code, mono), c in self.terms.items():
            e = (mono >> shift) & MASK
            if e:
                out[(kind, code, mono - (1 << shift))] = e * c
        return self._new(out)

    # ------------------------------------------------------------------ reading
    def is_zero(self) -> bool:
        """Whether no term is left."""
        return not self.terms

    def frequencies(self, code: int) -> tuple[int, ...]:
        """The frequency vector a key's code stands for."""
        return tuple(((code >> (BITS * (self.n_angles - 1 - k))) & MASK) - OFFSET for k in range(self.n_angles))

    def __iter__(self) -> Iterator[tuple[int, tuple[int, ...], dict[int, int], float]]:
        """(kind, frequencies, {variable: exponent}, coefficient) for each term."""
        for (kind, code, mono), c in self.terms.items():
            yield kind, self.frequencies(code), exponents(mono), c


def exponents(mono: int) -> dict[int, int]:
    """``{variable index: exponent}`` of a monomial code."""
    out: dict[int, int] = {}
    i = 0
    while mono:
        e = mono & MASK
        if e:
            out[i] = e
        mono >>= BITS
        i += 1
    return out


def _unit(n_angles: int, k: int) -> int:
    if not 0 <= k < n_angles:
        raise ValueError(f"angle index {k} outside 0..{n_angles - 1}")
    return 1 << (BITS * (n_angles - 1 - k))


def dot(a: list[Trig], b: list[Trig]) -> Trig:
    """``sum_i a_i b_i``."""
    out = a[0] * b[0]
    for x, y in zip(a[1:], b[1:], strict=True):
        out = out + x * y
    return out


def cross(a: list[Trig], b: list[Trig]) -> list[Trig]:
    """The cross product of two 3-vectors."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def matvec(R: list[list[Trig]], x: list[Trig]) -> list[Trig]:
    """``R @ x`` for a 3x3 matrix and a 3-vector."""
    return [dot(row, x) for row in R]


def matmul(A: list[list[Trig]], B: list[list[Trig]]) -> list[list[Trig]]:
    """``A @ B`` for 3x3 matrices."""
    cols = [[B[0][j], B[1][j], B[2][j]] for j in range(3)]
    return [[dot(row, col) for col in cols] for row in A]


def transpose(A: list[list[Trig]]) -> list[list[Trig]]:
    """``A^T`` for a 3x3 matrix."""
    return [[A[j][i] for j in range(3)] for i in range(3)]
