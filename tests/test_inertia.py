"""robodyn.inertia: uniform primitives about any point, against Pinocchio's Inertia and the book's Eq. (6.24)."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest

from robodyn import inertia
from robodyn.errors import InputError

RTOL = 1e-12  # the same closed forms evaluated two ways (ours, Pinocchio's C++): round-off only
ATOL = 1e-15  # [kg m^2]: zeros off the diagonal come out as round-off dust on one side
N_CASES = 25
rng = np.random.default_rng(20240610)


def _cases():
    for _ in range(N_CASES):
        yield (
            float(rng.uniform(0.1, 20.0)),  # mass [kg]
            rng.uniform(0.01, 2.0, size=3),  # sizes [m]
            rng.uniform(-1.5, 1.5, size=3),  # a point [m] relative to the centre
        )


def _about(I_center: pin.Inertia, point: np.ndarray) -> np.ndarray:
    """Pinocchio's rotational inertia about ``point``: the frame there sees the centre at -point."""
    moved = I_center.se3Action(pin.SE3(np.eye(3), -point))
    np.testing.assert_allclose(moved.lever, -point, rtol=0, atol=1e-15)
    return moved.matrix()[3:, 3:]


@pytest.mark.parametrize("case", list(_cases()))
def test_box_cylinder_sphere_match_pinocchio_about_the_centre_and_any_point(case):
    mass, size, point = case
    pairs = [
        (lambda about: inertia.box(mass, size, about=about), pin.Inertia.FromBox(mass, *size)),
        (
            lambda about: inertia.cylinder(mass, size[0], size[1], about=about),
            pin.Inertia.FromCylinder(mass, *size[:2]),
        ),
        (lambda about: inertia.sphere(mass, size[0], about=about), pin.Inertia.FromSphere(mass, size[0])),
    ]
    for ours, theirs in pairs:
        np.testing.assert_allclose(ours("center"), theirs.inertia, rtol=RTOL, atol=ATOL)
        np.testing.assert_allclose(ours(tuple(point)), _about(theirs, point), rtol=RTOL, atol=ATOL)


def test_box_about_its_corner_is_the_books_eq_6_24_and_pinocchios():
    m, w, l, h = 3.0, 0.2, 0.3, 0.4
    book = np.array(
        [
            [m / 3 * (l**2 + h**2), -m / 4 * w * l, -m / 4 * h * w],
            [-m / 4 * w * l, m / 3 * (w**2 + h**2), -m / 4 * h * l],
            [-m / 4 * h * w, -m / 4 * h * l, m / 3 * (l**2 + w**2)],
        ]
    )
    corner = inertia.box(m, (w, l, h), about="corner")
    np.testing.assert_allclose(corner, book, rtol=RTOL)
    np.testing.assert_allclose(corner, _about(pin.Inertia.FromBox(m, w, l, h), -np.array([w, l, h]) / 2), rtol=RTOL)
    np.testing.assert_allclose(corner, inertia.box(m, (w, l, h), about=(-w / 2, -l / 2, -h / 2)), rtol=RTOL)
    # The book's scalar products of inertia are +integral(x y dm) (6.21-6.23): positive for the corner box.
    assert inertia.products_of_inertia(corner) == pytest.approx((m * w * l / 4, m * h * w / 4, m * h * l / 4), rel=RTOL)


def test_products_convention_flips_only_the_off_diagonal():
    m, size = 2.0, (0.1, 0.2, 0.3)
    tensor = inertia.box(m, size, about="corner")
    products = inertia.box(m, size, about="corner", convention="products")
    np.testing.assert_array_equal(np.diag(products), np.diag(tensor))
    np.testing.assert_array_equal(products - np.diag(np.diag(products)), -(tensor - np.diag(np.diag(tensor))))
    assert products[0, 1] == pytest.approx(m * 0.1 * 0.2 / 4, rel=RTOL)  # +integral(x y dm), the book's I_xy


def test_the_tensor_gives_kinetic_energy_and_momentum_like_a_cloud_of_points():
    # A slow, obviously correct oracle: the box as a 40^3 grid of equal point masses about its corner.
    m, size = 1.7, np.array([0.3, 0.5, 0.2])
    n = 40
    axes = [(np.arange(n) + 0.5) / n * s for s in size]  # cell centres in [0, w] x [0, l] x [0, h]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    dm = m / len(pts)
    omega = np.array([0.7, -1.3, 2.1])
    momentum = dm * np.cross(pts, np.cross(omega, pts)).sum(axis=0)  # sum r x (omega x r) dm
    I = inertia.box(m, size, about="corner")
    # midpoint rule: each second moment is off by m s^2 / (12 n^2) at most
    tol = m * float(size.max()) ** 2 / (12 * n**2) * float(np.abs(omega).sum())
    np.testing.assert_allclose(I @ omega, momentum, rtol=0, atol=tol)


def test_parallel_axis_and_rotation_against_pinocchio_with_a_rotated_frame():
    for mass, size, point in _cases():
        R = pin.rpy.rpyToMatrix(*rng.uniform(-np.pi, np.pi, 3))
        I_c = inertia.box(mass, size)
        # Frame F: origin at `point` from the centre (box axes), axes rotated by R (x_F = R^T x_box).
        placement = pin.SE3(R, point)  # box -> F placement of F in the box's frame
        theirs = pin.Inertia.FromBox(mass, *size).se3Action(placement.inverse()).matrix()[3:, 3:]
        ours = inertia.rotated(inertia.parallel_axis(I_c, mass, point), R.T)
        np.testing.assert_allclose(ours, theirs, rtol=1e-10, atol=1e-14)


def test_parallel_axis_adds_m_d_squared_about_every_axis():
    I_c = inertia.cylinder(2.0, 0.1, 0.4)
    d = np.array([0.0, 0.0, 0.5])  # along the axis: Izz unchanged, Ixx and Iyy gain m d^2
    moved = inertia.parallel_axis(I_c, 2.0, d)
    np.testing.assert_allclose(np.diag(moved - I_c), [0.5, 0.5, 0.0], rtol=RTOL, atol=ATOL)
    assert np.trace(moved) - np.trace(I_c) == pytest.approx(2 * 2.0 * 0.25, rel=RTOL)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: inertia.box(-1.0, (1, 1, 1)), "mass: expected a finite number >= 0, got -1.0"),
        (lambda: inertia.box(1.0, (1, 0, 1)), "size[1]: expected a finite number > 0, got 0.0"),
        (lambda: inertia.box(1.0, (1, 1)), "size: expected (w, l, h) [m]"),
        (lambda: inertia.box(1.0, (1, 1, 1), about="middle"), "about: expected 'center', 'corner' or a point"),
        (lambda: inertia.cylinder(1.0, 0.1, 1.0, about="corner"), "about: expected 'center' or a point (x, y, z)"),
        (lambda: inertia.sphere(1.0, float("nan")), "radius: expected a finite number > 0"),
        (lambda: inertia.sphere(1.0, 0.1, about=(1, 2)), "about: expected a point (x, y, z) [m]"),
        (lambda: inertia.box(1.0, (1, 1, 1), convention="book"), "convention: expected one of tensor, products"),
    ],
)
def test_bad_input_names_the_argument(call, message):
    with pytest.raises(InputError, match="^" + re.escape(message)):
        call()
