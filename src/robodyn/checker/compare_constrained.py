"""A closed chain's reduced Lagrangian against Pinocchio's constrained dynamics, at random states on the loop.

A ``KIND = "constrained"`` formula (the contract: :mod:`robodyn.checker.constrained_kind`) gives M(theta),
C(theta, omega) and G(theta) (springs included) in the independent coordinates theta, and
``on_the_loop``, which maps (theta, omega) to the full state. At seeded random (theta, omega, tau)
-- theta uniform within the independent joints' URDF limits (within [-pi, pi]), omega uniform in
[-2, 2], tau uniform in [-1, 1] on the independent joints -- the check puts the tree on the loop
with ``on_the_loop`` and compares, with Pinocchio's M, C, G of the open tree and the loops'
Jacobian J there:

* S (nv, n), the basis of J's null space aligned with the independent joints (S = I on
  them, J S = 0): velocities on the loop are v = S omega;
* **M** against S^T M S; **G** against S^T (G + K (q - rest)) (the springs');
* **C omega** (the reduced bias: a C matrix is not unique, its product with omega is)
  against S^T (M (dS/dt) omega + C v). (dS/dt) omega is read off Pinocchio's own constrained
  acceleration a at (q, v): it is a - S a_independent, the one acceleration on the loop whose
  independent entries are 0;
* **the acceleration**: the formula's M^-1 (tau - C omega - G) against the independent entries of
  ``constraintDynamics(q, v, tau - K (q - rest))``;
* **V** (up to a constant) against Pinocchio's potential plus the springs';
* ``on_the_loop`` itself: the loops' residual at its q [m], its v against S omega, its
  independent entries against (theta, omega);
* the formula's own structure: dM/dt - 2C skew and G = dV/dtheta (finite differences).

Errors are relative to the largest magnitude of the quantity over the samples (absolute, in
the row's unit, where the reference is zero: the loop residual in metres). Nothing here
imports Pinocchio: the constrained dynamics come from :mod:`robodyn.constrained`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn import constrained, dynamics
from robodyn.checker.constrained_kind import LoopStates, checked_parameters
from robodyn.checker.rows import (
    FD_STEP,
    FD_TOL,
    Accumulator,
    CheckRow,
    formula_points,
    formula_values,
    skew_scale,
)
from robodyn.errors import FormulaError, InputError, UnknownNameError
from robodyn.kinds.formula import Formula
from robodyn.robot import JointInfo, Robot

Array = NDArray[np.float64]

SPEED = 2.0  # |omega| sampled up to this [rad/s | m/s]
TORQUE = 1.0  # |tau| on the independent joints sampled up to this [N m | N]
# Below this smallest singular value of J's dependent columns (relative to the largest) the loops do
# not fix the dependent joints: a fold of the linkage, where the reduced dynamics are not defined.
FOLD_RATIO = 1e-8


@dataclass(frozen=True)
class LoopCheck:
    """What :func:`loop_rows` found: the rows, the parameters used and notes for the report."""

    rows: tuple[CheckRow, ...]
    params: dict[str, float]
    notes: tuple[str, ...]


@dataclass(frozen=True)
class _Sample:
    q: Array  # the independent coordinates theta (n,)
    v: Array  # omega (n,)


@dataclass(frozen=True)
class _Springs:
    iq: NDArray[np.intp]
    iv: NDArray[np.intp]
    stiffness: Array
    rest: Array

    def torque(self, q: Array, nv: int) -> Array:
        tau = np.zeros(nv)
        np.add.at(tau, self.iv, -self.stiffness * (q[self.iq] - self.rest))
        return tau

    def energy(self, q: Array) -> float:
        return float(0.5 * np.sum(self.stiffness * (q[self.iq] - self.rest) ** 2))


def loop_rows(
    robot: Robot,
    formula: Any,
    *,
    loops: Iterable[Any],
    springs: Any = None,
    scene: str | None = None,
    params: Mapping[str, float] | None = None,
    samples: int,
    seed: int,
    rtol: float,
) -> LoopCheck:
    """The rows of a constrained ``formula`` (a loaded :class:`UserFormula` or :class:`ConstrainedFormula`).

    Args:
        robot: the open tree (loaded without the loops).
        formula: its ``independent`` names the URDF joints of its coordinates.
        loops: loop closures, each a mapping or an object with ``frame_a``, ``frame_b`` and
            ``kind`` (``"point"`` or ``"6d"``), as :class:`robodyn.sim.constraints.Loop`.
        springs: joint springs: a mapping joint -> ``{"stiffness": k, "rest": r}`` (or an
            object with those attributes, or ``(k, r)``), or (joint, spring) pairs.
        scene: the scene file's path, handed to the file's ``parameters(scene)``.
        params: the formula's parameters, given instead of ``parameters(scene)``.
        samples: number of random states on the loop.
        seed: seed of the random states.
        rtol: tolerance of the exact rows (finite-difference rows: ``max(rtol, FD_TOL)``).

    Raises:
        InputError: neither ``scene`` nor ``params``; a negative stiffness; the loops do not fix
            the dependent joints at a sample.
        UnknownNameError: an independent joint, a frame or a sprung joint the robot does not have.
        FormulaError: the file's functions fail, or ``on_the_loop`` names joints the model has not.
    """
    independent = _independent_joints(robot, tuple(formula.independent), formula.source)
    solver = _solver(robot, loops)
    spring = _springs(robot, springs)
    if params is not None:
        p = checked_parameters(dict(params), "params")
    elif scene is not None:
        p = formula.parameters(str(scene))
    else:
        raise InputError(
            f"{formula.source}: a constrained formula's parameters(scene) reads the scene: give scene= (or params=)"
        )
    n = len(independent)
    rng = np.random.default_rng(seed)
    low, high = _domain(robot, independent)
    theta = rng.uniform(low, high, (samples, n))
    omega = rng.uniform(-SPEED, SPEED, (samples, n))
    tau_i = rng.uniform(-TORQUE, TORQUE, (samples, n))
    states = formula.loop_states(theta, omega, p)
    q_full, v_user = _full_states(robot, states, formula.source)
    points = [_Sample(theta[k], omega[k]) for k in range(samples)]
    rows = _rows(robot, formula, p, points, q_full, v_user, tau_i, independent, solver, spring, rtol)
    names = ", ".join(j.name for j in independent)
    notes = (
        f"reduced coordinates: {names}; the q, v of a mismatch are theirs, sampled in "
        + ", ".join(f"[{lo:.4g}, {hi:.4g}]" for lo, hi in zip(low, high, strict=True)),
    )
    return LoopCheck(tuple(rows), p, notes)


def _independent_joints(robot: Robot, names: tuple[str, ...], source: str) -> list[JointInfo]:
    joints = {j.name: j for j in robot.joints}
    out = []
    for name in names:
        if name not in joints:
            raise UnknownNameError(f"independent joint (INDEPENDENT of {source})", name, joints)
        if joints[name].nq != 1 or joints[name].nv != 1:
            raise InputError(
                f"{source}: INDEPENDENT joint {name!r} has {joints[name].nq} coordinates; expected a 1-DoF joint"
            )
        out.append(joints[name])
    return out


def _domain(robot: Robot, joints: list[JointInfo]) -> tuple[Array, Array]:
    """Where each independent coordinate is sampled: its URDF limits within [-pi, pi] [rad | m]."""
    lower = np.asarray(robot.model.lowerPositionLimit, dtype=np.float64)
    upper = np.asarray(robot.model.upperPositionLimit, dtype=np.float64)
    low = np.array([max(-np.pi, float(lower[j.idx_q])) for j in joints])
    high = np.array([min(np.pi, float(upper[j.idx_q])) for j in joints])
    bad = ~(low < high)
    low[bad], high[bad] = -np.pi, np.pi  # no usable limits (or inverted ones): a full turn
    return low, high


def _field(entry: Any, key: str, default: Any = None) -> Any:
    return entry.get(key, default) if isinstance(entry, Mapping) else getattr(entry, key, default)


def _solver(robot: Robot, loops: Iterable[Any]) -> constrained.ConstraintSolver:
    """The loops as Pinocchio constraints (no Baumgarte pull: every state is on the loop)."""
    model = robot.model
    closures = []
    names = constrained.frame_names(model)
    for i, loop in enumerate(loops):
        pair = []
        for key in ("frame_a", "frame_b"):
            name = str(_field(loop, key))
            found = constrained.anchor(model, name)
            if found is None:
                raise UnknownNameError(f"frame (loops[{i}].{key})", name, names)
            pair.append(found)
        kind = str(_field(loop, "kind", "point"))
        if kind not in constrained.KINDS:
            raise InputError(f"loops[{i}].kind must be one of {', '.join(constrained.KINDS)}, got {kind!r}")
        closures.append(constrained.loop_model(model, kind, pair[0], pair[1], 0.0, 0.0))
    if not closures:
        raise InputError(
            "a constrained formula is checked on the loops it lives on: give loops (a scene's [constraints] loops)"
        )
    return constrained.ConstraintSolver(model, closures)


def _springs(robot: Robot, springs: Any) -> _Springs:
    pairs = list(springs.items()) if isinstance(springs, Mapping) else list(springs or ())
    joints = {j.name: j for j in robot.joints if j.nq == 1 and j.nv == 1}
    iq, iv, k, rest = [], [], [], []
    for name, spring in pairs:
        if name not in joints:
            raise UnknownNameError("joint (springs)", str(name), joints)
        if isinstance(spring, (tuple, list)):
            stiffness, r = float(spring[0]), float(spring[1])
        else:
            stiffness, r = float(_field(spring, "stiffness")), float(_field(spring, "rest", 0.0))
        if not (np.isfinite(stiffness) and stiffness >= 0 and np.isfinite(r)):
            raise InputError(f"springs.{name}: stiffness {stiffness!r} and rest {r!r}; expected stiffness >= 0")
        iq.append(joints[name].idx_q)
        iv.append(joints[name].idx_v)
        k.append(stiffness)
        rest.append(r)
    return _Springs(np.array(iq, dtype=np.intp), np.array(iv, dtype=np.intp), np.array(k), np.array(rest))


def _full_states(robot: Robot, states: LoopStates, source: str) -> tuple[Array, Array]:
    """``on_the_loop``'s states as (k, nq) and (k, nv) arrays in the robot's layout."""
    joints = {j.name: j for j in robot.joints}
    unknown = [name for name in states.joints if name not in joints]
    if unknown:
        raise FormulaError(
            f"{source}: on_the_loop names joint {unknown[0]!r}, which the model has not; "
            f"expected its joints {', '.join(joints)}"
        )
    missing = [name for name in joints if name not in states.joints]
    if missing:
        raise FormulaError(f"{source}: on_the_loop leaves out joint(s) {', '.join(missing)}: give every joint's q, v")
    k = len(states.q)
    Q, V = np.empty((k, robot.nq)), np.empty((k, robot.nv))
    for col, name in enumerate(states.joints):
        j = joints[name]
        if j.nv != 1 or j.nq not in (1, 2):
            raise FormulaError(f"{source}: on_the_loop gives joint {name!r} one number; it has {j.nq} coordinates")
        x = states.q[:, col]
        Q[:, j.idx_q : j.idx_q + j.nq] = x[:, None] if j.nq == 1 else np.column_stack([np.cos(x), np.sin(x)])
        V[:, j.idx_v] = states.v[:, col]
    return Q, V


def _basis(J: Array, ind: NDArray[np.intp], theta: Array, robot: Robot, source: str) -> Array:
    """S (nv, n): S[ind] = I and J S = 0; an InputError where the loops leave a dependent joint free."""
    nv = J.shape[1]
    dep = np.setdiff1d(np.arange(nv), ind)
    S = np.zeros((nv, ind.size))
    S[ind] = np.eye(ind.size)
    if dep.size:
        Jd = J[:, dep]
        sv = np.linalg.svd(Jd, compute_uv=False) if Jd.size else np.zeros(0)
        if sv.size < dep.size or not sv[-1] > FOLD_RATIO * max(float(sv[0]), 1.0):
            by_index = {j.idx_v: j.name for j in robot.joints if j.nv == 1}
            free = ", ".join(by_index.get(int(i), f"v[{i}]") for i in dep)
            raise InputError(
                f"{source}: at theta = {np.array2string(theta, precision=6)} the loops do not fix joint(s) {free} "
                "from the independent ones (a fold of the linkage, or too few loops); expected INDEPENDENT to "
                "name the joints the loops leave free"
            )
        S[dep] = -np.linalg.lstsq(Jd, J[:, ind], rcond=None)[0]
    return S


def _rows(
    robot: Robot,
    formula: Formula,
    p: Mapping[str, float],
    samples: list[_Sample],
    Q: Array,
    V_user: Array,
    tau_i: Array,
    joints: list[JointInfo],
    solver: constrained.ConstraintSolver,
    springs: _Springs,
    rtol: float,
) -> list[CheckRow]:
    model, data = robot.model, robot.data
    fd_tol = max(rtol, FD_TOL)
    ind = np.array([j.idx_v for j in joints], dtype=np.intp)
    ind_q = np.array([j.idx_q for j in joints], dtype=np.intp)
    acc = {
        "M": Accumulator("M (reduced: S^T M S)", "formula", "kg m^2 (kg on slides)", rtol),
        "b": Accumulator("C omega (reduced bias: S^T (M dS/dt omega + C v))", "formula", "N m", rtol),
        "G": Accumulator("G (reduced: S^T (G + springs))", "formula", "N m (N on slides)", rtol),
        "a": Accumulator("a (forward dynamics: constraintDynamics)", "formula", "rad/s^2 (m/s^2 on slides)", rtol),
        "V": Accumulator("V - V(q0) (gravity + springs)", "formula", "J", rtol),
        "r": Accumulator("on_the_loop q: loop residual", "formula", "m (rad on 6d loops)", rtol),
        "qi": Accumulator("on_the_loop q: independent entries = q", "formula", "rad (m on slides)", rtol),
        "v": Accumulator("on_the_loop v = S omega", "formula", "rad/s (m/s on slides)", rtol),
        "skew": Accumulator("N = dM/dt - 2C skew (formula)", "structure", "kg m^2/s", fd_tol),
    }
    if formula.potential_energy is None:
        del acc["V"]
    else:
        acc["dV"] = Accumulator("G = dV/dq (formula)", "structure", "N m", fd_tol)
    n, dof = len(samples), formula.dof
    values = formula_values(formula, p, formula_points(formula, samples, samples[0].q, dof))
    M_all, C_all, G_all, V_all = values.mass_matrix, values.coriolis_matrix, values.gravity, values.potential_energy
    V_ref0 = 0.0
    n_scale = 0.0
    for k, s in enumerate(samples):
        q = Q[k]
        S = _basis(solver.jacobian(q), ind, s.q, robot, formula.source)
        v = S @ s.v
        M = dynamics.mass_matrix(model, data, q)
        G = dynamics.gravity(model, data, q)
        h = dynamics.nonlinear_effects(model, data, q, v)
        tau = springs.torque(q, robot.nv)
        G_springs = G - tau
        tau[ind] += tau_i[k]
        a, _, _ = solver.acceleration(q, v, tau)
        Sdot_omega = a - S @ a[ind]
        M_f, C_f, G_f = M_all[k], C_all[k], G_all[k]
        acc["M"].add(S.T @ M @ S, M_f)
        acc["b"].add(S.T @ (M @ Sdot_omega + h - G), C_f @ s.v)
        acc["G"].add(S.T @ G_springs, G_f)
        acc["a"].add(a[ind], _solve(M_f, tau_i[k] - C_f @ s.v - G_f))
        acc["r"].add(np.zeros(solver.rows), solver.residual(q))
        acc["qi"].add(s.q, Q[k, ind_q])
        acc["v"].add(v, V_user[k])
        Mdot = (M_all[n + k] - M_all[2 * n + k]) / (2 * FD_STEP)
        N = Mdot - 2 * C_f
        acc["skew"].add(np.zeros_like(N), N + N.T)
        n_scale = max(n_scale, skew_scale(Mdot, C_f, M_f, s.v))
        if "V" in acc:
            V_ref = dynamics.potential_energy(model, data, q) + springs.energy(q)
            V_ref0 = V_ref if k == 0 else V_ref0
            acc["V"].add(V_ref - V_ref0, float(V_all[k]) - float(V_all[n]))
            plus = V_all[n + 1 + k : n + 1 + dof * n : n]
            minus = V_all[n + 1 + dof * n + k :: n]
            acc["dV"].add(G_f, (plus - minus) / (2 * FD_STEP))
    rows = [a.row(samples, scalar=key == "V") for key, a in acc.items()]
    rows[list(acc).index("skew")] = acc["skew"].row(samples, zero_reference_scale=n_scale)
    return rows


def _solve(M: Array, b: Array) -> Array:
    """M^-1 b, or NaN (a mismatch in its row) where a formula's M is singular."""
    try:
        return np.asarray(np.linalg.solve(M, b), dtype=np.float64)
    except np.linalg.LinAlgError:
        return np.full_like(b, np.nan)
