"""A ``KIND = "any"`` formula against Pinocchio: the model it describes, and Pinocchio in its coordinates.

The file (:mod:`robodyn.checker.any_kind`) names the joints its q1, q2, ... stand for. The model it
describes is the robot with every other joint locked at ``LOCKED`` (default: the neutral pose) and
welded to its parent, by the same reduction as ``--lock`` (:func:`robodyn.model.reduce.reduce`).
Its parameters are the file's ``PARAMETERS`` or its ``parameters(robot)`` of that model's per-link
table (:func:`robodyn.model.links.link_table`). Pinocchio's M, C, G, RNEA and ABA are then mapped to
the formula's coordinates exactly (:class:`robodyn.checker.reference.Reference`), and
:mod:`robodyn.checker.compare` compares them row by row as for a built-in kind. :func:`explain_rows` hands
``--explain`` (:mod:`robodyn.checker.explain`) what it fits, with the coordinates' kinds (angle or length).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from types import SimpleNamespace
from typing import Any

import numpy as np

from robodyn import dynamics
from robodyn.checker.constrained_kind import checked_parameters
from robodyn.checker.explain import QUANTITIES, Explained, Sets, explain, failing_keys
from robodyn.checker.explain_sets import Follower, by_table, by_values, parameter_sets
from robodyn.checker.reference import Reference
from robodyn.checker.rows import Accumulator, CheckRow
from robodyn.errors import FormulaError, InputError
from robodyn.kinds.formula import Formula
from robodyn.model.coordinate_map import CoordinateMap
from robodyn.model.links import JOINT_TYPES, LinkTable, link_table
from robodyn.model.reduce import reduce
from robodyn.robot import Robot


@dataclass(frozen=True, eq=False)
class AnySetup:
    """What a check of a ``KIND = "any"`` formula needs: the model it describes, Pinocchio on it, the parameters."""

    robot: Robot  # the model the formula describes: its JOINTS moving, the rest locked
    reference: Reference  # Pinocchio on ``robot``, in the formula's coordinates
    table: LinkTable  # the per-link table parameters(robot) read
    params: dict[str, float]
    notes: tuple[str, ...]


def prepare(robot: Robot, formula: Formula, params: dict[str, float] | None = None) -> AnySetup:
    """Reduce ``robot`` to the formula's joints, map Pinocchio to its coordinates and read its parameters.

    ``params``: the parameters given by the user (``--params``), in place of the file's.

    Raises:
        FormulaError: JOINTS or LOCKED names a joint the robot lacks, or a joint that is not revolute,
            continuous or prismatic; the file's parameters(robot) fails.
    """
    joints: tuple[str, ...] = getattr(formula, "independent", ())
    matrix: tuple[tuple[float, ...], ...] = getattr(formula, "matrix", ())
    offsets: tuple[float, ...] = getattr(formula, "offsets", ())
    locked: dict[str, float] = dict(getattr(formula, "locked", ()))
    names = robot.joint_names
    for joint in (*joints, *locked):
        if joint not in names:
            where = "JOINTS" if joint in joints else "LOCKED"
            raise FormulaError(
                f"{formula.source}: {where} names {joint!r}, which is not a moving joint of {robot.name}; "
                f"its moving joints are {', '.join(names)}"
            )
    for joint in joints:
        kind = robot.joint(joint).kind
        if kind not in JOINT_TYPES:
            raise FormulaError(
                f"{formula.source}: JOINTS names {joint!r}, a {kind}; KIND = 'any' takes revolute, continuous "
                "and prismatic joints (leave it out to lock it)"
            )
    rest = tuple(n for n in names if n not in joints)
    model = robot if not rest else reduce(robot, keep=joints, lock=locked).reduced
    n = len(joints)
    A = np.array(matrix, dtype=np.float64).reshape(n, n) if matrix else np.eye(n)
    cmap = CoordinateMap(joints, A, np.array(offsets, dtype=np.float64) if offsets else np.zeros(n))
    slides = [JOINT_TYPES.get(model.joint(j).kind) == "prismatic" for j in joints]
    try:
        cmap.check_units(slides, formula.source)
    except InputError as exc:
        raise FormulaError(str(exc)) from None
    reference = Reference.mapped(model, joints, cmap.A, cmap.b)
    table = link_table(model)
    if params is None:
        read = getattr(formula, "link_parameters", None)
        if read is None:
            raise FormulaError(f"{formula.source}: KIND = 'any' needs PARAMETERS or parameters(robot)")
        used = read(table)
    else:
        used = checked_parameters(params, formula.source)
    names = tuple(getattr(formula, "names", ()))
    return AnySetup(model, reference, table, used, _notes(cmap, reference.prismatic, rest, locked, names))


def _notes(
    cmap: CoordinateMap,
    prismatic: tuple[bool, ...],
    rest: tuple[str, ...],
    locked: dict[str, float],
    names: tuple[str, ...] = (),
) -> tuple[str, ...]:
    """``coordinates: q1 = joint1 + 1.5708 rad, q2 = joint1 + joint2`` (in the file's NAMES) and the locked joints."""
    parts = cmap.describe(prismatic, names=names)
    notes = [f"coordinates: {', '.join(parts)} (the q, v of a mismatch are the formula's)"]
    if rest:
        held = ", ".join(f"{name} at {locked[name]:.6g}" if name in locked else f"{name} at neutral" for name in rest)
        notes.append(f"locked (welded to their parents): {held}")
    return tuple(notes)


def follower(setup: AnySetup, formula: Formula, *, given: bool, seed: int) -> Follower:
    """How the file's parameters follow a varied model (:mod:`robodyn.checker.explain_sets`).

    Its ``parameters(robot)`` is asked again; or each constant (``PARAMETERS``, ``--params``) is matched to
    the per-link value it equals.
    """
    read = getattr(formula, "link_parameters", None)
    if given or read is None or getattr(formula, "constant_parameters", False):
        return by_values(setup.robot, setup.params, "--params" if given else "PARAMETERS", seed)
    return by_table(read)


def varied_sets(
    formula: Formula,
    ref: Reference,
    used: Mapping[str, float],
    states: Sequence[Any],
    rows: Sequence[CheckRow],
    follow: Follower,
    *,
    seed: int,
) -> Sets | None:
    """Formula - Pinocchio at the varied parameter sets, for the rows --explain fits (None: none fails)."""
    keys = failing_keys(rows)
    if not keys:
        return None
    return parameter_sets(formula, ref, used, states, keys, follow, seed=seed)


def explain_rows(
    rows: Sequence[CheckRow],
    kept: Mapping[str, Accumulator],
    states: Sequence[Any],
    ref: Reference,
    used: Mapping[str, float],
    *,
    sets: Sets | None = None,
    names: Sequence[str] = (),
) -> tuple[tuple[str, ...], tuple[Explained, ...]]:
    """``--explain``'s lines and terms (:func:`~robodyn.checker.explain.explain`); coordinate kinds from ``ref``."""
    prismatic = list(ref.prismatic)
    g = float(np.linalg.norm(dynamics.gravity_vector(ref.robot.model)))
    return explain(rows, kept, states, used, prismatic=prismatic, g=g, sets=sets, names=names or None)


def explain_in_joints(
    rows: Sequence[CheckRow],
    kept: Mapping[str, Accumulator],
    states: Sequence[Any],
    ref: Reference,
    used: Mapping[str, float],
    *,
    sets: Sets | None = None,
) -> tuple[Explained, ...]:
    """``--explain``'s terms in the model's own coordinates, whatever coordinates the formula chose.

    With the formula's q = A q_joints + b: q_joints = A^-1 (q - b), in the model's joint order and named by
    the joints (``cos(elbow)``), M and C become A^T X A, G and C v A^T x, V stays. One slip then reads the same
    in every file, whichever convention (a sign, an offset, absolute angles) or ``NAMES`` it was written in:
    ``robodyn grade``'s class report counts it once. The rows are remeasured in those coordinates, so an entry
    is one of the model's.
    """
    order = np.argsort(ref.columns)
    A = ref.A[:, order]  # q_formula = A q_sorted + b, q_sorted the joints in the model's order
    A_inv = np.linalg.inv(A)
    by_index = {j.idx_v: j.name for j in ref.robot.joints}
    names = [by_index[ref.columns[i]] for i in order]
    prismatic = [bool(np.any(np.array(ref.prismatic)[np.abs(A[:, j]) > 0])) for j in range(A.shape[1])]

    def to_joints(key: str, x: Any) -> Any:
        x = np.asarray(x, dtype=np.float64)
        if key == "V":
            return x
        if key == "M" or (key == "C" and x.shape[-2:] == A.shape):
            return np.swapaxes(A, 0, 1) @ x @ A
        return x @ A  # G, C v: A^T x, over any leading axes

    moved = [SimpleNamespace(q=A_inv @ (np.asarray(s.q) - ref.offsets), v=A_inv @ np.asarray(s.v)) for s in states]
    remeasured: dict[str, Accumulator] = {}
    new_rows = list(rows)
    for key, acc in kept.items():
        if key not in QUANTITIES or not acc.pairs:
            continue
        acc2 = Accumulator(acc.quantity, acc.group, acc.unit, acc.tolerance, counts=acc.counts)
        for ref_value, value in acc.pairs:
            acc2.add(to_joints(key, ref_value), to_joints(key, value), acc.floor)
        remeasured[key] = acc2
        for i, row in enumerate(new_rows):
            if row.quantity == QUANTITIES[key] and not row.passed:
                new_rows[i] = acc2.row(moved, scalar=key == "V")
    if sets is not None:
        sets = replace(sets, differences={k: to_joints(k, d) for k, d in sets.differences.items()})
    g = float(np.linalg.norm(dynamics.gravity_vector(ref.robot.model)))
    _, terms = explain(new_rows, remeasured, moved, used, prismatic=prismatic, g=g, sets=sets, names=names)
    return terms
