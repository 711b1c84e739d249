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
  T = [[R, 0], [0, I]], Tdot v = [R (w x v); 0].
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


def mujoco_base(q: Array, v: Array) -> tuple[Array, Array, Array, Array]:
    """MuJoCo's freejoint qpos (7) and qvel (6) for Pinocchio's base ``q`` (7) and ``v`` (6), with T and Tdot v."""
    R = rotation(q[3:7])
    T = np.zeros((6, 6))
    T[:3, :3], T[3:, 3:] = R, np.eye(3)
    drift = np.concatenate([R @ np.cross(v[3:], v[:3]), np.zeros(3)])
    return np.concatenate([q[:3], [q[6]], q[3:6]]), T @ v, T, drift


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
