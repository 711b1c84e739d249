"""Minimal models: locking joints keeps joint parameters and the constrained dynamics."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from robodyn.errors import InputError, UnknownNameError
from robodyn.model.consistency import inertial_findings
from robodyn.model.load import load, load_geometry, load_reduction
from robodyn.model.reduce import CARRIED, carry_joint_parameters, locked_acceleration, reduce

# One ABA call against one KKT solve at a single state: round-off of two factorizations.
ACCEL_RTOL = 1e-10
# CRBA of the reduced model against the full model's kept block: the same inertias, composed
# in another order where bodies were welded, so round-off of the sums.
MASS_RTOL = 1e-12

PANDA_KEEP = ["panda_joint2", "panda_joint4", "panda_joint6"]
TALOS_KEEP = ["arm_left_1_joint", "arm_left_2_joint", "arm_left_4_joint", "torso_1_joint"]


def test_reduced_acceleration_equals_constrained_full_acceleration():
    rng = np.random.default_rng(3)
    red = reduce(load("panda"), keep=PANDA_KEEP, reference="default")
    for _ in range(5):
        q, v = red.reduced.random_state(rng)
        tau = rng.uniform(-5, 5, red.reduced.nv)
        a_red = red.reduced.forward_dynamics(q, v, tau)
        a_full, lam = locked_acceleration(red, red.full_q(q), red.full_v(v), red.full_v(tau))
        np.testing.assert_allclose(a_full[red.kept_v], a_red, rtol=ACCEL_RTOL, atol=ACCEL_RTOL * np.abs(a_red).max())
        assert np.abs(a_full[red.locked_v]).max() < ACCEL_RTOL * np.abs(a_red).max()
        assert lam.shape == (red.full.nv - red.reduced.nv,)


def test_armature_damping_limits_survive_reduction():
    full = load("talos")
    red = reduce(full, keep=TALOS_KEEP)
    for name in TALOS_KEEP:
        jf, jr = full.joint(name), red.reduced.joint(name)
        for attr, space in CARRIED.items():
            src = np.asarray(getattr(full.model, attr))
            dst = np.asarray(getattr(red.reduced.model, attr))
            if space == "v":
                assert dst[jr.idx_v] == src[jf.idx_v], (attr, name)
            else:
                assert dst[jr.idx_q] == src[jf.idx_q], (attr, name)
    np.testing.assert_array_equal(red.reduced.armature, 0.1)
    # the armature is in the reduced M's diagonal: M_red = M_full[kept, kept] at the held state
    q = red.full_q(red.reduced.neutral())
    np.testing.assert_allclose(
        red.reduced.M(red.reduced.neutral()), full.M(q)[np.ix_(red.kept_v, red.kept_v)], rtol=MASS_RTOL, atol=1e-14
    )


def _dropping(build):
    """``pin.buildReducedModel`` as the reported releases behaved: every carried parameter zeroed."""

    def reduced_model(model, joint_ids, q):
        out = build(model, joint_ids, q)
        for attr in CARRIED:
            setattr(out, attr, np.zeros_like(np.asarray(getattr(out, attr), dtype=np.float64)))
        return out

    return reduced_model


def test_reduce_restores_what_pinocchio_drops(monkeypatch):
    # Talos: armature 0.1 kg m^2 (SRDF rotor parameters) on 30 of its 32 joints, damping 1 on arms and torso
    full = load("talos")
    monkeypatch.setattr(pin, "buildReducedModel", _dropping(pin.buildReducedModel))
    red = reduce(full, keep=TALOS_KEEP, reference="half_sitting")
    assert np.all(full.armature[red.kept_v] > 0)  # there is armature to lose
    np.testing.assert_array_equal(red.reduced.armature, full.armature[red.kept_v])
    for attr, space in CARRIED.items():
        kept = red.kept_v if space == "v" else red.kept_q
        src = np.asarray(getattr(full.model, attr))[kept]
        np.testing.assert_array_equal(np.asarray(getattr(red.reduced.model, attr)), src, err_msg=attr)
    # and M carries it: M_red(q) = M_full(q held)[kept, kept], armature on the diagonal included
    rng = np.random.default_rng(7)
    for _ in range(3):
        q, _v = red.reduced.random_state(rng)
        M_full = full.M(red.full_q(q))[np.ix_(red.kept_v, red.kept_v)]
        np.testing.assert_allclose(red.reduced.M(q), M_full, rtol=MASS_RTOL, atol=MASS_RTOL * np.abs(M_full).max())


def test_carry_restores_what_a_reduction_drops():
    full = load("geared_arm")
    reduced = pin.buildReducedModel(full.model, [], full.neutral())
    reduced.armature = np.zeros(reduced.nv)  # as the reported Pinocchio releases left it
    reduced.damping = np.zeros(reduced.nv)
    carry_joint_parameters(full.model, reduced)
    np.testing.assert_array_equal(reduced.armature, [2.7e-3])


def test_lock_values_and_reference_and_passive_joints():
    red = reduce(load("pendubot"), lock={"joint1": 0.5})
    assert red.locked == ("joint1",)
    assert red.reduced.passive_joints == ("joint2",)
    np.testing.assert_array_equal(red.lock_values()["joint1"], [0.5])
    half = reduce(load("talos"), keep=TALOS_KEEP, reference="half_sitting")
    assert half.lock_values()["leg_left_4_joint"][0] == pytest.approx(0.859395, abs=1e-6)


def test_geometry_loads_onto_the_reduced_model():
    robot = load("panda", keep=PANDA_KEEP, reference="default")
    geometry = load_geometry(robot)
    assert geometry.ngeoms > 0


def test_load_reduction_lets_a_scene_lock_massless_joints():
    # romeo's finger and hand joints move nothing: refused in full, fine once locked
    full = load("romeo", check_physics=False)
    massless = [f.body for f in inertial_findings(full.model) if f.code == "massless_subtree"]
    assert len(massless) >= 20
    reduction = load_reduction("romeo", lock=dict.fromkeys(massless, 0.0))
    assert reduction.reduced.nv == reduction.full.nv - len(massless)


def test_bad_lock_and_keep_are_named():
    robot = load("panda")
    with pytest.raises(UnknownNameError, match="panda_joint9"):
        reduce(robot, keep=["panda_joint9"])
    with pytest.raises(InputError, match="outside its limits"):
        reduce(robot, lock={"panda_joint4": 0.5})
    with pytest.raises(InputError, match="both kept and locked"):
        reduce(robot, keep=["panda_joint1"], lock={"panda_joint1": 0.0})
    with pytest.raises(InputError, match="leaves nothing to move"):
        reduce(robot, lock=dict.fromkeys(robot.joint_names, 0.01))
    with pytest.raises(UnknownNameError, match="half_sitting"):
        reduce(robot, keep=PANDA_KEEP, reference="half_sitting")


def test_continuous_joint_locks_by_angle():
    robot = load("double_pendulum_continuous")
    first = robot.joint_names[0]
    red = reduce(robot, lock={first: 0.3})
    np.testing.assert_allclose(red.lock_values()[first], [np.cos(0.3), np.sin(0.3)])
