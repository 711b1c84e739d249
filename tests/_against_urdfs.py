"""Small URDFs, each reproducing one way an engine reads a file differently from Pinocchio (tests/test_against.py)."""

from __future__ import annotations

import importlib.util
from collections.abc import Iterable
from pathlib import Path

import pytest

MODULES = {"mujoco": "mujoco", "pybullet": "pybullet", "drake": "pydrake"}


def needs(engines: Iterable[str]) -> None:
    """Skip the test, saying why, where one of ``engines`` is not installed (Drake, a 42 MB wheel, has its own extra)."""
    missing = [e for e in engines if importlib.util.find_spec(MODULES[e]) is None]
    if missing:
        pytest.skip(f"{missing[0]} is not installed: pip install 'robodyn[{missing[0]}]' (or the test extra) runs this")


BOX = '<collision><geometry><box size="0.1 0.05 0.3"/></geometry></collision>'


def inertial(mass: float, *, xyz: str = "0 0 -0.1", rpy: str = "0 0 0", inertia: str = "") -> str:
    """An <inertial>; ``inertia`` is the six ixx.. attributes (default: distinct diagonal moments)."""
    moments = inertia or 'ixx="0.003" iyy="0.0025" izz="0.002" ixy="0" ixz="0" iyz="0"'
    return f'<inertial><origin xyz="{xyz}" rpy="{rpy}"/><mass value="{mass!r}"/><inertia {moments}/></inertial>'


def arm(
    link2: str,
    *,
    extra: str = "",
    joint2: str = '<limit lower="-2" upper="2" effort="5" velocity="5"/>',
) -> str:
    """A two-joint arm; ``link2`` is the second moving link's content; ``extra`` more links and joints."""
    return f"""<?xml version="1.0"?>
<robot name="arm">
  <link name="base">{inertial(2.0)}</link>
  <link name="link1">{inertial(1.0)}{BOX}</link>
  <link name="link2">{link2}</link>
  <joint name="joint1" type="revolute"><parent link="base"/><child link="link1"/>
    <origin xyz="0 0 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="5" velocity="5"/></joint>
  <joint name="joint2" type="revolute"><parent link="link1"/><child link="link2"/>
    <origin xyz="0 0 -0.3" rpy="0.2 0 0"/><axis xyz="0 1 0"/>{joint2}</joint>
  {extra}
</robot>
"""


def tip(content: str, *, rpy: str = "0 0 0") -> str:
    """A link ``tip`` with ``content``, welded to link2 by a fixed joint."""
    return (
        f'<link name="tip">{content}</link><joint name="tip_joint" type="fixed"><parent link="link2"/>'
        f'<child link="tip"/><origin xyz="0 0.05 -0.3" rpy="{rpy}"/></joint>'
    )


ROTATED = 'ixx="0.004" iyy="0.0035" izz="0.003" ixy="0.0004" ixz="-0.0002" iyz="0.0003"'
CASES = {
    # a fixed link without <inertial>, with a collision box
    "no_inertial": arm(inertial(0.5) + BOX, extra=tip(BOX)),
    # a moving link of mass 0 (the fixed tip below it carries mass, so M stays invertible)
    "zero_mass_moving": arm(
        inertial(0.0, inertia='ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"'), extra=tip(inertial(0.3))
    ),
    # a fixed link of mass 0
    "zero_mass": arm(
        inertial(0.5) + BOX, extra=tip(inertial(0.0, inertia='ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"') + BOX)
    ),
    # the file's inertia is not its collision box's
    "collision": arm(inertial(0.5) + BOX),
    # an inertia whose <origin rpy> rotates it
    "rotated": arm(inertial(0.5, rpy="0.4 -0.3 0.9") + BOX),
    # a fixed link with a rotated, non-diagonal inertia, merged into its parent
    "merged_rotated": arm(
        inertial(0.5) + BOX, extra=tip(inertial(0.3, rpy="0.3 0.6 -0.2", inertia=ROTATED), rpy="0.5 0 0.4")
    ),
    # joint damping in <dynamics>
    "damping": arm(
        inertial(0.5), joint2='<limit lower="-2" upper="2" effort="5" velocity="5"/><dynamics damping="0.7"/>'
    ),
    # a continuous joint with a <limit> (its bounds mean nothing on a continuous joint)
    "continuous_limit": arm(inertial(0.5)).replace(
        'type="revolute"><parent link="link1"', 'type="continuous"><parent link="link1"'
    ),
    # a revolute <limit> without lower and upper: URDF's defaults are 0 and 0
    # a passive joint's effort limit 0 (MuJoCo: no limit) and dry friction (Drake: none)
    "effort_friction": arm(
        inertial(0.5), joint2='<limit lower="-2" upper="2" effort="0" velocity="3"/><dynamics friction="0.4"/>'
    ),
    # a ball spinning about its centre on a tilted axle: C v and G are zero at every state in exact arithmetic,
    # round-off in the engines' tilted frames
    "wheel": """<?xml version="1.0"?>
<robot name="wheel">
  <link name="base">"""
    + inertial(2.0)
    + """</link>
  <link name="wheel"><inertial><origin xyz="0 0 0"/><mass value="0.5"/>
    <inertia ixx="0.002" iyy="0.002" izz="0.002" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="axle" type="continuous"><parent link="base"/><child link="wheel"/>
    <origin xyz="0.1 0 0" rpy="0.3 0.2 0.1"/><axis xyz="0 0.6 0.8"/></joint>
</robot>
""",
    "limit_defaults": arm(inertial(0.5), joint2='<limit effort="5" velocity="5"/>'),
    # a prismatic joint
    "prismatic": arm(inertial(0.5)).replace(
        'type="revolute"><parent link="link1"', 'type="prismatic"><parent link="link1"'
    ),
    # a continuous joint: no limits
    "continuous": arm(inertial(0.5), joint2="").replace(
        'type="revolute"><parent link="link1"', 'type="continuous"><parent link="link1"'
    ),
    # a carriage on a vertical rail: its rotational inertia enters no M, C v or G (nothing rotates)
    "rail": f"""<?xml version="1.0"?>
<robot name="rail">
  <link name="base">{inertial(2.0)}</link>
  <link name="carriage">{inertial(0.731, xyz="0.013 0 0.021")}{BOX}</link>
  <joint name="rail" type="prismatic"><parent link="base"/><child link="carriage"/><axis xyz="0 0 1"/>
    <limit lower="-0.2" upper="0.2" effort="50" velocity="1"/></joint>
</robot>
""",
}

# A free-flying base with a rotated, non-diagonal inertia off its origin and a rotated sensor welded to it (merged
# into the base by Pinocchio and by MuJoCo's defaults), carrying a revolute and a prismatic joint: non-round numbers
# throughout, so that a wrong quaternion order or a velocity in the wrong frame shows in every block of M, C v, G.
FLOATING_BASE = """<?xml version="1.0"?>
<robot name="floating">
  <link name="trunk"><inertial><origin xyz="0.0123 -0.0347 0.0561" rpy="0.31 -0.47 0.73"/><mass value="3.1416"/>
    <inertia ixx="0.0431" iyy="0.0527" izz="0.0389" ixy="0.0031" ixz="-0.0022" iyz="0.0017"/></inertial></link>
  <link name="sensor"><inertial><origin xyz="0.021 0.013 -0.008" rpy="-0.2 0.5 0.35"/><mass value="0.2718"/>
    <inertia ixx="0.00041" iyy="0.00033" izz="0.00029" ixy="0.00004" ixz="-0.00002" iyz="0.00003"/></inertial></link>
  <link name="arm"><inertial><origin xyz="0.017 0.004 -0.137" rpy="0.11 0.07 -0.23"/><mass value="0.7071"/>
    <inertia ixx="0.0047" iyy="0.0051" izz="0.0009" ixy="0.0002" ixz="0.0003" iyz="-0.0001"/></inertial></link>
  <link name="slider"><inertial><origin xyz="0.003 -0.011 0.027"/><mass value="0.3183"/>
    <inertia ixx="0.00023" iyy="0.00019" izz="0.00017" ixy="0.00001" ixz="0" iyz="0.00002"/></inertial></link>
  <joint name="sensor_mount" type="fixed"><parent link="trunk"/><child link="sensor"/>
    <origin xyz="0.113 0.027 0.041" rpy="0.6 -0.1 1.2"/></joint>
  <joint name="shoulder" type="revolute"><parent link="trunk"/><child link="arm"/>
    <origin xyz="0.071 -0.093 -0.029" rpy="0.23 -0.41 0.17"/><axis xyz="0.267 0.535 0.802"/>
    <limit lower="-2.1" upper="2.3" effort="7" velocity="4"/></joint>
  <joint name="slide" type="prismatic"><parent link="arm"/><child link="slider"/>
    <origin xyz="0.009 0.012 -0.247" rpy="-0.37 0.29 0.05"/><axis xyz="0 0.6 0.8"/>
    <limit lower="-0.1" upper="0.15" effort="20" velocity="1"/></joint>
</robot>
"""
CASES["floating_base"] = FLOATING_BASE
# The same base, its own inertia broken (every entry 1e-6 kg m^2: principal moments 0, 0, 3e-6, as ANYmal's and Go1's
# base links have), the sensor's mass keeping the merged body valid: an engine that replaces the link's inertia
# changes the base.
CASES["invalid_base"] = FLOATING_BASE.replace(
    '<inertia ixx="0.0431" iyy="0.0527" izz="0.0389" ixy="0.0031" ixz="-0.0022" iyz="0.0017"/>',
    '<inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="1e-6" ixz="1e-6" iyz="1e-6"/>',
)
# The same robot under a root link named world, welded to the base at an offset (example-robot-data's TwoDofs.urdf does
# this): MuJoCo takes a link named world as its world body, and its freejoint goes on the base, not the root link.
CASES["world_root"] = FLOATING_BASE.replace(
    '<link name="trunk">',
    '<link name="world"/><joint name="world_to_trunk" type="fixed"><parent link="world"/><child link="trunk"/>'
    '<origin xyz="0.031 -0.017 0.052" rpy="0.1 -0.2 -1.57"/></joint>\n  <link name="trunk">',
)

ROTOR_SRDF = """<?xml version="1.0"?>
<robot name="arm"><rotor_params><joint name="joint2" mass="2e-6" gear_ratio="40"/></rotor_params></robot>
"""


def write(case: str, folder: Path) -> Path:
    """Write ``CASES[case]`` to ``folder/case.urdf``; the armature case also gets ``case.srdf``."""
    path = folder / f"{case}.urdf"
    path.write_text(CASES["collision"] if case == "armature" else CASES[case])
    if case == "armature":
        (folder / f"{case}.srdf").write_text(ROTOR_SRDF)
    return path
