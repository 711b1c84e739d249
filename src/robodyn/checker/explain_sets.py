"""``--explain``'s parameter sets: the model varied, the formula's parameters with it, formula - Pinocchio at each.

A coefficient matched at one set of parameter values can be matched by a coincidence (0.8 * 0.25 =
0.5 * 0.4). So ``--explain`` evaluates the formula and Pinocchio at :data:`SETS` more parameter sets:
the model's per-link values (masses, centres of mass, joint origins, inertias, armatures, gravity)
each multiplied by a seeded random factor in :data:`FACTORS` (:func:`robodyn.model.vary.varied`), and
the formula's parameters varied with them (:class:`Follower`):

* a built-in kind re-reads its parameters from the varied model (:func:`robodyn.kinds.params.extract`);
* a ``KIND = "any"`` file with ``parameters(robot)`` is asked again, with the varied model's table;
* a constant ``PARAMETERS`` dict (or ``--params``): each number is matched to the one per-link value
  it equals (said in the output), which is varied, and the parameter with it; a number that equals
  none, or several that vary apart, is held with every value it equals, and said so.

Only the rows ``--explain`` fits (M, C, G, V) are evaluated, at the first :data:`SAMPLES` states.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.checker.evaluation import Points
from robodyn.checker.explain import Sets
from robodyn.checker.reference import Reference
from robodyn.checker.rows import formula_values
from robodyn.errors import RobodynError
from robodyn.kinds.formula import Formula
from robodyn.model.links import LinkTable, link_table
from robodyn.model.vary import GRAVITY, Quantity, quantities, varied
from robodyn.robot import Robot

Array = NDArray[np.float64]
SETS = 4  # varied parameter sets on top of the check's own: 5 values per coefficient, against products of 3
FACTORS = (0.61, 1.47)  # each per-link value times a factor drawn uniformly here (never 1, never round)
SAMPLES = 40  # states per varied set: a fit of at most 6 known terms, checked on 6 times as many
MATCH_RTOL = 1e-9  # a PARAMETERS number equals a per-link value to this (both are printed to ~1e-12 at best)
KEYS = ("M", "C", "G", "V")
AXES = "xyz"


@dataclass(frozen=True)
class Follower:
    """How the formula's parameters follow a varied model: ``read(robot)``, and the quantities that may vary.

    ``vary``: the per-link quantities varied (None: all); ``followed``: parameter -> the per-link value it
    follows (constant PARAMETERS); ``held``: parameter -> why it cannot be varied; ``advice``: what would let it.
    """

    read: Callable[[Robot], dict[str, float]]
    vary: frozenset[Quantity] | None = None
    followed: Mapping[str, str] = field(default_factory=dict)
    held: Mapping[str, str] = field(default_factory=dict)
    advice: str = ""


def by_reading(read: Callable[[Robot], dict[str, float]], advice: str = "") -> Follower:
    """Parameters read afresh from each varied model (a built-in kind's extractor, a file's parameters(robot))."""
    return Follower(read, advice=advice)


def by_table(read: Callable[[LinkTable], dict[str, float]]) -> Follower:
    """A ``KIND = "any"`` file's ``parameters(robot)``, asked with each varied model's per-link table."""
    return by_reading(
        lambda robot: read(link_table(robot)),
        advice="read it from the per-link table in parameters(robot)",
    )


def _values(robot: Robot) -> dict[str, tuple[float, frozenset[Quantity]]]:
    """Every per-link value of ``robot`` by label (``"elbow com x"``), with the quantities that change it."""
    table = link_table(robot)
    out: dict[str, tuple[float, frozenset[Quantity]]] = {}
    for j, link in enumerate(table.links, start=1):
        name = link.joint
        inertia = frozenset((j, "inertia", i) for i in range(3))
        out[f"{name} mass"] = (link.mass, frozenset({(j, "mass", 0)}))
        for i in range(3):
            out[f"{name} com {AXES[i]}"] = (float(link.com[i]), frozenset({(j, "com", i)}))
            out[f"{name} origin {AXES[i]}"] = (float(link.origin[i]), frozenset({(j, "origin", i)}))
            for k in range(i, 3):
                out[f"{name} inertia {AXES[i]}{AXES[k]}"] = (float(link.inertia[i, k]), inertia)
        out[f"{name} inertia about its axis"] = (link.inertia_about_axis, inertia)
        out[f"{name} armature"] = (link.armature, frozenset({(j, "armature", 0)}))
    out["|gravity|"] = (table.g, frozenset({GRAVITY}))
    return out


def by_values(robot: Robot, numbers: Mapping[str, float], where: str, seed: int) -> Follower:
    """Constant parameters (``PARAMETERS``, ``--params``), each matched to the one per-link value it equals.

    A number that equals a per-link value up to sign follows it. One that equals several which vary
    apart (two values of 0.5), or none, is held, with every value it equals: nothing can tell those apart.
    """
    nominal = _values(robot)
    probe = _values(varied(robot, _factors(robot, np.random.default_rng(seed + 7919), None)))
    matches: dict[str, list[tuple[str, float]]] = {}
    for name, x in numbers.items():
        found = []
        for label, (value, _) in nominal.items():
            for sign in (1.0, -1.0):
                if x != 0 and abs(x - sign * value) <= MATCH_RTOL * abs(x):
                    found.append((label, sign))
        matches[name] = found
    followed: dict[str, str] = {}
    held: dict[str, str] = {}
    hold: set[Quantity] = set()
    for name, found in matches.items():
        apart = {round(sign * probe[label][0] / numbers[name], 9) for label, sign in found}
        if len(found) == 1 or (found and len(apart) == 1):
            label, sign = found[0]
            followed[name] = f"{'-' if sign < 0 else ''}{label}"
            continue
        if found:
            labels = ", ".join(label for label, _ in found)
            held[name] = f"{name} = {numbers[name]:.6g} equals several per-link values ({labels})"
            for label, _ in found:
                hold |= nominal[label][1]
        else:
            held[name] = f"{name} = {numbers[name]:.6g} equals no per-link value"
    vary: set[Quantity] = set()
    for name, label in followed.items():
        touched = nominal[label.lstrip("-")][1]
        if touched & hold:
            held[name] = f"{name} shares a per-link value with {', '.join(sorted(held))}"
        else:
            vary |= touched
    for name in held:
        followed.pop(name, None)
    follow = {name: (followed[name].lstrip("-"), -1.0 if followed[name].startswith("-") else 1.0) for name in followed}

    def read(model: Robot) -> dict[str, float]:
        values = _values(model)
        return {
            name: (follow[name][1] * values[follow[name][0]][0] if name in follow else x) for name, x in numbers.items()
        }

    return Follower(read, frozenset(vary), followed, held, advice=f"define parameters(robot) in place of {where}")


def _factors(robot: Robot, rng: np.random.Generator, vary: frozenset[Quantity] | None) -> dict[Quantity, float]:
    return {q: float(rng.uniform(*FACTORS)) for q in quantities(robot) if vary is None or q in vary}


def parameter_sets(
    formula: Formula,
    reference: Reference,
    params: Mapping[str, float],
    samples: Sequence[Any],
    keys: Sequence[str],
    follower: Follower,
    *,
    seed: int,
    sets: int = SETS,
) -> Sets:
    """Formula - Pinocchio for ``keys`` (of :data:`KEYS`) at ``sets`` varied parameter sets, at the first states."""
    robot = reference.robot
    g0 = float(np.linalg.norm(robot.model.gravity.linear))
    states = list(samples[:SAMPLES])
    q = np.array([s.q for s in states])
    v = np.array([s.v for s in states])
    rng = np.random.default_rng(seed + 104729)
    out_params: list[dict[str, float]] = [dict(params)]
    gravity = [g0]
    diffs: dict[str, list[Array]] = {key: [] for key in keys}
    scales: dict[str, list[float]] = {key: [] for key in keys}
    for _ in range(sets):
        model = varied(robot, _factors(robot, rng, follower.vary))
        try:
            p = follower.read(model)
        except RobodynError as exc:  # the extractor or the file refuses the varied model: say so
            failure = f"the parameters could not be read of a varied model ({str(exc).splitlines()[0]})"
            return _sets((dict(params),), (g0,), {}, {}, follower, failure)
        ref = replace(reference, robot=model)
        for key, (d, scale) in _differences(formula, ref, p, q, v, keys).items():
            diffs[key].append(d)
            scales[key].append(scale)
        out_params.append(p)
        gravity.append(float(np.linalg.norm(model.model.gravity.linear)))
    return _sets(
        tuple(out_params),
        tuple(gravity),
        {key: np.array(d) for key, d in diffs.items()},
        {key: np.array(s) for key, s in scales.items()},
        follower,
    )


def _sets(
    params: tuple[dict[str, float], ...],
    gravity: tuple[float, ...],
    differences: dict[str, Array],
    scales: dict[str, Array],
    follower: Follower,
    failure: str = "",
) -> Sets:
    return Sets(
        params, gravity, differences, scales, dict(follower.followed), dict(follower.held), follower.advice, failure
    )


def _differences(
    formula: Formula, ref: Reference, p: Mapping[str, float], q: Array, v: Array, keys: Sequence[str]
) -> dict[str, tuple[Array, float]]:
    """Formula - Pinocchio (k, *shape) and Pinocchio's largest |entry| for each of ``keys``, at the states q, v."""
    anchor = ref.anchor()
    none = q[:0]
    potential = np.concatenate([q, anchor[None, :]]) if "V" in keys else none
    points = Points(
        q if "M" in keys else none,
        q if "C" in keys else none,
        v if "C" in keys else v[:0],
        q if "G" in keys else none,
        potential,
    )
    values = formula_values(formula, p, points)
    out: dict[str, tuple[Array, float]] = {}
    if "M" in keys:
        out["M"] = _minus(values.mass_matrix, [ref.mass_matrix(x) for x in q])
    if "C" in keys:
        out["C"] = _minus(values.coriolis_matrix, [ref.coriolis_matrix(x, y) for x, y in zip(q, v, strict=True)])
    if "G" in keys:
        out["G"] = _minus(values.gravity, [ref.gravity(x) for x in q])
    if "V" in keys:
        V0 = ref.potential_energy(anchor)
        pin_V = [ref.potential_energy(x) - V0 for x in q]
        out["V"] = _minus(values.potential_energy[:-1] - values.potential_energy[-1], pin_V)
    return out


def _minus(formula: Array, pinocchio: Sequence[Array] | Sequence[float]) -> tuple[Array, float]:
    ref = np.array(pinocchio, dtype=np.float64)
    return np.asarray(formula, dtype=np.float64) - ref, float(np.max(np.abs(ref))) if ref.size else 1.0
