"""Pinocchio's dynamics in a formula's own coordinates: what ``robodyn check`` compares a formula with.

A built-in kind is written in Pinocchio's coordinates (:meth:`Reference.identity`). A
``KIND = "any"`` file names its joints in its own order and measures each as
``q_formula = sign * q_urdf + offset`` (:mod:`robodyn.kinds.any_file`). With S = dq_urdf/dq_formula
(nv, n), a signed permutation here, the map is exact:

* M_formula = S^T M S, C_formula = S^T C S, G_formula = S^T G, and likewise RNEA's torques;
* v_urdf = S v_formula, a_urdf = S a_formula, tau_urdf = S tau_formula (S^T S = I, so tau_formula =
  S^T tau_urdf), ABA's accelerations a_formula = S^T a_urdf;
* a continuous joint's angle is atan2(sin, cos) of its (cos, sin) pair.

The potential is the same number in both coordinates.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robodyn import dynamics
from robodyn.robot import Robot

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Reference:
    """Pinocchio on ``robot`` (every joint one coordinate of the formula), in the formula's coordinates.

    ``columns[i]`` is the index in v of the formula's coordinate i, ``signs`` and ``offsets`` its map,
    ``q_columns[i]`` its first index in q and ``pairs[i]`` True for a continuous joint (cos, sin).
    """

    robot: Robot
    columns: tuple[int, ...]
    q_columns: tuple[int, ...]
    pairs: tuple[bool, ...]
    signs: Array
    offsets: Array
    plain: bool = False  # Pinocchio's own coordinates: every map is the identity, skipped

    @classmethod
    def identity(cls, robot: Robot) -> Reference:
        """Pinocchio's own coordinates (nq = nv): the built-in kinds."""
        n = robot.nv
        return cls(robot, tuple(range(n)), tuple(range(n)), (False,) * n, np.ones(n), np.zeros(n), plain=True)

    @classmethod
    def mapped(cls, robot: Robot, joints: Sequence[str], signs: Sequence[float], offsets: Sequence[float]) -> Reference:
        """The formula's coordinate i is joint ``joints[i]`` of ``robot`` (one DoF), as sign * q + offset."""
        infos = [robot.joint(name) for name in joints]
        return cls(
            robot,
            tuple(j.idx_v for j in infos),
            tuple(j.idx_q for j in infos),
            tuple(j.nq == 2 for j in infos),
            np.array(signs, dtype=np.float64),
            np.array(offsets, dtype=np.float64),
        )

    @property
    def S(self) -> Array:
        """dq_urdf / dq_formula, (nv, n)."""
        S = np.zeros((self.robot.nv, len(self.columns)))
        S[list(self.columns), np.arange(len(self.columns))] = self.signs
        return S

    # ----------------------------------------------------------------- the maps
    def formula_q(self, q: Array) -> Array:
        """The formula's q (n,) of a configuration (nq,) of the robot."""
        if self.plain:
            return np.asarray(q, dtype=np.float64)
        angles = np.array(
            [np.arctan2(q[i + 1], q[i]) if pair else q[i] for i, pair in zip(self.q_columns, self.pairs, strict=True)]
        )
        return self.signs * angles + self.offsets

    def formula_v(self, v: Array) -> Array:
        """The formula's v (or a, or tau: S^T x) of the robot's (nv,)."""
        if self.plain:
            return np.asarray(v, dtype=np.float64)
        return self.signs * np.asarray(v)[list(self.columns)]

    def urdf_q(self, q: Array) -> Array:
        """The robot's configuration (nq,) of the formula's q (n,)."""
        if self.plain:
            return np.asarray(q, dtype=np.float64)
        angles = self.signs * (np.asarray(q, dtype=np.float64) - self.offsets)
        out = self.robot.neutral()
        for i, pair, x in zip(self.q_columns, self.pairs, angles, strict=True):
            if pair:
                out[i], out[i + 1] = np.cos(x), np.sin(x)
            else:
                out[i] = x
        return out

    def urdf_v(self, v: Array) -> Array:
        """S v: the robot's (nv,) of the formula's (n,)."""
        if self.plain:
            return np.asarray(v, dtype=np.float64)
        out = np.zeros(self.robot.nv)
        out[list(self.columns)] = self.signs * np.asarray(v, dtype=np.float64)
        return out

    def _project(self, A: Array) -> Array:
        """S^T A S of an (nv, nv) matrix."""
        if self.plain:
            return A
        idx = list(self.columns)
        return np.asarray(A[np.ix_(idx, idx)] * np.outer(self.signs, self.signs), dtype=np.float64)

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
        return self.formula_v(dynamics.gravity(self.robot.model, self.robot.data, self.urdf_q(q)))

    def nonlinear_effects(self, q: Array, v: Array) -> Array:
        """S^T (C v + G) by RNEA."""
        model, data = self.robot.model, self.robot.data
        return self.formula_v(dynamics.nonlinear_effects(model, data, self.urdf_q(q), self.urdf_v(v)))

    def rnea(self, q: Array, v: Array, a: Array) -> Array:
        """S^T RNEA(q, S v, S a)."""
        model, data = self.robot.model, self.robot.data
        return self.formula_v(dynamics.rnea(model, data, self.urdf_q(q), self.urdf_v(v), self.urdf_v(a)))

    def aba(self, q: Array, v: Array, tau: Array) -> Array:
        """S^T ABA(q, S v, S tau)."""
        model, data = self.robot.model, self.robot.data
        return self.formula_v(dynamics.aba(model, data, self.urdf_q(q), self.urdf_v(v), self.urdf_v(tau)))

    def gravity_scale(self, q: Array) -> float:
        """The energy scale |g| sum m_i |c_i| [J] (the round-off floors' scale), the same in every coordinate."""
        return dynamics.gravity_scale(self.robot.model, self.robot.data, self.urdf_q(q))

    def potential_energy(self, q: Array) -> float:
        """V [J], the same in every coordinate."""
        return dynamics.potential_energy(self.robot.model, self.robot.data, self.urdf_q(q))
