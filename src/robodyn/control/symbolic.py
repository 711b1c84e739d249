"""The hand-derived closed forms linearised by sympy: the reference that Robot.linearize is checked against.

A built-in kind writes its Lagrangian closed form once (:mod:`robodyn.kinds.formula`), generic in its
scalar type. Here it is evaluated on sympy symbols (through :class:`_Symbolic`, a scalar that
answers ``np.cos`` and ``np.sin``), so M(q), C(q, v), G(q) come out as expressions, and

    f(x, u) = [v, M(q)^-1 (S u - C(q, v) v - G(q) - D v)]

is differentiated exactly: A = df/dx, B = df/du at the equilibrium, with the state and input
ordering of :meth:`robodyn.Robot.linearize` (x = [q, v], u = the actuated torques). Nothing here
touches Pinocchio, so agreement is evidence for both. sympy is imported on first use.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn.errors import MissingDependencyError
from robodyn.kinds.catalog import closed_form

Array = NDArray[np.float64]


def _sympy() -> Any:
    try:
        import sympy
    except ImportError:
        raise MissingDependencyError(
            "the symbolic linearisation needs sympy: pip install sympy (or robodyn[test])"
        ) from None
    return sympy


class _Symbolic:
    """A sympy expression that NumPy's ufuncs can take: ``np.cos(x)`` calls ``x.cos()``."""

    __slots__ = ("expr",)

    def __init__(self, expr: Any) -> None:
        self.expr = expr

    @staticmethod
    def _of(other: Any) -> Any:
        return other.expr if isinstance(other, _Symbolic) else other

    def __add__(self, other: Any) -> _Symbolic:
        return _Symbolic(self.expr + self._of(other))

    def __radd__(self, other: Any) -> _Symbolic:
        return _Symbolic(self._of(other) + self.expr)

    def __sub__(self, other: Any) -> _Symbolic:
        return _Symbolic(self.expr - self._of(other))

    def __rsub__(self, other: Any) -> _Symbolic:
        return _Symbolic(self._of(other) - self.expr)

    def __mul__(self, other: Any) -> _Symbolic:
        return _Symbolic(self.expr * self._of(other))

    def __rmul__(self, other: Any) -> _Symbolic:
        return _Symbolic(self._of(other) * self.expr)

    def __truediv__(self, other: Any) -> _Symbolic:
        return _Symbolic(self.expr / self._of(other))

    def __rtruediv__(self, other: Any) -> _Symbolic:
        return _Symbolic(self._of(other) / self.expr)

    def __neg__(self) -> _Symbolic:
        return _Symbolic(-self.expr)

    def __pow__(self, other: Any) -> _Symbolic:
        return _Symbolic(self.expr ** self._of(other))

    def cos(self) -> _Symbolic:
        """The cosine of the expression (what ``np.cos`` calls on an object)."""
        return _Symbolic(_sympy().cos(self.expr))

    def sin(self) -> _Symbolic:
        """The sine of the expression (what ``np.sin`` calls on an object)."""
        return _Symbolic(_sympy().sin(self.expr))


def equations(kind: str) -> tuple[Any, Any, Any, Any, Any, tuple[Any, ...]]:
    """(M, C, G, q, v, params): the kind's closed form as sympy matrices in symbols q_i, v_i and its parameters."""
    sp = _sympy()
    form = closed_form(kind)
    n = form.dof
    q = sp.symbols(f"q1:{n + 1}", real=True)
    v = sp.symbols(f"v1:{n + 1}", real=True)
    params = tuple(sp.Symbol(name, real=True) for name in form.params)
    P = [_Symbolic(s) for s in params]
    Q = [_Symbolic(s) for s in q]
    V = [_Symbolic(s) for s in v]
    mass = [_Symbolic._of(x) for x in form.mass(P, *Q)]
    cor = [_Symbolic._of(x) for x in form.coriolis(P, *Q, *V)]
    grav = [_Symbolic._of(x) for x in form.gravity(P, *Q)]
    if n == 1:
        M = sp.Matrix([[mass[0]]])
    else:
        M = sp.Matrix([[mass[0], mass[1]], [mass[1], mass[2]]])
    return M, sp.Matrix(n, n, cor), sp.Matrix(grav), sp.Matrix(q), sp.Matrix(v), params


def linearize(
    kind: str,
    params: Mapping[str, float],
    q_eq: ArrayLike,
    *,
    actuated: Sequence[bool],
    u_eq: ArrayLike | None = None,
    damping: ArrayLike | None = None,
) -> tuple[Array, Array]:
    """(A (2n, 2n), B (2n, n_act)) of ``kind`` at (q_eq, v = 0, u_eq), differentiated by sympy.

    ``params`` maps the kind's parameter names to values (:func:`robodyn.kinds.params.extract`);
    ``actuated`` (n,) marks the actuated joints (the columns of B); ``damping`` (n,) the viscous
    joint damping [N m s/rad | N s/m], as :func:`robodyn.simulate` applies it.
    """
    sp = _sympy()
    M, C, G, q, v, symbols = equations(kind)
    n = q.shape[0]
    mask = np.asarray(actuated, dtype=bool)
    S = sp.Matrix(np.eye(n)[:, mask].astype(int).tolist())
    u = sp.Matrix(sp.symbols(f"u1:{int(mask.sum()) + 1}", real=True))
    D = sp.diag(*[sp.Float(float(d)) for d in (np.zeros(n) if damping is None else np.asarray(damping))])
    accel = M.LUsolve(S * u - C * v - G - D * v)
    f = sp.Matrix.vstack(v, accel)
    x = sp.Matrix.vstack(q, v)
    u0 = np.zeros(int(mask.sum())) if u_eq is None else np.asarray(u_eq, dtype=np.float64)
    point = dict(zip(symbols, (float(params[s.name]) for s in symbols), strict=True))
    point.update(zip(q, np.asarray(q_eq, dtype=np.float64).tolist(), strict=True))
    point.update(dict.fromkeys(v, 0.0))
    point.update(zip(u, u0.tolist(), strict=True))
    A = np.array(f.jacobian(x).subs(point).evalf(), dtype=np.float64)
    B = np.array(f.jacobian(u).subs(point).evalf(), dtype=np.float64)
    return A, B
