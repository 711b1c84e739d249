"""Loading: built-ins, variants, paths, SRDF pairing, errors, geometry on demand."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robodyn.errors import ModelError, UnknownNameError
from robodyn.model.files import (
    BUILTIN_NAMES,
    VARIANT_NAMES,
    mesh_references,
    reference_configurations,
    resolve_resource,
)
from robodyn.model.load import load
from robodyn.model.sources import resolve

# geared arm, armature vs rotor-as-a-body: identical physics, so CRBA agrees to round-off.
ROUNDOFF_RTOL = 1e-12


@pytest.mark.parametrize("name", BUILTIN_NAMES + VARIANT_NAMES)
def test_builtins_and_variants_load(name):
    robot = load(name, mimic=name == "geared_arm_rotor")
    assert robot.nv >= 1


def test_geared_arm_rotor_variant_equals_armature_model():
    minimal, rotor = load("geared_arm"), load("geared_arm_rotor", mimic=True)
    assert rotor.nv == 1 and rotor.armature[0] == 0.0 and minimal.armature[0] == pytest.approx(1.08e-6 * 50**2)
    rng = np.random.default_rng(0)
    for _ in range(5):
        q, v = minimal.random_state(rng)
        np.testing.assert_allclose(rotor.M(q), minimal.M(q), rtol=ROUNDOFF_RTOL)
        np.testing.assert_allclose(rotor.nle(q, v), minimal.nle(q, v), rtol=ROUNDOFF_RTOL)


def test_point_bob_variant_differs_only_in_pole_inertia():
    rod, bob = load("cart_pole"), load("cart_pole_point_bob")
    q = np.array([0.0, 0.0])
    # M[1,1] about the hinge: m l^2 + I_rod (8.3333333e-3 kg m^2) against m l^2
    assert rod.M(q)[1, 1] - bob.M(q)[1, 1] == pytest.approx(8.3333333e-3, rel=1e-9)
    np.testing.assert_allclose(rod.G(q), bob.G(q))
    assert bob.passive_joints == ("hinge",)


def test_path_and_srdf_pairing(tmp_path):
    robot = load(resolve("panda").urdf)
    assert robot.name == "panda" and robot.srdf_path is not None
    assert set(reference_configurations(robot)) == {"default"}


def test_errors_name_the_problem(tmp_path):
    with pytest.raises(UnknownNameError, match="unknown model .pandaa.; did you mean panda"):
        load("pandaa")
    with pytest.raises(ModelError, match="no such URDF file"):
        load(tmp_path / "missing.urdf")
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'>")
    with pytest.raises(ModelError, match="malformed URDF XML"):
        load(bad)
    notrobot = tmp_path / "n.urdf"
    notrobot.write_text("<sdf/>")
    with pytest.raises(ModelError, match="expected <robot>"):
        load(notrobot)


def test_mesh_references_resolve_without_parsing_meshes():
    refs = mesh_references(resolve("panda").urdf)
    assert refs and all(r.path is not None and r.path.is_file() for r in refs)


_TRIANGLE_STL = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 0.1 0 0\nvertex 0 0.1 0\nendloop\nendfacet\nendsolid t\n"


def test_resource_uris_resolve_as_pinocchio_resolves_them(tmp_path):
    # package:// with two and three slashes, file://, a relative path: the file Pinocchio's own
    # geometry loader opens is the one robodyn's mesh check finds.
    import pinocchio as pin

    share, robots = tmp_path / "share", tmp_path / "robots"
    (share / "pkg" / "meshes").mkdir(parents=True)
    robots.mkdir()
    (share / "pkg" / "meshes" / "tri.stl").write_text(_TRIANGLE_STL)
    (robots / "rel.stl").write_text(_TRIANGLE_STL)
    uris = [
        "package:///pkg/meshes/tri.stl",
        "package://pkg/meshes/tri.stl",
        f"file://{share}/pkg/meshes/tri.stl",
        "rel.stl",
    ]
    visuals = "".join(f'<visual><geometry><mesh filename="{u}"/></geometry></visual>' for u in uris)
    urdf = robots / "r.urdf"
    urdf.write_text(
        '<robot name="r"><link name="base"/><link name="a"><inertial><mass value="1"/>'
        '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>' + visuals + "</link>"
        '<joint name="j" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
    )
    dirs = [robots, share]
    model = pin.buildModelFromUrdf(str(urdf))
    geom = pin.buildGeomFromUrdf(model, str(urdf), pin.GeometryType.VISUAL, package_dirs=[str(d) for d in dirs])
    opened = [Path(obj.meshPath).resolve() for obj in geom.geometryObjects]
    found = [resolve_resource(u, dirs) for u in uris]
    assert all(f is not None for f in found)
    assert [f.resolve() for f in found if f is not None] == opened
    assert resolve_resource("package://pkg/meshes/missing.stl", dirs) is None
    assert resolve_resource("http://example.org/tri.stl", dirs) is None  # a scheme Pinocchio does not handle


def test_talos_package_uris_with_three_slashes_are_found():
    # talos_full_v2.urdf writes package:///example-robot-data/robots/...: every file exists.
    refs = mesh_references(resolve("talos_full").urdf)
    assert any(r.uri.startswith("package:///") for r in refs)
    assert [r.uri for r in refs if r.path is None] == []


def test_a_urdf_path_is_named_by_its_robot_name_and_a_name_keeps_its_name(tmp_path):
    source = resolve("pendubot").urdf
    renamed = tmp_path / "file_stem.urdf"
    renamed.write_text(source.read_text().replace('<robot name="pendubot"', '<robot name="spong"'))
    assert load(renamed).name == "spong"
    assert load("pendubot").name == "pendubot" and load("ur5").name == "ur5"  # library names stay


def test_an_srdf_must_be_an_srdf(tmp_path):
    with pytest.raises(ModelError, match=r"this is a URDF \(it has <link> or <joint type=...>\), not an SRDF"):
        load("pendubot", srdf=resolve("pendubot").urdf)
    not_robot = tmp_path / "x.srdf"
    not_robot.write_text("<groups/>")
    with pytest.raises(ModelError, match="SRDF root element is <groups>, expected <robot>"):
        load("pendubot", srdf=not_robot)
    # a real SRDF: groups list <joint name=...> without a type, a virtual joint has one
    good = tmp_path / "good.srdf"
    good.write_text(
        '<robot name="pendubot"><virtual_joint name="w" type="fixed" parent_frame="world" child_link="base"/>'
        '<group name="arm"><joint name="joint1"/></group><passive_joint name="joint2"/></robot>'
    )
    assert load("pendubot", srdf=good).passive_joints == ("joint2",)


def test_robot_repr_is_one_line():
    text = repr(load("talos"))
    assert text == "Robot(name='talos', nq=32, nv=32)"


def test_unknown_model_names_close_matches_first():
    with pytest.raises(UnknownNameError, match=r"unknown model 'pendubott'; did you mean pendubot") as info:
        load("pendubott")
    assert "robodyn info --list" in str(info.value) and info.value.choices  # the full list stays on the error


XACRO_TEXT = (
    '<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">'
    '<xacro:property name="damping" value="0.1"/><link name="base"/></robot>'
)


def test_an_existing_file_is_a_path_and_xacro_or_sdf_is_named(tmp_path, monkeypatch, capsys):
    """issue 39 item 7: ``stretch.xacro`` in the current folder was 'unknown model'; a xacro with a path, a number error."""
    from robodyn.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "mybot").write_text((Path(__file__).parents[1] / "models" / "pendubot.urdf").read_text())
    assert load("mybot").nv == 2  # a bare name that is no model's but a file's
    (tmp_path / "stretch.xacro").write_text(XACRO_TEXT)
    (tmp_path / "model.sdf").write_text('<sdf version="1.6"><model name="m"/></sdf>')
    (tmp_path / "arm.urdf").write_text(XACRO_TEXT)
    expected = {
        "stretch.xacro": "stretch.xacro: a xacro file: robodyn reads URDF; "
        "expand it first: xacro stretch.xacro > stretch.urdf (pip install xacro)",
        str(tmp_path / "arm.urdf"): "arm.urdf: holds xacro macros (<xacro:...>): robodyn reads plain URDF; "
        "expand it first: xacro arm.urdf > arm_expanded.urdf (pip install xacro)",
        "model.sdf": "model.sdf: an SDFormat file: robodyn reads URDF only",
    }
    for given, message in expected.items():
        assert main(["info", given]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
