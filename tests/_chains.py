"""Small tree robots written as URDF for the derivation's tests: none of them is one of robodyn's kinds."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Body:
    """A link and the joint that carries it (its parent given by joint name; None: the base)."""

    joint: str
    kind: str  # revolute, continuous, prismatic
    parent: str | None
    xyz: tuple[float, float, float]
    axis: tuple[float, float, float]
    mass: float
    com: tuple[float, float, float]
    inertia: tuple[float, float, float, float, float, float]  # ixx iyy izz ixy ixz iyz
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)


def write(path: Path, bodies: list[Body], name: str = "chain") -> Path:
    """Write ``bodies`` as a URDF at ``path``."""
    parts = [f'<robot name="{name}"><link name="base"/>']
    for b in bodies:
        ixx, iyy, izz, ixy, ixz, iyz = b.inertia
        parts.append(
            f'<link name="{b.joint}_link"><inertial><origin xyz="{b.com[0]!r} {b.com[1]!r} {b.com[2]!r}"/>'
            f'<mass value="{b.mass!r}"/><inertia ixx="{ixx!r}" iyy="{iyy!r}" izz="{izz!r}" ixy="{ixy!r}" '
            f'ixz="{ixz!r}" iyz="{iyz!r}"/></inertial></link>'
        )
        parent = "base" if b.parent is None else f"{b.parent}_link"
        limit = '<limit lower="-10" upper="10" effort="10" velocity="10"/>' if b.kind != "continuous" else ""
        parts.append(
            f'<joint name="{b.joint}" type="{b.kind}"><parent link="{parent}"/><child link="{b.joint}_link"/>'
            f'<origin xyz="{b.xyz[0]!r} {b.xyz[1]!r} {b.xyz[2]!r}" rpy="{b.rpy[0]!r} {b.rpy[1]!r} {b.rpy[2]!r}"/>'
            f'<axis xyz="{b.axis[0]} {b.axis[1]} {b.axis[2]}"/>{limit}</joint>'
        )
    parts.append("</robot>")
    path.write_text("\n".join(parts))
    return path


def _rod(mass: float, length: float, axis: int) -> tuple[float, float, float, float, float, float]:
    """A thin rod's inertia about its centre, lying along ``axis`` (0 x, 1 y, 2 z) [kg m^2]."""
    side = mass * length**2 / 12.0
    diag = [side, side, side]
    diag[axis] = 1e-4 * mass
    return (diag[0], diag[1], diag[2], 0.0, 0.0, 0.0)


def hanging_double_pendulum(path: Path) -> Path:
    """Two rods hanging down (-z) from revolute joints about +y: the textbook double pendulum."""
    return write(
        path,
        [
            Body("j1", "revolute", None, (0.0, 0.0, 0.0), (0, 1, 0), 1.2, (0.0, 0.0, -0.25), _rod(1.2, 0.5, 2)),
            Body("j2", "revolute", "j1", (0.0, 0.0, -0.5), (0, 1, 0), 0.8, (0.0, 0.0, -0.2), _rod(0.8, 0.4, 2)),
        ],
        "hanging_double_pendulum",
    )


def prismatic_arm(path: Path) -> Path:
    """A vertical-plane arm: a shoulder, a telescoping slide along the first link, an elbow."""
    return write(
        path,
        [
            Body("shoulder", "revolute", None, (0.0, 0.0, 0.3), (0, 1, 0), 1.5, (0.2, 0.0, 0.0), _rod(1.5, 0.4, 0)),
            Body("slide", "prismatic", "shoulder", (0.4, 0.0, 0.0), (1, 0, 0), 0.7, (0.1, 0.0, 0.0), _rod(0.7, 0.2, 0)),
            Body("elbow", "revolute", "slide", (0.2, 0.0, 0.0), (0, 1, 0), 0.5, (0.15, 0.0, 0.0), _rod(0.5, 0.3, 0)),
        ],
        "prismatic_arm",
    )


def cart_double_pendulum(path: Path) -> Path:
    """A cart on a rail along x carrying a double pendulum about y."""
    return write(
        path,
        [
            Body(
                "rail", "prismatic", None, (0.0, 0.0, 0.0), (1, 0, 0), 2.0, (0.0, 0.0, 0.0), (0.01, 0.02, 0.02, 0, 0, 0)
            ),
            Body("hinge1", "revolute", "rail", (0.0, 0.0, 0.1), (0, 1, 0), 0.4, (0.0, 0.0, 0.3), _rod(0.4, 0.6, 2)),
            Body(
                "hinge2", "continuous", "hinge1", (0.0, 0.0, 0.6), (0, 1, 0), 0.3, (0.0, 0.0, 0.25), _rod(0.3, 0.5, 2)
            ),
        ],
        "cart_double_pendulum",
    )


def spatial_arm(path: Path) -> Path:
    """A spatial 3-DoF arm: a waist about z, a shoulder and an elbow about y, a tilted joint frame, full tensors."""
    tensor = (0.02, 0.03, 0.015, 0.002, -0.001, 0.0015)
    return write(
        path,
        [
            Body("waist", "continuous", None, (0.0, 0.0, 0.2), (0, 0, 1), 2.0, (0.01, 0.0, 0.1), tensor),
            Body("shoulder", "revolute", "waist", (0.0, 0.05, 0.2), (0, 1, 0), 1.5, (0.15, 0.01, 0.0), tensor),
            Body(
                "elbow",
                "revolute",
                "shoulder",
                (0.3, 0.0, 0.0),
                (0, 1, 0),
                0.8,
                (0.12, -0.01, 0.02),
                tensor,
                (0.3, 0.0, 0.0),
            ),
        ],
        "spatial_arm",
    )


SYSTEMS = {
    "hanging_double_pendulum": hanging_double_pendulum,
    "prismatic_arm": prismatic_arm,
    "cart_double_pendulum": cart_double_pendulum,
    "spatial_arm": spatial_arm,
}
