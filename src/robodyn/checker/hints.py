"""Convention hints: a failing formula that is right in other coordinates, or with gravity or C the other way.

The commonest slip in a hand derivation is not a wrong term but a convention: an angle measured
the other way round, or from another zero (the URDF's hangs down, the textbook's stands up, or
lies a quarter turn away), two joints numbered the other way round, gravity's sign, a C written
transposed. Each gives a wall of mismatches whose terms name nothing of it.

:func:`convention_hints` tries each such convention on the formula values the check has already
evaluated (the formula is not run again): Pinocchio is re-mapped to each candidate's coordinates
(:meth:`robodyn.checker.reference.Reference.remapped`) at the same formula states, on the first
:data:`HINT_SAMPLES` of them, and a candidate is reported when under it M, C, G (and V when the
file gives it) ALL agree, to the check's own tolerance (its rtol of each quantity's scale, or its
round-off floor). The candidates, for q_formula = A q_urdf + b:

* one coordinate i measured the other way (row i of A negated), from another zero (b_i + pi,
  b_i + pi/2, b_i - pi/2; angles only), or both;
* two coordinates of one kind swapped (rows i and k of A and b);
* gravity's sign (G -> -G, V -> -V), or the sign of G alone or of V alone (then the formula's own
  G = dV/dq fails too, and is the one row outside the comparison that may);
* C transposed (the formula's C^T is Pinocchio's C).

Any other failing row outside the formula-vs-Pinocchio group (the formula's own dM/dt - 2C or M = M^T,
or Pinocchio's identities) means something is wrong beyond a convention: no hint then.

Each hint is one line, ``hint: the mismatch vanishes with <the fix>: <why>``; for a ``KIND = "any"``
file the fix is the exact ``COORDINATES`` entry (or ``JOINTS``, ``OFFSETS``) that makes it agree.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.checker.reference import Reference
from robodyn.checker.rows import Accumulator, CheckRow
from robodyn.model.coordinate_map import CoordinateMap

Array = NDArray[np.float64]

HINT_SAMPLES = 8  # states a candidate must agree at: 8 random states leave no coincidence of M, C and G
MAX_HINTS = 3  # a robot symmetric enough to admit more equivalent fixes gets the first three
COMPARED = ("M", "C", "G", "V")  # what a candidate must make agree (the other formula rows follow from them)
GV_ROW = "G = dV/dq (formula)"  # the one row outside the comparison a convention (G's sign alone) may fail
_SHIFTS = ((0.0, ""), (math.pi, "half a turn"), (math.pi / 2, "a quarter turn"), (-math.pi / 2, "a quarter turn"))


@dataclass(frozen=True)
class _Candidate:
    """One convention: Pinocchio's quantities under it, and the line that says it."""

    line: str
    ref: Reference  # Pinocchio re-mapped (the current map for gravity's sign and C transposed)
    tier: int = 0  # 0: one change; 1: a sign and a zero at once (said only when no one change does)
    gravity: float = 1.0  # -1: G negated
    potential: float = 1.0  # -1: V negated
    transpose: bool = False  # True: the formula's C is compared transposed
    inconsistent: bool = False  # True: it makes the formula's G and V disagree (G = dV/dq fails under it)


def convention_hints(
    rows: Sequence[CheckRow],
    kept: Mapping[str, Accumulator],
    states: Sequence[Any],
    ref: Reference,
    kind: str | None,
    names: Sequence[str] = (),
) -> tuple[str, ...]:
    """One line per convention under which everything that mismatched agrees (at most :data:`MAX_HINTS`).

    ``kept``: the check's formula accumulators (pairs (Pinocchio, formula) per state); ``states``:
    the states in the formula's coordinates; ``ref``: Pinocchio in the formula's coordinates;
    ``kind``: the formula's kind (``"any"``: the fix is said as a COORDINATES entry); ``names``: the
    formula's own names of its coordinates (its ``NAMES``; default q1, q2, ...).
    """
    failing = [r for r in rows if r.counts and not r.passed]
    beyond = {r.quantity for r in failing if r.group != "formula"}
    if not failing or beyond - {GV_ROW} or not all(k in kept for k in COMPARED[:3]):
        return ()
    base = ref if not ref.plain else _unit_reference(ref)
    if base is None:
        return ()
    if _agrees(_Candidate("", base), kept, states, base):
        return ()  # M, C, G and V agree as they are: what fails is no convention
    found: list[_Candidate] = []
    for candidate in _candidates(base, kind, names):
        if candidate.inconsistent != (GV_ROW in beyond):
            continue  # G = dV/dq fails exactly when the candidate is G's sign alone or V's alone
        if (not found or candidate.tier <= found[0].tier) and _agrees(candidate, kept, states, base):
            found = [c for c in found if c.tier <= candidate.tier] + [candidate]
    return tuple(c.line for c in sorted(found, key=lambda c: c.tier)[:MAX_HINTS])


def _unit_reference(ref: Reference) -> Reference | None:
    """A built-in kind's Pinocchio coordinates as an explicit identity map (None: a joint with nq != nv)."""
    joints = ref.robot.joints
    if any(j.nq != 1 or j.nv != 1 for j in joints):
        return None
    n = len(joints)
    return Reference.mapped(ref.robot, [j.name for j in joints], np.eye(n), np.zeros(n))


def _candidates(ref: Reference, kind: str | None, coordinates: Sequence[str] = ()) -> Iterator[_Candidate]:
    """Every convention tried, the likeliest first: a sign or a zero, a swap, gravity, C transposed."""
    names = tuple(j.name for j in ref.joint_infos())
    cmap = CoordinateMap(names, ref.A, ref.offsets)
    prismatic = ref.prismatic
    q = tuple(coordinates) if len(coordinates) == len(names) else tuple(f"q{i + 1}" for i in range(len(names)))
    say = _Wording(cmap, prismatic, kind, q)
    for i in range(len(names)):
        for flip in (False, True):
            for shift, turn in _SHIFTS if not prismatic[i] else _SHIFTS[:1]:
                if not flip and not shift:
                    continue
                A, b = ref.A.copy(), ref.offsets.copy()
                if flip:
                    A[i] = -A[i]
                b[i] = b[i] + (-shift if shift == math.pi and b[i] > 0 else shift)  # half a turn: toward 0
                why = _why(i, flip, turn, names, cmap, kind, q)
                yield _Candidate(say.change(i, A, b, why), ref.remapped(A, b), tier=int(flip and bool(shift)))
    for i in range(len(names)):
        for k in range(i + 1, len(names)):
            if prismatic[i] != prismatic[k]:
                continue
            order = list(range(len(names)))
            order[i], order[k] = k, i
            A, b = ref.A[order], ref.offsets[order]
            yield _Candidate(say.swap(i, k, A, b), ref.remapped(A, b))
    yield _Candidate(
        "hint: the mismatch vanishes with gravity's sign reversed: your G (and V) has the opposite sign; "
        "V = m g h grows with the height h against gravity, and G = +dV/dq",
        ref,
        gravity=-1.0,
        potential=-1.0,
    )
    yield _Candidate(
        "hint: the mismatch vanishes with G's sign reversed: your G is -dV/dq of your own V; G = +dV/dq "
        "(the torque gravity asks of the joints, V = m g h growing with the height h)",
        ref,
        gravity=-1.0,
        inconsistent=True,
    )
    yield _Candidate(
        "hint: the mismatch vanishes with V's sign reversed: your V falls as the links rise; V = m g h grows "
        "with the height h against gravity (and G = +dV/dq, as your G has it)",
        ref,
        potential=-1.0,
        inconsistent=True,
    )
    yield _Candidate(
        "hint: the mismatch vanishes with C transposed: your C[i,j] is the Christoffel C[j,i] "
        "(C[i,j] = sum_k Gamma_ijk v_k, Gamma_ijk = 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i))",
        ref,
        transpose=True,
    )


def _why(
    i: int, flip: bool, turn: str, names: Sequence[str], cmap: CoordinateMap, kind: str | None, q: Sequence[str]
) -> str:
    """``q1 is measured the other way round and from another zero, half a turn from the URDF's`` (q: the names)."""
    parts = []
    if flip:
        axis = f" (against the URDF axis of {names[i]})" if cmap.diagonal else ""
        parts.append(f"{q[i]} turns the other way round{axis}")
    if turn:
        hangs = " (the URDF's zero may hang down where yours stands up)" if "half" in turn else ""
        where = "the URDF's" if kind != "any" else f"the one {'COORDINATES' if cmap.diagonal else 'OFFSETS'} gives"
        parts.append(f"{'it' if flip else q[i]} is measured from a zero {turn} from {where}{hangs}")
    return " and ".join(parts)


class _Wording:
    """How a candidate map is said: a COORDINATES entry, JOINTS, OFFSETS, or (a built-in kind) the equation."""

    def __init__(self, cmap: CoordinateMap, prismatic: tuple[bool, ...], kind: str | None, q: Sequence[str]) -> None:
        self.cmap, self.prismatic, self.kind, self.q = cmap, prismatic, kind, q

    def change(self, i: int, A: Array, b: Array, why: str) -> str:
        names = self.cmap.joints
        if self.kind != "any":
            equation = self.cmap.with_rows(A, b).describe(self.prismatic, lambda x: _angle(x).replace("math.", ""))[i]
            pair = f"({A[i, i]:g}, {_angle(_wrap(b[i]))})"
            return (
                f"hint: the mismatch vanishes with {equation}: {why}; the {self.kind} kind takes every angle as the "
                f'URDF measures it, so write the formula in those or as KIND = "any" with '
                f'COORDINATES = {{"{names[i]}": {pair}}}'
            )
        if self.cmap.diagonal:
            pair = f"({A[i, i]:g}, {_angle(_wrap(b[i]))})"
            return f'hint: the mismatch vanishes with COORDINATES["{names[i]}"] = {pair}: {why}'
        fixes = [f"COORDINATES[{i}] = {_row(A[i])}"] if not np.array_equal(A[i], self.cmap.A[i]) else []
        if b[i] != self.cmap.b[i]:
            fixes.append(f"OFFSETS = [{', '.join(_angle(x) for x in b)}]")
        return f"hint: the mismatch vanishes with {' and '.join(fixes)}: {why}"

    def swap(self, i: int, k: int, A: Array, b: Array) -> str:
        why = f"your {self.q[i]} and {self.q[k]} are the other way round"
        names = list(self.cmap.joints)
        if self.kind == "any" and self.cmap.diagonal:
            names[i], names[k] = names[k], names[i]
            return f"hint: the mismatch vanishes with JOINTS = {json.dumps(names)}: {why}"
        if self.kind == "any":
            rows = f"COORDINATES[{i}] and COORDINATES[{k}] swapped (and OFFSETS[{i}] and OFFSETS[{k}])"
            return f"hint: the mismatch vanishes with {rows}: {why}"
        return f"hint: the mismatch vanishes with {self.q[i]} = {names[k]} and {self.q[k]} = {names[i]}: {why}"


def _agrees(c: _Candidate, kept: Mapping[str, Accumulator], states: Sequence[Any], base: Reference) -> bool:
    """True when M, C, G (and V) of the formula agree with Pinocchio under ``c`` at the first HINT_SAMPLES states."""
    anchor = base.anchor()
    v_anchor = c.ref.potential_energy(anchor) if "V" in kept else 0.0
    quantities: dict[str, Callable[[Any], Array]] = {
        "G": lambda s: c.gravity * c.ref.gravity(s.q),
        "M": lambda s: c.ref.mass_matrix(s.q),
        "C": lambda s: c.ref.coriolis_matrix(s.q, s.v).T if c.transpose else c.ref.coriolis_matrix(s.q, s.v),
        "V": lambda s: np.atleast_1d(c.potential * (c.ref.potential_energy(s.q) - v_anchor)),
    }
    used = [k for k in ("G", "M", "C", "V") if k in kept]
    expected = {k: [] for k in used}  # type: dict[str, list[Array]]
    for k, s in enumerate(states[:HINT_SAMPLES]):
        for name in used:
            ref_value = np.atleast_1d(quantities[name](s))
            got = kept[name].pairs[k][1]
            if not np.all(np.isfinite(got)):
                return False
            expected[name].append(ref_value)
            scale = max(float(np.abs(x).max()) for x in expected[name])
            tolerance = max(kept[name].tolerance * scale, kept[name].floor)
            if float(np.abs(got - ref_value).max()) > tolerance:
                return False
    return True


def _row(x: Array) -> str:
    """A row of COORDINATES as Python: whole numbers bare, other floats with every digit."""
    return "[" + ", ".join(f"{int(v)}" if float(v).is_integer() else repr(float(v)) for v in x) + "]"


def _wrap(x: float) -> float:
    """An angle in (-pi, pi] (a +-1 diagonal map is the same at offsets 2 pi apart)."""
    y = math.remainder(x, 2 * math.pi)
    return math.pi if math.isclose(y, -math.pi, abs_tol=1e-12) else y


def _angle(x: float) -> str:
    """``math.pi``, ``-math.pi / 2``, ``0`` or the number: as the file would write it."""
    quarters = x / (math.pi / 4)
    k = round(quarters)
    if abs(quarters - k) < 1e-12 and k != 0:
        text = {4: "math.pi", 2: "math.pi / 2", 1: "math.pi / 4", 3: "3 * math.pi / 4"}.get(abs(k))
        if text is not None:
            return f"-{text}" if k < 0 else text
    return "0" if x == 0 else f"{x:.10g}"
