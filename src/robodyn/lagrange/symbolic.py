"""A :class:`~robodyn.lagrange.derivation.Derivation` as sympy expressions, grouped as a textbook prints them.

Each entry is written as a sum over its inertial factors (a mass, an inertia, a rotor inertia,
``g`` times a mass) of that factor times the geometry it multiplies, e.g.
``I1 + I2 + lc1**2*m1 + m2*(l1**2 + 2*l1*lc2*cos(q2) + lc2**2)``. The trigonometric part is the
derivation's canonical Fourier form (``cos(q1 + q2)``, never ``cos q1 cos q2 - sin q1 sin q2``),
so nothing is left to simplify. A coefficient that is a small fraction is printed as one.

sympy is imported on first use; without it :class:`robodyn.errors.MissingDependencyError` says
which extra to install.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from robodyn.errors import MissingDependencyError
from robodyn.lagrange.derivation import Derivation
from robodyn.lagrange.trig import Trig

INERTIAL = ("m", "I", "J", "g")  # the stems of the parameters an entry is grouped by

# Past this many terms in M, G and the Christoffel symbols together, expressions are printed in the
# order sympy holds their terms rather than sorted: sorting is half the printing time of a spatial
# 6-joint arm's ~10^5 terms, which nobody reads in order anyway.
LARGE = 5000

# A float coefficient this close to a fraction of denominator <= 1000 is that fraction.
FRACTION_TOL = 1e-12


def sympy() -> Any:
    """The sympy module, or :class:`MissingDependencyError` naming the extra that brings it."""
    try:
        import sympy
    except ImportError:
        raise MissingDependencyError(
            "robodyn derive needs sympy, which is not installed: pip install 'robodyn[derive]' (or pip install sympy)"
        ) from None
    return sympy


@dataclass(frozen=True)
class Symbolic:
    """The derivation's expressions: q, v and parameter symbols; M, C (Christoffel), G, V; the Gammas on demand."""

    derivation: Derivation
    q: tuple[Any, ...]
    v: tuple[Any, ...]
    params: tuple[Any, ...]
    M: Any  # sympy Matrix (n, n)
    C: Any  # sympy Matrix (n, n)
    G: Any  # sympy Matrix (n, 1)
    V: Any
    cache: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    @property
    def large(self) -> bool:
        """Whether the expressions are long enough to print unsorted (see :data:`LARGE`)."""
        if "large" not in self.cache:
            d = self.derivation
            count = sum(len(x.terms) for row in d.M for x in row) + sum(len(x.terms) for x in d.G)
            count += sum(len(x.terms) for plane in d.christoffel for row in plane for x in row)
            self.cache["large"] = count > LARGE
        return bool(self.cache["large"])

    def sstr(self, expr: Any) -> str:
        """``expr`` as text: sorted as sympy prints it, unsorted when :attr:`large` (each text printed once)."""
        texts = self.cache.setdefault("sstr", {})
        if expr not in texts:
            texts[expr] = str(sympy().sstr(expr, order="none" if self.large else None))
        return str(texts[expr])

    def printer_settings(self) -> dict[str, Any]:
        """NumPyPrinter settings: unsorted when :attr:`large`."""
        return {"order": "none"} if self.large else {}

    @property
    def gamma(self) -> dict[tuple[int, int, int], Any]:
        """(i, j, k) -> Gamma_ijk, the non-zero Christoffel symbols with j <= k (built on demand: they are long)."""
        d = self.derivation
        out = {}
        for i in range(d.n):
            for j in range(d.n):
                for k in range(j, d.n):
                    g = d.christoffel[i][j][k]
                    if not g.is_zero():
                        out[(i, j, k)] = self.expression(g)
        return out

    def expression(self, trig: Trig, rates: Iterable[tuple[Trig, Any]] | None = None) -> Any:
        """A Trig (or ``sum_k trig_k * v_k`` given as pairs) as a grouped sympy expression."""
        return _grouped(self, [(trig, 1)] if rates is None else list(rates))


def symbolic(derivation: Derivation) -> Symbolic:
    """The derivation's M, C, G and V as grouped sympy expressions."""
    sp = sympy()
    n = derivation.n
    q = tuple(sp.Symbol(f"q{i + 1}", real=True) for i in range(n))
    v = tuple(sp.Symbol(f"v{i + 1}", real=True) for i in range(n))
    params = tuple(sp.Symbol(p.name, real=True) for p in derivation.params)
    partial = Symbolic(derivation, q, v, params, None, None, None, None)
    M = sp.Matrix(n, n, lambda i, j: partial.expression(derivation.M[i][j]) if i <= j else 0)
    M = M + M.T - sp.diag(*(M[i, i] for i in range(n)))
    C = sp.Matrix(
        n,
        n,
        lambda i, j: partial.expression(Trig(derivation.n_angles), zip(derivation.christoffel[i][j], v, strict=True)),
    )
    G = sp.Matrix(n, 1, lambda i, _: partial.expression(derivation.G[i]))
    V = partial.expression(derivation.V)
    return Symbolic(derivation, q, v, params, M, C, G, V)


def number(c: float) -> Any:
    """``c`` as a sympy Rational when it is a small fraction, else a Float."""
    sp = sympy()
    f = Fraction(c).limit_denominator(1000)
    if abs(float(f) - c) <= FRACTION_TOL * max(1.0, abs(c)):
        return sp.Rational(f.numerator, f.denominator)
    return sp.Float(c, 15)


def _grouped(s: Symbolic, pieces: list[tuple[Trig, Any]]) -> Any:
    """The sum over pieces of trig * rate, grouped by inertial factor (see the module docstring).

    Terms are gathered as plain Python keys first (inertial monomial -> geometric monomial and
    trigonometric term -> rate -> coefficient), so that each sympy object is built once.
    """
    sp = sympy()
    d = s.derivation
    first = sum(1 for x in d.variable_of if x is not None)
    inertial = {k for k, p in enumerate(d.params) if p.name.startswith(INERTIAL)}
    groups: dict[tuple[tuple[int, int], ...], dict[tuple[Any, ...], dict[int, float]]] = {}
    for r, (trig, _) in enumerate(pieces):
        for kind, freqs, powers, c in trig:
            key = tuple((v, e) for v, e in powers.items() if v >= first and v - first in inertial)
            geometry = tuple((v, e) for v, e in powers.items() if not (v >= first and v - first in inertial))
            rates = groups.setdefault(key, {}).setdefault((kind, freqs, geometry), {})
            rates[r] = rates.get(r, 0.0) + c
    coordinate_of = {var: i for i, var in enumerate(d.variable_of) if var is not None}
    angles = [s.q[i] for i, a in enumerate(d.angle_of) if a is not None]

    def power(var: int, e: int) -> Any:
        base = s.q[coordinate_of[var]] if var < first else s.params[var - first]
        return base**e

    # A long expression is assembled unevaluated: its terms are distinct by construction, and
    # sympy's flattening and sorting of 10^4-term sums is most of the time it would take.
    evaluate = not s.large
    trig_of = s.cache.setdefault("trig", {})
    terms = []
    for key, shapes in groups.items():
        inner = []
        for (kind, freqs, geometry), rates in shapes.items():
            factors = [power(v, e) for v, e in geometry]
            if any(freqs):
                if (kind, freqs) not in trig_of:
                    arg = sp.Add(*(n * a for n, a in zip(freqs, angles, strict=True)))
                    trig_of[(kind, freqs)] = sp.sin(arg) if kind else sp.cos(arg)
                factors.append(trig_of[(kind, freqs)])
            rate = sp.Add(*(number(c) * pieces[r][1] for r, c in rates.items() if c != 0))
            inner.append(sp.Mul(rate, *factors, evaluate=evaluate))
        terms.append(sp.Mul(*(power(v, e) for v, e in key)) * sp.Add(*inner, evaluate=evaluate))
    return sp.Add(*terms, evaluate=evaluate)
