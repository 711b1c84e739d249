"""The first stages of a derivation: the joints as coordinates, each link's motion, the frames of the tree.

:func:`setup` reads the per-link table into a :class:`Setup` (the joints in the formula's
coordinates, the parameters as variables of the trigonometric polynomials); :func:`local_motions`
gives each link's rotation and offset relative to its parent; :func:`frames` composes them into
each link's frame in every ancestor's and in the base's. :mod:`robodyn.lagrange.derivation` takes M,
G, V and the Christoffel symbols from there. NumPy and :mod:`robodyn.lagrange` only.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from robodyn.lagrange.coordinates import Coordinate, coordinates_of, whole_inverse
from robodyn.lagrange.naming import Param, name_parameters, snap
from robodyn.lagrange.trig import Trig, matmul, matvec
from robodyn.model.coordinate_map import CoordinateMap

Matrix = list[list[Trig]]
Vector = list[Trig]
Frame = tuple[Matrix, Vector]  # (rotation, origin) of a link's frame in another's


@dataclass(frozen=True)
class Setup:
    """What every stage reads: the joints in the formula's coordinates and the parameters as variables.

    ``back`` maps the formula's coordinates to the URDF's (q_urdf = back (q - b)); ``angle_of[i]``
    (``variable_of[i]``) is coordinate i's place among the angles (the other variables), or None.
    """

    links: Mapping[str, Any]
    tree: tuple[str, ...]  # the table's joints, in its order (the moving ones: exactly cmap's)
    cmap: CoordinateMap
    index: Mapping[str, int]  # a joint's column of A (its row of q_urdf)
    turns: Mapping[str, bool]
    back: Any
    angle_of: tuple[int | None, ...]
    variable_of: tuple[int | None, ...]
    n_angles: int
    params: list[Param]
    per_link: Mapping[str, Any]
    pvar: Mapping[str, Trig]
    zero: Trig

    @property
    def joints(self) -> tuple[str, ...]:
        """The moving joints, in the formula's order."""
        return tuple(self.cmap.joints)

    @property
    def n(self) -> int:
        """Degrees of freedom."""
        return len(self.cmap.joints)

    def const(self, x: float) -> Trig:
        """The constant ``x``."""
        return Trig.constant(self.n_angles, x)

    def vec(self, x: Sequence[float]) -> Vector:
        """A 3-vector of constants, snapped."""
        return [self.const(snap(float(v))) for v in x]

    def mat(self, A: Any) -> Matrix:
        """A 3x3 matrix of constants, snapped."""
        return [[self.const(snap(float(A[r][c]))) for c in range(3)] for r in range(3)]


def setup(
    table: Any,
    coordinates: Sequence[Coordinate] | CoordinateMap | None,
    unused: frozenset[str],
    max_joints: int,
    planar: Callable[[Any], Mapping[str, Any]],
) -> Setup:
    """The :class:`Setup` of ``table`` in ``coordinates`` (InputError: too many joints, or ones that do not match)."""
    links = {link.joint: link for link in table.links}
    cmap = coordinates_of(table, coordinates, max_joints)
    joints = cmap.joints
    n = len(joints)
    turns = {name: links[name].joint_type != "prismatic" for name in joints}
    angular = cmap.check_units([not turns[j] for j in joints], "the coordinates")
    angular = tuple(not x for x in angular)
    back = whole_inverse(cmap, angular)
    n_angles = sum(angular)
    first_param = n - n_angles
    params, per_link = name_parameters(table, list(joints), planar=planar(table), unused=unused)
    return Setup(
        links=links,
        tree=tuple(table.joints),
        cmap=cmap,
        index={name: j for j, name in enumerate(joints)},
        turns=turns,
        back=back,
        angle_of=tuple(sum(angular[:i]) if angular[i] else None for i in range(n)),
        variable_of=tuple(sum(not a for a in angular[:i]) if not angular[i] else None for i in range(n)),
        n_angles=n_angles,
        params=params,
        per_link=per_link,
        pvar={p.name: Trig.variable(n_angles, first_param + k) for k, p in enumerate(params)},
        zero=Trig(n_angles),
    )


def local_motions(su: Setup) -> dict[str, Frame]:
    """Each link's motion relative to its parent: rotation A_b and offset t_b (Trig)."""
    local: dict[str, Frame] = {}
    for name in su.tree:
        link, row = su.links[name], su.back[su.index[name]]
        R0, origin, axis = su.mat(link.rotation), su.per_link[name].origin(su.pvar, su.zero), su.vec(link.axis)
        phase = float(row @ su.cmap.b)  # q_urdf = row . q - phase
        if su.turns[name]:
            cos_x, sin_x = _angle_sum([(su.angle_of[k], int(m)) for k, m in enumerate(row) if m], su.n_angles)
            co, so = snap(np.cos(phase)), snap(np.sin(phase))
            cphi = cos_x.scale(co) + sin_x.scale(so)  # cos(x - phase)
            sphi = sin_x.scale(co) - cos_x.scale(so)  # sin(x - phase)
            local[name] = (matmul(R0, _rotation(axis, cphi, sphi, su.const)), origin)
        else:
            d = su.const(-phase)
            for k, m in enumerate(row):
                if m:
                    d = d + Trig.variable(su.n_angles, su.variable_of[k]).scale(float(m))  # type: ignore[arg-type]
            slide = matvec(R0, [a * d for a in axis])
            local[name] = (R0, [o + s for o, s in zip(origin, slide, strict=True)])
    return local


def frames(
    su: Setup, local: Mapping[str, Frame], check: Callable[[str], None]
) -> tuple[dict[str, dict[str, Frame]], dict[str, Frame], Callable[[str], list[str]]]:
    """(rel, world, subtree): rel[k][b] is link b's frame in link k's (b in k's subtree), world[b] in the base's."""
    links, zero = su.links, su.zero
    children: dict[str | None, list[str]] = {}
    for name in su.tree:
        children.setdefault(links[name].parent, []).append(name)

    def subtree(root: str) -> list[str]:
        out, stack = [], [root]
        while stack:
            b = stack.pop(0)
            out.append(b)
            stack.extend(children.get(b, []))
        return out

    eye = su.mat(np.eye(3))
    rel: dict[str, dict[str, Frame]] = {}
    for k in su.tree:
        found = {k: (eye, [zero, zero, zero])}
        for b in subtree(k)[1:]:
            R, p = found[links[b].parent]
            A, t = local[b]
            found[b] = (matmul(R, A), [pi + ti for pi, ti in zip(p, matvec(R, t), strict=True)])
        rel[k] = found
        check(f"the frames below {k}")
    world: dict[str, Frame] = {}
    for b in su.tree:
        parent = links[b].parent
        A, t = local[b]
        if parent is None:
            world[b] = (A, t)
        else:
            R, p = world[parent]
            world[b] = (matmul(R, A), [pi + ti for pi, ti in zip(p, matvec(R, t), strict=True)])
    return rel, world, subtree


def _angle_sum(terms: Sequence[tuple[int | None, int]], n_angles: int) -> tuple[Trig, Trig]:
    """The cos and sin of sum_k m_k q_{a_k} (whole m_k), by the angle-sum rule."""
    c, s = Trig.constant(n_angles, 1.0), Trig(n_angles)
    for angle, m in terms:
        assert angle is not None  # a joint angle combines angles only (CoordinateMap.check_units)
        ca, sa = Trig.cos(n_angles, angle), Trig.sin(n_angles, angle)
        if m < 0:
            sa, m = -sa, -m
        for _ in range(m):
            c, s = c * ca - s * sa, s * ca + c * sa
    return c, s


def _rotation(axis: Vector, c: Trig, s: Trig, const: Callable[[float], Trig]) -> Matrix:
    """Rodrigues: ``c 1 + s [a]x + (1 - c) a a^T``."""
    ax, ay, az = axis
    skew = [[None, -az, ay], [az, None, -ax], [-ay, ax, None]]
    one_minus_c = const(1.0) - c
    out: Matrix = []
    for r in range(3):
        row = []
        for col in range(3):
            term = one_minus_c * axis[r] * axis[col]
            if r == col:
                term = term + c
            else:
                term = term + s * skew[r][col]  # type: ignore[operator]
            row.append(term)
        out.append(row)
    return out
