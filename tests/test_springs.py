"""Joint springs: a spring on a coupled follower is the spring k r^2 on its leader, with the same energy and torque."""

from __future__ import annotations

import numpy as np
import pytest

import robodyn
from robodyn.sim.constraints import Spring
from robodyn.sim.springs import springs_on

K, REST = 3.0, 0.25  # [N m/rad], [rad] the follower's own spring
# Energy and torque from the moved spring against the follower's own, written out: the same
# arithmetic up to association, round-off only.
SAME_RTOL = 1e-12


@pytest.mark.parametrize(("ratio", "offset"), [(2.0, 0.1), (-0.5, -0.3), (3.0, 0.0)])
def test_a_followers_spring_keeps_its_energy_and_torque_on_the_leader(ratio: float, offset: float) -> None:
    """q_f = r q_l + o: E = 1/2 k (q_f - rest)^2 = 1/2 (k r^2) (q_l - (rest - o)/r)^2, tau_l = -dE/dq_l = -k r (q_f - rest)."""
    robot = robodyn.load("pendubot")  # joint2 plays the follower of joint1
    springs = springs_on(robot, {"joint2": Spring(K, REST)}, {"joint2": ("joint1", ratio, offset)})
    assert springs.names == ("joint2",) and springs.iv.tolist() == [robot.joint("joint1").idx_v]
    assert springs.stiffness[0] == pytest.approx(K * ratio**2, rel=SAME_RTOL)
    assert springs.rest[0] == pytest.approx((REST - offset) / ratio, rel=SAME_RTOL)
    q_leader = np.linspace(-1.2, 1.4, 7)
    Q = np.zeros((q_leader.size, robot.nq))
    Q[:, robot.joint("joint1").idx_q] = q_leader
    stretch = ratio * q_leader + offset - REST  # the follower's own stretch [rad]
    np.testing.assert_allclose(springs.energy(Q), 0.5 * K * stretch**2, rtol=SAME_RTOL, atol=1e-15)
    for q, s in zip(Q, stretch, strict=True):
        tau = springs.torque(q, robot.nv)
        assert tau[robot.joint("joint1").idx_v] == pytest.approx(-K * ratio * s, rel=SAME_RTOL, abs=1e-15)
        assert tau[robot.joint("joint2").idx_v] == 0.0
