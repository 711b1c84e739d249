"""The built-in controllers' torque laws, written once for NumPy batches, numba and CUDA device code.

A law is a function ``u(c, p, b, q0, q1, v0, v1)`` of a controller's float64 parameter vector ``c``
(the layout below), the kind's closed-form parameters ``p`` (its ``PARAMS`` order), the joint
damping ``b`` (2,) and one state of a two-degree-of-freedom built-in kind (the cart-pole, the
Pendubot). :func:`law` builds it for arrays (``jit=None``: NumPy, q0 ... v1 columns of a batch) or
for scalars (``jit=numba.njit`` or ``cuda.jit(device=True)``) from ONE body: its branches are
written with ``pick`` (``np.where`` on arrays, ``a if cond else b`` on scalars), ``smaller`` and
``larger`` (``np.minimum``/``np.maximum``, or their scalar forms), so the GPU runs the arithmetic
the CPU's batch policy runs (:mod:`robodyn.sweep.policy`), in the same order.

The laws (the controllers of :mod:`robodyn.control`, which build ``c`` from their own numbers):

* ``"lqr"``: u = sat(u_eq - K e), e = [q - q_eq (revolute entries wrapped to [-pi, pi)), v];
* ``"pendubot_energy"``: the LQR where e^T P e < rho, else the energy pump on link 2 with a PD on
  link 1, through collocated PFL (:class:`robodyn.control.swing_up.PendubotEnergy`);
* ``"cart_pole_energy"``: the LQR where e^T P e < rho, else the Astrom-Furuta cart acceleration with
  its rail guard, through collocated PFL (:class:`robodyn.control.swing_up.CartPoleEnergy`).

M, C v and G come from the kind's own closed form (:func:`robodyn.kinds.catalog.closed_form`): no
formula is copied. This module needs only NumPy and :mod:`robodyn.kinds` (no Pinocchio), so a GPU
worker builds the laws from arrays alone (``benchmarks/bench_gpu.py --run``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from robodyn.errors import InputError
from robodyn.kinds.catalog import closed_form

LAWS = ("lqr", "pendubot_energy", "cart_pole_energy")
# The kinds a law's energy part is written for (the LQR serves both).
LAW_KINDS = {"lqr": ("pendubot", "cart_pole"), "pendubot_energy": ("pendubot",), "cart_pole_energy": ("cart_pole",)}

# The parameter vector c (float64), slot by slot.
ACT = 0  # the actuated coordinate (0 or 1); the other one is passive
EFFORT = 1  # its effort limit [N m | N] (inf: none)
U_EQ = 2  # the equilibrium torque [N m | N]
K = 3  # 4 gains on e = (dq0, dq1, v0, v1)
Q_EQ = 7  # 2: the equilibrium q
ANGULAR = 9  # 2 flags: 1.0 where the coordinate's error wraps to [-pi, pi)
P = 11  # 16: the LQR's P, row-major over e
RHO = 27  # the switch's level: LQR where e^T P e < rho
GAINS = 28  # the energy law's numbers, GAIN_NAMES[law] in order
SIZE = GAINS + 13
GAIN_NAMES = {
    "lqr": (),
    "pendubot_energy": (
        *("k_energy", "accel_max", "k_p", "k_d", "kick"),
        *("weight", "inertia", "energy_up", "swing_effort"),
    ),
    "cart_pole_energy": (
        *("k_energy", "accel_max", "k_position", "k_velocity", "kick", "m", "l", "J", "g", "energy_up"),
        *("rail", "rail_lo", "rail_hi"),
    ),
}


def _pick(cond: Any, a: Any, b: Any) -> Any:
    return a if cond else b


def _smaller(a: Any, b: Any) -> Any:
    """min(a, b), NaN when either is NaN (as np.minimum)."""
    return a if (a < b or a != a) else b


def _larger(a: Any, b: Any) -> Any:
    """max(a, b), NaN when either is NaN (as np.maximum)."""
    return a if (a > b or a != a) else b


def _wrap(x: Any) -> Any:
    """Angles [rad] wrapped to [-pi, pi) (:func:`robodyn.control.plant.wrap`)."""
    return (x + math.pi) % (2.0 * math.pi) - math.pi


def law(kind: str, name: str, jit: Any = None) -> Callable[..., Any]:
    """The law ``name`` of ``kind`` as ``u(c, p, b, q0, q1, v0, v1)`` -> the actuated joint's torque [N m | N].

    ``jit=None`` gives the NumPy form (q0 ... v1 arrays (m,), u (m,)); ``jit`` a numba decorator
    (``numba.njit``, ``cuda.jit(device=True)``) gives the scalar form it compiles.
    """
    if name not in LAWS or kind not in LAW_KINDS[name]:
        raise InputError(f"torque law {name!r} for {kind!r}: expected one of {', '.join(LAWS)} for its kinds")
    form = closed_form(kind)
    if jit is None:
        pick, smaller, larger, wrap = np.where, np.minimum, np.maximum, _wrap
        mass, coriolis, gravity = form.mass, form.coriolis, form.gravity
    else:
        pick, smaller, larger, wrap = (jit(f) for f in (_pick, _smaller, _larger, _wrap))
        mass, coriolis, gravity = (jit(f) for f in (form.mass, form.coriolis, form.gravity))
    use = jit if jit is not None else (lambda f: f)

    @use
    def error(c, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        """The state error x - x_eq, revolute entries wrapped (:meth:`robodyn.control.plant.Plant.error`)."""
        d0 = q0 - c[Q_EQ]
        d1 = q1 - c[Q_EQ + 1]
        return pick(c[ANGULAR] > 0.5, wrap(d0), d0), pick(c[ANGULAR + 1] > 0.5, wrap(d1), d1), v0, v1

    @use
    def lqr(c, e0, e1, e2, e3):  # type: ignore[no-untyped-def]
        """u_eq - K e, the product summed term by term in e's order."""
        return c[U_EQ] - e0 * c[K] - e1 * c[K + 1] - e2 * c[K + 2] - e3 * c[K + 3]

    @use
    def row(c, s, i, ei, e0, e1, e2, e3):  # type: ignore[no-untyped-def]
        """S plus row i of e^T P e (ei = e[i]), term by term (no tuple indexed at run time: a GPU's registers)."""
        s = s + ei * c[P + 4 * i] * e0
        s = s + ei * c[P + 4 * i + 1] * e1
        s = s + ei * c[P + 4 * i + 2] * e2
        return s + ei * c[P + 4 * i + 3] * e3

    @use
    def quadratic(c, e0, e1, e2, e3):  # type: ignore[no-untyped-def]
        """e^T P e, summed term by term, row by row."""
        s = row(c, 0.0, 0, e0, e0, e1, e2, e3)
        s = row(c, s, 1, e1, e0, e1, e2, e3)
        s = row(c, s, 2, e2, e0, e1, e2, e3)
        return row(c, s, 3, e3, e0, e1, e2, e3)

    @use
    def reduced(c, p, b, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        """(Mbar, hbar, m11, m12, m22) of the collocated PFL u = Mbar a_act + hbar, h = C v + G + B v."""
        m11, m12, m22 = mass(p, q0, q1)
        c11, c12, c21, c22 = coriolis(p, q0, q1, v0, v1)
        g0, g1 = gravity(p, q0, q1)
        h0 = (c11 * v0 + c12 * v1) + g0 + b[0] * v0
        h1 = (c21 * v0 + c22 * v1) + g1 + b[1] * v1
        first = c[ACT] < 0.5
        ratio = m12 / pick(first, m22, m11)
        return pick(first, m11, m22) - ratio * m12, pick(first, h0, h1) - ratio * pick(first, h1, h0), m11, m12, m22

    @use
    def pendubot_energy(c, p, b, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        """The shoulder torque of :class:`~robodyn.control.swing_up.PendubotEnergy`, clipped to its swing effort."""
        k_energy, accel_max, k_p, k_d, kick = c[GAINS], c[GAINS + 1], c[GAINS + 2], c[GAINS + 3], c[GAINS + 4]
        weight, inertia, energy_up, cap = c[GAINS + 5], c[GAINS + 6], c[GAINS + 7], c[GAINS + 8]
        e1 = wrap(q0 - c[Q_EQ])
        psi = q0 + q1 - c[Q_EQ] - c[Q_EQ + 1]
        rate = v0 + v1
        energy = 0.5 * inertia * rate * rate + weight * (np.cos(psi) - 1.0)
        sigma = rate * np.cos(psi) * np.cos(e1) + kick
        pump = smaller(larger(k_energy * (energy - energy_up) * sigma, -1.0), 1.0)
        w = accel_max * pump - k_p * e1 - k_d * v0
        mbar, hbar, _m11, _m12, _m22 = reduced(c, p, b, q0, q1, v0, v1)
        return smaller(larger(mbar * w + hbar, -cap), cap)

    @use
    def cart_pole_energy(c, p, b, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        """The cart force of :class:`~robodyn.control.swing_up.CartPoleEnergy`, unsaturated (rail guard applied)."""
        k_energy, accel_max, k_position = c[GAINS], c[GAINS + 1], c[GAINS + 2]
        k_velocity, kick = c[GAINS + 3], c[GAINS + 4]
        m, length, J, g, energy_up = c[GAINS + 5], c[GAINS + 6], c[GAINS + 7], c[GAINS + 8], c[GAINS + 9]
        energy = 0.5 * J * (v1 * v1) + m * g * length * (np.cos(q1) - np.cos(c[Q_EQ + 1]))  # 0 upright at rest
        sigma = v1 * np.cos(q1) + kick
        side = pick(length < 0.0, -1.0, 1.0)  # a pole below its hinge at q = 0 pumps reversed
        pump = smaller(larger(side * k_energy * (energy - energy_up) * sigma, -1.0), 1.0)
        accel = accel_max * pump - k_position * q0 - k_velocity * v0
        rail = c[GAINS + 10] > 0.5  # robodyn.control.swing_up.rail_guard, braking at accel_max
        stop = q0 + v0 * abs(v0) / (2.0 * accel_max)
        accel = pick(rail & (v0 > 0) & (stop >= c[GAINS + 12]), smaller(accel, -accel_max), accel)
        accel = pick(rail & (v0 < 0) & (stop <= c[GAINS + 11]), larger(accel, accel_max), accel)
        mbar, hbar, _m11, _m12, _m22 = reduced(c, p, b, q0, q1, v0, v1)
        return mbar * accel + hbar

    energy_law = pendubot_energy if name == "pendubot_energy" else cart_pole_energy
    switched = name != "lqr"

    @use
    def torque(c, p, b, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        e0, e1, e2, e3 = error(c, q0, q1, v0, v1)
        u = lqr(c, e0, e1, e2, e3)
        if switched:
            u = pick(quadratic(c, e0, e1, e2, e3) < c[RHO], u, energy_law(c, p, b, q0, q1, v0, v1))
        return smaller(larger(u, -c[EFFORT]), c[EFFORT])

    return torque  # type: ignore[no-any-return]


def forces(kind: str, name: str, jit: Any) -> Callable[..., Any]:
    """``(t0, t1) = f(c, p, b, q0, q1, v0, v1)``: the law's torque on the actuated coordinate, 0 on the other."""
    torque = law(kind, name, jit)
    pick = jit(_pick)

    @jit
    def generalized(c, p, b, q0, q1, v0, v1):  # type: ignore[no-untyped-def]
        u = torque(c, p, b, q0, q1, v0, v1)
        first = c[ACT] < 0.5
        return pick(first, u, 0.0), pick(first, 0.0, u)

    return generalized  # type: ignore[no-any-return]
