"""Rotational inertia of uniform primitives (box, cylinder, sphere) about any point.

Each function returns the 3x3 inertia [kg m^2] of a body of uniform density, about its
centre or another point, in axes parallel to the shape's own (the parallel-axis theorem,
:func:`parallel_axis`, does the move).

Sign convention of the products of inertia. The textbook (Craig, Eqs. 6.16-6.17) defines
the scalar products of inertia as ``I_xy = +integral(x y dm)`` and writes the inertia
tensor with them *negated* off the diagonal::

        [  I_xx  -I_xy  -I_xz ]
    I = [ -I_xy   I_yy  -I_yz ]        (6.16; for the box about its corner, 6.24:
        [ -I_xz  -I_yz   I_zz ]         I_xy = m w l / 4 and the tensor holds -m w l / 4)

That matrix is the inertia tensor: ``L = I @ omega`` and ``T = omega @ I @ omega / 2``. It is
what Pinocchio's ``Inertia.inertia`` holds and what a URDF's ``ixy ixz iyz`` attributes are
(the tensor's entries, so ``-integral(x y dm)``). ``convention="tensor"`` (the default)
returns it. ``convention="products"`` returns the same diagonal with the book's *scalars*
``+integral(x y dm)`` off the diagonal (6.17, 6.21-6.23): a table of numbers, not a tensor;
never put it into a URDF. :func:`products_of_inertia` reads the book's scalars off a tensor.

The cylinder's axis is z, as in URDF (``<cylinder radius length>``) and Pinocchio
(``Inertia.FromCylinder``). This module imports only NumPy.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodyn.errors import InputError

Array = NDArray[np.float64]
Point = Literal["center", "corner"] | tuple[float, float, float] | ArrayLike
Convention = Literal["tensor", "products"]
CONVENTIONS = ("tensor", "products")


def _positive(name: str, value: float, *, allow_zero: bool = False) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected a number, got {value!r}") from None
    if not np.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        expected = ">= 0" if allow_zero else "> 0"
        raise InputError(f"{name}: expected a finite number {expected}, got {x!r}")
    return x


def _point(about: Point, corner: Array | None, shape: str) -> Array:
    """The point ``about`` names, relative to the centre [m]."""
    if isinstance(about, str):
        if about == "center":
            return np.zeros(3)
        if about == "corner" and corner is not None:
            return corner
        choices = "'center', 'corner' or a point (x, y, z)" if corner is not None else "'center' or a point (x, y, z)"
        raise InputError(f"about: expected {choices} for a {shape}, got {about!r}")
    p = np.asarray(about, dtype=np.float64)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise InputError(f"about: expected a point (x, y, z) [m] relative to the {shape}'s centre, got {about!r}")
    return p


def parallel_axis(inertia_at_com: ArrayLike, mass: float, point: ArrayLike) -> Array:
    """The inertia tensor about ``point``, from the one about the centre of mass.

    Args:
        inertia_at_com: (3, 3) tensor about the centre of mass [kg m^2].
        mass: the body's mass [kg], >= 0.
        point: (3,) position of the new reference point relative to the centre of mass [m],
            in the same axes.

    Returns:
        (3, 3) tensor ``I_c + m (|d|^2 1 - d d^T)`` with ``d = point`` [kg m^2] (axes unchanged).
    """
    I_c = np.asarray(inertia_at_com, dtype=np.float64)
    if I_c.shape != (3, 3):
        raise InputError(f"inertia_at_com: expected a (3, 3) matrix, got shape {I_c.shape}")
    m = _positive("mass", mass, allow_zero=True)
    d = np.asarray(point, dtype=np.float64)
    if d.shape != (3,):
        raise InputError(f"point: expected (x, y, z) [m], got shape {d.shape}")
    return I_c + m * (float(d @ d) * np.eye(3) - np.outer(d, d))


def rotated(inertia: ArrayLike, rotation: ArrayLike) -> Array:
    """``R I R^T``: the same tensor in the frame whose axes are the columns of ``R^T``.

    ``rotation`` (3, 3) maps coordinates in the tensor's current axes to the new axes
    (a vector ``x`` in the old axes is ``R @ x`` in the new ones).
    """
    R = np.asarray(rotation, dtype=np.float64)
    I = np.asarray(inertia, dtype=np.float64)
    if R.shape != (3, 3) or I.shape != (3, 3):
        raise InputError(f"rotated: expected two (3, 3) matrices, got {I.shape} and {R.shape}")
    return R @ I @ R.T


def products_of_inertia(inertia: ArrayLike) -> tuple[float, float, float]:
    """The book's scalar products of inertia ``(I_xy, I_xz, I_yz)`` (+integral, Eq. 6.17) of a tensor."""
    I = np.asarray(inertia, dtype=np.float64)
    return (-float(I[0, 1]), -float(I[0, 2]), -float(I[1, 2]))


def _finish(I_c: Array, mass: float, point: Array, convention: str) -> Array:
    if convention not in CONVENTIONS:
        raise InputError(f"convention: expected one of {', '.join(CONVENTIONS)}, got {convention!r}")
    I = parallel_axis(I_c, mass, point)
    if convention == "products":
        I = np.diag(np.diag(I)) - (I - np.diag(np.diag(I)))
    return I


def box(
    mass: float,
    size: ArrayLike,
    *,
    about: Point = "center",
    convention: Convention = "tensor",
) -> Array:
    """Inertia of a uniform box of edges ``size = (w, l, h)`` along x, y, z.

    Args:
        mass: [kg], >= 0.
        size: (w, l, h) [m], each > 0 (URDF's ``<box size="x y z">``).
        about: ``"center"``; ``"corner"``, the corner at (-w/2, -l/2, -h/2) from the centre,
            so that the box fills [0, w] x [0, l] x [0, h] as in the book's Example 6.1;
            or any point (x, y, z) relative to the centre [m]. Axes stay the box's edges.
        convention: ``"tensor"`` (the book's matrix 6.16/6.24, Pinocchio's and URDF's) or
            ``"products"`` (the book's scalars +integral(x y dm) off the diagonal); see the module.

    Returns:
        (3, 3) [kg m^2]. About the corner with the default convention that is Eq. (6.24):
        diagonal ``m/3 (l^2 + h^2), m/3 (w^2 + h^2), m/3 (l^2 + w^2)``, off-diagonal
        ``-m w l / 4, -m h w / 4, -m h l / 4``.
    """
    m = _positive("mass", mass, allow_zero=True)
    dims = np.asarray(size, dtype=np.float64)
    if dims.shape != (3,):
        raise InputError(f"size: expected (w, l, h) [m], got {size!r}")
    w, l, h = (_positive(f"size[{i}]", x) for i, x in enumerate(dims))
    I_c = m / 12.0 * np.diag([l**2 + h**2, w**2 + h**2, w**2 + l**2])
    return _finish(I_c, m, _point(about, -dims / 2.0, "box"), convention)


def cylinder(
    mass: float,
    radius: float,
    length: float,
    *,
    about: Point = "center",
    convention: Convention = "tensor",
) -> Array:
    """Inertia of a uniform solid cylinder whose axis is z.

    About the centre: ``diag(m (3 r^2 + L^2) / 12, same, m r^2 / 2)``. ``about`` is
    ``"center"`` or a point (x, y, z) relative to the centre [m]; see :func:`box`.
    """
    m = _positive("mass", mass, allow_zero=True)
    r = _positive("radius", radius)
    L = _positive("length", length)
    side = m * (3.0 * r**2 + L**2) / 12.0
    I_c = np.diag([side, side, m * r**2 / 2.0])
    return _finish(I_c, m, _point(about, None, "cylinder"), convention)


def sphere(
    mass: float,
    radius: float,
    *,
    about: Point = "center",
    convention: Convention = "tensor",
) -> Array:
    """Inertia of a uniform solid sphere: ``2/5 m r^2`` about any axis through its centre.

    ``about`` is ``"center"`` or a point (x, y, z) relative to the centre [m]; see :func:`box`.
    """
    m = _positive("mass", mass, allow_zero=True)
    r = _positive("radius", radius)
    I_c = 0.4 * m * r**2 * np.eye(3)
    return _finish(I_c, m, _point(about, None, "sphere"), convention)
