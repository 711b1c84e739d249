"""What a run is asked to respect: the frozen :class:`Constraints` spec and its validation.

One value holds every option of the constraint engine -- joint stops and their restitution,
effort limits, loop closures, couplings and joint springs -- checked when it is built, so that
``robodyn.simulate``'s keyword arguments, a scene's ``[constraints]``/``[springs]`` tables and a
JSON file all go through the same door:

    Constraints.build(limits=True, restitution=0.0, loops=[{"frame_a": "bc_tip", "frame_b": "collar"}],
                      couplings=[{"joint": "spin", "leader": "slide", "ratio": 3.0303}],
                      springs={"joint_a": {"stiffness": 5.0, "rest": 0.0}})
    Constraints.from_mapping(table, springs=springs_table, where="scene.toml [constraints]")

Every refusal is one :class:`~robodyn.errors.InputError` line naming the entry, what was
expected and what came. Names are checked against a robot later (:mod:`robodyn.sim.plant`),
where the close matches are known.
"""

from __future__ import annotations

import reprlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from robodyn.errors import InputError
from robodyn.fileio import is_number

LOOP_KINDS = ("point", "6d")
_LOOP_KEYS = ("frame_a", "frame_b", "kind")
_COUPLING_KEYS = ("joint", "leader", "ratio", "offset")
_SPRING_KEYS = ("stiffness", "rest")
_TABLE_KEYS = ("limits", "restitution", "effort_limits", "loops", "couplings", "springs")


# The largest |ratio| of a coupling: the follower's armature and damping enter the leader's times ratio^2, and a
# gear train of a million to one is already past any real one (1e200 would overflow that product).
MAX_COUPLING_RATIO = 1e6


def _number(value: Any, what: str) -> float:
    if not is_number(value):
        raise InputError(f"{what} must be a finite number, got {reprlib.repr(value)}")
    return float(value)


def _name(value: Any, what: str) -> str:
    if not isinstance(value, str) or not value:
        raise InputError(f"{what} must be a non-empty name (a string), got {value!r}")
    return value


def _flag(value: Any, what: str) -> bool:
    if not isinstance(value, bool):
        raise InputError(f"{what} must be true or false, got {value!r}")
    return value


def _keys(entry: Mapping[str, Any], allowed: tuple[str, ...], what: str) -> None:
    unknown = sorted(set(entry) - set(allowed))
    if unknown:
        raise InputError(f"{what}: unknown key {unknown[0]!r}; expected {', '.join(allowed)}")


@dataclass(frozen=True)
class Loop:
    """Two frames held together: ``"point"`` (their origins coincide) or ``"6d"`` (the frames coincide).

    Frames are URDF link names, or the other frames Pinocchio makes (joints, fixed joints).
    """

    frame_a: str
    frame_b: str
    kind: str = "point"

    def __post_init__(self) -> None:
        _name(self.frame_a, "loop frame_a")
        _name(self.frame_b, "loop frame_b")
        if self.kind not in LOOP_KINDS:
            raise InputError(f"loop kind must be one of {', '.join(LOOP_KINDS)}, got {self.kind!r}")
        if self.frame_a == self.frame_b:
            raise InputError(f"loop holds frame {self.frame_a!r} on itself: give two different frames")

    def describe(self) -> str:
        """``bc_tip ~ collar (point)``."""
        return f"{self.frame_a} ~ {self.frame_b} ({self.kind})"


@dataclass(frozen=True)
class Coupling:
    """q_joint = ratio * q_leader + offset: the follower ``joint`` carried by ``leader`` [rad | m]."""

    joint: str
    leader: str
    ratio: float
    offset: float = 0.0

    def __post_init__(self) -> None:
        _name(self.joint, "coupling joint")
        _name(self.leader, "coupling leader")
        ratio = _number(self.ratio, f"coupling {self.joint!r} ratio")
        if abs(ratio) > MAX_COUPLING_RATIO:
            raise InputError(
                f"coupling {self.joint!r}: ratio must be at most {MAX_COUPLING_RATIO:g} in magnitude, got {ratio:g}"
            )
        _number(self.offset, f"coupling {self.joint!r} offset")
        if ratio == 0.0:
            raise InputError(f"coupling {self.joint!r}: ratio must be non-zero (a zero ratio locks the joint)")
        if self.joint == self.leader:
            raise InputError(f"coupling cycle: joint {self.joint!r} follows itself")

    def describe(self) -> str:
        """``spin = 3.0303 * slide + 0``."""
        return f"{self.joint} = {self.ratio:g} * {self.leader} + {self.offset:g}"


@dataclass(frozen=True)
class Spring:
    """A joint spring tau = -stiffness (q - rest): stiffness [N m/rad | N/m] >= 0, rest [rad | m]."""

    stiffness: float
    rest: float = 0.0

    def __post_init__(self) -> None:
        k = _number(self.stiffness, "spring stiffness")
        _number(self.rest, "spring rest")
        if k < 0:
            raise InputError(f"spring stiffness must be >= 0 [N m/rad | N/m], got {k:g}")


@dataclass(frozen=True)
class Constraints:
    """Everything a run must respect; the default is the URDF's stops and efforts, nothing more.

    Attributes:
        limits: enforce the URDF joint limits as stops (False: joints pass through them).
        restitution: e in [0, 1]: the speed into a stop comes back times e (0: inelastic).
        effort_limits: clamp the commanded torque at the URDF ``effort`` of each joint.
        loops: loop closures.
        couplings: joints carried by others (mimic joints).
        springs: (joint name, spring) pairs, one per joint.
    """

    limits: bool = True
    restitution: float = 0.0
    effort_limits: bool = True
    loops: tuple[Loop, ...] = ()
    couplings: tuple[Coupling, ...] = ()
    springs: tuple[tuple[str, Spring], ...] = field(default=())

    def __post_init__(self) -> None:
        _flag(self.limits, "limits")
        _flag(self.effort_limits, "effort_limits")
        e = _number(self.restitution, "restitution")
        if not 0.0 <= e <= 1.0:
            raise InputError(f"restitution must lie in [0, 1] (0 inelastic, 1 elastic), got {e:g}")
        followers = [c.joint for c in self.couplings]
        twice = sorted({j for j in followers if followers.count(j) > 1})
        if twice:
            raise InputError(f"coupling: joint {twice[0]!r} follows two leaders; give it one coupling")
        _refuse_cycles(self.couplings)
        names = [name for name, _ in self.springs]
        if len(set(names)) != len(names):
            raise InputError("springs: a joint has two springs; give one spring per joint")

    @property
    def spring_map(self) -> dict[str, Spring]:
        """Joint name -> spring."""
        return dict(self.springs)

    @property
    def is_default(self) -> bool:
        """True when nothing beyond the URDF's stops and efforts is asked for."""
        return self == Constraints()

    @classmethod
    def build(
        cls,
        *,
        limits: bool = True,
        restitution: float = 0.0,
        effort_limits: bool = True,
        loops: Iterable[Loop | Mapping[str, Any]] = (),
        couplings: Iterable[Coupling | Mapping[str, Any]] = (),
        springs: Mapping[str, Spring | Mapping[str, Any] | tuple[float, float] | float] | None = None,
    ) -> Constraints:
        """The spec from keyword arguments; loops, couplings and springs may be dicts.

        ``springs`` maps a joint name to a :class:`Spring`, a dict ``{"stiffness": k, "rest": r}``,
        a pair (k, rest) or a bare stiffness k (rest 0).
        """
        return cls(
            limits=limits,
            restitution=restitution,
            effort_limits=effort_limits,
            loops=tuple(_loop(x, i) for i, x in enumerate(_sequence(loops, "loops"))),
            couplings=tuple(_coupling(x, i) for i, x in enumerate(_sequence(couplings, "couplings"))),
            springs=tuple(_springs(springs)),
        )

    @classmethod
    def from_mapping(
        cls, table: Mapping[str, Any] | None, *, springs: Mapping[str, Any] | None = None, where: str = "constraints"
    ) -> Constraints:
        """The spec from a scene's ``[constraints]`` table (and ``[springs]``), or a JSON object.

        ``springs`` may also sit inside ``table``. Errors start with ``where``.
        """
        table = dict(table or {})
        try:
            _keys(table, _TABLE_KEYS, where)
            inner = table.pop("springs", None)
            if inner is not None and springs is not None:
                raise InputError(f"{where}: springs are given twice (inside and outside the table)")
            return cls.build(**table, springs=springs if springs is not None else inner)
        except InputError as exc:
            message = str(exc)
            raise InputError(message if message.startswith(where) else f"{where}: {message}") from None

    def describe(self) -> dict[str, Any]:
        """The spec as plain data, for a trajectory's metadata."""
        return {
            "limits": self.limits,
            "restitution": self.restitution,
            "effort_limits": self.effort_limits,
            "loops": [{"frame_a": x.frame_a, "frame_b": x.frame_b, "kind": x.kind} for x in self.loops],
            "couplings": [
                {"joint": c.joint, "leader": c.leader, "ratio": c.ratio, "offset": c.offset} for c in self.couplings
            ],
            "springs": {name: {"stiffness": s.stiffness, "rest": s.rest} for name, s in self.springs},
        }


def _sequence(value: Any, what: str) -> list[Any]:
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, Iterable):
        raise InputError(f"{what} must be a list, got {value!r}")
    return list(value)


def _loop(x: Loop | Mapping[str, Any], i: int) -> Loop:
    if isinstance(x, Loop):
        return x
    if not isinstance(x, Mapping):
        raise InputError(f"loops[{i}] must be a table {{frame_a, frame_b, kind}}, got {x!r}")
    _keys(x, _LOOP_KEYS, f"loops[{i}]")
    for key in ("frame_a", "frame_b"):
        if key not in x:
            raise InputError(f"loops[{i}]: missing {key} (a frame name)")
    return Loop(x["frame_a"], x["frame_b"], x.get("kind", "point"))


def _coupling(x: Coupling | Mapping[str, Any], i: int) -> Coupling:
    if isinstance(x, Coupling):
        return x
    if not isinstance(x, Mapping):
        raise InputError(f"couplings[{i}] must be a table {{joint, leader, ratio, offset}}, got {x!r}")
    _keys(x, _COUPLING_KEYS, f"couplings[{i}]")
    for key in ("joint", "leader", "ratio"):
        if key not in x:
            raise InputError(f"couplings[{i}]: missing {key}")
    return Coupling(x["joint"], x["leader"], x["ratio"], x.get("offset", 0.0))


def _springs(springs: Mapping[str, Any] | None) -> list[tuple[str, Spring]]:
    if springs is None:
        return []
    if not isinstance(springs, Mapping):
        raise InputError(f"springs must map joint names to {{stiffness, rest}}, got {springs!r}")
    out = []
    for name, x in springs.items():
        _name(name, "spring joint")
        if isinstance(x, Spring):
            spring = x
        elif isinstance(x, Mapping):
            _keys(x, _SPRING_KEYS, f"springs.{name}")
            if "stiffness" not in x:
                raise InputError(f"springs.{name}: missing stiffness [N m/rad | N/m]")
            spring = _spring(name, x["stiffness"], x.get("rest", 0.0))
        elif isinstance(x, tuple) and len(x) == 2:
            spring = _spring(name, *x)
        else:
            spring = _spring(name, x, 0.0)
        out.append((name, spring))
    return out


def _spring(name: str, stiffness: Any, rest: Any) -> Spring:
    try:
        return Spring(stiffness, rest)
    except InputError as exc:
        raise InputError(f"springs.{name}: {exc}") from None


def _refuse_cycles(couplings: tuple[Coupling, ...]) -> None:
    """A follower whose chain of leaders comes back to it is a cycle: one line naming it."""
    leader_of = {c.joint: c.leader for c in couplings}
    for start in leader_of:
        chain = [start]
        joint = start
        while joint in leader_of:
            joint = leader_of[joint]
            if joint in chain:
                loop = [*chain[chain.index(joint) :], joint]
                raise InputError(f"coupling cycle: {' -> '.join(loop)} (each joint follows the next); break the cycle")
            chain.append(joint)
