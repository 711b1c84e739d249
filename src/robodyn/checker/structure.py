"""``robodyn check``'s rows that need no formula: Pinocchio's structure, its identities, its routines.

At each sampled state: M symmetric positive definite, dM/dt - 2C skew and G = dV/dq (by central
differences of step ``FD_STEP``, held to ``FD_TOL``); C v + G = RNEA(q, v, 0), CRBA = columns of
RNEA, RNEA(ABA(tau)) = tau and M^-1 (tau - nle) = ABA; and, reported without failing the check,
1/2 v^T M v against ``computeKineticEnergy`` and ``computeCoriolisMatrix`` against the Christoffel C.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.checker.rows import FD_STEP, FD_TOL, Accumulator, CheckRow, skew_scale
from robodyn.checker.scales import scales
from robodyn.robot import Robot

SINGULAR_RATIO = 1e-12  # lambda_min / lambda_max of M at or below this: singular to working precision (as simulate)

Array = NDArray[np.float64]


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


def structure_rows(robot: Robot, samples: list[Any], rtol: float) -> list[CheckRow]:
    """The rows that need no formula, at ``samples`` (``.q``, ``.v``, ``.a``, ``.tau``) in ``robot``'s coordinates."""
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
        a_crba, a_aba, aba_here = _accelerations(robot, s, forward, inverse)
        aba_ok = aba_ok and aba_here
        forward.add(a_aba, a_crba, sc.forward_floor(a_aba))
        # tau -> a -> tau: ABA solves with a matrix off by eps |M|, which comes back through RNEA as eps |M| |a|
        # (|a| is up to |M^-1| |tau - nle|: cond(M) times the torques' terms on an ill-conditioned M)
        a_size = float(np.abs(a_crba).max())
        inverse.add(s.tau, dynamics.rnea(model, data, s.q, s.v, a_crba), sc.floor(sc.mass * a_size + sc.torque_terms))
        energy_refused = _add_kinetic(kinetic, robot, s, M, sc) or energy_refused
    rows = [
        spd.row(samples),
        skew.row(samples, zero_reference_scale=n_scale),
        grad.row(samples),
        _nle_row(nle, samples, mimic=mimic),
        columns.row(samples),
        inverse.row(samples),
    ]
    forward_row = forward.row(samples)
    if not aba_ok:
        forward_row = replace(forward_row, counts=False, applicable=False, note="ABA refuses mimic joints")
    rows.append(forward_row)
    rows.append(_kinetic_row(kinetic, samples, robot, refused=energy_refused))
    rows.append(_coriolis_row(coriolis, samples, mimic=mimic))
    rows[0] = replace(rows[0], note=f"min over samples of lambda_min / lambda_max = {min_eig_ratio:.3g}")
    return rows


def _accelerations(robot: Robot, s: Any, forward: Accumulator, inverse: Accumulator) -> tuple[Array, Array, bool]:
    """(a by CRBA, a by ABA, whether ABA ran) at sample ``s``; a failed solve is noted on the rows it feeds."""
    model, data = robot.model, robot.data
    aba_ok = True
    try:
        a_crba = dynamics.crba_solve(model, data, s.q, s.v, s.tau)
    except np.linalg.LinAlgError:  # M not positive definite: the rows solving through it fail, saying so
        a_crba = np.full(robot.nv, np.nan)
        forward.note = inverse.note = forward.note or f"M(q) is not positive definite at sample {len(forward.pairs)}"
    try:
        a_aba = dynamics.aba(model, data, s.q, s.v, s.tau)
    except (RuntimeError, ValueError):
        aba_ok, a_aba = False, a_crba
    return a_crba, a_aba, aba_ok


def _nle_row(nle: Accumulator, samples: list[Any], *, mimic: bool) -> CheckRow:
    """C v + G = RNEA(q, v, 0), said to hold by construction on mimic joints."""
    row = nle.row(samples)
    if mimic:  # C itself comes from RNEA here: the identity holds by construction
        row = replace(row, note="on mimic joints robodyn's C is built from RNEA, so this row holds by construction")
    return row


def _kinetic_row(kinetic: Accumulator, samples: list[Any], robot: Robot, *, refused: bool) -> CheckRow:
    """1/2 v^T M v against computeKineticEnergy, with the note that says why they differ."""
    kinetic_row = kinetic.row(samples, scalar=True)
    if refused:
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
    return kinetic_row


def _coriolis_row(coriolis: Accumulator, samples: list[Any], *, mimic: bool) -> CheckRow:
    """Pinocchio's computeCoriolisMatrix against the Christoffel C, with the note that says why they differ."""
    coriolis_row = coriolis.row(samples)
    if not coriolis_row.passed:
        coriolis_row = replace(
            coriolis_row,
            note="Pinocchio's computeCoriolisMatrix is wrong on models with mimic joints (C v + G != RNEA, "
            "dM/dt - 2C not skew); robodyn's C is the Christoffel matrix from RNEA"
            if mimic
            else "Pinocchio's computeCoriolisMatrix disagrees with the Christoffel C from RNEA",
        )
    return coriolis_row


def _add_kinetic(kinetic: Accumulator, robot: Robot, s: Any, M: Array, sc: Any) -> bool:
    """Add 1/2 v^T M v against computeKineticEnergy at ``s``; True when Pinocchio refused (mimic joints)."""
    T = 0.5 * float(s.v @ M @ s.v)
    try:
        kinetic.add(
            T, dynamics.pinocchio_kinetic_energy(robot.model, robot.data, s.q, s.v), sc.floor(sc.mass * sc.speed**2)
        )
    except RuntimeError:  # computeKineticEnergy refuses mimic joints
        kinetic.add(T, T)
        return True
    return False
