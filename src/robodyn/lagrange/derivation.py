"""The Lagrangian of a tree robot, derived from its per-link table in exact trigonometric form.

:func:`derive` reads a per-link table (:class:`robodyn.model.links.LinkTable`: mass, centre of
mass and inertia in each joint frame, joint origin, rotation and axis) and returns a
:class:`Derivation`: M(q), the Christoffel symbols, G(q) and V(q) as :class:`~robodyn.lagrange.trig.Trig`
polynomials in the formula's coordinates, whose parameters are named per link
(:mod:`robodyn.lagrange.naming`).

How. Every link's frame is written in the frame of each of its ancestors (3x3 rotations and
offsets whose entries are Trig polynomials: cos and sin of the joint angles, exact 0 and +-1 for
the usual axes, named symbols for lengths). M's entry (i, j), i an ancestor of j, is summed over
the links b that j carries, in joint i's frame, where only the angles after joint i appear::

    M_ij = sum_b  m_b Jv_i . Jv_j  +  w_i^T I_b w_j

with Jv_i = a_i x r (revolute) or a_i (prismatic), r the centre of mass of b, and w_i the axis
of joint i seen from b's frame (the angular Jacobian in body axes). V is -m_b g . r_b summed in
the base frame, G = dV/dq, and the Christoffel symbols come from dM/dq. Every step stays in
canonical Fourier form, so no simplifier runs and a 6-joint arm takes seconds.

This module reads the table by duck typing (it never imports Pinocchio or the Robot) and
imports only NumPy and :mod:`robodyn.lagrange`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robodyn.errors import InputError
from robodyn.lagrange.coordinates import Coordinate, congruence
from robodyn.lagrange.kinematics import frames, local_motions, setup
from robodyn.lagrange.naming import Param, snap
from robodyn.lagrange.trig import Trig, cross, dot, matvec, transpose
from robodyn.model.coordinate_map import CoordinateMap

__all__ = ["DEFAULT_TIME_LIMIT", "MAX_JOINTS", "Coordinate", "Derivation", "derive"]

MAX_JOINTS = 6
"""The most moving joints ``robodyn derive`` takes: past it the printed expressions run over pages."""

DEFAULT_TIME_LIMIT = 120.0
"""Seconds a derivation may take before it stops (a 6-joint arm takes a few)."""

# Three axes are parallel when their cross product is below this (unit vectors, 1e-9 printed digits).
PARALLEL_TOL = 1e-9

Matrix = list[list[Trig]]
Vector = list[Trig]


@dataclass(frozen=True)
class Derivation:
    """M, the Christoffel symbols, G and V of a robot as Trig polynomials (see the module docstring).

    ``coordinates`` is the map q = A q_urdf + b over the joints ``coordinates.joints`` (of types
    ``joint_types``). Variables: ``angle_of[i]`` is the angle index of coordinate i (None for a prismatic one),
    ``variable_of[i]`` its polynomial index (None for an angle); the parameters are polynomial
    variables from ``len(prismatic coordinates)`` on, in the order of ``params``.
    """

    robot: str
    coordinates: CoordinateMap
    joint_types: tuple[str, ...]  # of coordinates.joints: revolute, continuous or prismatic
    params: tuple[Param, ...]
    n_angles: int
    angle_of: tuple[int | None, ...]
    variable_of: tuple[int | None, ...]
    M: tuple[tuple[Trig, ...], ...]
    christoffel: tuple[tuple[tuple[Trig, ...], ...], ...]  # [i][j][k] = Gamma_ijk
    G: tuple[Trig, ...]
    V: Trig
    com: tuple[tuple[Trig, ...], ...]  # each link's centre of mass in the base frame (formula order)
    angular_velocity: tuple[tuple[tuple[Trig, ...], ...], ...]  # [b][k]: link b's body-axes omega per unit v_k
    inertia: tuple[tuple[tuple[Trig, ...], ...], ...]  # [b]: link b's inertia about its centre (body axes)
    gravity_direction: tuple[float, float, float]
    wall_time_s: float = field(default=0.0, compare=False)

    @property
    def n(self) -> int:
        """Degrees of freedom."""
        return len(self.coordinates.joints)

    @property
    def angular(self) -> tuple[bool, ...]:
        """For each formula coordinate: True for an angle, False for a length."""
        return tuple(v is None for v in self.variable_of)

    def d(self, expr: Trig, i: int) -> Trig:
        """The partial derivative of ``expr`` with respect to coordinate i."""
        angle = self.angle_of[i]
        if angle is not None:
            return expr.d_angle(angle)
        variable = self.variable_of[i]
        assert variable is not None  # a coordinate is an angle or a polynomial variable
        return expr.d_variable(variable)

    def used_parameters(self) -> frozenset[str]:
        """The names of the parameters that appear in M, G or V."""
        first = sum(1 for v in self.variable_of if v is not None)
        seen = 0
        for expr in (*(x for row in self.M for x in row), *self.G, self.V):
            for mono in (key[2] for key in expr.terms):
                seen |= mono
        used = set()
        for k, p in enumerate(self.params):
            if (seen >> (8 * (first + k))) & 0xFF:
                used.add(p.name)
        return frozenset(used)

    def mass(self, b: int) -> Trig:
        """Link b's mass as a Trig (zero when dropped)."""
        return self._param(f"m{b + 1}")

    def _param(self, name: str) -> Trig:
        first = sum(1 for v in self.variable_of if v is not None)
        for k, p in enumerate(self.params):
            if p.name == name:
                return Trig.variable(self.n_angles, first + k)
        return Trig(self.n_angles)


class _Deadline:
    """Raise :class:`InputError` once ``limit`` seconds have passed since the start."""

    def __init__(self, limit: float) -> None:
        self.limit = limit
        self.start = time.monotonic()

    def __call__(self, what: str) -> None:
        if time.monotonic() - self.start > self.limit:
            raise InputError(
                f"the derivation took longer than its limit of {self.limit:g} s (at {what}); "
                "lock joints with --coordinates or raise --time-limit"
            )


def derive(
    table: Any,
    coordinates: Sequence[Coordinate] | CoordinateMap | None = None,
    *,
    time_limit: float = DEFAULT_TIME_LIMIT,
    tick: Callable[[str], None] | None = None,
) -> Derivation:
    """Derive M, the Christoffel symbols, G and V of the robot in ``table`` (see :func:`_derive`).

    A first pass finds the parameters that appear in none of M, G and V (an offset along the axis
    of a planar chain, a centre of mass off the plane); a second names the rest, so that a length
    left alone on one axis takes the single name (``l1`` rather than ``lx1``). Both passes share
    ``time_limit``.
    """
    started = time.monotonic()
    first = _derive(table, coordinates, time_limit=time_limit, tick=tick)
    used = first.used_parameters()
    unused = frozenset(p.name for p in first.params) - used
    if not unused:
        return first
    left = time_limit - (time.monotonic() - started)
    second = _derive(table, coordinates, time_limit=max(left, 0.0), tick=tick, unused=unused)
    object.__setattr__(second, "wall_time_s", time.monotonic() - started)
    return second


def _derive(
    table: Any,
    coordinates: Sequence[Coordinate] | CoordinateMap | None = None,
    *,
    time_limit: float = DEFAULT_TIME_LIMIT,
    tick: Callable[[str], None] | None = None,
    unused: frozenset[str] = frozenset(),
) -> Derivation:
    """Derive M, the Christoffel symbols, G and V of the robot in ``table``.

    Args:
        table: a per-link table (:class:`robodyn.model.links.LinkTable`) whose moving joints are
            exactly the coordinates' joints (lock the others first).
        coordinates: the formula's coordinates: ``q = A q_urdf + b`` (a CoordinateMap), or one
            Coordinate per joint in the formula's order (default: the table's joints, in model
            order, ``q = q_urdf``). In the formula's coordinates every joint angle is
            ``q_urdf = A^-1 (q - b)``, so A^-1 must be whole numbers between angles (a trigonometric
            polynomial has whole frequencies); M = A^-T M_urdf A^-1.
        time_limit: seconds before the derivation stops with an :class:`InputError`.
        tick: called with a stage name between stages (a test's hook; the deadline runs anyway).
        unused: parameters to leave out (see :func:`derive`).

    Raises:
        InputError: more than :data:`MAX_JOINTS` joints, coordinates that do not match the
            table's joints, or the time limit passed.
    """
    started = time.monotonic()
    deadline = _Deadline(time_limit)

    def check(what: str) -> None:
        deadline(what)
        if tick is not None:
            tick(what)

    su = setup(table, coordinates, unused, MAX_JOINTS, _planar_links)
    links, cmap, joints, n, index, turns = su.links, su.cmap, su.joints, su.n, su.index, su.turns
    back, angle_of, variable_of, n_angles, params, per_link, pvar, zero = (
        su.back, su.angle_of, su.variable_of, su.n_angles, su.params, su.per_link, su.pvar, su.zero
    )  # fmt: skip
    vec = su.vec
    local = local_motions(su)
    check("the joint transforms")
    rel, world, subtree = frames(su, local, check)

    # M_urdf first (the joints' own rates), then M = A^-T M_urdf A^-1 (d q_urdf / d q = A^-1).
    axes = {name: vec(links[name].axis) for name in table.joints}
    com = {name: per_link[name].com(pvar, zero) for name in table.joints}
    inertia = {name: per_link[name].inertia(pvar, zero) for name in table.joints}
    mass = {name: per_link[name].mass(pvar, zero) for name in table.joints}

    M_urdf = [[zero for _ in range(n)] for _ in range(n)]
    for i_name in table.joints:
        for j_name in subtree(i_name):
            i, j = index[i_name], index[j_name]
            entry = _mass_entry(i_name, j_name, subtree(j_name), turns, rel, axes, com, inertia, mass)
            if i == j:
                entry = entry + per_link[i_name].armature(pvar, zero)
            M_urdf[i][j] = entry
            M_urdf[j][i] = entry
            check(f"M[{i},{j}]")
    M = congruence(M_urdf, back, zero)
    # V = -sum_b m_b g . r_b in the base frame; G = dV/dq.
    gdir = [snap(float(x)) for x in np.asarray(table.gravity, dtype=np.float64) / max(float(table.g), 1e-300)]
    g = pvar.get("g", zero)
    V = zero
    com_world: list[Vector] = []
    for b in joints:
        R, p = world[b]
        r = [pi + ri for pi, ri in zip(p, matvec(R, com[b]), strict=True)]
        com_world.append(r)
        V = V - mass[b] * g * dot(vec(gdir), r)
    derivation = Derivation(
        str(table.name),
        cmap,
        tuple(links[j].joint_type for j in joints),
        tuple(params),
        n_angles,
        angle_of,
        variable_of,
        tuple(tuple(row) for row in M),
        (),
        (),
        V,
        tuple(tuple(r) for r in com_world),
        tuple(
            tuple(tuple(w) for w in _body_rates(b, _ancestors(links, b), back, joints, turns, rel, axes, zero))
            for b in joints
        ),
        tuple(tuple(tuple(row) for row in inertia[b]) for b in joints),
        (gdir[0], gdir[1], gdir[2]),
    )
    G = tuple(derivation.d(V, i) for i in range(n))
    check("G")
    gamma = _christoffel_symbols(derivation, M, n, check)
    check("the Christoffel symbols")
    object.__setattr__(derivation, "christoffel", gamma)
    object.__setattr__(derivation, "G", G)
    object.__setattr__(derivation, "wall_time_s", time.monotonic() - started)
    return derivation


def _ancestors(links: Mapping[str, Any], b: str) -> list[str]:
    """Link ``b`` and the links above it, up to the base."""
    out = []
    cur: str | None = b
    while cur is not None:
        out.append(cur)
        cur = links[cur].parent
    return out


def _christoffel_symbols(
    derivation: Derivation, M: Sequence[Sequence[Trig]], n: int, check: Callable[[str], None]
) -> tuple[tuple[tuple[Trig, ...], ...], ...]:
    """Gamma[i][j][k] = 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i)."""
    dM = [[[derivation.d(M[i][j], k) for k in range(n)] for j in range(n)] for i in range(n)]  # dM[i][j][k]
    check("dM/dq")
    gamma = tuple(
        tuple(tuple((dM[i][j][k] + dM[i][k][j] - dM[j][k][i]).scale(0.5) for k in range(n)) for j in range(n))
        for i in range(n)
    )
    return gamma


def _planar_links(table: Any) -> dict[str, np.ndarray | None]:
    """For each link: the common axis (body axes) of every revolute joint carrying it, when they are parallel.

    Then the link turns about that one axis only and its inertia enters as one number ``u^T I u``;
    otherwise (None) the whole tensor does. A link that no revolute joint turns has an empty entry
    (a zero vector): its inertia never enters.
    """
    links = {link.joint: link for link in table.links}
    out: dict[str, np.ndarray | None] = {}
    for link in table.links:
        # Walk up, carrying the rotation of each ancestor's frame in this link's frame (at q = 0).
        R = np.eye(3)  # ancestor frame -> this link's frame
        axes = []
        cur = link
        while True:
            if cur.joint_type != "prismatic":
                axes.append(R @ np.asarray(cur.axis, dtype=np.float64))
            R = R @ np.asarray(cur.rotation, dtype=np.float64).T
            if cur.parent is None:
                break
            cur = links[cur.parent]
        if not axes:
            out[link.joint] = np.zeros(3)
            continue
        u = axes[0] / np.linalg.norm(axes[0])
        parallel = all(np.linalg.norm(np.cross(u, a)) < PARALLEL_TOL for a in axes)
        out[link.joint] = np.array([snap(x) for x in u]) if parallel else None
    return out


def _mass_entry(
    i_name: str,
    j_name: str,
    bodies: list[str],
    turns: Mapping[str, bool],
    rel: Mapping[str, Mapping[str, tuple[Matrix, Vector]]],
    axes: Mapping[str, Vector],
    com: Mapping[str, Vector],
    inertia: Mapping[str, Matrix],
    mass: Mapping[str, Trig],
) -> Trig:
    """M_urdf ij (i an ancestor of j, or j itself) summed over the links j carries, in joint i's frame."""
    i_turns, j_turns = turns[i_name], turns[j_name]
    a_i = axes[i_name]
    R_ij, p_ij = rel[i_name][j_name]
    z_j = matvec(R_ij, axes[j_name])
    entry = Trig(a_i[0].n_angles)
    for b in bodies:
        R_ib, p_ib = rel[i_name][b]
        if not mass[b].is_zero():
            r = [p + x for p, x in zip(p_ib, matvec(R_ib, com[b]), strict=True)]
            jv_i = cross(a_i, r) if i_turns else a_i
            if i_name == j_name:
                jv_j = jv_i
            else:
                jv_j = cross(z_j, [x - p for x, p in zip(r, p_ij, strict=True)]) if j_turns else z_j
            entry = entry + mass[b] * dot(jv_i, jv_j)
        if i_turns and j_turns and any(not x.is_zero() for row in inertia[b] for x in row):
            w_i = matvec(transpose(R_ib), a_i)
            w_j = w_i if i_name == j_name else matvec(transpose(rel[j_name][b][0]), axes[j_name])
            entry = entry + dot(w_i, matvec(inertia[b], w_j))
    return entry


def _body_rates(
    b: str,
    chain: list[str],
    back: np.ndarray,
    joints: Sequence[str],
    turns: Mapping[str, bool],
    rel: Mapping[str, Mapping[str, tuple[Matrix, Vector]]],
    axes: Mapping[str, Vector],
    zero: Trig,
) -> list[Vector]:
    """Link b's angular velocity in its own axes per unit rate of each formula coordinate (A^-1's columns)."""
    own = {
        j: matvec(transpose(rel[j][b][0]), axes[j]) for j in joints if j in chain and turns[j]
    }  # per unit rate of joint j
    out: list[Vector] = []
    for k in range(len(joints)):
        w = [zero, zero, zero]
        for j, name in enumerate(joints):
            if name in own and back[j, k]:
                w = [x + y.scale(float(back[j, k])) for x, y in zip(w, own[name], strict=True)]
        out.append(w)
    return out
