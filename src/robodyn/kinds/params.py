"""Parameters of the built-in kinds, read from a loaded model so one formula serves every URDF.

``extract(robot, kind)`` hands the model's moving bodies (:func:`bodies`, plain arrays at q = 0)
to the kind's own reader (``Kind.read``, in the kind's module), which checks the kind's assumptions
(joint types and axes, the link line, the centre of mass on it, no extra moving joints, no armature
where the formula has none) and raises :class:`AssumptionError` naming the first one broken.
Inertial frames with ``rpy`` are handled: the moment of inertia about the joint axis is a^T R I R^T a.

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
from robodyn.kinds import catalog
from robodyn.kinds.bodies import Body
from robodyn.kinds.units import RENAMED
from robodyn.robot import Robot

Array = NDArray[np.float64]


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


def bodies(robot: Robot) -> list[Body]:
    """The moving bodies of ``robot`` at q = neutral, in world coordinates (what a kind's reader reads)."""
    model = robot.model
    frames = dynamics.joint_frames(model, robot.data, robot.neutral())
    out = []
    for j, (placement, lin, ang) in enumerate(frames, start=1):
        R, p = placement[:3, :3], placement[:3, 3]
        inertia = model.inertias[j]
        info = robot.joints[j - 1]
        idx = info.idx_v
        out.append(
            Body(
                name=info.name,
                kind=info.kind,
                nq=info.nq,
                origin=p,
                linear_axis=lin,
                angular_axis=ang,
                mass=float(inertia.mass),
                com=p + R @ np.array(inertia.lever),
                inertia_com=R @ np.array(inertia.inertia) @ R.T,
                armature=float(model.armature[idx]) if info.nv else 0.0,
                parent=int(model.parents[j]),
                rotor_inertia=float(model.rotorInertia[idx]) if info.nv else 0.0,
                gear_ratio=float(model.rotorGearRatio[idx]) if info.nv else 0.0,
            )
        )
    return out


def _read(robot: Robot, kind: str) -> dict[str, float]:
    return catalog.kind(kind).read(bodies(robot), np.array(robot.model.gravity.linear, dtype=np.float64))


def extract(robot: Robot, kind: str) -> Params:
    """The parameters of ``kind`` read from ``robot``; AssumptionError if it is not one."""
    values = _read(robot, kind)
    return Params(kind, values)


def from_mapping(kind: str, values: Mapping[str, object]) -> Params:
    """Parameters given by the user (e.g. a datasheet), checked against the kind's names."""
    names = catalog.kind(kind).params
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
    for kind in catalog.names():
        try:
            _read(robot, kind)
        except AssumptionError:
            continue
        return kind
    return None
