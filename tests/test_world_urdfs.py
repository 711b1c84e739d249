"""Every URDF of example-robot-data and of pybullet_data through ``robodyn info`` and ``robodyn check``.

No traceback, no false FAIL: ``info`` exits 0 or refuses (2), ``check`` passes (0) or refuses (2),
and a refusal is one ``error:`` line naming its reason (besides one-line warnings); a refusal for
physics names ``--no-physics-check``, and with that flag the file loads. pybullet is in the test
extra for its data only (``pybullet_data``); without it those files are skipped. Of the 1,000
generated files of ``random_urdfs/`` a seeded sample runs here (all of them:
``python benchmarks/world_urdfs.py``).
"""

from __future__ import annotations

import random
import re
from pathlib import Path

import pytest

from robodyn.cli import main
from robodyn.errors import InputError, ModelError
from robodyn.model.files import robots_dir
from robodyn.model.sources import sources

RANDOM_SAMPLE = 40  # of the 1,000 random_urdfs: their generator makes one kind of file, 40 cover its variety
PHYSICS = "physically impossible model"
SINGULAR_ROW = re.compile(r"^M symmetric positive definite .* FAIL ", re.MULTILINE)


def _pybullet_files(*, random_only: bool) -> list[Path]:
    try:
        import pybullet_data
    except ImportError:
        return []
    root = Path(pybullet_data.getDataPath())
    return [f for f in sorted(root.glob("**/*.urdf")) if ("random_urdfs" in f.relative_to(root).parts) == random_only]


def _label(path: Path) -> str:
    parts = path.parts
    anchor = "pybullet_data" if "pybullet_data" in parts else "robots"
    return "/".join(parts[parts.index(anchor) + 1 :])


ERD_FOLDER = robots_dir()
ERD_NAMES = sorted(sources())
ERD_FILES = sorted(ERD_FOLDER.glob("**/*.urdf")) if ERD_FOLDER is not None else []
PYBULLET_FILES = _pybullet_files(random_only=False)
RANDOM_FILES = (
    sorted(random.Random(0).sample(_pybullet_files(random_only=True), RANDOM_SAMPLE))
    if (_pybullet_files(random_only=True))
    else []
)

TARGETS = (
    [pytest.param(name, id=f"erd-name:{name}") for name in ERD_NAMES]
    + [pytest.param(str(p), id=f"erd-file:{_label(p)}") for p in ERD_FILES]
    + [pytest.param(str(p), id=f"pybullet:{_label(p)}") for p in PYBULLET_FILES]
    + [pytest.param(str(p), id=f"pybullet:{_label(p)}", marks=pytest.mark.slow) for p in RANDOM_FILES]
)


def _run(capfd: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, list[str]]:
    """Exit code, stdout and the non-empty stderr lines of ``robodyn ARGV`` (native output included)."""
    code = main(argv)
    out, err = capfd.readouterr()
    return code, out, [line for line in err.splitlines() if line.strip()]


def _assert_one_line_refusal(command: str, err: list[str]) -> str:
    """The refusal's one error line; every other line of stderr is a one-line warning."""
    errors = [line for line in err if line.startswith(f"robodyn {command}: error: ")]
    others = [line for line in err if line not in errors]
    assert len(errors) == 1, err
    assert all(line.startswith(f"robodyn {command}: warning: ") for line in others), err
    assert "Traceback" not in "\n".join(err)
    if PHYSICS in errors[0]:
        assert "--no-physics-check" in errors[0]
    return errors[0]


@pytest.mark.parametrize("target", TARGETS)
def test_info_and_check_read_the_file_or_refuse_in_one_line(capfd, target):
    code, _, err = _run(capfd, ["info", target])
    assert code in (0, 2), err
    if code == 2:
        _assert_one_line_refusal("info", err)
    code, out, err = _run(capfd, ["check", target])
    # 1 would be a false FAIL on the world's own robots, but for a mass matrix singular at the neutral pose
    # (icub's, 6e-18 of its largest eigenvalue), which simulate refuses too: a true finding
    assert code in (0, 2) or (code == 1 and SINGULAR_ROW.search(out)), out[-2000:] + "\n".join(err)
    if code == 2:
        refusal = _assert_one_line_refusal("check", err)
        if PHYSICS in refusal:  # the way past it works: the file's numbers load as written
            code, _, err = _run(capfd, ["info", target, "--no-physics-check"])
            assert code == 0, err
            assert sum("warning: --no-physics-check" in line for line in err) == 1, err
            code, _, err = _run(capfd, ["check", target, "--no-physics-check", "--samples", "5"])
            assert code in (0, 1), err  # 1: a singular M (a joint that moves nothing) is what the check says


@pytest.mark.parametrize("name", ["anymal", "anymal_kinova", "b1", "b1_z1", "go1"])
def test_a_welded_root_with_a_placeholder_inertia_loads_fixed_base(capfd, name):
    code, out, err = _run(capfd, ["check", name, "--samples", "5"])
    assert code == 0, err
    code, out, _ = _run(capfd, ["info", name])
    assert "welded_root" in out and "does not enter the dynamics" in out
    code, _, err = _run(capfd, ["check", name, "--free-flyer", "--samples", "5"])  # then the base moves: refused
    assert code == 2 and "--no-physics-check" in err[-1]


def test_a_genuinely_impossible_inertia_is_refused_naming_the_flag_and_loads_with_it(capfd):
    code, _, err = _run(capfd, ["check", "hyq", "--samples", "5"])
    assert code == 2 and PHYSICS in err[-1] and "--no-physics-check" in err[-1]
    code, _, err = _run(capfd, ["check", "hyq", "--samples", "5", "--no-physics-check"])
    assert code == 0
    assert len(err) == 1 and "warning: --no-physics-check: hyq is loaded with its file's masses" in err[0]


def test_a_link_of_zero_mass_with_inertia_is_named_in_info(capfd):
    code, out, _ = _run(capfd, ["info", "bolt"])
    assert code == 0
    assert "massless_inertia" in out and "robodyn reads it literally" in out and "substitute a mass" in out


def _copy_with(tmp_path: Path, text: str, name: str = "two.urdf") -> str:
    path = tmp_path / name
    path.write_bytes(text.encode())
    return str(path)


_TWO_LINKS = """<robot name="two">
  <link name="a"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="a.stl" scale="SCALE"/></geometry></visual></link>
  <link name="b"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>
    </inertial></link>
  <joint name="j" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 0.5"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""


def test_a_blank_line_before_the_declaration_is_skipped_with_a_warning(capfd, tmp_path):
    path = _copy_with(tmp_path, '\n\n<?xml version="1.0"?>\n' + _TWO_LINKS.replace("SCALE", "1 1 1"))
    code, _, err = _run(capfd, ["info", path])
    assert code == 0
    assert len(err) == 1 and "2 blank line(s) before the <?xml ...?> declaration, skipped" in err[0], err


@pytest.mark.parametrize(("scale", "read"), [("1 1 1 1", True), ("2 2 2 1", True), ("1 1 1 2", False)])
def test_a_mesh_scale_with_a_fourth_number_1_is_read_as_three(capfd, tmp_path, scale, read):
    path = _copy_with(tmp_path, _TWO_LINKS.replace("SCALE", scale))
    code, _, err = _run(capfd, ["info", path])
    if read:
        assert code == 0 and len(err) == 1 and "read as its first three numbers" in err[0], err
    else:  # an ambiguous fourth number stays refused
        assert code == 2 and "<mesh scale='1 1 1 2'> is not 3 finite numbers" in err[-1], err


def test_a_nul_byte_is_named(capfd, tmp_path):
    path = _copy_with(tmp_path, _TWO_LINKS.replace("SCALE", "1 1 1") + "\0")
    code, _, err = _run(capfd, ["info", path])
    assert code == 2 and len(err) == 1
    assert "a NUL byte (0x00) on line 9, column 0, after </robot>" in err[0], err


def test_a_mimic_of_a_missing_joint_names_both_joints(capfd, tmp_path):
    text = _TWO_LINKS.replace("SCALE", "1 1 1").replace(
        '<axis xyz="1 0 0"/>', '<axis xyz="1 0 0"/><mimic joint="k" multiplier="2"/>'
    )
    path = _copy_with(tmp_path, text)
    code, _, err = _run(capfd, ["info", path, "--mimic"])
    assert code == 2 and "joint 'j' mimics joint 'k', which is not a joint of this robot" in err[-1], err
    code, _, _ = _run(capfd, ["info", path])  # without --mimic the coupling is dropped: it loads
    assert code == 0


def test_a_mimic_model_run_without_mimic_says_why_q0_is_short(capfd):
    code, _, err = _run(capfd, ["simulate", "geared_arm_rotor", "--q0", "0.1", "--duration", "0.01"])
    assert code == 2 and len(err) == 1
    assert "q0 must have 2 entries" in err[0] and "pass --mimic to keep the coupling" in err[0], err


def test_physics_check_false_in_a_scene_and_no_physics_check_on_run(capfd, tmp_path):
    from robodyn.scene import read_scene

    scene = tmp_path / "hyq.toml"
    scene.write_text('[model]\nname = "hyq"\n\n[simulate]\nduration = 0.002\ndt = 1e-3\n')
    with pytest.raises(ModelError, match="--no-physics-check"):
        read_scene(scene).build()
    code, _, err = _run(capfd, ["run", str(scene), "--out", str(tmp_path / "out1"), "--no-physics-check"])
    assert code == 0, err
    assert sum("warning: --no-physics-check: hyq is loaded" in line for line in err) == 1, err
    scene.write_text('[model]\nname = "hyq"\nphysics_check = false\n\n[simulate]\nduration = 0.002\ndt = 1e-3\n')
    robot, _ = read_scene(scene).build()
    assert robot.nv == 12
    code, _, err = _run(capfd, ["check", str(scene), "--samples", "3"])
    assert code == 0 and sum("hyq is loaded with its file's masses" in line for line in err) == 1, err
    scene.write_text('[model]\nname = "hyq"\nphysics_check = "no"\n')
    code, _, err = _run(capfd, ["check", str(scene)])
    assert code == 2 and "physics_check" in err[-1], err


def test_physics_check_false_in_a_sweep_file(tmp_path):
    import robodyn.sweep as sweep
    from robodyn.sweep.source import AsWritten

    spec = {"model": "hyq", "duration": 0.002, "dt": 1e-3}
    with pytest.raises(ModelError, match="--no-physics-check"):
        sweep.prepare(spec, tmp_path / "a")
    prepared = sweep.prepare({**spec, "physics_check": False}, tmp_path / "b")
    assert all(isinstance(c.model, AsWritten) for c in prepared.plan.chunks)
    with pytest.raises(InputError, match="physics_check must be true or false"):
        sweep.prepare({**spec, "physics_check": 0}, tmp_path / "d")


def test_a_geometry_that_is_no_urdf_shape_is_skipped_with_a_warning(capfd, tmp_path):
    text = _TWO_LINKS.replace('<mesh filename="a.stl" scale="SCALE"/>', '<plane normal="0 0 1"/>')
    code, _, err = _run(capfd, ["check", _copy_with(tmp_path, text), "--samples", "3"])
    assert code == 0 and len(err) == 1, err
    assert "link 'a' <visual> <plane>: not a URDF shape" in err[0] and "skipped" in err[0]
