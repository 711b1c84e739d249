"""Parameters of the built-in kinds, read from a loaded model so one formula serves every URDF.

``extract(robot, kind)`` checks the kind's assumptions (joint types and axes, the link
line, the centre of mass on it, no extra moving joints, no armature where the formula has
none) and raises :class:`AssumptionError` naming the first one broken. Inertial frames with
``rpy`` are handled: the moment of inertia about the joint axis is a^T R I R^T a.

Conventions (see the README): Pendubot planar in x-z, axes 0 -1 0, links along +x at q = 0;
cart-pole rail along +x, pole axis 0 1 0, pole up at theta = 0; geared arm hanging down
at q = 0 with a horizontal axis.
"""

from __future__ import annotations

import reprlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.errors import AssumptionError, InputError
from robodyn.fileio import is_number
from robodyn.kinds.formulas import closed_form
from robodyn.kinds.units import RENAMED
from robodyn.registry import Registry
from robodyn.robot import Robot

Array = NDArray[np.float64]

# Geometric tests (axes parallel, COM on the link line) allow this much [m or unit-vector
# component]: URDF numbers are printed to ~1e-9 at best.
GEOMETRY_TOL = 1e-9

EX, EY, EZ = np.eye(3)


@dataclass(frozen=True)
class Params(Mapping[str, float]):
    """Named parameters of a kind (SI units), e.g. ``p["m1"]`` [kg], ``p["l1"]`` [m]."""

    kind: str
    table: Mapping[str, float]

    def __getitem__(self, key: str) -> float:
        if key not in self.table and (self.kind, key) in RENAMED:
            raise KeyError(
                f"{key!r}: the {self.kind}'s parameter {key} is now {RENAMED[self.kind, key]!r} (M is the mass matrix)"
            )
        return self.table[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.table)

    def __len__(self) -> int:
        return len(self.table)

    def as_dict(self) -> dict[str, float]:
        """A plain dict copy."""
        return dict(self.table)


@dataclass(frozen=True)
class _Body:
    """One moving joint and the body it carries, at q = neutral, in world coordinates."""

    name: str
    kind: str
    nq: int
    origin: Array  # joint origin [m]
    linear_axis: Array
    angular_axis: Array
    mass: float  # [kg]
    com: Array  # centre of mass [m]
    inertia_com: Array  # (3, 3) about the COM, world axes [kg m^2]
    armature: float
    parent: int


def _bodies(robot: Robot) -> list[_Body]:
    model = robot.model
    frames = dynamics.joint_frames(model, robot.data, robot.neutral())
    bodies = []
    for j, (placement, lin, ang) in enumerate(frames, start=1):
        R, p = placement[:3, :3], placement[:3, 3]
        inertia = model.inertias[j]
        I_local = np.array(inertia.inertia)
        info = robot.joints[j - 1]
        bodies.append(
            _Body(
                name=info.name,
                kind=info.kind,
                nq=info.nq,
                origin=p,
                linear_axis=lin,
                angular_axis=ang,
                mass=float(inertia.mass),
                com=p + R @ np.array(inertia.lever),
                inertia_com=R @ I_local @ R.T,
                armature=float(model.armature[info.idx_v]) if info.nv else 0.0,
                parent=int(model.parents[j]),
            )
        )
    return bodies


def _fail(kind: str, message: str) -> AssumptionError:
    return AssumptionError(f"not a {kind}: {message}")


def _same(a: Array, b: Array) -> bool:
    return bool(np.allclose(a, b, rtol=0.0, atol=GEOMETRY_TOL))


def _fmt(x: Array) -> str:
    return "(" + " ".join(f"{c + 0.0:.6g}" for c in x) + ")"  # + 0.0 prints -0 as 0


def _require_joints(kind: str, bodies: list[_Body], expected: tuple[str, ...]) -> None:
    """Check count, chain and type ('R' revolute with a plain angle, 'P' prismatic)."""
    if len(bodies) != len(expected):
        names = ", ".join(f"{b.name} ({b.kind})" for b in bodies) or "none"
        raise _fail(kind, f"expected {len(expected)} moving joint(s), found {len(bodies)}: {names}")
    for i, (body, want) in enumerate(zip(bodies, expected, strict=True)):
        if body.parent != i:
            raise _fail(kind, f"joint {body.name} must be a child of {'the base' if i == 0 else bodies[i - 1].name}")
        if body.nq != 1:
            raise _fail(
                kind,
                f"joint {body.name} ({body.kind}) has nq = {body.nq}; the formula needs a plain coordinate "
                "(use type revolute or prismatic, not continuous)",
            )
        revolute = np.linalg.norm(body.angular_axis) > 0.5 and np.linalg.norm(body.linear_axis) < GEOMETRY_TOL
        prismatic = np.linalg.norm(body.linear_axis) > 0.5 and np.linalg.norm(body.angular_axis) < GEOMETRY_TOL
        if (want == "R" and not revolute) or (want == "P" and not prismatic):
            raise _fail(kind, f"joint {body.name} ({body.kind}) must be {'revolute' if want == 'R' else 'prismatic'}")


def _require_axis(kind: str, body: _Body, axis: Array, which: str) -> None:
    got = body.angular_axis if which == "angular" else body.linear_axis
    if not _same(got, axis):
        raise _fail(kind, f"joint {body.name} axis is {_fmt(got)} in world, expected {_fmt(axis)}")


def _require_gravity(kind: str, robot: Robot) -> float:
    g_vec = np.array(robot.model.gravity.linear)
    g = float(np.linalg.norm(g_vec))
    if g == 0.0 or not _same(g_vec / g, -EZ):
        raise _fail(kind, f"gravity is {_fmt(g_vec)} m/s^2, expected along -z")
    return g


def _require_no_armature(kind: str, bodies: list[_Body]) -> None:
    for body in bodies:
        if body.armature != 0.0:
            raise _fail(
                kind,
                f"joint {body.name} has armature {body.armature:.6g} kg m^2; the {kind} formula has no rotor inertia",
            )


def _in_plane(vector: Array, axis: Array) -> Array:
    """Component of ``vector`` perpendicular to ``axis`` (offsets along an axis change nothing)."""
    return vector - (vector @ axis) * axis


def _along(kind: str, what: str, vector: Array, direction: Array, axis: Array) -> float:
    """Signed length of ``vector`` along ``direction``; it must have nothing else in the plane."""
    planar = _in_plane(vector, axis)
    length = float(planar @ direction)
    off = planar - length * direction
    if np.linalg.norm(off) > GEOMETRY_TOL:
        raise _fail(kind, f"{what} is off the line {_fmt(direction)} by {_fmt(off)} m at q = 0")
    return length


def _axis_inertia(body: _Body, axis: Array) -> float:
    return float(axis @ body.inertia_com @ axis)


def _pendubot(robot: Robot) -> dict[str, float]:
    kind = "pendubot"
    bodies = _bodies(robot)
    _require_joints(kind, bodies, ("R", "R"))
    axis = -EY
    for body in bodies:
        _require_axis(kind, body, axis, "angular")
    g = _require_gravity(kind, robot)
    _require_no_armature(kind, bodies)
    b1, b2 = bodies
    l1 = _along(kind, f"joint {b2.name} (link 1's end)", b2.origin - b1.origin, EX, axis)
    lc1 = _along(kind, f"the centre of mass of link 1 ({b1.name})", b1.com - b1.origin, EX, axis)
    lc2 = _along(kind, f"the centre of mass of link 2 ({b2.name})", b2.com - b2.origin, EX, axis)
    if l1 <= 0:
        raise _fail(
            kind, f"link 1 must point along +x at q = 0 (joint {b2.name} is at x = {l1:.6g} m from joint {b1.name})"
        )
    return {
        "m1": b1.mass,
        "m2": b2.mass,
        "l1": l1,
        "lc1": lc1,
        "lc2": lc2,
        "I1": _axis_inertia(b1, axis),
        "I2": _axis_inertia(b2, axis),
        "g": g,
    }


def _cart_pole(robot: Robot) -> dict[str, float]:
    kind = "cart_pole"
    bodies = _bodies(robot)
    _require_joints(kind, bodies, ("P", "R"))
    cart, pole = bodies
    _require_axis(kind, cart, EX, "linear")
    _require_axis(kind, pole, EY, "angular")
    g = _require_gravity(kind, robot)
    _require_no_armature(kind, bodies)
    l = _along(kind, f"the pole's centre of mass ({pole.name})", pole.com - pole.origin, EZ, EY)
    return {"m_cart": cart.mass, "m": pole.mass, "l": l, "I": _axis_inertia(pole, EY), "g": g}


def _geared_arm(robot: Robot) -> dict[str, float]:
    kind = "geared_arm"
    bodies = _bodies(robot)
    _require_joints(kind, bodies, ("R",))
    (arm,) = bodies
    axis = arm.angular_axis
    if abs(axis @ EZ) > GEOMETRY_TOL:
        raise _fail(kind, f"joint {arm.name} axis {_fmt(axis)} must be horizontal (perpendicular to gravity)")
    g = _require_gravity(kind, robot)
    l = _along(kind, f"the link's centre of mass ({arm.name})", arm.com - arm.origin, -EZ, axis)
    idx = robot.joint(arm.name).idx_v
    J_m = float(robot.model.rotorInertia[idx])
    n = float(robot.model.rotorGearRatio[idx])
    if J_m == 0.0:
        # Armature given without rotor parameters: read it as a rotor on a 1:1 drive.
        J_m, n = arm.armature, 1.0
    elif not np.isclose(arm.armature, J_m * n**2, rtol=1e-12, atol=0.0):
        raise _fail(
            kind,
            f"armature {arm.armature:.6g} kg m^2 of joint {arm.name} is not J_m n^2 = {J_m * n**2:.6g} "
            "(load rotor parameters once, from the SRDF)",
        )
    J_l = _axis_inertia(arm, axis) + arm.mass * float(np.sum(_in_plane(arm.com - arm.origin, axis) ** 2))
    return {"J_m": J_m, "J_l": J_l, "n": n, "m": arm.mass, "l": l, "g": g}


EXTRACTORS: Registry = Registry("formula kind")
EXTRACTORS.register("pendubot", _pendubot)
EXTRACTORS.register("cart_pole", _cart_pole)
EXTRACTORS.register("geared_arm", _geared_arm)


def extract(robot: Robot, kind: str) -> Params:
    """The parameters of ``kind`` read from ``robot``; AssumptionError if it is not one."""
    values = EXTRACTORS.get(kind)(robot)
    return Params(kind, values)


def from_mapping(kind: str, values: Mapping[str, object]) -> Params:
    """Parameters given by the user (e.g. a datasheet), checked against the kind's names."""
    names = closed_form(kind).params
    missing = [n for n in names if n not in values]
    extra = [n for n in values if n not in names]
    if missing or extra:
        raise InputError(
            f"{kind} parameters must be exactly {', '.join(names)}"
            + (f"; missing {', '.join(missing)}" if missing else "")
            + (f"; unknown {', '.join(extra)}" if extra else "")
        )
    out: dict[str, float] = {}
    for n in names:
        value = values[n]
        if not is_number(value):  # an integer of 400 digits too: it has no float
            raise InputError(f"parameter {n} must be a finite number, got {reprlib.repr(value)}")
        out[n] = float(value)  # type: ignore[arg-type]  # is_number: a finite int or float
    return Params(kind, out)


def detect_kind(robot: Robot) -> str | None:
    """The first built-in kind whose assumptions ``robot`` meets, or None."""
    for kind in EXTRACTORS.names():
        try:
            EXTRACTORS.get(kind)(robot)
        except AssumptionError:
            continue
        return kind
    return None
