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
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from robodyn.errors import MissingDependencyError
from robodyn.lagrange.derivation import Derivation
from robodyn.lagrange.trig import Trig

INERTIAL = ("m", "I", "J", "g")  # the stems of the parameters an entry is grouped by

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
    """The derivation's expressions: q, v and parameter symbols; M, C (Christoffel), G, V, T and the Gammas."""

    derivation: Derivation
    q: tuple[Any, ...]
    v: tuple[Any, ...]
    params: tuple[Any, ...]
    M: Any  # sympy Matrix (n, n)
    C: Any  # sympy Matrix (n, n)
    G: Any  # sympy Matrix (n, 1)
    V: Any
    T: Any
    gamma: dict[tuple[int, int, int], Any]  # (i, j, k) -> Gamma_ijk, non-zero ones, j <= k

    def expression(self, trig: Trig, rates: Iterable[tuple[Trig, Any]] | None = None) -> Any:
        """A Trig (or ``sum_k trig_k * v_k`` given as pairs) as a grouped sympy expression."""
        return _grouped(self, [(trig, 1)] if rates is None else list(rates))


def symbolic(derivation: Derivation) -> Symbolic:
    """The derivation's M, C, G, V, T and Christoffel symbols as grouped sympy expressions."""
    sp = sympy()
    n = derivation.n
    q = tuple(sp.Symbol(f"q{i + 1}", real=True) for i in range(n))
    v = tuple(sp.Symbol(f"v{i + 1}", real=True) for i in range(n))
    params = tuple(sp.Symbol(p.name, real=True) for p in derivation.params)
    partial = Symbolic(derivation, q, v, params, None, None, None, None, None, {})
    M = sp.Matrix(n, n, lambda i, j: partial.expression(derivation.M[i][j]))
    gamma = {}
    for i in range(n):
        for j in range(n):
            for k in range(j, n):
                g = derivation.christoffel[i][j][k]
                if not g.is_zero():
                    gamma[(i, j, k)] = partial.expression(g)
    C = sp.Matrix(
        n,
        n,
        lambda i, j: partial.expression(Trig(derivation.n_angles), zip(derivation.christoffel[i][j], v, strict=True)),
    )
    G = sp.Matrix(n, 1, lambda i, _: partial.expression(derivation.G[i]))
    V = partial.expression(derivation.V)
    T = sp.Rational(1, 2) * sum(
        (M[i, j] * v[i] * v[j] for i in range(n) for j in range(n) if M[i, j] != 0), sp.Integer(0)
    )
    return Symbolic(derivation, q, v, params, M, C, G, V, T, gamma)


def number(c: float) -> Any:
    """``c`` as a sympy Rational when it is a small fraction, else a Float."""
    sp = sympy()
    f = Fraction(c).limit_denominator(1000)
    if abs(float(f) - c) <= FRACTION_TOL * max(1.0, abs(c)):
        return sp.Rational(f.numerator, f.denominator)
    return sp.Float(c, 15)


def _grouped(s: Symbolic, pieces: list[tuple[Trig, Any]]) -> Any:
    """The sum over pieces of trig * rate, grouped by inertial factor (see the module docstring)."""
    sp = sympy()
    d = s.derivation
    first = sum(1 for x in d.variable_of if x is not None)
    coordinate_of = {var: i for i, var in enumerate(d.variable_of) if var is not None}
    angles = [s.q[i] for i, a in enumerate(d.angle_of) if a is not None]
    # groups[inertial factor][the rest but the rate] = the sum of the rates it multiplies
    groups: dict[Any, dict[Any, Any]] = {}
    for trig, rate in pieces:
        for kind, freqs, powers, c in trig:
            key, rest = sp.Integer(1), [number(c)]
            for var, e in powers.items():
                if var < first:
                    rest.append(s.q[coordinate_of[var]] ** e)
                    continue
                name = d.params[var - first].name
                symbol = s.params[var - first] ** e
                if name.startswith(INERTIAL):
                    key = key * symbol
                else:
                    rest.append(symbol)
            if any(freqs):
                arg = sp.Add(*(n * a for n, a in zip(freqs, angles, strict=True)))
                rest.append(sp.sin(arg) if kind else sp.cos(arg))
            term = sp.Mul(*rest)
            coefficient, shape = term.as_coeff_Mul()
            inner = groups.setdefault(key, {})
            inner[shape] = inner.get(shape, sp.Integer(0)) + coefficient * rate
    return sp.Add(*(key * sp.Add(*(shape * rates for shape, rates in inner.items())) for key, inner in groups.items()))
