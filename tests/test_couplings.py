"""Couplings: a follower's stops become its leader's, whatever the sign of the ratio."""

from __future__ import annotations

from pathlib import Path

import pytest

import robodyn
from robodyn.sim.constraints import Coupling
from robodyn.sim.couplings import couple
from robodyn.sim.simulation import simulate

# A joint held at its stop sits on it to round-off (the located impact, then the hold).
STOP_TOL = 1e-9  # [rad]
FOLLOWER = (-3.0, 3.0)  # [rad] the follower's own stops; the leader's are (-10, 10)


def chain(tmp_path: Path) -> robodyn.Robot:
    """Two revolute joints on one base: ``a_lead`` (stops -10, 10) and ``b_follow`` (stops -3, 3), in that order (Pinocchio wants a leader before its follower)."""
    joint = (
        '<joint name="{n}" type="revolute"><parent link="base"/><child link="{n}_l"/><axis xyz="0 1 0"/>'
        '<limit lower="{lo}" upper="{hi}" effort="5" velocity="100"/></joint>'
    )
    link = (
        '<link name="{n}_l"><inertial><origin xyz="0.1 0 0"/><mass value="0.2"/>'
        '<inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>'
    )
    body = "".join(
        link.format(n=n) + joint.format(n=n, lo=lo, hi=hi)
        for n, lo, hi in [("a_lead", -10, 10), ("b_follow", *FOLLOWER)]
    )
    path = tmp_path / "chain.urdf"
    path.write_text(f'<?xml version="1.0"?><robot name="chain"><link name="base"/>{body}</robot>')
    return robodyn.load(path)


@pytest.mark.parametrize(("ratio", "offset"), [(2.0, 0.5), (-2.0, 0.5), (-0.5, 0.0)])
def test_the_followers_stops_bind_its_leader_for_either_sign_of_the_ratio(
    tmp_path: Path, ratio: float, offset: float
) -> None:
    robot = chain(tmp_path)
    coupled = couple(robot, (Coupling("b_follow", "a_lead", ratio, offset),))
    assert coupled is not None
    lo, hi = sorted(((FOLLOWER[0] - offset) / ratio, (FOLLOWER[1] - offset) / ratio))
    lo, hi = max(lo, -10.0), min(hi, 10.0)
    j = coupled.coupled.joint("a_lead")
    assert coupled.coupled.model.lowerPositionLimit[j.idx_q] == pytest.approx(lo, rel=1e-15)
    assert coupled.coupled.model.upperPositionLimit[j.idx_q] == pytest.approx(hi, rel=1e-15)
    # Pushed both ways, the leader stops where the follower meets its stop; the follower never passes it.
    for push in (5.0, -5.0):
        traj = simulate(robot, [0.0], [0.0], duration=1.0, dt=1e-3, torque=[push, 0.0], couplings=[
            {"joint": "b_follow", "leader": "a_lead", "ratio": ratio, "offset": offset}])  # fmt: skip
        lead = traj.q[:, 0]
        follow = ratio * lead + offset
        assert traj.meta["stops"]["a_lead"] == pytest.approx([lo, hi], rel=1e-15)
        assert lo - STOP_TOL <= lead.min() and lead.max() <= hi + STOP_TOL
        assert (
            FOLLOWER[0] - abs(ratio) * STOP_TOL <= follow.min() and follow.max() <= FOLLOWER[1] + abs(ratio) * STOP_TOL
        )
        assert min(abs(lead[-1] - lo), abs(lead[-1] - hi)) < STOP_TOL  # it reached a stop and stays there


def test_a_follower_before_its_leader_is_refused_in_one_line_whose_advice_works(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import json

    from robodyn.cli import main

    chain(tmp_path)  # writes chain.urdf: a_lead comes first, so a_lead cannot follow b_follow
    spec = tmp_path / "couplings.json"
    spec.write_text(json.dumps({"couplings": [{"joint": "a_lead", "leader": "b_follow", "ratio": 2.0, "offset": 0.0}]}))
    argv = ["simulate", str(tmp_path / "chain.urdf"), "--duration", "0.01", "--backend", "crba"]
    assert main([*argv, "--constraints", str(spec)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "'a_lead' comes before its leader 'b_follow'" in line and "Traceback" not in line
    advice = json.loads(line.split("the other way round: ")[1])
    assert advice == {"joint": "b_follow", "leader": "a_lead", "ratio": 0.5, "offset": 0.0}
    assert '"offset": 0.0' in line  # not -0.0
    spec.write_text(json.dumps({"couplings": [advice]}))
    assert main([*argv, "--constraints", str(spec)]) == 0
