"""Write URDF variants of the built-in kinds with chosen parameters, for tests.

Independent of robodyn's parameter extraction: the tests compute what the parameters
should be from the numbers written here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF convention: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _inertial(mass: float, xyz: tuple[float, float, float], inertia: np.ndarray, rpy=(0.0, 0.0, 0.0)) -> str:
    I = inertia
    return (
        f'<inertial><origin xyz="{xyz[0]!r} {xyz[1]!r} {xyz[2]!r}" rpy="{rpy[0]!r} {rpy[1]!r} {rpy[2]!r}"/>'
        f'<mass value="{mass!r}"/>'
        f'<inertia ixx="{float(I[0, 0])!r}" iyy="{float(I[1, 1])!r}" izz="{float(I[2, 2])!r}" ixy="{float(I[0, 1])!r}" ixz="{float(I[0, 2])!r}" iyz="{float(I[1, 2])!r}"/>'
        "</inertial>"
    )


def _joint(name: str, kind: str, parent: str, child: str, xyz, axis, damping: float = 0.0) -> str:
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz[0]!r} {xyz[1]!r} {xyz[2]!r}"/><axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>'
        f'<limit lower="-100" upper="100" effort="10" velocity="10"/><dynamics damping="{damping!r}"/></joint>'
    )


def pendubot(
    path: Path,
    *,
    m1=0.9,
    m2=0.4,
    l1=0.2,
    lc1=0.08,
    lc2=0.11,
    inertia1=None,
    inertia2=None,
    rpy1=(0.0, 0.0, 0.0),
    rpy2=(0.0, 0.0, 0.0),
    axis=(0, -1, 0),
    com_offset_z=0.0,
    extra_joint=False,
    continuous=False,
) -> Path:
    """A Pendubot URDF; inertias are given in the (possibly rotated) inertial frame."""
    inertia1 = np.diag([2e-4, 3e-3, 3.1e-3]) if inertia1 is None else inertia1
    inertia2 = np.diag([1e-4, 1.5e-3, 1.55e-3]) if inertia2 is None else inertia2
    kind = "continuous" if continuous else "revolute"
    extra = ""
    if extra_joint:
        extra = '<link name="l3">' + _inertial(0.1, (0.05, 0, 0), np.diag([1e-5, 1e-4, 1e-4])) + "</link>"
        extra += _joint("j3", "revolute", "l2", "l3", (0.25, 0, 0), axis)
    text = (
        '<?xml version="1.0"?><robot name="pendubot_variant"><link name="base"/>'
        f'<link name="l1">{_inertial(m1, (lc1, 0.0, com_offset_z), inertia1, rpy1)}</link>'
        f'<link name="l2">{_inertial(m2, (lc2, 0.0, 0.0), inertia2, rpy2)}</link>'
        + _joint("j1", kind, "base", "l1", (0, 0, 0.5), axis)
        + _joint("j2", kind, "l1", "l2", (l1, 0.03, 0), axis)
        + extra
        + "</robot>"
    )
    path.write_text(text)
    return path


def cart_pole(path: Path, *, M=2.0, m=0.3, l=0.4, pole_inertia=None, rpy=(0.0, 0.0, 0.0), slide_axis=(1, 0, 0)) -> Path:
    """A cart-pole URDF; ``pole_inertia`` None means a uniform rod of length 2 l."""
    rod = m * (2 * l) ** 2 / 12
    pole_inertia = np.diag([rod, rod, 1e-6]) if pole_inertia is None else pole_inertia
    text = (
        '<?xml version="1.0"?><robot name="cart_pole_variant"><link name="rail"/>'
        f'<link name="cart">{_inertial(M, (0.0, 0.0, 0.0), np.diag([0.01, 0.02, 0.02]))}</link>'
        f'<link name="pole">{_inertial(m, (0.0, 0.0, l), pole_inertia, rpy)}</link>'
        + _joint("slide", "prismatic", "rail", "cart", (0, 0, 0), slide_axis)
        + _joint("hinge", "revolute", "cart", "pole", (0, 0, 0.1), (0, 1, 0))
        + "</robot>"
    )
    path.write_text(text)
    return path


def geared_arm(
    path: Path, *, mass=0.5, l=0.2, J_m=2e-6, n=30.0, inertia=None, rpy=(0.0, 0.0, 0.0), axis=(0, 1, 0)
) -> Path:
    """A geared-arm URDF plus an SRDF with rotor parameters next to it."""
    inertia = np.diag([4e-3, 4e-3, 1e-4]) if inertia is None else inertia
    text = (
        '<?xml version="1.0"?><robot name="geared_arm_variant"><link name="base"/>'
        f'<link name="arm">{_inertial(mass, (0.0, 0.0, -l), inertia, rpy)}</link>'
        + _joint("shoulder", "revolute", "base", "arm", (0, 0, 0), axis)
        + "</robot>"
    )
    path.write_text(text)
    path.with_suffix(".srdf").write_text(
        f'<robot name="geared_arm_variant"><rotor_params><joint name="shoulder" mass="{J_m!r}" gear_ratio="{n!r}"/>'
        "</rotor_params></robot>"
    )
    return path
