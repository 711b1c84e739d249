"""A free-flying base in each engine's coordinates, mapped to and from Pinocchio's.

Pinocchio's free flyer (robodyn's ``--free-flyer``): q = [x y z qx qy qz qw], the base link's origin in the world
[m] and its orientation (unit quaternion, scalar last); v = [v; w], the velocity of the base's origin [m/s] and
its angular velocity [rad/s], both expressed in the base link's own (local) axes.

An engine with base velocity u = T(q) v (T a 6 x 6 block, measured per engine and written in its module) holds
M_e, C_e u and G_e; the same motion in Pinocchio's coordinates has the kinetic energy 1/2 v^T T^T M_e T v and the
generalised forces T^T tau_e, so

    M = T^T M_e T,    G = T^T G_e,    C v = T^T (C_e u + M_e Tdot v),

where Tdot v is the part of the engine's base acceleration that Pinocchio's v changing in the moving base
frame makes. Written below for each engine's convention:

- MuJoCo ``<freejoint>``: qpos = [x y z qw qx qy qz], qvel = [R v; w] (world linear, local angular):
  T = [[R, 0], [0, I]], Tdot v = [R (w x v); 0]. Where MuJoCo's free body is not the URDF's root link but sits
  at a fixed placement (R_X, p_X) in it (MuJoCo takes a root link named ``world`` as its world body, and the
  freejoint goes on its child), the body's origin moves at R (v + w x p_X) and turns at R_X^T w in its own axes:
  T = [[R, -R [p_X]x], [0, R_X^T]], Tdot v = [R (w x (v + w x p_X)); 0].
- Drake's ``quaternion_floating`` joint: q = [qw qx qy qz x y z], v = [R w; R v] (both in the world):
  T = [[0, R], [R, 0]], Tdot v = [0; R (w x v)].
"""

from __future__ import annotations

import numpy as np

from robodyn.other_engines.reading import Array

FREE_FLYER = "root_joint"  # the name Pinocchio (and robodyn's --free-flyer) gives the free-flying joint


def rotation(quaternion_xyzw: Array) -> Array:
    """The rotation matrix (base to world) of a unit quaternion stored scalar last, as Pinocchio stores it."""
    x, y, z, w = quaternion_xyzw / np.linalg.norm(quaternion_xyzw)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def mujoco_base(
    q: Array, v: Array, offset: tuple[Array, Array, Array] | None = None
) -> tuple[Array, Array, Array, Array]:
    """MuJoCo's freejoint qpos (7) and qvel (6) for Pinocchio's base ``q`` (7) and ``v`` (6), with T and Tdot v.

    ``offset``: (R_X, p_X, its quaternion w x y z), the free body's fixed placement in the root link's frame
    (None: the free body is the root link).
    """
    R = rotation(q[3:7])
    R_X, p_X, quaternion_X = offset if offset is not None else (np.eye(3), np.zeros(3), np.array([1.0, 0, 0, 0]))
    T = np.zeros((6, 6))
    T[:3, :3], T[:3, 3:], T[3:, 3:] = R, -R @ _skew(p_X), R_X.T
    drift = np.concatenate([R @ np.cross(v[3:], v[:3] + np.cross(v[3:], p_X)), np.zeros(3)])
    turned = _product(np.concatenate([[q[6]], q[3:6]]), quaternion_X)
    return np.concatenate([q[:3] + R @ p_X, turned]), T @ v, T, drift


def _skew(x: Array) -> Array:
    return np.array([[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]])


def _product(a: Array, b: Array) -> Array:
    """The Hamilton product of two quaternions stored scalar first (w x y z): rotation a, then b in a's axes."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def drake_base(q: Array, v: Array) -> tuple[Array, Array, Array, Array]:
    """Drake's quaternion_floating q (7) and v (6) for Pinocchio's base ``q`` and ``v``, with T and Tdot v."""
    R = rotation(q[3:7])
    T = np.zeros((6, 6))
    T[:3, 3:], T[3:, :3] = R, R
    drift = np.concatenate([np.zeros(3), R @ np.cross(v[3:], v[:3])])
    return np.concatenate([[q[6]], q[3:6], q[:3]]), T @ v, T, drift


def to_pinocchio(M: Array, Cv: Array, G: Array, T: Array, drift: Array) -> tuple[Array, Array, Array]:
    """M, C v, G held by an engine whose first 6 velocities are its base's, in Pinocchio's base coordinates."""
    n = M.shape[0]
    P = np.eye(n)
    P[:6, :6] = T
    a = np.zeros(n)
    a[:6] = drift
    return P.T @ M @ P, P.T @ (Cv + M @ a), P.T @ G
