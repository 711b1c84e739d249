"""``robodyn check``: Pinocchio's dynamics against hand-derived formulas and against itself.

Over seeded random states (q uniform in [-pi, pi] around neutral, v and a uniform in
[-2, 2], tau uniform in [-1, 1]) the check compares

* with a formula: M, C, G, C v + G, inverse and forward dynamics, kinetic and potential
  energy (the latter up to a constant);
* always, the structural properties: M symmetric positive definite, dM/dt - 2C skew,
  G = dV/dq, and Pinocchio's identities C v + G = RNEA(q, v, 0), M^-1 (tau - nle) = ABA,
  RNEA(ABA(tau)) = tau, CRBA = columns of RNEA;
* Pinocchio's routines with each other: 1/2 v^T M v against ``computeKineticEnergy``, and
  ``computeCoriolisMatrix`` against the Christoffel C built from RNEA (they differ on mimic joints).
  Disagreements there are Pinocchio's own gaps; they are reported plainly but do not fail
  the check, because robodyn uses 1/2 v^T M v.

Each kind of formula is compared by a function of its own (``_COMPARISONS``), all returning the
same typed result: a ``KIND = "constrained"`` formula (a closed chain's reduced Lagrangian) on the
loop (:mod:`robodyn.checker.compare_constrained`), a ``KIND = "any"`` one in its own coordinates
(:mod:`robodyn.checker.compare_any`), a built-in kind's with the model's parameters. The rows that
need no formula are :mod:`robodyn.checker.structure`'s. Errors are relative to the largest magnitude
the quantity takes over the sampled states.
Finite differences (dM/dt, dV/dq) use a central step of ``FD_STEP`` and are held to
``FD_TOL``.

A row also passes when its absolute error is within its round-off floor: ``ROUNDOFF`` eps times
the magnitude of the terms the quantity is computed from, from the model's own scales (the norm
of M, the speeds and accelerations of the sample, the energy scale |g| sum m_i |c_i|); the
round trips through M are held to the same times |M| |a| (cond(M) on an ill-conditioned M), and
the finite differences to it divided by their step. A quantity that is zero by the robot's
symmetry, or tiny against its terms, then passes on round-off; an error of 1e-6 relative still
fails.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn.checker import compare_any
from robodyn.checker.any_kind import KIND as ANY
from robodyn.checker.compare_constrained import loop_rows
from robodyn.checker.constrained_kind import KIND as CONSTRAINED
from robodyn.checker.explain import Explained, Sets, one_set
from robodyn.checker.explain_sets import by_reading
from robodyn.checker.hints import convention_hints
from robodyn.checker.reference import Reference
from robodyn.checker.rows import (
    DEFAULT_RTOL,
    FD_STEP,
    FD_TOL,
    GROUP_ORDER,
    Accumulator,
    CheckReport,
    CheckRow,
    formula_points,
    formula_values,
    skew_scale,
)
from robodyn.checker.sandbox import DEFAULT_TIMEOUT
from robodyn.checker.scales import scales
from robodyn.checker.structure import SINGULAR_RATIO, structure_rows
from robodyn.checker.user_formula import UserFormula, resolve
from robodyn.checker.velocity_terms import VECTOR
from robodyn.errors import AssumptionError, InputError, RobodynError
from robodyn.kinds.formula import Formula
from robodyn.kinds.params import Params, extract, from_mapping
from robodyn.robot import Robot

Array = NDArray[np.float64]
__all__ = ["DEFAULT_RTOL", "FD_STEP", "FD_TOL", "MAX_SAMPLES", "CheckReport", "CheckRow", "check"]
SPEED = 2.0  # |v|, |a| sampled up to this [rad/s, rad/s^2 | m/s, m/s^2]
TORQUE = 1.0  # |tau| sampled up to this [N m | N]
NON_NEGATIVE = ("m1", "m2", "m_cart", "m", "I1", "I2", "I", "J_l", "J_m")  # masses [kg], inertias [kg m^2]: given >= 0
# The most random states one check takes: ~40 s for the Pendubot with a formula file (6 s of it the file's, inside
# sandbox.DEFAULT_TIMEOUT). The worst error over 10^5 states is rarely beaten by more; another seed explores as well.
MAX_SAMPLES = 100_000
C_NOT_CHECKED = (
    "C and dM/dt - 2C skew not checked: {source} gives C v (coriolis_vector), not C; C v + G, tau and a are "
    "checked with it"
)
GIVEN = "the parameters were given (--params), not read from the model, so they cannot follow a varied model"


@dataclass(frozen=True)
class _Sample:
    q: Array
    v: Array
    a: Array
    tau: Array


def _draw_samples(robot: Robot, samples: int, seed: int) -> list[_Sample]:
    """``samples`` seeded states; the last poses are the neutral one and the SRDF's named ones.

    A run starts from the neutral pose unless told otherwise, and a mass matrix can be singular
    there only (iCub's at q = 0): those poses are always checked, whatever the draw. They take the
    last places, so that the random states keep their numbers.
    """
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(samples):
        q, v = robot.random_state(rng, speed=SPEED)
        out.append(_Sample(q, v, rng.uniform(-SPEED, SPEED, robot.nv), rng.uniform(-TORQUE, TORQUE, robot.nv)))
    fixed = _fixed_poses(robot)[:samples]
    for k, q in enumerate(fixed, start=samples - len(fixed)):
        out[k] = replace(out[k], q=q)
    return out


def _fixed_poses(robot: Robot) -> list[Array]:
    """The neutral configuration, then the SRDF's ``<group_state>`` ones (none where the SRDF cannot give them)."""
    from robodyn.model.files import reference_configurations

    try:
        named = list(reference_configurations(robot).values())
    except RobodynError:  # the SRDF's states are the check's extra samples, not its input: the neutral pose stays
        named = []
    return [robot.neutral(), *named]


def _given_params(kind: str, params: Mapping[str, float], where: str) -> Params:
    """The user's ``params`` for ``kind``: the kind's names, finite, masses and inertias >= 0 (else ``where`` + why)."""
    try:
        p = from_mapping(kind, params)
    except InputError as exc:
        raise InputError(f"{where}{exc}") from None
    negative = [f"{n} = {p[n]:g}" for n in p if n in NON_NEGATIVE and p[n] < 0]
    if negative:
        raise InputError(f"{where}given {kind} parameters {', '.join(negative)} (expected masses and inertias >= 0)")
    return p


def _extracted(robot: Robot, *, kind: str) -> dict[str, float]:
    """The parameters of ``kind`` read from ``robot`` (a varied model, for --explain's parameter sets)."""
    return extract(robot, kind).as_dict()


def _refuse_singular(p: Params, mass: Array, samples: list[_Sample], where: str) -> None:
    """Refuse given parameters whose formula M(q), ``mass`` (n, nv, nv) [kg m^2] at the samples, is not SPD."""
    for k, M in enumerate(mass):
        eig = np.linalg.eigvalsh(0.5 * (M + M.T)) if np.all(np.isfinite(M)) else np.full(1, np.nan)
        if eig[0] > SINGULAR_RATIO * eig[-1]:
            continue
        what = "not finite" if np.isnan(eig[0]) else ("singular" if eig[0] >= 0 else "not positive definite")
        listed = ", ".join(f"{n} = {v:g}" for n, v in p.items())
        spread = "" if np.isnan(eig[0]) else f", eigenvalues {eig[0]:.3g} to {eig[-1]:.3g} kg m^2"
        raise InputError(
            f"{where}with the given {p.kind} parameters {listed} the formula's mass matrix M(q) is {what} at sample "
            f"{k} (q = {np.array2string(samples[k].q, precision=4, separator=', ')}{spread}); "
            "expected masses and inertias that give every joint some inertia"
        )


def _solve(M: Array, b: Array) -> Array:
    """M^-1 b, or NaN (a mismatch in its row) where a formula's M is singular."""
    try:
        return np.asarray(np.linalg.solve(M, b), dtype=np.float64)
    except np.linalg.LinAlgError:
        return np.full_like(b, np.nan)


def _formula_rows(
    robot: Robot,
    formula: Formula,
    p: Params,
    samples: list[_Sample],
    rtol: float,
    given: str | None,
    reference: Reference | None = None,
    keep: dict[str, Accumulator] | None = None,
) -> list[CheckRow]:
    """The rows; ``given``: None, or the parameters were given (their refusals start with it) and M must be SPD.

    ``reference`` is Pinocchio in the formula's coordinates (``samples`` are in them too; default: Pinocchio's
    own); ``keep``, when given, receives the accumulators (what ``--explain`` fits).
    """
    ref = reference if reference is not None else Reference.identity(robot)
    fd_tol = max(rtol, FD_TOL)
    acc = {
        "M": Accumulator("M", "formula", "kg m^2 (kg on slides)", rtol),
        "C": Accumulator("C", "formula", "kg m^2/s", rtol),
        "G": Accumulator("G", "formula", "N m (N on slides)", rtol),
        "nle": Accumulator("nle = C v + G", "formula", "N m", rtol),
        "id": Accumulator("tau (inverse dynamics)", "formula", "N m", rtol),
        "fd": Accumulator("a (forward dynamics)", "formula", "rad/s^2 (m/s^2 on slides)", rtol),
        "T": Accumulator("T = 1/2 v^T M v", "formula", "J", rtol),
        "skew": Accumulator("N = dM/dt - 2C skew (formula)", "structure", "kg m^2/s", fd_tol),
        "sym": Accumulator("M = M^T (formula)", "structure", "kg m^2 (kg on slides)", rtol),
    }
    if formula.coriolis_form == VECTOR:  # the file gives C v alone: there is no C to compare, nor dM/dt - 2C
        del acc["C"], acc["skew"]
    if formula.potential_energy is not None:
        acc["V"] = Accumulator("V - V(q0)", "formula", "J", rtol)
        acc["dV"] = Accumulator("G = dV/dq (formula)", "structure", "N m", fd_tol)
    q_anchor = ref.anchor()
    n, nv = len(samples), robot.nv
    values = formula_values(formula, p, formula_points(formula, samples, q_anchor, nv))
    M_all, C_all, G_all, V_all = values.mass_matrix, values.coriolis_matrix, values.gravity, values.potential_energy
    if given is not None:
        _refuse_singular(p, M_all[:n], samples, given)
    n_scale = 0.0  # dM/dt - 2C has no reference of its own: see skew_scale
    m_scale = 0.0  # nor has M - M^T: the formula's largest |M| entry
    for k, s in enumerate(samples):
        M_p = ref.mass_matrix(s.q)
        M_f, C_f, G_f = M_all[k], C_all[k], G_all[k]
        sc = scales(robot, s, M_p, energy=ref.gravity_scale(s.q))
        a_p = ref.aba(s.q, s.v, s.tau)
        acc["M"].add(M_p, M_f, sc.floor(sc.mass))
        if "C" in acc:
            acc["C"].add(ref.coriolis_matrix(s.q, s.v), C_f, sc.floor(sc.coriolis_terms))
        acc["G"].add(ref.gravity(s.q), G_f, sc.floor(sc.energy))
        nle_terms = sc.mass * sc.speed**2 + sc.energy
        acc["nle"].add(ref.nonlinear_effects(s.q, s.v), C_f @ s.v + G_f, sc.floor(nle_terms))
        acc["id"].add(ref.rnea(s.q, s.v, s.a), M_f @ s.a + C_f @ s.v + G_f, sc.floor(sc.torque_terms))
        acc["fd"].add(a_p, _solve(M_f, s.tau - C_f @ s.v - G_f), sc.forward_floor(a_p))
        acc["T"].add(0.5 * float(s.v @ M_p @ s.v), 0.5 * float(s.v @ M_f @ s.v), sc.floor(sc.mass * sc.speed**2))
        Mdot = (M_all[n + k] - M_all[2 * n + k]) / (2 * FD_STEP)  # central difference along v
        N = Mdot - 2 * C_f
        if "skew" in acc:
            acc["skew"].add(np.zeros_like(N), N + N.T, sc.floor(sc.mass * sc.speed / FD_STEP))
        acc["sym"].add(np.zeros_like(M_f), M_f - M_f.T, sc.floor(sc.mass))
        m_scale = max(m_scale, float(np.abs(M_f).max()))
        n_scale = max(n_scale, skew_scale(Mdot, C_f, M_f, s.v))
        if formula.potential_energy is not None:
            acc["V"].add(
                ref.potential_energy(s.q) - ref.potential_energy(q_anchor),
                float(V_all[k]) - float(V_all[n]),
                sc.floor(sc.energy + ref.gravity_scale(q_anchor)),
            )
            plus = V_all[n + 1 + k : n + 1 + nv * n : n]  # V(q + h e_i), i = 0 .. nv-1
            minus = V_all[n + 1 + nv * n + k :: n]  # V(q - h e_i)
            acc["dV"].add(G_f, (plus - minus) / (2 * FD_STEP), sc.floor(sc.energy / FD_STEP))
    if keep is not None:
        keep.update(acc)
    scalars = {"T", "V"}
    rows = [a.row(samples, scalar=k in scalars) for k, a in acc.items()]
    if "skew" in acc:
        rows[list(acc).index("skew")] = acc["skew"].row(samples, zero_reference_scale=n_scale)
    rows[list(acc).index("sym")] = acc["sym"].row(samples, zero_reference_scale=m_scale)
    return rows


@dataclass(frozen=True)
class _Request:
    """What every kind of formula's comparison is asked: the states, the tolerance, the user's options."""

    robot: Robot
    states: list[_Sample]  # drawn on ``robot``'s own coordinates
    samples: int
    seed: int
    rtol: float
    params: Mapping[str, float] | None
    params_source: str | None
    loops: Iterable[Any]
    springs: Any
    scene: str | Path | None
    explain: bool


@dataclass(frozen=True)
class _Compared:
    """One formula's comparison, whatever its kind: its rows, the parameters used, and what --explain needs."""

    rows: tuple[CheckRow, ...]
    params: dict[str, float]
    notes: tuple[str, ...] = ()
    kept: dict[str, Accumulator] = field(default_factory=dict)  # the formula rows' accumulators, for --explain
    explained: tuple[list[_Sample], Reference] | None = None  # and the states they were taken at
    sets: Sets | None = None  # and formula - Pinocchio at the varied parameter sets
    names: tuple[str, ...] = ()  # the formula's coordinates (NAMES)


def _constrained(formula: Formula, ask: _Request) -> _Compared:
    """A closed chain's reduced Lagrangian against Pinocchio's constrained dynamics, on the loop."""
    found = loop_rows(
        ask.robot, formula, loops=ask.loops, springs=ask.springs, scene=None if ask.scene is None else str(ask.scene),
        params=ask.params, samples=ask.samples, seed=ask.seed, rtol=ask.rtol,
    )  # fmt: skip
    return _Compared(tuple(found.rows), found.params, found.notes)


def _any(formula: Formula, ask: _Request) -> _Compared:
    """A ``KIND = "any"`` formula against Pinocchio in the formula's own coordinates."""
    setup = compare_any.prepare(ask.robot, formula, None if ask.params is None else dict(ask.params))
    ref = setup.reference
    mapped = [
        _Sample(ref.formula_q(s.q), ref.formula_v(s.v), ref.formula_v(s.a), ref.formula_tau(s.tau))
        for s in _draw_samples(setup.robot, ask.samples, ask.seed)
    ]
    kept: dict[str, Accumulator] = {}
    rows = _formula_rows(
        setup.robot, formula, Params(ANY, setup.params), mapped, ask.rtol, None, reference=ref, keep=kept
    )
    sets = None
    if ask.explain:
        follower = compare_any.follower(setup, formula, given=ask.params is not None, seed=ask.seed)
        sets = compare_any.varied_sets(formula, ref, setup.params, mapped, rows, follower, seed=ask.seed)
    names = tuple(getattr(formula, "names", ()))
    return _Compared(tuple(rows), setup.params, setup.notes, kept, (mapped, ref), sets, names)


def _built_in(formula: Formula, ask: _Request) -> _Compared:
    """A built-in kind's formula (its closed form, or a user's file of that kind) with the model's parameters."""
    robot = ask.robot
    try:
        p = extract(robot, formula.kind)
    except AssumptionError as exc:  # say which model: the message names only the assumption it breaks
        raise AssumptionError(str(exc), path=robot.urdf_path or robot.name) from None
    given = None if ask.params is None else (f"{ask.params_source}: " if ask.params_source else "")
    if ask.params is not None and given is not None:
        p = _given_params(formula.kind, ask.params, given)
    used = p.as_dict()
    kept: dict[str, Accumulator] = {}
    rows = _formula_rows(robot, formula, p, ask.states, ask.rtol, given, keep=kept)
    explained = (ask.states, Reference.identity(robot))
    sets = None
    if ask.explain and ask.params is None:
        follower = by_reading(functools.partial(_extracted, kind=formula.kind))
        sets = compare_any.varied_sets(formula, explained[1], used, ask.states, rows, follower, seed=ask.seed)
    elif ask.explain:
        sets = one_set(used, used.get("g", 0.0), failure=GIVEN)
    return _Compared(tuple(rows), used, (), kept, explained, sets)


# How each kind of formula is compared: the file kinds by name, every other kind as a built-in one.
_COMPARISONS: dict[str, Callable[[Formula, _Request], _Compared]] = {CONSTRAINED: _constrained, ANY: _any}


def _compared(
    formula: Formula | str, ask: _Request, timeout: float
) -> tuple[_Compared, str | None, str | None, tuple[str, ...]]:
    """``formula`` (a file's path: loaded now, closed after) compared by its kind: (result, source, kind, renamed)."""
    resolved = resolve(formula, timeout=timeout) if isinstance(formula, str) else formula
    try:
        source, kind = (formula if isinstance(formula, str) else resolved.source), resolved.kind
        found = _COMPARISONS.get(kind, _built_in)(resolved, ask)
        if resolved.coriolis_form == VECTOR:
            found = replace(found, notes=(*found.notes, C_NOT_CHECKED.format(source=source)))
        return found, source, kind, (resolved.renamed if isinstance(resolved, UserFormula) else ())
    finally:
        if isinstance(formula, str) and isinstance(resolved, UserFormula):
            resolved.close()  # the file's process was this check's own


def check(
    robot: Robot,
    formula: Formula | str | None = None,
    *,
    samples: int = 100,
    seed: int = 0,
    rtol: float = DEFAULT_RTOL,
    params: Mapping[str, float] | None = None,
    formula_timeout: float = DEFAULT_TIMEOUT,
    params_source: str | None = None,
    loops: Iterable[Any] = (),
    springs: Any = None,
    scene: str | Path | None = None,
    explain: bool = False,
) -> CheckReport:
    """Compare ``robot``'s Pinocchio dynamics with ``formula`` and with its own identities.

    A formula file with ``KIND = "constrained"`` is a closed chain's reduced Lagrangian: it is
    compared with Pinocchio's constrained dynamics on ``loops`` (with ``springs``) at random
    states on the loop (:mod:`robodyn.checker.compare_constrained`); its parameters come from its
    ``parameters(scene)``, or are ``params``. Other formulas check the open tree, and take no
    loops or springs (a note says so when they are given).

    Args:
        robot: a loaded model (see :func:`robodyn.load`).
        formula: a kind name (``"pendubot"``...), a path to a user's formula file, a
            :class:`robodyn.kinds.catalog.Formula`, or None for the structural checks only.
        samples: number of random states, 1 to ``MAX_SAMPLES``.
        seed: seed of the random states.
        rtol: relative tolerance for exact comparisons (finite-difference rows use
            ``max(rtol, FD_TOL)``).
        params: the formula's parameters as given by the user (e.g. from a datasheet)
            instead of those read from the model; the model's kind is still checked. They
            must be finite, masses and inertias >= 0, and give a positive-definite M at
            every sampled state.
        params_source: where ``params`` came from (a file name), named in their refusals.
        formula_timeout: when ``formula`` is a file's path, the seconds its code may run: its
            import, then the whole batch of evaluations (it runs in a process of its own, see
            :mod:`robodyn.checker.sandbox`). A loaded :class:`UserFormula` keeps its own limit.
        loops: a constrained formula's loop closures: mappings or objects with ``frame_a``,
            ``frame_b`` and ``kind`` (:class:`robodyn.sim.constraints.Loop`).
        springs: a constrained formula's joint springs: joint -> ``{"stiffness", "rest"}`` (or
            a Spring, or ``(k, rest)``), or (joint, spring) pairs.
        scene: the scene file a constrained formula's ``parameters(scene)`` reads.
        explain: name the wrong term of each mismatching entry of M, C, G and V in the formula's own
            symbols, and say what the knock-on rows follow from (:mod:`robodyn.checker.explain`); the lines
            are the report's ``explanation``.

    Raises:
        AssumptionError: the model is not of the formula's kind.
        InputError: bad ``samples`` or ``rtol``, or given ``params`` that are not the kind's, not
            finite, negative masses or inertias, or whose M(q) is not positive definite.
        FormulaError: a user's formula file fails to import, returns wrong shapes, exits or
            runs past ``formula_timeout``.
    """
    if not 1 <= samples <= MAX_SAMPLES:
        raise InputError(f"samples must be >= 1 and <= {MAX_SAMPLES}, got {samples}")
    if robot.nv == 0:
        raise InputError(
            f"{robot.urdf_path or robot.name}: {robot.name} has no moving joint, so it has no dynamics to check "
            "(a lone body: load it with free_flyer=True, --free-flyer on the command line)"
        )
    if not (rtol > 0 and np.isfinite(rtol)):
        raise InputError(f"rtol must be a positive number, got {rtol}")
    start = time.perf_counter()
    states = _draw_samples(robot, samples, seed)
    ask = _Request(robot, states, samples, seed, rtol, params, params_source, loops, springs, scene, explain)
    renamed: tuple[str, ...]
    found, source, kind, renamed = _Compared((), {}), None, None, ()  # no formula: the structural rows alone
    if formula is not None:
        found, source, kind, renamed = _compared(formula, ask, formula_timeout)
    used, notes, kept, explained, names = found.params, found.notes, found.kept, found.explained, found.names
    rows = [*found.rows, *structure_rows(robot, states, rtol)]
    rows.sort(key=lambda r: GROUP_ORDER.index(r.group))  # stable: keeps the order within a group
    hints = convention_hints(rows, kept, *explained, kind, names) if explained is not None else ()
    explanation: tuple[str, ...] = ()
    terms: tuple[Explained, ...] = ()
    joint_terms: tuple[Explained, ...] = ()
    if explain and explained is not None:
        explanation, terms = compare_any.explain_rows(rows, kept, *explained, used, sets=found.sets, names=names)
        joint_terms = compare_any.explain_in_joints(rows, kept, *explained, used, sets=found.sets)
    elif explain and kind == CONSTRAINED:
        explanation = ("explain: not available for a KIND = 'constrained' formula (its rows are on the loop)",)
    if kind != CONSTRAINED and (tuple(loops) or springs):
        notes += ("the loops and springs are not checked: only a KIND = 'constrained' formula lives on them",)
    return CheckReport(
        model=robot.name,
        urdf=str(robot.urdf_path),
        formula=source,
        kind=kind,
        params=used,
        samples=samples,
        seed=seed,
        rtol=rtol,
        rows=tuple(rows),
        wall_time_s=time.perf_counter() - start,
        notes=notes,
        params_given=params is not None,
        explanation=explanation,
        renamed=renamed,
        explain_terms=tuple(t.as_dict() for t in terms),
        joint_terms=tuple(t.as_dict() for t in joint_terms),
        hints=hints,
    )
