"""``robodyn check``: Pinocchio's dynamics against hand-derived formulas and against itself.

Over seeded random states (q uniform in [-pi, pi] around neutral, v and a uniform in
[-2, 2], tau uniform in [-1, 1]) the check compares

* with a formula: M, C, G, C v + G, inverse and forward dynamics, kinetic and potential
  energy (the latter up to a constant);
* always, the structural properties: M symmetric positive definite, dM/dt - 2C skew,
  G = dV/dq, and Pinocchio's identities C v + G = RNEA(q, v, 0), M^-1 (tau - nle) = ABA,
  RNEA(ABA(tau)) = tau, CRBA = columns of RNEA;
* Pinocchio's routines with each other: 1/2 v^T M v against ``computeKineticEnergy``.
  Disagreements there are Pinocchio's own gaps; they are reported plainly but do not fail
  the check, because robodyn uses 1/2 v^T M v.

Errors are relative to the largest magnitude the quantity takes over the sampled states.
Finite differences (dM/dt, dV/dq) use a central step of ``FD_STEP`` and are held to
``FD_TOL``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics
from robodyn.errors import AssumptionError, InputError
from robodyn.kinds.evaluation import Points, Values, evaluate
from robodyn.kinds.formula import Formula
from robodyn.kinds.params import Params, extract, from_mapping
from robodyn.kinds.sandbox import DEFAULT_TIMEOUT
from robodyn.kinds.user import UserFormula, resolve
from robodyn.robot import Robot

Array = NDArray[np.float64]

GROUP_ORDER = ("formula", "structure", "identity", "pinocchio")
DEFAULT_RTOL = 1e-9  # formula vs Pinocchio, and Pinocchio vs itself: round-off only
FD_STEP = 1e-6  # central finite differences: truncation ~ h^2 = 1e-12, round-off ~ eps/h = 2e-10
FD_TOL = 1e-6  # what the finite-difference rows are held to (above their error, far below a misprint)
SPEED = 2.0  # |v|, |a| sampled up to this [rad/s, rad/s^2 | m/s, m/s^2]
TORQUE = 1.0  # |tau| sampled up to this [N m | N]
SINGULAR_RATIO = 1e-12  # lambda_min / lambda_max of M at or below this: singular to working precision (as simulate)
NON_NEGATIVE = ("m1", "m2", "M", "m", "I1", "I2", "I", "J_l", "J_m")  # masses [kg], inertias [kg m^2]: given >= 0
# The most random states one check takes: ~40 s for the Pendubot with a formula file (6 s of it the file's, inside
# sandbox.DEFAULT_TIMEOUT). The worst error over 10^5 states is rarely beaten by more; another seed explores as well.
MAX_SAMPLES = 100_000


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

    @property
    def passed(self) -> bool:
        """True when the worst relative error is within tolerance."""
        return bool(self.max_rel_error <= self.tolerance)

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
        return {**out, "status": self.status}


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

    @property
    def passed(self) -> bool:
        """True when every row that counts is within tolerance."""
        return all(r.passed for r in self.rows if r.counts)

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
        out.update(notes=list(self.notes), rows=[r.as_dict() for r in self.rows])
        return {**out, "passed": self.passed}


@dataclass(frozen=True)
class _Sample:
    q: Array
    v: Array
    a: Array
    tau: Array


class _Accumulator:
    """Collect (reference, value) pairs per sample and reduce them to a CheckRow."""

    def __init__(self, quantity: str, group: str, unit: str, tolerance: float, *, counts: bool = True, note: str = ""):
        self.quantity, self.group, self.unit, self.tolerance = quantity, group, unit, tolerance
        self.counts, self.note = counts, note
        self.pairs: list[tuple[Array, Array]] = []

    def add(self, reference: ArrayLike, value: ArrayLike) -> None:
        self.pairs.append(
            (np.atleast_1d(np.asarray(reference, dtype=np.float64)), np.atleast_1d(np.asarray(value, dtype=np.float64)))
        )

    def row(self, samples: list[_Sample], scalar: bool = False) -> CheckRow:
        scale = max(float(np.max(np.abs(ref))) for ref, _ in self.pairs)
        errors = [np.abs(val - ref) for ref, val in self.pairs]
        worst = int(np.argmax([e.max() for e in errors]))
        abs_err = float(errors[worst].max())
        # A reference that is zero at every sample (C of a constant M) leaves only round-off:
        # then the error is measured against 1 in the row's unit.
        rel_err = 0.0 if abs_err == 0.0 else (abs_err / scale if scale > 0 else abs_err)
        ref, val = self.pairs[worst]
        entry = np.unravel_index(int(np.argmax(errors[worst])), errors[worst].shape)
        return CheckRow(
            self.quantity, self.group, self.unit, abs_err, rel_err, self.tolerance, worst,
            samples[worst].q.copy(), samples[worst].v.copy(),
            () if scalar else tuple(int(i) for i in entry),
            float(ref[entry]), float(val[entry]), self.counts, self.note,
        )  # fmt: skip


def _draw_samples(robot: Robot, samples: int, seed: int) -> list[_Sample]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(samples):
        q, v = robot.random_state(rng, speed=SPEED)
        out.append(_Sample(q, v, rng.uniform(-SPEED, SPEED, robot.nv), rng.uniform(-TORQUE, TORQUE, robot.nv)))
    return out


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


def _formula_points(formula: Formula, samples: list[_Sample], q_anchor: Array, nv: int) -> Points:
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


def _formula_values(formula: Formula, p: Params, points: Points) -> Values:
    """A user's file in one round trip to its own process; a built-in kind here."""
    if isinstance(formula, UserFormula):
        return formula.evaluate(p, points)
    return evaluate(formula, p, points)


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
    robot: Robot, formula: Formula, p: Params, samples: list[_Sample], rtol: float, given: str | None
) -> list[CheckRow]:
    """The rows; ``given``: None, or the parameters were given (their refusals start with it) and M must be SPD."""
    model, data = robot.model, robot.data
    fd_tol = max(rtol, FD_TOL)
    acc = {
        "M": _Accumulator("M", "formula", "kg m^2 (kg on slides)", rtol),
        "C": _Accumulator("C", "formula", "kg m^2/s", rtol),
        "G": _Accumulator("G", "formula", "N m (N on slides)", rtol),
        "nle": _Accumulator("nle = C v + G", "formula", "N m", rtol),
        "id": _Accumulator("tau (inverse dynamics)", "formula", "N m", rtol),
        "fd": _Accumulator("a (forward dynamics)", "formula", "rad/s^2 (m/s^2 on slides)", rtol),
        "T": _Accumulator("T = 1/2 v^T M v", "formula", "J", rtol),
        "skew": _Accumulator("N = dM/dt - 2C skew (formula)", "structure", "kg m^2/s", fd_tol),
    }
    if formula.potential_energy is not None:
        acc["V"] = _Accumulator("V - V(q0)", "formula", "J", rtol)
        acc["dV"] = _Accumulator("G = dV/dq (formula)", "structure", "N m", fd_tol)
    q_anchor = dynamics.neutral(model)
    n, nv = len(samples), robot.nv
    values = _formula_values(formula, p, _formula_points(formula, samples, q_anchor, nv))
    M_all, C_all, G_all, V_all = values.mass_matrix, values.coriolis_matrix, values.gravity, values.potential_energy
    if given is not None:
        _refuse_singular(p, M_all[:n], samples, given)
    skew_scale = 0.0  # dM/dt - 2C has no reference of its own: see _skew_scale
    for k, s in enumerate(samples):
        M_p = dynamics.mass_matrix(model, data, s.q)
        M_f, C_f, G_f = M_all[k], C_all[k], G_all[k]
        acc["M"].add(M_p, M_f)
        acc["C"].add(dynamics.coriolis_matrix(model, data, s.q, s.v), C_f)
        acc["G"].add(dynamics.gravity(model, data, s.q), G_f)
        acc["nle"].add(dynamics.nonlinear_effects(model, data, s.q, s.v), C_f @ s.v + G_f)
        acc["id"].add(dynamics.rnea(model, data, s.q, s.v, s.a), M_f @ s.a + C_f @ s.v + G_f)
        acc["fd"].add(dynamics.aba(model, data, s.q, s.v, s.tau), _solve(M_f, s.tau - C_f @ s.v - G_f))
        acc["T"].add(0.5 * float(s.v @ M_p @ s.v), 0.5 * float(s.v @ M_f @ s.v))
        Mdot = (M_all[n + k] - M_all[2 * n + k]) / (2 * FD_STEP)  # central difference along v
        N = Mdot - 2 * C_f
        acc["skew"].add(np.zeros_like(N), N + N.T)
        skew_scale = max(skew_scale, _skew_scale(Mdot, C_f, M_f, s.v))
        if formula.potential_energy is not None:
            acc["V"].add(
                dynamics.potential_energy(model, data, s.q) - dynamics.potential_energy(model, data, q_anchor),
                float(V_all[k]) - float(V_all[n]),
            )
            plus = V_all[n + 1 + k : n + 1 + nv * n : n]  # V(q + h e_i), i = 0 .. nv-1
            minus = V_all[n + 1 + nv * n + k :: n]  # V(q - h e_i)
            acc["dV"].add(G_f, (plus - minus) / (2 * FD_STEP))
    scalars = {"T", "V"}
    rows = [a.row(samples, scalar=k in scalars) for k, a in acc.items()]
    rows[list(acc).index("skew")] = _rescale(acc["skew"].row(samples), skew_scale)
    return rows


def _skew_scale(Mdot: Array, C: Array, M: Array, v: Array) -> float:
    """Reference magnitude for N = dM/dt - 2C: max(|dM/dt|, |2C|, |M| |v|); |M| |v| for M nearly constant, C ~ 0."""
    return max(float(np.abs(Mdot).max()), 2 * float(np.abs(C).max()), float(np.abs(M).max() * np.abs(v).max()))


def _rescale(row: CheckRow, scale: float) -> CheckRow:
    """Express a row whose reference is zero relative to ``scale`` instead.

    With ``scale`` zero (M constant and C zero: nothing moves the metric) only round-off
    can be left, so the error is measured against 1 in the row's unit.
    """
    error = row.max_abs_error
    return replace(row, max_rel_error=0.0 if error == 0.0 else error / scale if scale > 0 else error)


def _structure_rows(robot: Robot, samples: list[_Sample], rtol: float) -> list[CheckRow]:
    model, data = robot.model, robot.data
    fd_tol = max(rtol, FD_TOL)
    integrate = lambda q, dq: dynamics.integrate(model, q, dq)  # noqa: E731
    mass = lambda q: dynamics.mass_matrix(model, data, q)  # noqa: E731
    spd = _Accumulator("M symmetric positive definite", "structure", "kg m^2", rtol)
    skew = _Accumulator("N = dM/dt - 2C skew", "structure", "kg m^2/s", fd_tol)
    grad = _Accumulator("G = dV/dq", "structure", "N m", fd_tol)
    nle = _Accumulator("C v + G = RNEA(q, v, 0)", "identity", "N m", rtol)
    columns = _Accumulator("CRBA = RNEA columns", "identity", "kg m^2", rtol)
    inverse = _Accumulator("RNEA(q, v, ABA(q, v, tau)) = tau", "identity", "N m", rtol)
    forward = _Accumulator("M^-1 (tau - nle) = ABA", "identity", "rad/s^2", rtol)
    kinetic = _Accumulator(
        "1/2 v^T M v = computeKineticEnergy", "pinocchio", "J", rtol, counts=False,
        note="Pinocchio's computeKineticEnergy leaves out armature on joints with a non-canonical axis; "
        "robodyn uses 1/2 v^T M v",
    )  # fmt: skip
    skew_scale = 0.0  # N's reference magnitude over the samples (see _skew_scale)
    min_eig_ratio = np.inf
    aba_ok = True
    energy_refused = False
    for s in samples:
        M = mass(s.q)
        raw = np.array(M)
        eig = np.linalg.eigvalsh(raw) if np.all(np.isfinite(raw)) else np.full(robot.nv, np.nan)
        min_eig_ratio = min(min_eig_ratio, eig[0] / eig[-1])
        # Positive definiteness: a non-positive eigenvalue shows as an error of its size.
        spd.add(np.zeros(1), np.array([max(0.0, -eig[0]) + (eig[-1] if eig[0] <= 0 else 0.0)]))
        C = dynamics.coriolis_matrix(model, data, s.q, s.v)
        G = dynamics.gravity(model, data, s.q)
        Mdot = _mdot(mass, integrate, s.q, s.v)
        skew_scale = max(skew_scale, _skew_scale(Mdot, C, M, s.v))
        N = Mdot - 2 * C
        skew.add(np.zeros_like(N), N + N.T)
        grad.add(G, _grad(lambda q: dynamics.potential_energy(model, data, q), integrate, s.q, robot.nv))
        b = dynamics.nonlinear_effects(model, data, s.q, s.v)
        nle.add(b, C @ s.v + G)
        zero = np.zeros(robot.nv)
        cols = np.column_stack([dynamics.rnea(model, data, s.q, zero, e) - G for e in np.eye(robot.nv)])
        columns.add(M, cols)
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
        forward.add(a_aba, a_crba)
        inverse.add(s.tau, dynamics.rnea(model, data, s.q, s.v, a_crba))
        T = 0.5 * float(s.v @ M @ s.v)
        try:
            kinetic.add(T, dynamics.pinocchio_kinetic_energy(model, data, s.q, s.v))
        except RuntimeError:  # computeKineticEnergy refuses mimic joints
            energy_refused = True
            kinetic.add(T, T)
    rows = [
        spd.row(samples),
        _rescale(skew.row(samples), skew_scale),
        grad.row(samples),
        nle.row(samples),
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
) -> CheckReport:
    """Compare ``robot``'s Pinocchio dynamics with ``formula`` and with its own identities.

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
    if formula is not None:
        resolved = resolve(formula, timeout=formula_timeout) if isinstance(formula, str) else formula
        try:
            try:
                p = extract(robot, resolved.kind)
            except AssumptionError as exc:  # say which model: the message names only the assumption it breaks
                raise AssumptionError(str(exc), path=robot.urdf_path or robot.name) from None
            given = None if params is None else (f"{params_source}: " if params_source else "")
            if params is not None and given is not None:
                p = _given_params(resolved.kind, params, given)
            used, kind = p.as_dict(), resolved.kind
            source = formula if isinstance(formula, str) else resolved.source
            rows += _formula_rows(robot, resolved, p, states, rtol, given)
        finally:
            if isinstance(formula, str) and isinstance(resolved, UserFormula):
                resolved.close()  # the file's process was this check's own
    rows += _structure_rows(robot, states, rtol)
    rows.sort(key=lambda r: GROUP_ORDER.index(r.group))  # stable: keeps the order within a group
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
        params_given=params is not None,
    )
