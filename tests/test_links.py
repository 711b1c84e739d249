"""robodyn's per-link table (robodyn.model.links): the numbers a KIND = "any" formula's parameters(robot) reads."""

import numpy as np
import pytest

import robodyn
from robodyn.errors import InputError
from robodyn.model.links import LinkTable, link_table
from robodyn.model.reduce import reduce

EXACT = 0.0  # the table copies Pinocchio's numbers: no arithmetic, no round-off


def test_pendubot_links_read_the_urdf():
    table = link_table(robodyn.load("pendubot"))
    assert table.joints == ("joint1", "joint2")
    l1, l2 = table.links
    assert l1.parent is None and l2.parent == "joint1"
    assert (l1.joint_type, l2.joint_type) == ("revolute", "revolute")
    assert l1.mass == pytest.approx(1.336, abs=EXACT)
    np.testing.assert_allclose(l2.origin, [0.15, -0.02, 0.0], atol=EXACT)
    np.testing.assert_allclose(l2.com, [0.126, 0.0, 0.0], atol=EXACT)
    np.testing.assert_allclose(l1.axis, [0.0, -1.0, 0.0], atol=1e-15)
    assert l2.inertia_about_axis == pytest.approx(2.6502e-3, rel=1e-15)
    assert table.g == pytest.approx(9.81, rel=1e-15)


def test_cart_pole_names_prismatic_and_revolute():
    table = link_table(robodyn.load("cart_pole"))
    assert [link.joint_type for link in table.links] == ["prismatic", "revolute"]
    np.testing.assert_allclose(table["slider"].axis, [1.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(table["hinge"].com, [0.0, 0.0, 0.5], atol=EXACT)


def test_round_trip_through_json_is_exact():
    table = link_table(robodyn.load("pendubot"))
    again = LinkTable.from_dict(table.as_dict())
    assert again.as_dict() == table.as_dict()
    assert again["joint2"].rpy.tolist() == [0.0, 0.0, 0.0]


def test_locked_joint_is_welded_into_its_parent_link():
    robot = robodyn.load("pendubot")
    table = link_table(reduce(robot, lock={"joint2": 0.0}).reduced)
    assert table.joints == ("joint1",)
    assert table["joint1"].mass == pytest.approx(1.336 + 0.5, rel=1e-15)


def test_free_flyer_is_refused_by_name():
    with pytest.raises(InputError, match="root_joint.*revolute, continuous and prismatic"):
        link_table(robodyn.load("pendubot", free_flyer=True))


def test_continuous_joint_off_a_canonical_axis_reads_its_axis():
    table = link_table(robodyn.load("examples/urdf/double_pendulum.urdf"))
    assert table["shoulder"].joint_type == "continuous"
    np.testing.assert_allclose(table["shoulder"].axis, [0.0, -1.0, 0.0], atol=EXACT)
    np.testing.assert_allclose(table["elbow"].axis, [0.0, 1.0, 0.0], atol=EXACT)
