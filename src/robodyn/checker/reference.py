"""Pinocchio's dynamics in a formula's own coordinates: what ``robodyn check`` compares a formula with.

A built-in kind is written in Pinocchio's coordinates (:meth:`Reference.identity`). A
``KIND = "any"`` file names its joints in its own order and measures them as
``q_formula = A q_urdf + b`` (:mod:`robodyn.model.coordinate_map`; the ``{joint: (sign, offset)}``
form is a diagonal A of signs). With P (nv, n) picking the JOINTS' columns of v and
S = dq_urdf/dq_formula = P A^-1, the map is exact (a constant Jacobian: the Christoffel C maps as M):

* M_formula = S^T M S = A^-T M A^-1, C_formula = A^-T C A^-1, G_formula = A^-T G, and likewise RNEA's
  torques and C v + G (forces are covectors);
* v_formula = A v, a_formula = A a (ABA's accelerations), and a formula torque acts as
  tau_urdf = A^T tau_formula (the same power);
* a continuous joint's angle is atan2(sin, cos) of its (cos, sin) pair.

The potential is the same number in both coordinates.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn import dynamics
from robodyn.model.links import JOINT_TYPES
from robodyn.robot import Robot

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Reference:
    """Pinocchio on ``robot`` (every joint one coordinate of the formula), in the formula's coordinates.

    ``columns[j]`` is the index in v of the j-th joint of JOINTS, ``q_columns[j]`` its first index in q
    and ``pairs[j]`` True for a continuous joint (cos, sin); ``A`` and ``offsets`` (b) the map
    q_formula = A q_joints + b; ``prismatic[i]`` True when the formula's coordinate i is a length.
    """

    robot: Robot
    columns: tuple[int, ...]
    q_columns: tuple[int, ...]
    pairs: tuple[bool, ...]
    A: Array
    offsets: Array
    plain: bool = False  # Pinocchio's own coordinates: every map is the identity, skipped

    @classmethod
    def identity(cls, robot: Robot) -> Reference:
        """Pinocchio's own coordinates (nq = nv): the built-in kinds."""
        n = robot.nv
        return cls(robot, tuple(range(n)), tuple(range(n)), (False,) * n, np.eye(n), np.zeros(n), plain=True)

    @classmethod
    def mapped(cls, robot: Robot, joints: Sequence[str], A: ArrayLike, offsets: ArrayLike) -> Reference:
        """The formula's q = A q_joints + offsets, q_joints the joints ``joints`` of ``robot`` (one DoF each).

        ``A``: (n, n) invertible, or (n,) the signs of a diagonal A.
        """
        infos = [robot.joint(name) for name in joints]
        matrix = np.asarray(A, dtype=np.float64)
        return cls(
            robot,
            tuple(j.idx_v for j in infos),
            tuple(j.idx_q for j in infos),
            tuple(j.nq == 2 for j in infos),
            np.diag(matrix) if matrix.ndim == 1 else matrix,
            np.array(offsets, dtype=np.float64),
        )

    def remapped(self, A: Array, offsets: Array) -> Reference:
        """The same joints under another map (a convention hint's candidate, :mod:`robodyn.checker.hints`)."""
        return Reference(self.robot, self.columns, self.q_columns, self.pairs, A, offsets)

    @cached_property
    def A_inv(self) -> Array:
        """A^-1 = d q_joints / d q_formula."""
        return _inverse(self.A)

    @property
    def S(self) -> Array:
        """dq_urdf / dq_formula = P A^-1, (nv, n)."""
        S = np.zeros((self.robot.nv, len(self.columns)))
        S[list(self.columns), :] = self.A_inv
        return S

    @property
    def prismatic(self) -> tuple[bool, ...]:
        """For each formula coordinate: True for a length (its row of A names slides only)."""
        slides = [JOINT_TYPES.get(j.kind) == "prismatic" for j in self.joint_infos()]
        return tuple(any(slides[j] for j in np.flatnonzero(row)) for row in self.A)

    def joint_infos(self) -> list[Any]:
        """The JOINTS' joints of ``robot`` (:class:`robodyn.robot.JointInfo`), in the formula's JOINTS order."""
        by_column = {j.idx_v: j for j in self.robot.joints}
        return [by_column[c] for c in self.columns]

    # ----------------------------------------------------------------- the maps
    def formula_q(self, q: Array) -> Array:
        """The formula's q (n,) of a configuration (nq,) of the robot."""
        if self.plain:
            return np.asarray(q, dtype=np.float64)
        angles = np.array(
            [np.arctan2(q[i + 1], q[i]) if pair else q[i] for i, pair in zip(self.q_columns, self.pairs, strict=True)]
        )
        return np.asarray(self.A @ angles + self.offsets, dtype=np.float64)

    def formula_v(self, v: Array) -> Array:
        """The formula's v (or a) of the robot's (nv,): A v."""
        if self.plain:
            return np.asarray(v, dtype=np.float64)
        return np.asarray(self.A @ np.asarray(v)[list(self.columns)], dtype=np.float64)

    def formula_tau(self, tau: Array) -> Array:
        """The formula's generalized force (tau, G, C v + G) of the robot's (nv,): S^T tau = A^-T tau."""
        if self.plain:
            return np.asarray(tau, dtype=np.float64)
        return np.asarray(self.A_inv.T @ np.asarray(tau)[list(self.columns)], dtype=np.float64)

    def urdf_q(self, q: Array) -> Array:
        """The robot's configuration (nq,) of the formula's q (n,)."""
        if self.plain:
            return np.asarray(q, dtype=np.float64)
        angles = self.A_inv @ (np.asarray(q, dtype=np.float64) - self.offsets)
        out = self.robot.neutral()
        for i, pair, x in zip(self.q_columns, self.pairs, angles, strict=True):
            if pair:
                out[i], out[i + 1] = np.cos(x), np.sin(x)
            else:
                out[i] = x
        return out

    def urdf_v(self, v: Array) -> Array:
        """S v: the robot's (nv,) of the formula's v or a (n,)."""
        if self.plain:
            return np.asarray(v, dtype=np.float64)
        out = np.zeros(self.robot.nv)
        out[list(self.columns)] = self.A_inv @ np.asarray(v, dtype=np.float64)
        return out

    def urdf_tau(self, tau: Array) -> Array:
        """The robot's torques (nv,) doing the work of the formula's (n,): A^T tau."""
        if self.plain:
            return np.asarray(tau, dtype=np.float64)
        out = np.zeros(self.robot.nv)
        out[list(self.columns)] = self.A.T @ np.asarray(tau, dtype=np.float64)
        return out

    def _project(self, X: Array) -> Array:
        """S^T X S = A^-T X_JJ A^-1 of an (nv, nv) matrix."""
        if self.plain:
            return X
        idx = list(self.columns)
        A_inv = self.A_inv
        return np.asarray(A_inv.T @ X[np.ix_(idx, idx)] @ A_inv, dtype=np.float64)

    # ----------------------------------------------------------------- Pinocchio, in the formula's coordinates
    def anchor(self) -> Array:
        """The formula's q at the robot's neutral configuration (the zero of V - V(q0))."""
        return self.formula_q(self.robot.neutral())

    def mass_matrix(self, q: Array) -> Array:
        """S^T M S [kg m^2 | kg]."""
        return self._project(dynamics.mass_matrix(self.robot.model, self.robot.data, self.urdf_q(q)))

    def coriolis_matrix(self, q: Array, v: Array) -> Array:
        """S^T C(q, S v) S."""
        model, data = self.robot.model, self.robot.data
        return self._project(dynamics.coriolis_matrix(model, data, self.urdf_q(q), self.urdf_v(v)))

    def gravity(self, q: Array) -> Array:
        """S^T G [N m | N]."""
        return self.formula_tau(dynamics.gravity(self.robot.model, self.robot.data, self.urdf_q(q)))

    def nonlinear_effects(self, q: Array, v: Array) -> Array:
        """S^T (C v + G) by RNEA."""
        model, data = self.robot.model, self.robot.data
        return self.formula_tau(dynamics.nonlinear_effects(model, data, self.urdf_q(q), self.urdf_v(v)))

    def rnea(self, q: Array, v: Array, a: Array) -> Array:
        """S^T RNEA(q, S v, S a)."""
        model, data = self.robot.model, self.robot.data
        return self.formula_tau(dynamics.rnea(model, data, self.urdf_q(q), self.urdf_v(v), self.urdf_v(a)))

    def aba(self, q: Array, v: Array, tau: Array) -> Array:
        """A ABA(q, S v, A^T tau): the formula's accelerations."""
        model, data = self.robot.model, self.robot.data
        return self.formula_v(dynamics.aba(model, data, self.urdf_q(q), self.urdf_v(v), self.urdf_tau(tau)))

    def gravity_scale(self, q: Array) -> float:
        """The energy scale |g| sum m_i |c_i| [J] (the round-off floors' scale), the same in every coordinate."""
        return dynamics.gravity_scale(self.robot.model, self.robot.data, self.urdf_q(q))

    def potential_energy(self, q: Array) -> float:
        """V [J], the same in every coordinate."""
        return dynamics.potential_energy(self.robot.model, self.robot.data, self.urdf_q(q))


def _inverse(A: Array) -> Array:
    """A^-1; exact for the +-1 diagonal of the ``{joint: (sign, offset)}`` form (its own inverse)."""
    if np.array_equal(A, np.diag(np.diag(A))) and np.all(np.abs(np.diag(A)) == 1.0):
        return A.copy()
    return np.asarray(np.linalg.inv(A), dtype=np.float64)
