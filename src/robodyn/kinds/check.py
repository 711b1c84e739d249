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

A ``KIND = "constrained"`` formula (a closed chain's reduced Lagrangian) replaces the formula
rows by those of :mod:`robodyn.kinds.loop_check`. Errors are relative to the largest magnitude
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

import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.errors import AssumptionError, InputError, RobodynError
from robodyn.kinds import any_check
from robodyn.kinds.any_file import KIND as ANY
from robodyn.kinds.check_rows import (
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
from robodyn.kinds.check_scales import scales
from robodyn.kinds.formula import Formula
from robodyn.kinds.loop_check import loop_rows
from robodyn.kinds.params import Params, extract, from_mapping
from robodyn.kinds.reduced import KIND as CONSTRAINED
from robodyn.kinds.reference import Reference
from robodyn.kinds.sandbox import DEFAULT_TIMEOUT
from robodyn.kinds.user import UserFormula, resolve
from robodyn.robot import Robot

Array = NDArray[np.float64]
__all__ = ["DEFAULT_RTOL", "FD_STEP", "FD_TOL", "MAX_SAMPLES", "CheckReport", "CheckRow", "check"]
SPEED = 2.0  # |v|, |a| sampled up to this [rad/s, rad/s^2 | m/s, m/s^2]
TORQUE = 1.0  # |tau| sampled up to this [N m | N]
SINGULAR_RATIO = 1e-12  # lambda_min / lambda_max of M at or below this: singular to working precision (as simulate)
NON_NEGATIVE = ("m1", "m2", "m_cart", "m", "I1", "I2", "I", "J_l", "J_m")  # masses [kg], inertias [kg m^2]: given >= 0
# The most random states one check takes: ~40 s for the Pendubot with a formula file (6 s of it the file's, inside
# sandbox.DEFAULT_TIMEOUT). The worst error over 10^5 states is rarely beaten by more; another seed explores as well.
MAX_SAMPLES = 100_000


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


def _mdot(mass: Callable[[Array], Array], integrate: Callable[[Array, Array], Array], q: Array, v: Array) -> Array:
    """dM/dt along v by a central difference of step FD_STEP."""
    return (mass(integrate(q, FD_STEP * v)) - mass(integrate(q, -FD_STEP * v))) / (2 * FD_STEP)


def _grad(potential: Callable[[Array], float], integrate: Callable[[Array, Array], Array], q: Array, nv: int) -> Array:
    """dV/dq by central differences of step FD_STEP along each tangent direction."""
    grad = np.empty(nv)
    for i in range(nv):
        e = np.zeros(nv)
        e[i] = FD_STEP
        grad[i] = (potential(integrate(q, e)) - potential(integrate(q, -e))) / (2 * FD_STEP)
    return grad


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
        acc["C"].add(ref.coriolis_matrix(s.q, s.v), C_f, sc.floor(sc.coriolis_terms))
        acc["G"].add(ref.gravity(s.q), G_f, sc.floor(sc.energy))
        nle_terms = sc.mass * sc.speed**2 + sc.energy
        acc["nle"].add(ref.nonlinear_effects(s.q, s.v), C_f @ s.v + G_f, sc.floor(nle_terms))
        acc["id"].add(ref.rnea(s.q, s.v, s.a), M_f @ s.a + C_f @ s.v + G_f, sc.floor(sc.torque_terms))
        acc["fd"].add(a_p, _solve(M_f, s.tau - C_f @ s.v - G_f), sc.forward_floor(a_p))
        acc["T"].add(0.5 * float(s.v @ M_p @ s.v), 0.5 * float(s.v @ M_f @ s.v), sc.floor(sc.mass * sc.speed**2))
        Mdot = (M_all[n + k] - M_all[2 * n + k]) / (2 * FD_STEP)  # central difference along v
        N = Mdot - 2 * C_f
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
    rows[list(acc).index("skew")] = acc["skew"].row(samples, zero_reference_scale=n_scale)
    rows[list(acc).index("sym")] = acc["sym"].row(samples, zero_reference_scale=m_scale)
    return rows


def _structure_rows(robot: Robot, samples: list[_Sample], rtol: float) -> list[CheckRow]:
    model, data = robot.model, robot.data
    fd_tol = max(rtol, FD_TOL)
    integrate = lambda q, dq: dynamics.integrate(model, q, dq)  # noqa: E731
    mass = lambda q: dynamics.mass_matrix(model, data, q)  # noqa: E731
    spd = Accumulator("M symmetric positive definite", "structure", "kg m^2", rtol)
    skew = Accumulator("N = dM/dt - 2C skew", "structure", "kg m^2/s", fd_tol)
    grad = Accumulator("G = dV/dq", "structure", "N m", fd_tol)
    nle = Accumulator("C v + G = RNEA(q, v, 0)", "identity", "N m", rtol)
    columns = Accumulator("CRBA = RNEA columns", "identity", "kg m^2", rtol)
    inverse = Accumulator("RNEA(q, v, ABA(q, v, tau)) = tau", "identity", "N m", rtol)
    forward = Accumulator("M^-1 (tau - nle) = ABA", "identity", "rad/s^2", rtol)
    kinetic = Accumulator(
        "1/2 v^T M v = computeKineticEnergy", "pinocchio", "J", rtol, counts=False,
        note="Pinocchio's computeKineticEnergy leaves out armature on joints with a non-canonical axis; "
        "robodyn uses 1/2 v^T M v",
    )  # fmt: skip
    mimic = dynamics.has_mimic_joints(model)
    coriolis = Accumulator(
        "computeCoriolisMatrix = C by RNEA", "pinocchio", "kg m^2/s", rtol, counts=False,
    )  # fmt: skip
    n_scale = 0.0  # N's reference magnitude over the samples (see skew_scale)
    min_eig_ratio = np.inf
    aba_ok = True
    energy_refused = False
    for s in samples:
        M = mass(s.q)
        raw = np.array(M)
        eig = np.linalg.eigvalsh(raw) if np.all(np.isfinite(raw)) else np.full(robot.nv, np.nan)
        min_eig_ratio = min(min_eig_ratio, eig[0] / eig[-1])
        sc = scales(robot, s, raw)
        # Positive definiteness: a non-positive eigenvalue shows as an error of its size. An eigenvalue
        # within round-off of zero (a body without inertia: icub) is still singular, so no floor here.
        singular = eig[0] <= SINGULAR_RATIO * eig[-1]  # as simulate refuses it
        spd.add(np.zeros(1), np.array([max(0.0, -eig[0]) + (eig[-1] if singular else 0.0)]))
        C = dynamics.coriolis_matrix(model, data, s.q, s.v)
        coriolis.add(
            dynamics.pinocchio_coriolis_matrix(model, data, s.q, s.v),
            C if mimic else dynamics.christoffel_coriolis(model, data, s.q, s.v),
            sc.floor(sc.coriolis_terms),
        )
        G = dynamics.gravity(model, data, s.q)
        Mdot = _mdot(mass, integrate, s.q, s.v)
        n_scale = max(n_scale, skew_scale(Mdot, C, M, s.v))
        N = Mdot - 2 * C
        skew.add(np.zeros_like(N), N + N.T, sc.floor(sc.mass * sc.speed / FD_STEP))
        grad.add(
            G,
            _grad(lambda q: dynamics.potential_energy(model, data, q), integrate, s.q, robot.nv),
            sc.floor(sc.energy / FD_STEP),
        )
        b = dynamics.nonlinear_effects(model, data, s.q, s.v)
        nle.add(b, C @ s.v + G, sc.floor(sc.mass * sc.speed**2 + sc.energy))
        zero = np.zeros(robot.nv)
        cols = np.column_stack([dynamics.rnea(model, data, s.q, zero, e) - G for e in np.eye(robot.nv)])
        columns.add(M, cols, sc.floor(sc.mass + sc.energy))
        try:
            a_crba = dynamics.crba_solve(model, data, s.q, s.v, s.tau)
        except np.linalg.LinAlgError:  # M not positive definite: the rows solving through it fail, saying so
            a_crba = np.full(robot.nv, np.nan)
            forward.note = inverse.note = (
                forward.note or f"M(q) is not positive definite at sample {len(forward.pairs)}"
            )
        try:
            a_aba = dynamics.aba(model, data, s.q, s.v, s.tau)
        except (RuntimeError, ValueError):
            aba_ok, a_aba = False, a_crba
        forward.add(a_aba, a_crba, sc.forward_floor(a_aba))
        # tau -> a -> tau: ABA solves with a matrix off by eps |M|, which comes back through RNEA as eps |M| |a|
        # (|a| is up to |M^-1| |tau - nle|: cond(M) times the torques' terms on an ill-conditioned M)
        a_size = float(np.abs(a_crba).max())
        inverse.add(s.tau, dynamics.rnea(model, data, s.q, s.v, a_crba), sc.floor(sc.mass * a_size + sc.torque_terms))
        T = 0.5 * float(s.v @ M @ s.v)
        t_floor = sc.floor(sc.mass * sc.speed**2)
        try:
            kinetic.add(T, dynamics.pinocchio_kinetic_energy(model, data, s.q, s.v), t_floor)
        except RuntimeError:  # computeKineticEnergy refuses mimic joints
            energy_refused = True
            kinetic.add(T, T)
    nle_row = nle.row(samples)
    if mimic:  # C itself comes from RNEA here: the identity holds by construction
        nle_row = replace(
            nle_row, note="on mimic joints robodyn's C is built from RNEA, so this row holds by construction"
        )
    rows = [
        spd.row(samples),
        skew.row(samples, zero_reference_scale=n_scale),
        grad.row(samples),
        nle_row,
        columns.row(samples),
        inverse.row(samples),
    ]
    forward_row = forward.row(samples)
    if not aba_ok:
        forward_row = replace(forward_row, counts=False, applicable=False, note="ABA refuses mimic joints")
    rows.append(forward_row)
    kinetic_row = kinetic.row(samples, scalar=True)
    if energy_refused:
        kinetic_row = replace(
            kinetic_row, counts=False, applicable=False, note="computeKineticEnergy refuses mimic joints"
        )
    elif kinetic_row.passed:
        kinetic_row = replace(kinetic_row, note="")
    else:
        unaligned = [j.name for j in robot.joints if "Unaligned" in j.kind and robot.armature[j.idx_v] != 0]
        if unaligned:
            kinetic_row = replace(
                kinetic_row,
                note=f"Pinocchio's computeKineticEnergy leaves out the armature of joint(s) {', '.join(unaligned)} "
                "(non-canonical axis, RevoluteUnaligned); 1/2 v^T M v includes it and is what robodyn uses",
            )
        else:
            kinetic_row = replace(kinetic_row, note="Pinocchio's kinetic-energy routine disagrees with 1/2 v^T M v")
    rows.append(kinetic_row)
    coriolis_row = coriolis.row(samples)
    if not coriolis_row.passed:
        coriolis_row = replace(
            coriolis_row,
            note="Pinocchio's computeCoriolisMatrix is wrong on models with mimic joints (C v + G != RNEA, "
            "dM/dt - 2C not skew); robodyn's C is the Christoffel matrix from RNEA"
            if mimic
            else "Pinocchio's computeCoriolisMatrix disagrees with the Christoffel C from RNEA",
        )
    rows.append(coriolis_row)
    rows[0] = replace(rows[0], note=f"min over samples of lambda_min / lambda_max = {min_eig_ratio:.3g}")
    return rows


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
    states on the loop (:mod:`robodyn.kinds.loop_check`); its parameters come from its
    ``parameters(scene)``, or are ``params``. Other formulas check the open tree, and take no
    loops or springs (a note says so when they are given).

    Args:
        robot: a loaded model (see :func:`robodyn.load`).
        formula: a kind name (``"pendubot"``...), a path to a user's formula file, a
            :class:`robodyn.kinds.formulas.Formula`, or None for the structural checks only.
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
            :mod:`robodyn.kinds.sandbox`). A loaded :class:`UserFormula` keeps its own limit.
        loops: a constrained formula's loop closures: mappings or objects with ``frame_a``,
            ``frame_b`` and ``kind`` (:class:`robodyn.sim.constraints.Loop`).
        springs: a constrained formula's joint springs: joint -> ``{"stiffness", "rest"}`` (or
            a Spring, or ``(k, rest)``), or (joint, spring) pairs.
        scene: the scene file a constrained formula's ``parameters(scene)`` reads.
        explain: name the wrong term of each mismatching entry of M, C, G and V in the formula's own
            symbols, and say what the knock-on rows follow from (:mod:`robodyn.kinds.explain`); the lines
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
    rows: list[CheckRow] = []
    used: dict[str, float] = {}
    kind = None
    source = None
    notes: tuple[str, ...] = ()
    kept: dict[str, Accumulator] = {}  # the formula rows' accumulators, for --explain
    explained: tuple[list[_Sample], Reference] | None = None  # and the states they were taken at
    if formula is not None:
        resolved = resolve(formula, timeout=formula_timeout) if isinstance(formula, str) else formula
        try:
            source, kind = (formula if isinstance(formula, str) else resolved.source), resolved.kind
            if kind == CONSTRAINED:
                found = loop_rows(
                    robot, resolved, loops=loops, springs=springs, scene=None if scene is None else str(scene),
                    params=params, samples=samples, seed=seed, rtol=rtol,
                )  # fmt: skip
                rows, used, notes = list(found.rows), found.params, found.notes
            elif kind == ANY:
                setup = any_check.prepare(robot, resolved, None if params is None else dict(params))
                ref = setup.reference
                mapped = [
                    _Sample(ref.formula_q(s.q), ref.formula_v(s.v), ref.formula_v(s.a), ref.formula_v(s.tau))
                    for s in _draw_samples(setup.robot, samples, seed)
                ]
                used, notes = setup.params, setup.notes
                p_any = Params(ANY, used)
                rows += _formula_rows(setup.robot, resolved, p_any, mapped, rtol, None, reference=ref, keep=kept)
                explained = (mapped, ref)
            else:
                try:
                    p = extract(robot, resolved.kind)
                except AssumptionError as exc:  # say which model: the message names only the assumption it breaks
                    raise AssumptionError(str(exc), path=robot.urdf_path or robot.name) from None
                given = None if params is None else (f"{params_source}: " if params_source else "")
                if params is not None and given is not None:
                    p = _given_params(resolved.kind, params, given)
                used = p.as_dict()
                rows += _formula_rows(robot, resolved, p, states, rtol, given, keep=kept)
                explained = (states, Reference.identity(robot))
        finally:
            if isinstance(formula, str) and isinstance(resolved, UserFormula):
                resolved.close()  # the file's process was this check's own
    rows += _structure_rows(robot, states, rtol)
    rows.sort(key=lambda r: GROUP_ORDER.index(r.group))  # stable: keeps the order within a group
    explanation: tuple[str, ...] = ()
    if explain and explained is not None:
        explanation = any_check.explain_rows(rows, kept, *explained, used)
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
    )
