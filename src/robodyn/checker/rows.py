"""The pieces every ``robodyn check`` is made of: its rows, its report, and the points a formula is evaluated at.

A :class:`CheckRow` is one compared quantity reduced to its worst error over the samples;
a :class:`CheckReport` is everything one check found. :class:`Accumulator` collects
(reference, value) pairs sample by sample and reduces them to a row; :func:`formula_points`
and :func:`formula_values` evaluate a formula (a user's file in one round trip to its
process) at every state a check needs, finite-difference neighbours included. Both the
open-chain check (:mod:`robodyn.checker.compare`) and the reduced-Lagrangian check of a closed
chain (:mod:`robodyn.checker.compare_constrained`) are built from them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn.checker.evaluation import Points, Values, evaluate
from robodyn.checker.user_formula import UserFormula
from robodyn.kinds.formula import Formula

Array = NDArray[np.float64]

GROUP_ORDER = ("formula", "structure", "identity", "pinocchio")
DEFAULT_RTOL = 1e-9  # formula vs Pinocchio, and Pinocchio vs itself: round-off only
FD_STEP = 1e-6  # central finite differences: truncation ~ h^2 = 1e-12, round-off ~ eps/h = 2e-10
FD_TOL = 1e-6  # what the finite-difference rows are held to (above their error, far below a misprint)
EPS = float(np.finfo(np.float64).eps)  # 2.2e-16: the round-off of one floating-point operation
# The absolute floor of a row: a quantity computed by recursions over the model's bodies carries a
# round-off of a few eps times the magnitude of the terms it is summed from (its torque, inertia or
# energy scale), whatever its own value; a quantity that is zero by the model's symmetry (C v + G of
# r2d2) is only that round-off. ROUNDOFF eps times the terms' scale bounds it with room: the largest
# error measured on every file of example-robot-data and pybullet_data was 0.11 of the floor (7 eps,
# 1/2 v^T M v on simple_humanoid), and a misprint of 1e-6 relative is 10^8 times larger than the floor.
# Round trips through M (ABA, M^-1) multiply it by cond(M); finite differences divide it by their step.
ROUNDOFF = 64.0
# The verdicts of a check. Only a formula whose equations of motion differ from Pinocchio's is a FAIL: a C whose
# C v is right but which is not the Christoffel C (its dM/dt - 2C not skew) gives the same M a + C v + G.
PASS, EQUATIONS_AGREE, FAIL = "PASS", "EQUATIONS AGREE", "FAIL"
CHRISTOFFEL_ONLY = ("C", "N = dM/dt - 2C skew (formula)")  # the rows only a non-Christoffel C v fails


@dataclass(frozen=True)
class EntryMismatch:
    """One entry of a compared quantity that is out of tolerance: its worst error over the samples, and where."""

    entry: tuple[int, ...]
    max_abs_error: float
    max_rel_error: float  # relative to the row's scale (the largest magnitude of the whole quantity)
    worst_sample: int
    worst_q: Array
    worst_v: Array
    expected: float
    got: float

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out.update(worst_q=self.worst_q.tolist(), worst_v=self.worst_v.tolist(), entry=list(self.entry))
        return out


@dataclass(frozen=True)
class CheckRow:
    """One compared quantity: the worst error over the samples, and where it happened."""

    quantity: str
    group: str  # "formula", "structure", "identity" or "pinocchio"
    unit: str
    max_abs_error: float
    max_rel_error: float
    tolerance: float
    worst_sample: int
    worst_q: Array
    worst_v: Array
    entry: tuple[int, ...]  # index of the worst entry; () for a scalar
    expected: float  # reference value at the worst entry (Pinocchio, or exact property)
    got: float  # compared value at the worst entry
    counts: bool = True  # False: reported, but does not fail the check (Pinocchio's own gaps)
    note: str = ""
    applicable: bool = True  # False: Pinocchio refuses the routine on this model (mimic joints)
    floor: float = 0.0  # absolute error [the row's unit] below which a difference is round-off (see ROUNDOFF)
    # Every entry out of tolerance, worst first (the row's own worst entry included); of a symmetric
    # quantity only the upper triangle. Empty for a row within tolerance.
    mismatches: tuple[EntryMismatch, ...] = ()

    @property
    def passed(self) -> bool:
        """True when the worst error is within the relative tolerance, or within the round-off floor."""
        return bool(self.max_rel_error <= self.tolerance or self.max_abs_error <= self.floor)

    @property
    def within_floor_only(self) -> bool:
        """True when the row passes only because its error is round-off (below the floor, above rtol)."""
        return bool(self.max_rel_error > self.tolerance and self.max_abs_error <= self.floor)

    @property
    def status(self) -> str:
        """``pass``, ``FAIL``, ``n/a`` (not comparable on this model) or, for a row that does not count, ``gap``."""
        if not self.applicable:
            return "n/a"
        if self.passed:
            return "pass"
        return "FAIL" if self.counts else "gap"

    def entry_name(self) -> str:
        """E.g. ``M[0,1]`` or ``G[1]`` or ``T``."""
        symbol = self.quantity.split(" ")[0]
        return f"{symbol}[{','.join(str(i) for i in self.entry)}]" if self.entry else symbol

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict: every field (arrays as lists) and the status."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out.update(worst_q=self.worst_q.tolist(), worst_v=self.worst_v.tolist(), entry=list(self.entry))
        out.update(mismatches=[m.as_dict() for m in self.mismatches])
        return {**out, "status": self.status}

    def entry_label(self, entry: tuple[int, ...]) -> str:
        """``M[0,1]`` for any ``entry`` of this row's quantity."""
        return replace(self, entry=entry).entry_name()


@dataclass(frozen=True)
class CheckReport:
    """Everything ``robodyn check`` found."""

    model: str
    urdf: str
    formula: str | None  # kind name or formula file, None for identities only
    kind: str | None
    params: dict[str, float]
    samples: int
    seed: int
    rtol: float
    rows: tuple[CheckRow, ...]
    wall_time_s: float
    notes: tuple[str, ...] = field(default_factory=tuple)
    params_given: bool = False  # True: the parameters were given by the user, not read from the model
    explanation: tuple[str, ...] = ()  # --explain: the lines naming each mismatching entry's wrong term
    renamed: tuple[str, ...] = ()  # one note per earlier parameter name the formula file read (p["M"])
    # --explain, for machines: per mismatching entry {quantity, entry, label, status, terms, reason}
    # (robodyn.checker.explain.Explained.as_dict)
    explain_terms: tuple[dict[str, Any], ...] = ()
    # --explain: the same terms in the model's own coordinates, named by its joints, in its joint order, whatever
    # coordinates the formula chose (compare_any.explain_in_joints): one slip reads the same in every convention
    joint_terms: tuple[dict[str, Any], ...] = ()
    hints: tuple[str, ...] = ()  # ``hint: ...`` lines: a convention under which the mismatch vanishes (kinds.hints)

    @property
    def passed(self) -> bool:
        """True when every row that counts is within tolerance."""
        return all(r.passed for r in self.rows if r.counts)

    @property
    def equations_agree(self) -> bool:
        """True when only the formula's C and its dM/dt - 2C skew fail: a C v that is right, not in Christoffel form.

        C v + G, inverse and forward dynamics (the equations of motion) then all agree with Pinocchio.
        """
        failing = self.failures
        return bool(failing) and all(r.quantity in CHRISTOFFEL_ONLY for r in failing)

    @property
    def verdict(self) -> str:
        """``PASS``; ``EQUATIONS AGREE`` (:attr:`equations_agree`: the C is not Christoffel's); or ``FAIL``."""
        if self.passed:
            return PASS
        return EQUATIONS_AGREE if self.equations_agree else FAIL

    @property
    def failures(self) -> tuple[CheckRow, ...]:
        """Rows that fail the check."""
        return tuple(r for r in self.rows if r.counts and not r.passed)

    @property
    def gaps(self) -> tuple[CheckRow, ...]:
        """Rows where Pinocchio disagrees with itself (reported, not failing)."""
        return tuple(r for r in self.rows if not r.counts and not r.passed)

    def row(self, quantity: str) -> CheckRow:
        """The row called ``quantity``."""
        for r in self.rows:
            if r.quantity == quantity:
                return r
        raise KeyError(quantity)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict: every field (rows as dicts) and the verdict."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out.update(notes=list(self.notes), rows=[r.as_dict() for r in self.rows], explanation=list(self.explanation))
        out.update(renamed=list(self.renamed), explain_terms=list(self.explain_terms), hints=list(self.hints))
        out.update(joint_terms=list(self.joint_terms))
        return {**out, "passed": self.passed, "verdict": self.verdict}


class Accumulator:
    """Collect (reference, value) pairs per sample and reduce them to a CheckRow."""

    def __init__(self, quantity: str, group: str, unit: str, tolerance: float, *, counts: bool = True, note: str = ""):
        self.quantity, self.group, self.unit, self.tolerance = quantity, group, unit, tolerance
        self.counts, self.note = counts, note
        self.pairs: list[tuple[Array, Array]] = []
        self.floor = 0.0

    def add(self, reference: ArrayLike, value: ArrayLike, floor: float = 0.0) -> None:
        """One sample's reference (Pinocchio, or the exact property), compared value and round-off floor.

        ``floor`` [the row's unit] is the round-off this sample's computation may leave (see
        ROUNDOFF); the row keeps the largest over the samples.
        """
        self.pairs.append(
            (np.atleast_1d(np.asarray(reference, dtype=np.float64)), np.atleast_1d(np.asarray(value, dtype=np.float64)))
        )
        if np.isfinite(floor):
            self.floor = max(self.floor, float(floor))

    def row(self, samples: list[Any], scalar: bool = False, zero_reference_scale: float | None = None) -> CheckRow:
        """The worst error over the pairs, relative to the largest reference; ``samples[k]`` has q and v.

        ``zero_reference_scale``: what a quantity whose reference is zero is measured against (:func:`rescale`).
        """
        scale = max(float(np.max(np.abs(ref))) for ref, _ in self.pairs)
        errors = [np.abs(val - ref) for ref, val in self.pairs]
        worst = int(np.argmax([e.max() for e in errors]))
        abs_err = float(errors[worst].max())
        # A reference that is zero at every sample (C of a constant M) leaves only round-off:
        # then the error is measured against 1 in the row's unit.
        rel_err = 0.0 if abs_err == 0.0 else (abs_err / scale if scale > 0 else abs_err)
        ref, val = self.pairs[worst]
        entry = np.unravel_index(int(np.argmax(errors[worst])), errors[worst].shape)
        row = CheckRow(
            self.quantity, self.group, self.unit, abs_err, rel_err, self.tolerance, worst,
            samples[worst].q.copy(), samples[worst].v.copy(),
            () if scalar else tuple(int(i) for i in entry),
            float(ref[entry]), float(val[entry]), self.counts, self.note, floor=self.floor,
        )  # fmt: skip
        if zero_reference_scale is not None:
            row = rescale(row, zero_reference_scale)
        return with_mismatches(row, self.pairs, samples, scalar=scalar)


SYMMETRIC = ("M",)  # entries in pairs M[i,j] = M[j,i]; not C, whose errors may be equal and opposite


def with_mismatches(
    row: CheckRow, pairs: list[tuple[Array, Array]], samples: list[Any], *, scalar: bool = False
) -> CheckRow:
    """``row`` with every entry out of tolerance listed (:attr:`CheckRow.mismatches`).

    An entry's relative error is its worst absolute error over the samples divided by the row's own
    ratio of absolute to relative error.
    """
    if row.passed or not pairs or any(ref.shape != pairs[0][0].shape for ref, _ in pairs):
        return replace(row, mismatches=())
    refs = np.array([ref for ref, _ in pairs])
    vals = np.array([val for _, val in pairs])
    errors = np.abs(vals - refs)  # (k, *shape)
    scale = row.max_abs_error / row.max_rel_error if row.max_rel_error > 0 else 1.0
    per_entry = errors.max(axis=0)
    # A symmetric quantity (M) lists one entry of each pair: the pair's errors agree to round-off (a formula that
    # computes M[1,0] another way than M[0,1] differs from it by a few eps); a formula's M that is asymmetric by
    # more lists both.
    signed = vals - refs
    symmetric = (
        row.quantity in SYMMETRIC
        and per_entry.ndim == 2
        and per_entry.shape[0] == per_entry.shape[1]
        and float(np.max(np.abs(signed - signed.transpose(0, 2, 1)))) <= _roundoff(row, refs, vals)
    )
    found = []
    out_of_tolerance = (per_entry / scale > row.tolerance) & (per_entry > row.floor)  # not round-off either
    for entry in zip(*np.nonzero(out_of_tolerance), strict=True):
        if symmetric and entry[0] > entry[1]:
            continue
        k = int(np.argmax(errors[(slice(None), *entry)]))
        found.append(
            EntryMismatch(
                () if scalar else tuple(int(i) for i in entry),
                float(per_entry[entry]),
                float(per_entry[entry] / scale),
                k,
                samples[k].q.copy(),
                samples[k].v.copy(),
                float(refs[(k, *entry)]),
                float(vals[(k, *entry)]),
            )
        )
    found.sort(key=lambda m: -m.max_abs_error)
    return replace(row, mismatches=tuple(found))


def _roundoff(row: CheckRow, refs: Array, vals: Array) -> float:
    """The round-off of ``row``'s quantity: its floor, or ROUNDOFF eps times the largest magnitude compared."""
    return max(row.floor, ROUNDOFF * EPS * float(max(np.max(np.abs(refs)), np.max(np.abs(vals)))))


def formula_points(formula: Formula, samples: list[Any], q_anchor: Array, nv: int) -> Points:
    """Every state at which the check evaluates the formula, so that it is evaluated in one batch.

    M at q, q + h v and q - h v (h = FD_STEP, for dM/dt); C at (q, v); G at q; with a potential,
    V at q, at ``q_anchor`` and at q +- h e_i for each of the ``nv`` coordinates (for dV/dq).
    The formulas' coordinates are plain numbers, so q + dq is plain addition.
    """
    q = np.array([s.q for s in samples])
    v = np.array([s.v for s in samples])
    step = FD_STEP * v
    potential = np.empty((0, q.shape[1]))
    if formula.potential_energy is not None:
        shifted = []
        for sign in (1.0, -1.0):
            for i in range(nv):
                e = np.zeros(q.shape[1])
                e[i] = sign * FD_STEP
                shifted.append(q + e)
        potential = np.concatenate([q, q_anchor[None, :], *shifted])
    return Points(np.concatenate([q, q + step, q + (-step)]), q, v, q, potential)


def formula_values(formula: Formula, p: Mapping[str, float], points: Points) -> Values:
    """A user's file in one round trip to its own process; a built-in kind here."""
    if isinstance(formula, UserFormula):
        return formula.evaluate(p, points)
    return evaluate(formula, p, points)


def skew_scale(Mdot: Array, C: Array, M: Array, v: Array) -> float:
    """Reference magnitude for N = dM/dt - 2C: max(|dM/dt|, |2C|, |M| |v|); |M| |v| for M nearly constant, C ~ 0."""
    return max(float(np.abs(Mdot).max()), 2 * float(np.abs(C).max()), float(np.abs(M).max() * np.abs(v).max()))


def rescale(row: CheckRow, scale: float) -> CheckRow:
    """Express a row whose reference is zero relative to ``scale`` instead.

    With ``scale`` zero (M constant and C zero: nothing moves the metric) only round-off
    can be left, so the error is measured against 1 in the row's unit.
    """
    error = row.max_abs_error
    ratio = scale if scale > 0 else 1.0
    return replace(row, max_rel_error=0.0 if error == 0.0 else error / ratio)
