"""The Robot API against Pinocchio's own identities, on seeded random states."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import robodyn

RTOL = 1e-10  # same algorithms, different association of sums: round-off only
N_STATES = 25


@pytest.fixture(params=["geared_arm", "cart_pole", "pendubot", "ur5"])
def robot(request):
    return robodyn.load(request.param)


def test_api_matches_pinocchio_identities(robot):
    rng = np.random.default_rng(2024)
    for _ in range(N_STATES):
        q, v = robot.random_state(rng)
        tau = rng.uniform(-1, 1, robot.nv)
        a = rng.uniform(-2, 2, robot.nv)
        M, C, G = robot.M(q), robot.C(q, v), robot.G(q)
        scale = max(1.0, np.abs(robot.nle(q, v)).max())
        np.testing.assert_allclose(
            C @ v + G,
            pin.rnea(robot.model, robot.model.createData(), q, v, np.zeros(robot.nv)),
            rtol=RTOL,
            atol=RTOL * scale,
        )
        np.testing.assert_allclose(
            np.linalg.solve(M, tau - robot.nle(q, v)), robot.forward_dynamics(q, v, tau), rtol=1e-8, atol=1e-9
        )
        np.testing.assert_allclose(
            robot.forward_dynamics(q, v, tau, backend="crba"), robot.forward_dynamics(q, v, tau), rtol=1e-8, atol=1e-9
        )
        np.testing.assert_allclose(robot.inverse_dynamics(q, v, a), M @ a + C @ v + G, rtol=RTOL, atol=RTOL * scale)
        np.testing.assert_array_equal(M, M.T)
        assert robot.kinetic_energy(q, v) == pytest.approx(0.5 * v @ M @ v, rel=1e-14)


def test_returned_arrays_are_fresh_copies(robot):
    rng = np.random.default_rng(1)
    q1, _ = robot.random_state(rng)
    q2, _ = robot.random_state(rng)
    M1 = robot.M(q1)
    kept = M1.copy()
    robot.M(q2)
    np.testing.assert_array_equal(M1, kept)


def test_armature_is_in_M_and_in_the_energy():
    arm = robodyn.load("geared_arm")
    assert arm.armature[0] == pytest.approx(1.08e-6 * 50**2, rel=1e-14)
    J_l = 1.840725e-3 + 0.243 * 0.15**2
    assert arm.M([0.3])[0, 0] == pytest.approx(J_l + 2.7e-3, rel=1e-12)
    assert arm.kinetic_energy([0.3], [2.0]) == pytest.approx(0.5 * (J_l + 2.7e-3) * 4.0, rel=1e-12)


def test_bad_vectors_are_refused_with_the_argument_named():
    r = robodyn.load("pendubot")
    with pytest.raises(robodyn.InputError, match=r"q must have 2 entries, got shape \(3,\)"):
        r.M([0, 0, 0])
    with pytest.raises(robodyn.InputError, match="tau must have 2 entries"):
        r.forward_dynamics([0, 0], [0, 0], [1])
    with pytest.raises(robodyn.InputError, match="v must be finite"):
        r.C([0, 0], [np.nan, 0])
    with pytest.raises(robodyn.UnknownNameError, match="expected one of: aba, crba"):
        r.forward_dynamics([0, 0], [0, 0], [0, 0], backend="featherstone")


@pytest.mark.parametrize("size", [1, 9, 40])
def test_the_fast_path_still_refuses_what_is_not_a_finite_vector(size):
    """float64 arrays of the right shape skip np.asarray, not the finiteness test; the rest takes the full path."""
    from robodyn.robot import as_vector

    good = np.linspace(-1.0, 1.0, size)
    assert as_vector(good, size, "q") is good  # no copy on the fast path
    for bad in (np.nan, np.inf, -np.inf):
        for where in (0, size - 1):
            x = good.copy()
            x[where] = bad
            with pytest.raises(robodyn.InputError, match="q must be finite"):
                as_vector(x, size, "q")
    x = np.full(size, np.inf)
    x[0] = -np.inf  # inf - inf is NaN: still refused
    with pytest.raises(robodyn.InputError, match="q must be finite"):
        as_vector(x, size, "q")
    huge = np.full(size, 1.5e308)  # finite, but (from 2 entries) its sum overflows: the full test accepts it
    np.testing.assert_array_equal(as_vector(huge, size, "q"), huge)
    np.testing.assert_array_equal(as_vector(good.astype(np.float32), size, "q"), good.astype(np.float32))
    np.testing.assert_array_equal(as_vector(good.tolist(), size, "q"), good)
    for wrong in (good[None, :], np.append(good, 0.0), np.array(["a"] * size)):
        with pytest.raises(robodyn.InputError):
            as_vector(wrong, size, "q")


def test_every_per_state_call_refuses_a_nan_array():
    """M, C, G and the others validate float64 arrays too (the fast path), naming the argument."""
    r = robodyn.load("panda")
    q, v = r.random_state(np.random.default_rng(3))
    bad = v.copy()
    bad[4] = np.nan
    bad_q = np.full(r.nq, np.nan)
    for call, name in [
        (lambda: r.M(bad_q), "q"),
        (lambda: r.C(q, bad), "v"),
        (lambda: r.G(bad_q), "q"),
        (lambda: r.nle(q, bad), "v"),
        (lambda: r.inverse_dynamics(q, v, bad), "a"),
        (lambda: r.forward_dynamics(q, v, bad), "tau"),
        (lambda: r.kinetic_energy(q, bad), "v"),
        (lambda: r.potential_energy(bad_q), "q"),
        (lambda: r.integrate(q, bad), "dq"),
    ]:
        with pytest.raises(robodyn.InputError, match=f"^{name} must be finite"):
            call()


def test_M_is_symmetric_even_from_a_crba_that_fills_one_triangle(monkeypatch):
    """Should a Pinocchio release return only CRBA's upper triangle, the probe sees it and M is mirrored from it."""
    from robodyn import dynamics

    r = robodyn.load("panda")
    q, v = r.random_state(np.random.default_rng(4))
    full = r.M(q)
    real = pin.crba
    monkeypatch.setattr(pin, "crba", lambda model, data, q: np.triu(real(model, data, q)))
    dynamics.crba_fills_both_triangles.cache_clear()
    try:
        assert not dynamics.crba_fills_both_triangles()
        np.testing.assert_array_equal(r.M(q), full)
        assert r.kinetic_energy(q, v) == pytest.approx(0.5 * v @ full @ v, rel=1e-14)
    finally:
        monkeypatch.undo()
        dynamics.crba_fills_both_triangles.cache_clear()
    assert dynamics.crba_fills_both_triangles()  # the installed release fills both


def test_passive_joints_come_from_the_srdf():
    assert robodyn.load("pendubot").passive_joints == ("joint2",)
    assert robodyn.load("cart_pole").passive_joints == ("hinge",)
    assert list(robodyn.load("cart_pole").actuated) == [True, False]
    assert robodyn.load("geared_arm").passive_joints == ()


# ----------------------------------------------------------------------------- C is the Christoffel form
# C v alone does not determine C: C + S(v) with S(v) v = 0 has the same product. These tests pin
# C down entrywise. Every tolerance is relative to |M| |v|, the size of dM/dt and of C.
CHRISTOFFEL_ROBOTS = ["geared_arm", "cart_pole", "pendubot", "ur5", "panda"]
SEED_KINDS = ["geared_arm", "cart_pole", "pendubot"]
FD_STEP = 1e-6  # central difference of M along v, [s] (or along e_k, [rad | m]): truncation ~1e-12
FD_RTOL = 1e-6  # finite differences of M: measured <= 9e-10 with FD_STEP (round-off eps |M| / FD_STEP)
LINEAR_RTOL = 1e-13  # C(q, v) is linear in v: round-off only, measured <= 5e-16
FORMULA_RTOL = 1e-9  # hand-derived formula vs Pinocchio, measured <= 3e-16
N_C_STATES = 10


@pytest.fixture(params=CHRISTOFFEL_ROBOTS)
def chain(request):
    return robodyn.load(request.param)


def _scale(robot, q, *velocities):
    """|M(q)| max |v|: the size of dM/dt and C along velocities of that size."""
    return float(np.abs(robot.M(q)).max() * max(np.abs(v).max() for v in velocities))


def _mass_rate(robot, q, v):
    """dM/dt at (q, v) by a central difference of M along v (step FD_STEP [s])."""
    ahead = robot.M(robot.integrate(q, FD_STEP * v))
    behind = robot.M(robot.integrate(q, -FD_STEP * v))
    return (ahead - behind) / (2.0 * FD_STEP)


def _christoffel_oracle(robot, q, v):
    """C_ij = sum_k 1/2 (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i) v_k, dM/dq by central differences.

    The slow, obviously correct loop that Robot.C must match entrywise.
    """
    nv = robot.nv
    dM = np.empty((nv, nv, nv))  # dM[i, j, k] = dM_ij / dq_k
    for k in range(nv):
        e = np.zeros(nv)
        e[k] = FD_STEP
        dM[:, :, k] = (robot.M(robot.integrate(q, e)) - robot.M(robot.integrate(q, -e))) / (2.0 * FD_STEP)
    C = np.zeros((nv, nv))
    for i in range(nv):
        for j in range(nv):
            for k in range(nv):
                C[i, j] += 0.5 * (dM[i, j, k] + dM[i, k, j] - dM[j, k, i]) * v[k]
    return C


def test_mass_rate_minus_twice_C_is_skew(chain):
    rng = np.random.default_rng(11)
    for _ in range(N_C_STATES):
        q, v = chain.random_state(rng)
        N = _mass_rate(chain, q, v) - 2.0 * chain.C(q, v)
        np.testing.assert_allclose(N + N.T, 0.0, atol=FD_RTOL * _scale(chain, q, v))


def test_C_plus_its_transpose_is_the_mass_rate(chain):
    rng = np.random.default_rng(12)
    for _ in range(N_C_STATES):
        q, v = chain.random_state(rng)
        C = chain.C(q, v)
        np.testing.assert_allclose(C + C.T, _mass_rate(chain, q, v), rtol=0, atol=FD_RTOL * _scale(chain, q, v))


def test_C_is_linear_in_v(chain):
    rng = np.random.default_rng(13)
    for _ in range(N_C_STATES):
        q, v1 = chain.random_state(rng)
        v2 = rng.uniform(-2.0, 2.0, chain.nv)
        a, b = rng.uniform(-3.0, 3.0, 2)
        np.testing.assert_allclose(
            chain.C(q, a * v1 + b * v2),
            a * chain.C(q, v1) + b * chain.C(q, v2),
            rtol=0,
            atol=LINEAR_RTOL * _scale(chain, q, a * v1, b * v2),
        )


def test_C_matches_the_christoffel_symbols_of_M_entrywise(chain):
    """Catches C + S(v) with S skew and S(v) v = 0 (e.g. a cross-product block), which the
    skew, transpose and linearity tests cannot see on three or more joints."""
    rng = np.random.default_rng(14)
    for _ in range(N_C_STATES):
        q, v = chain.random_state(rng)
        np.testing.assert_allclose(
            chain.C(q, v), _christoffel_oracle(chain, q, v), rtol=0, atol=FD_RTOL * _scale(chain, q, v)
        )


@pytest.mark.parametrize("kind", SEED_KINDS)
def test_C_matches_the_hand_derived_formula_entrywise(kind):
    robot = robodyn.load(kind)
    formula, p = robodyn.formulas.get(kind), robodyn.extract_params(robot, kind)
    rng = np.random.default_rng(15)
    for _ in range(N_STATES):
        q, v = robot.random_state(rng)
        np.testing.assert_allclose(
            robot.C(q, v),
            formula.coriolis_matrix(q, v, p),
            rtol=FORMULA_RTOL,
            atol=FORMULA_RTOL * _scale(robot, q, v),
        )


def test_total_mass_is_the_moving_mass_as_its_docstring_says():
    """The UR5's 4 kg base is welded to the world: left out, as Pinocchio's centre of mass leaves it out."""
    fixed = robodyn.load("ur5")
    assert fixed.model.inertias[0].mass == pytest.approx(4.0)  # the welded base, on the world's body
    moving = sum(fixed.model.inertias[j].mass for j in range(1, fixed.model.njoints))
    assert fixed.total_mass == pytest.approx(moving, rel=1e-15)
    data = fixed.model.createData()
    pin.centerOfMass(fixed.model, data, fixed.neutral())
    assert fixed.total_mass == pytest.approx(data.mass[0], rel=1e-15)  # what the potential energy's route uses
    flying = robodyn.load("ur5", free_flyer=True)
    assert flying.total_mass == pytest.approx(moving + 4.0, rel=1e-15)  # on a free flyer, every link moves
