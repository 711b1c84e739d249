"""The parameters of a derivation, named per link as a textbook names them.

Link i (the joint of the formula's coordinate q_i) has the mass ``m{i}``; its centre of mass
``lc{i}`` when it lies on one axis of the joint frame (else ``lcx{i}``, ``lcy{i}``, ``lcz{i}``);
the offset from joint i to its child joint ``l{i}`` (``lx{i}``, ``ly{i}``, ``lz{i}`` off an
axis; ``l{i}_{k}`` when joint i carries several, k the child's coordinate; ``l0`` from the base
to the first joint); its inertia about the centre of mass ``I{i}`` when every joint turning it
has one axis (a planar chain: the moment about that axis), else the tensor's entries ``Ixx{i}``,
``Iyy{i}``, ``Izz{i}``, ``Ixy{i}``, ``Ixz{i}``, ``Iyz{i}``; the reflected rotor inertia ``Ja{i}``;
and ``g``. Parameters that are zero in the model are dropped. Each :class:`Param` carries its
value, unit and the Python expression that reads it from a per-link table (``robot``), which the
generated formula file's ``parameters(robot)`` uses.

Imports only NumPy and :mod:`robodyn.lagrange.trig`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from robodyn.lagrange.trig import Trig

SNAP_TOL = 1e-11
"""A rotation entry or axis component this close to 0, +-1/2 or +-1 is exact (ur5 prints pi/2 to 5e-12)."""

DROP_TOL = 0.0
"""Only exact zeros are dropped: hextilt's inertia entries of 5e-13 kg m^2, left out, move its C v by 1e-10 relative."""

AXES = "xyz"


def snap(x: float) -> float:
    """``x`` rounded to 0, +-1/2 or +-1 when within :data:`SNAP_TOL`, else itself."""
    for target in (0.0, 1.0, -1.0, 0.5, -0.5):
        if abs(x - target) < SNAP_TOL:
            return target
    return float(x)


@dataclass(frozen=True)
class Param:
    """One named parameter: its value [unit] and the expression that reads it from a per-link table ``robot``."""

    name: str
    value: float
    unit: str
    code: str
    meaning: str


Getter = Callable[[Mapping[str, Trig], Trig], Any]


@dataclass(frozen=True)
class LinkTerms:
    """How one link's quantities are written in its parameters (each a function of the parameter Trigs)."""

    mass: Callable[[Mapping[str, Trig], Trig], Trig]
    com: Callable[[Mapping[str, Trig], Trig], list[Trig]]
    origin: Callable[[Mapping[str, Trig], Trig], list[Trig]]
    inertia: Callable[[Mapping[str, Trig], Trig], list[list[Trig]]]
    armature: Callable[[Mapping[str, Trig], Trig], Trig]


def name_parameters(
    table: Any,
    order: Sequence[str],
    *,
    planar: Mapping[str, np.ndarray | None],
    unused: frozenset[str] = frozenset(),
) -> tuple[list[Param], dict[str, LinkTerms]]:
    """The parameters of ``table`` (links numbered by ``order``) and how each link is written in them.

    ``planar[joint]`` is the one axis (link axes) about which the link turns, a zero vector when
    it does not turn, or None when it turns about several (then the whole inertia tensor enters).
    ``unused`` names parameters a first pass found in none of M, G and V (an offset along the
    axis of a planar chain): they are left out as if zero, so that the component that remains
    takes the single name (``l1``, not ``lx1``).
    """
    links = {link.joint: link for link in table.links}
    number = {joint: i + 1 for i, joint in enumerate(order)}
    children: dict[str | None, list[str]] = {}
    for joint in table.joints:
        children.setdefault(links[joint].parent, []).append(joint)
    params: list[Param] = []
    terms: dict[str, LinkTerms] = {}

    def add(name: str, value: float, unit: str, code: str, meaning: str) -> str | None:
        if abs(value) <= DROP_TOL or name in unused:
            return None
        params.append(Param(name, float(value), unit, code, meaning))
        return name

    for joint in order:
        i, link = number[joint], links[joint]
        ref = f"robot[{joint!r}]"
        mass = add(f"m{i}", link.mass, "kg", f"{ref}.mass", f"mass of link {i} ({joint})")
        com = (
            _vector(
                add,
                f"lc{i}",
                f"lc{{axis}}{i}",
                np.asarray(link.com),
                f"{ref}.com",
                f"centre of mass of link {i}",
                unused,
            )
            if mass
            else [None, None, None]
        )
        inertia = _inertia(add, i, ref, np.asarray(link.inertia), planar[joint])
        armature = add(
            f"Ja{i}", link.armature, _unit(link, "kg m^2", "kg"), f"{ref}.armature", f"rotor inertia of joint {i}"
        )
        terms[joint] = LinkTerms(
            mass=_scalar(mass),
            com=_vec(com),
            origin=_vec([None, None, None]),  # filled below, once every link is numbered
            inertia=_mat(inertia),
            armature=_scalar(armature),
        )
    for parent, kids in children.items():
        p = number[parent] if parent is not None else 0
        for kid in kids:
            k = number[kid]
            stem = f"{p}" if len(kids) == 1 else f"{p}_{k}"
            what = f"offset from joint {p} to joint {k}" if p else f"offset from the base to joint {k}"
            origin = _vector(
                add,
                f"l{stem}",
                f"l{{axis}}{stem}",
                np.asarray(links[kid].origin),
                f"robot[{kid!r}].origin",
                what,
                unused,
            )
            old = terms[kid]
            terms[kid] = LinkTerms(old.mass, old.com, _vec(origin), old.inertia, old.armature)
    if any(abs(link.mass) > DROP_TOL for link in table.links):
        add("g", float(table.g), "m/s^2", "robot.g", "gravity")
    return _sorted(params, order), terms


def _unit(link: Any, angular: str, linear: str) -> str:
    return linear if link.joint_type == "prismatic" else angular


def _sorted(params: list[Param], order: Sequence[str]) -> list[Param]:
    """Link by link (m1, lc1, l1, I1, ..., m2, ...), then g."""

    def key(p: Param) -> tuple[int, int]:
        digits = "".join(ch if ch.isdigit() else " " for ch in p.name).split()
        link = int(digits[0]) if digits else len(order) + 1
        stem = p.name.rstrip("0123456789_")
        kind = 1 if stem.startswith("lc") else {"m": 0, "l": 2, "I": 3, "J": 4}.get(stem[:1], 5)
        return link, kind

    return sorted(params, key=key)


def _vector(
    add: Callable[..., str | None],
    single: str,
    per_axis: str,
    x: np.ndarray,
    code: str,
    meaning: str,
    unused: frozenset[str] = frozenset(),
) -> list[tuple[str, float] | None]:
    """A vector as ``single`` times a signed unit axis when on one axis, else one name per non-zero component.

    Returns per component (name, factor) or None: component k = factor * param.
    """
    nonzero = [k for k in range(3) if abs(x[k]) > DROP_TOL and per_axis.format(axis=AXES[k]) not in unused]
    if len(nonzero) == 1:
        k = nonzero[0]
        sign = 1.0 if x[k] > 0 else -1.0
        name = add(
            single,
            abs(float(x[k])),
            "m",
            f"{'-' if sign < 0 else ''}{code}[{k}]",
            f"{meaning} (along {'-' if sign < 0 else '+'}{AXES[k]})",
        )
        out: list[tuple[str, float] | None] = [None, None, None]
        if name:
            out[k] = (name, sign)
        return out
    return [
        (n, 1.0)
        if (n := add(per_axis.format(axis=AXES[k]), float(x[k]), "m", f"{code}[{k}]", f"{meaning} ({AXES[k]})"))
        else None
        for k in range(3)
    ]


def _inertia(
    add: Callable[..., str | None], i: int, ref: str, I: np.ndarray, axis: np.ndarray | None
) -> list[list[tuple[str, float] | None]] | tuple[str, np.ndarray] | None:
    """The inertia's parameters: (name, u) for one moment about u, a 3x3 of (name, 1) entries, or None."""
    if axis is not None:
        if not np.any(axis):
            return None  # the link never turns
        k = int(np.argmax(np.abs(axis)))
        if abs(abs(axis[k]) - 1.0) < 1e-15:
            code = f"{ref}.inertia[{k}, {k}]"
        else:
            u = ", ".join(repr(float(a)) for a in axis)
            code = f"float(np.array([{u}]) @ {ref}.inertia @ np.array([{u}]))"
        name = add(f"I{i}", float(axis @ I @ axis), "kg m^2", code, f"moment of inertia of link {i} about its axis")
        return (name, axis) if name else None
    out: list[list[tuple[str, float] | None]] = [[None] * 3 for _ in range(3)]
    for r in range(3):
        for c in range(r, 3):
            name = add(
                f"I{AXES[r]}{AXES[c]}{i}", float(I[r, c]), "kg m^2", f"{ref}.inertia[{r}, {c}]", f"inertia of link {i}"
            )
            if name:
                out[r][c] = out[c][r] = (name, 1.0)
    return out


def _scalar(name: str | None) -> Callable[[Mapping[str, Trig], Trig], Trig]:
    def get(p: Mapping[str, Trig], zero: Trig) -> Trig:
        return p[name] if name else zero

    return get


def _vec(entries: Sequence[tuple[str, float] | None]) -> Callable[[Mapping[str, Trig], Trig], list[Trig]]:
    def get(p: Mapping[str, Trig], zero: Trig) -> list[Trig]:
        return [p[e[0]].scale(e[1]) if e else zero for e in entries]

    return get


def _mat(spec: Any) -> Callable[[Mapping[str, Trig], Trig], list[list[Trig]]]:
    def get(p: Mapping[str, Trig], zero: Trig) -> list[list[Trig]]:
        if spec is None:
            return [[zero] * 3 for _ in range(3)]
        if isinstance(spec, tuple):  # one moment I about the axis u: I u u^T
            name, u = spec
            return [[p[name].scale(float(u[r] * u[c])) for c in range(3)] for r in range(3)]
        return [[p[e[0]].scale(e[1]) if e else zero for e in row] for row in spec]

    return get
