"""LQR balance at an equilibrium: the Riccati gain from SciPy, applied with the effort limit.

The plant is linearised by :meth:`robodyn.Robot.linearize` at (q_eq, 0, u_eq), state
x = [q, v] (2n,), input u = the actuated torques (n_act,). The gain minimises
integral(e^T Q e + du^T R du) dt for the linear model, from the continuous algebraic Riccati
equation A^T P + P A - P B R^-1 B^T P + Q = 0 solved by ``scipy.linalg.solve_continuous_are``
(SciPy is a dependency already, its solver is LAPACK's Schur method, and python-control would
call the same routine through slycot or SciPy): K = R^-1 B^T P. The controller is

    u = sat(u_eq - K e),  e = x - x_eq (revolute errors wrapped to [-pi, pi)),

clipped to the URDF's effort limits. What it assumes: the state is measured exactly, the model
is the plant (see the benchmark's mass-error runs for how much that matters), and the state
starts inside the region of attraction (:mod:`robodyn.control.region` estimates one).
V(e) = e^T P e is its Lyapunov function.
"""

from __future__ import annotations

import reprlib
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics
from robodyn.control.plant import Plant, plant
from robodyn.errors import InputError
from robodyn.robot import EQUILIBRIUM_TOL, Robot

Array = NDArray[np.float64]

# Default weights: angles and positions cost 10 per unit^2, velocities 1, torque 1 per (N m)^2.
DEFAULT_Q_POSITION = 10.0
DEFAULT_Q_VELOCITY = 1.0
DEFAULT_R = 1.0


@dataclass(frozen=True, eq=False)
class LQR:
    """A balancing controller u = sat(u_eq - K (x - x_eq)); call it as tau(t, q, v) -> u (n_act,).

    ``A`` (2n, 2n), ``B`` (2n, n_act) the linearisation; ``Q`` (2n, 2n), ``R`` (n_act, n_act) the
    weights; ``K`` (n_act, 2n) the gain; ``P`` (2n, 2n) the Lyapunov matrix of the closed loop
    (the Riccati solution, or for a given K the solution of (A - B K)^T P + P (A - B K) = -(Q + K^T R K)).
    """

    plant: Plant
    q_eq: Array
    u_eq: Array
    A: Array
    B: Array
    Q: Array
    R: Array
    K: Array
    P: Array

    def __call__(self, t: float, q: Array, v: Array) -> Array:
        """The actuated torques [N m | N] (n_act,) at state (q, v); ``t`` is not used."""
        e = self.plant.error(q, v, self.q_eq)
        return self.plant.saturate(self.u_eq - self.K @ e)

    def batch(self, q: Array, v: Array) -> Array:
        """Torques (m, n_act) for a batch of states q (m, nq), v (m, nv)."""
        e = self.plant.error(q, v, self.q_eq)
        return self.plant.saturate(self.u_eq - e @ self.K.T)

    def value(self, q: ArrayLike, v: ArrayLike) -> Array:
        """V = e^T P e for one state () or a batch (m,)."""
        e = self.plant.error(q, v, self.q_eq)
        return np.asarray(np.einsum("...i,ij,...j->...", e, self.P, e), dtype=np.float64)

    @property
    def poles(self) -> NDArray[np.complex128]:
        """Eigenvalues of the closed loop A - B K (all with negative real part)."""
        return np.asarray(np.linalg.eigvals(self.A - self.B @ self.K))


def design(
    robot: Robot,
    *,
    q_eq: ArrayLike | None = None,
    u_eq: ArrayLike | None = None,
    Q: ArrayLike | None = None,
    R: ArrayLike | None = None,
    K: ArrayLike | None = None,
) -> LQR:
    """The LQR balance controller of ``robot`` at the equilibrium ``q_eq`` (default: the built-in kind's upright).

    Args:
        robot: the robot (nq == nv).
        q_eq: the equilibrium configuration (nq,) [rad | m].
        u_eq: the actuated torques that hold it (n_act,); default the least-squares solution of
            S u = G(q_eq), checked by :meth:`Robot.linearize`.
        Q: state weight: a number (times I), 2n diagonal entries, or a (2n, 2n) matrix (symmetric,
            positive semi-definite); default 10 on positions, 1 on velocities.
        R: input weight: a number, n_act diagonal entries, or an (n_act, n_act) matrix (positive definite).
        K: a gain (n_act, 2n) to use instead of the Riccati one (it must stabilise the linearisation).

    Raises:
        InputError: a state that is not an equilibrium (with its residual), weights or gain of the
            wrong shape (naming the shape expected), or a linearisation that no gain stabilises.
    """
    p = plant(robot)
    n, n_act = p.n, p.n_act
    q0 = p.upright() if q_eq is None else robot.q_(q_eq)
    S = robot.input_matrix()
    if u_eq is None:
        G = dynamics.gravity(robot.model, robot.data, q0)
        u0 = np.asarray(np.linalg.lstsq(S, G, rcond=None)[0], dtype=np.float64)
    else:
        u0 = robot.input_vector(u_eq, "u_eq")
    _require_equilibrium(robot, q0, S @ u0)
    A, B = robot.linearize(q0, np.zeros(n), u0)
    Qm = _weight(Q, 2 * n, "Q", default=np.r_[np.full(n, DEFAULT_Q_POSITION), np.full(n, DEFAULT_Q_VELOCITY)])
    Rm = _weight(R, n_act, "R", default=np.full(n_act, DEFAULT_R))
    if np.min(np.linalg.eigvalsh(Qm)) < -1e-12 * max(1.0, float(np.max(np.abs(Qm)))):
        raise InputError(f"lqr weight Q must be positive semi-definite, got eigenvalues {np.linalg.eigvalsh(Qm)}")
    if np.min(np.linalg.eigvalsh(Rm)) <= 0:
        raise InputError(f"lqr weight R must be positive definite, got eigenvalues {np.linalg.eigvalsh(Rm)}")
    if K is None:
        _require_stabilisable(robot, q0, A, B)
        try:
            P = scipy.linalg.solve_continuous_are(A, B, Qm, Rm)
        except (np.linalg.LinAlgError, ValueError) as exc:
            raise InputError(
                f"{robot.name}: no LQR gain at q_eq = {q0}: the linearisation is not stabilisable "
                f"with these weights ({exc})"
            ) from None
        Km = np.linalg.solve(Rm, B.T @ P)
    else:
        Km = gain_matrix(K, n_act, 2 * n)
        P = _closed_loop_lyapunov(A, B, Km, Qm, Rm, robot.name)
    return LQR(p, q0, u0, A, B, Qm, Rm, np.asarray(Km, dtype=np.float64), 0.5 * (P + P.T))


def _require_equilibrium(robot: Robot, q: Array, tau: Array) -> None:
    """Refuse, in one line, a q_eq that the torques tau (nv,) do not hold at rest: name each joint's missing torque.

    At rest the dynamics are M a = tau - G(q); an equilibrium needs G(q) - tau = 0, to the tolerance
    of :meth:`Robot.linearize` (``EQUILIBRIUM_TOL`` of the weight scale m_total |g| (1 m)).
    """
    residual = dynamics.gravity(robot.model, robot.data, q) - tau
    scale = robot.total_mass * float(np.linalg.norm(robot.model.gravity.linear))
    tol = EQUILIBRIUM_TOL * max(scale, 1.0)
    worst = float(np.max(np.abs(residual))) if residual.size else 0.0
    if worst <= tol:
        return
    needed = []
    for joint in robot.joints:
        for k in range(joint.idx_v, joint.idx_v + joint.nv):
            if abs(residual[k]) > tol:
                drive = "passive: no actuator gives it" if not joint.actuated else "beyond u_eq"
                needed.append(f"{joint.name} {residual[k]:+.6g} {_unit(joint.kind)} ({drive})")
    raise InputError(
        f"{robot.name}: q_eq = {np.array2string(q, precision=6)} is not an equilibrium: residual nle(q) - B u = "
        f"{np.array2string(residual, precision=6)} [N m | N] (max |.| {worst:.3g} > {tol:.3g}): holding it at rest "
        f"needs {', '.join(needed)}"
    )


def _unit(kind: str) -> str:
    return "N" if kind.startswith("JointModelP") else "N m"


# PBH test: a mode lambda of A (Re >= -STABLE_MARGIN |lambda|_max) is uncontrollable when the smallest
# singular value of [A - lambda I, B] is below this fraction of the matrix's largest: round-off in
# an exactly uncontrollable mode is ~1e-16 of it, a weakly controllable one (a Pendubot) ~1e-3.
PBH_RTOL = 1e-9
STABLE_MARGIN = 1e-9


def _require_stabilisable(robot: Robot, q: Array, A: Array, B: Array) -> None:
    """Refuse, in one line, a linearisation with an unstable mode that no input reaches (the PBH test).

    (A, B) is stabilisable iff rank [A - lambda I, B] = 2n for every eigenvalue lambda of A with
    Re lambda >= 0 (Popov-Belevitch-Hautus). The message names the mode and the joints it moves.
    """
    eigenvalues, vectors = np.linalg.eig(A)
    size = max(float(np.max(np.abs(eigenvalues))), 1.0)
    n = robot.nv
    for k, lam in enumerate(eigenvalues):
        if lam.real < -STABLE_MARGIN * size:
            continue
        test = np.hstack([A - lam * np.eye(A.shape[0]), B])
        sigma = np.linalg.svd(test, compute_uv=False)
        if sigma[-1] > PBH_RTOL * sigma[0]:
            continue
        motion = np.abs(vectors[:n, k]) + np.abs(vectors[n:, k])
        moved = [j.name for j in robot.joints if np.max(motion[j.idx_v : j.idx_v + j.nv]) > 1e-6 * np.max(motion)]
        actuated = [j.name for j in robot.joints if j.actuated]
        raise InputError(
            f"{robot.name}: the linearisation at q_eq = {np.array2string(q, precision=6)} is not stabilisable: "
            f"its {'unstable' if lam.real > STABLE_MARGIN * size else 'undamped'} mode lambda = {lam.real:.4g} "
            f"{lam.imag:+.4g}j [1/s] moves {', '.join(moved)} and no actuator ({', '.join(actuated)}) reaches it "
            "(PBH rank test): no gain makes it decay"
        )


def gain_matrix(K: ArrayLike, n_act: int, nx: int) -> Array:
    """``K`` as an (n_act, nx) float64 matrix, or an InputError naming that shape.

    A single row (nx,) is accepted when there is one actuated joint.
    """
    expected = f"({n_act}, {nx}) (one row per actuated joint, one column per state x = [q, v])"
    try:
        arr = np.asarray(K, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"lqr gain K must be a matrix of shape {expected}, got {K!r}") from None
    if arr.shape == (nx,) and n_act == 1:
        arr = arr.reshape(1, nx)
    if arr.shape != (n_act, nx):
        raise InputError(f"lqr gain K must have shape {expected}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"lqr gain K must be finite, got {arr.tolist()}")
    return arr


def _weight(value: ArrayLike | None, size: int, name: str, *, default: Array) -> Array:
    """A weight as a symmetric (size, size) matrix from a number, a diagonal or a matrix."""
    if value is None:
        return np.diag(default)
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError, RecursionError):  # an integer of 400 digits overflows float64
        raise InputError(f"lqr weight {name} must be numbers, got {reprlib.repr(value)}") from None
    if arr.ndim == 0:
        arr = np.full(size, float(arr))
    if arr.shape == (size,):
        arr = np.diag(arr)
    if arr.shape != (size, size):
        raise InputError(
            f"lqr weight {name} must be a number, {size} diagonal entries or a ({size}, {size}) matrix, "
            f"got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)) or not np.allclose(arr, arr.T, rtol=1e-12, atol=0.0):
        raise InputError(f"lqr weight {name} must be finite and symmetric, got {arr.tolist()}")
    return arr


def _closed_loop_lyapunov(A: Array, B: Array, K: Array, Q: Array, R: Array, name: str) -> Array:
    """P with (A - B K)^T P + P (A - B K) = -(Q + K^T R K); InputError when A - B K is not stable."""
    Acl = A - B @ K
    poles = np.linalg.eigvals(Acl)
    if np.max(poles.real) >= 0:
        raise InputError(
            f"{name}: the given gain K does not stabilise the linearisation: closed-loop poles "
            f"{np.array2string(poles, precision=3)} (all need a negative real part)"
        )
    W = Q + K.T @ R @ K
    if np.min(np.linalg.eigvalsh(W)) <= 0:  # a Lyapunov function needs a positive-definite right-hand side
        W = W + 1e-9 * np.eye(W.shape[0]) * max(1.0, float(np.max(np.abs(W))))
    return np.asarray(scipy.linalg.solve_continuous_lyapunov(Acl.T, -W), dtype=np.float64)
