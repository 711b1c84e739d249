"""Hostile and malformed URDFs: refused in one line before they reach the numerics, or loaded exactly as written.

Every hostile file is the Pendubot (models/pendubot.urdf) with one text mutation, refused by
``robodyn.load`` and by ``robodyn info`` in process (exit 2, exactly one stderr line: no
traceback, no urdfdom ``Error:`` line), and a few by a real ``robodyn`` process. One section per
defect class of the hostile-input issue: 1 a silently wrong robot, 2 structure, 3 physics,
4 unreadable files, 5 big models, 9 urdfdom's own stderr.
"""

from __future__ import annotations

import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import ClassVar

import numpy as np
import pinocchio as pin
import pytest

import robodyn
from robodyn.cli import main
from robodyn.errors import ModelError
from robodyn.model import consistency, files, urdf
from robodyn.model import load as loading
from robodyn.model.consistency import link_inertials

ROOT = Path(__file__).resolve().parents[1]
PENDUBOT = (ROOT / "models" / "pendubot.urdf").read_text()
ROBODYN = Path(sys.executable).parent / "robodyn"

# Numbers read by float() and by urdfdom's strtod are both correctly rounded: identical.
EXACT = 0.0
# Pinocchio adds a link's inertia to its (empty) body: a rounding of 0.1 m or of 1e-3 kg m^2 at most.
ONE_ROUNDING = 1e-15

MASS1 = '<mass value="1.336"/>'
INERTIAL1 = '<origin xyz="0.10 0 0" rpy="0 0 0"/>'
INERTIA1 = '<inertia ixx="4.0e-4" iyy="6.19e-3" izz="6.0e-3" ixy="0" ixz="0" iyz="0"/>'
TIP = '<link name="tip"/>'
BASE = '<link name="base">'
LIMIT1 = '<limit lower="-1000" upper="1000" effort="2.0" velocity="40"/>'


def mutated(tmp_path: Path, old: str, new: str, name: str = "p.urdf") -> Path:
    """The Pendubot with the first ``old`` replaced by ``new``, written to ``tmp_path / name``."""
    assert old in PENDUBOT, old
    path = tmp_path / name
    path.write_text(PENDUBOT.replace(old, new, 1), encoding="utf-8")
    return path


def inertial(mass: str, ixx: str = "1e-4", iyy: str = "1e-4", izz: str = "1e-4", iyz: str = "0") -> str:
    return (
        f'<inertial><mass value="{mass}"/>'
        f'<inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="0" ixz="0" iyz="{iyz}"/></inertial>'
    )


def one_line(err: str) -> str:
    """The single line of ``err``, which must hold no traceback and none of urdfdom's own lines."""
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert "Traceback" not in err and "Error:" not in err and " at line " not in err, err
    return err.rstrip("\n")


def refused(path: Path, capfd: pytest.CaptureFixture[str], command: str = "info", **options: object) -> str:
    """The one line in which ``robodyn.load`` and ``robodyn <command>`` (in process) refuse ``path``."""
    with pytest.raises(ModelError) as exc:
        robodyn.load(path, **options)  # type: ignore[arg-type]
    assert capfd.readouterr().err == ""  # urdfdom's lines were captured, not leaked
    assert main([command, str(path)]) == 2
    line = one_line(capfd.readouterr().err)
    assert line == f"robodyn {command}: error: {exc.value}"
    assert line.startswith(f"robodyn {command}: error: {path}: ")
    return line


def run_cli(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(ROBODYN), *argv], capture_output=True, text=True, check=False, timeout=120)


# --------------------------------------------------------------------------- 1. a silently wrong robot

NOT_URDFDOM_NUMBERS = [
    ("spaces", MASS1, '<mass value=" 1.336 "/>', "<mass value=' 1.336 '>"),
    ("underscore", MASS1, '<mass value="1_336"/>', "<mass value='1_336'>"),
    ("arabic digits", MASS1, '<mass value="١.٣٣٦"/>', "<mass value='١.٣٣٦'>"),
    ("no-break space", MASS1, '<mass value="1.336\u00a0"/>', "<mass value='1.336\\xa0'>"),
    ("decimal comma", MASS1, '<mass value="1,336"/>', "<mass value='1,336'>"),
    ("hexadecimal", MASS1, '<mass value="0x1p0"/>', "<mass value='0x1p0'>"),
    ("overflow", MASS1, '<mass value="1e400"/>', "<mass value='1e400'>"),
    ("TAB reference", INERTIAL1, '<origin xyz="0.10&#9;0 0" rpy="0 0 0"/>', "<origin xyz='0.10\\t0 0'>"),
    ("newline reference", INERTIAL1, '<origin xyz="0.10 0&#10;0" rpy="0 0 0"/>', "<origin xyz='0.10 0\\n0'>"),
]


@pytest.mark.parametrize(("case", "old", "new", "shown"), NOT_URDFDOM_NUMBERS, ids=[c[0] for c in NOT_URDFDOM_NUMBERS])
def test_numbers_urdfdom_would_not_read_are_refused_naming_element_and_value(tmp_path, capfd, case, old, new, shown):
    line = refused(mutated(tmp_path, old, new), capfd)
    assert f"link 'link1': {shown} is not " in line, line
    assert "(expected " in line and "plain decimal such as 1.336" in line, line


def _urdfdom_reading(text: str, *, vector: bool) -> tuple[float, ...] | None:
    """What urdfdom reads for ``text`` as link1's mass (or its inertial's xyz); None if it says Error."""
    if vector:
        xml = PENDUBOT.replace(INERTIAL1, f'<origin xyz="{text}" rpy="0 0 0"/>', 1).replace(MASS1, '<mass value="1"/>')
    else:
        xml = PENDUBOT.replace(MASS1, f'<mass value="{text}"/>', 1)
    with loading.native_stderr() as said:
        model = pin.buildModelFromXML(xml)
    if loading.urdfdom_errors(said):
        return None
    body = model.inertias[1]
    return tuple(float(x) for x in body.lever) if vector else (float(body.mass),)


GRAMMAR_CASES = [
    "1.336", "+1.5", "-0.25", ".5", "1.", "1e2", "1E-2", "00.5", "5e-0003", "1e-310", "1e-330", "-0",
    " 1.336", "1.336 ", "\t1", "1\t", "1_336", "1,5", "0x10", "nan", "inf", "1e400", "1e", "1e+", ".", "",
    "١", "1.3.3", "+-1", "1d2",
]  # fmt: skip
VECTOR_CASES = ["0.1 0 0", " 0.1  0 0 ", "0.1 0", "0.1 0 0 0", "0.1,0,0", "0.1 nan 0", "-1e-3 +2 3E2", "1e400 0 0"]


def test_robodyn_reads_a_number_only_where_urdfdom_reads_the_same_one():
    """robodyn's grammar is urdfdom's or stricter: whatever robodyn accepts, urdfdom reads to the same double."""
    rng = np.random.default_rng(11)
    alphabet = [*"0123456789..eE+- \t_,x", "١", "\u00a0"]
    fuzz = ["".join(rng.choice(alphabet, size=rng.integers(1, 7))) for _ in range(300)]
    accepted = 0
    for text in GRAMMAR_CASES + fuzz:
        mine = urdf.parse_numbers(text, 1)
        if mine is not None:
            accepted += 1
            theirs = _urdfdom_reading(text, vector=False)
            assert theirs is not None and abs(theirs[0] - mine[0]) <= EXACT, (text, mine, theirs)
    for text in VECTOR_CASES:
        mine = urdf.parse_numbers(text, 3)
        theirs = _urdfdom_reading(text, vector=True)
        assert (mine is None) == (theirs is None), (text, mine, theirs)
        if mine is not None:
            np.testing.assert_allclose(theirs, mine, rtol=EXACT, atol=EXACT)  # type: ignore[arg-type]
    assert accepted >= 12  # the fuzz did exercise the accepting branch
    for text in (" 1.336 ", "1_336", "١", "1.336\u00a0", "1e400", "nan"):  # the examples: urdfdom refuses too
        assert urdf.parse_numbers(text, 1) is None and _urdfdom_reading(text, vector=False) is None, text


def test_a_raw_tab_is_white_space_in_xml_and_loads_as_written(tmp_path, capfd):
    """A TAB typed in an attribute is a space to XML; Pinocchio gets robodyn's reading, so it reads 0.10 too."""
    path = mutated(tmp_path, INERTIAL1, '<origin xyz="0.10\t0\n0" rpy="0 0 0"/>')
    robot = robodyn.load(path)
    np.testing.assert_allclose(robot.model.inertias[1].lever, [0.10, 0.0, 0.0], rtol=0, atol=1e-16)
    assert robot.model.inertias[1].mass == 1.336
    assert capfd.readouterr().err == ""


@pytest.mark.parametrize(
    "doctype",
    [
        '<!DOCTYPE robot [<!ENTITY m "1.336">]>',
        '<!DOCTYPE robot SYSTEM "file:///etc/passwd">',
        '<!DOCTYPE robot [<!ENTITY a "aaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;">]>',
    ],
    ids=["internal entity", "external DTD", "entity expansion"],
)
def test_a_dtd_is_refused_outright(tmp_path, capfd, doctype):
    path = mutated(tmp_path, '<?xml version="1.0"?>', f'<?xml version="1.0"?>\n{doctype}')
    path.write_text(path.read_text().replace(MASS1, '<mass value="&m;"/>' if "ENTITY m" in doctype else MASS1))
    line = refused(path, capfd)
    assert "<!DOCTYPE robot> declared (expected none: robodyn refuses DTDs and entity declarations" in line


def _float_reading(text: str, count: int) -> tuple[float, ...] | None:
    """The number reading robodyn had before this test's fix: Python's float() on white-space pieces."""
    values = tuple(float(x) for x in text.split())
    return values if len(values) == count else None


def test_a_model_that_differs_from_the_file_is_refused(tmp_path, capfd, monkeypatch):
    """Belt and braces: were robodyn's reading loose and blind to urdfdom's stderr, the comparison still refuses."""
    path = mutated(tmp_path, MASS1, '<mass value="1.336 "/>')  # urdfdom drops link1's inertial
    monkeypatch.setattr(loading, "validate_urdf", lambda *args, **kwargs: None)
    monkeypatch.setattr(consistency, "parse_numbers", _float_reading)
    monkeypatch.setattr(loading, "urdfdom_errors", lambda said: [])
    line = refused(path, capfd)
    assert line.endswith(
        "the model Pinocchio built differs from the file: link 'link1': mass 0 kg in the model, 1.336 kg in the file"
    ), line


def _compare(model: pin.Model, path: Path) -> None:
    root = ET.parse(path).getroot()
    loading.check_model_matches_file(model, root, link_inertials(root), path)


def test_the_comparison_sums_welded_links_and_names_what_differs(tmp_path):
    """The file's tip (welded to link2 by a fixed joint) gets 0.25 kg: Pinocchio's body 'link2' must have 0.75 kg."""
    path = mutated(tmp_path, TIP, f'<link name="tip">{inertial("0.25")}</link>')
    model = robodyn.load(path).model
    _compare(model, path)  # the model of the file itself passes
    pendubot = robodyn.load("pendubot").model
    with pytest.raises(ModelError, match=r"links 'link2', 'tip' \(welded\): mass 0.5 kg in the model, 0.75 kg"):
        _compare(pendubot, path)
    tilted = mutated(tmp_path, '<origin xyz="0.126 0 0" rpy="0 0 0"/>', '<origin xyz="0.126 0 0" rpy="0.3 0 0"/>')
    with pytest.raises(ModelError, match=r"link2.*: inertia about the body frame differs by up to"):
        _compare(pendubot, tilted)
    shifted = mutated(tmp_path, '<origin xyz="0.126 0 0" rpy="0 0 0"/>', '<origin xyz="0.127 0 0" rpy="0 0 0"/>')
    with pytest.raises(ModelError, match=r"link2.*: centre of mass \(first moment m c\) differs"):
        _compare(pendubot, shifted)
    renamed = mutated(tmp_path, '<joint name="joint2"', '<joint name="elbow"')
    with pytest.raises(ModelError, match="joint 'elbow' is in the file but not in the model"):
        _compare(pendubot, renamed)


# --------------------------------------------------------------------------- 9. urdfdom's own stderr


def test_urdfdom_error_on_a_built_model_is_refused_in_one_line(tmp_path, capfd):
    """urdfdom cannot read a <capsule>: it prints Error: and drops the visual, yet builds the model."""
    path = mutated(tmp_path, '<box size="0.15 0.02 0.03"/>', '<capsule radius="0.1" length="1"/>')
    line = refused(path, capfd)
    assert "urdfdom reported an error yet built a model without the part it could not read: " in line
    assert "Could not parse visual element for Link [link1]" in line


def test_urdfdom_messages_end_the_line_when_pinocchio_fails(tmp_path, capfd):
    line = refused(mutated(tmp_path, LIMIT1, ""), capfd)
    assert "Pinocchio cannot parse this URDF: " in line
    assert "(urdfdom said: Joint [joint1] is of type REVOLUTE but it does not specify limits" in line


def test_a_good_file_loads_without_a_word_on_stderr(capfd):
    for name in ("pendubot", "talos"):
        robodyn.load(name)
    assert capfd.readouterr().err == ""


def test_native_stderr_is_restored_when_the_block_raises(capfd):
    with pytest.raises(RuntimeError), loading.native_stderr() as said:
        os.write(2, b"Error:   captured\n")
        raise RuntimeError("inside")
    os.write(2, b"after\n")
    assert loading.urdfdom_errors(said) == ["captured"]
    assert capfd.readouterr().err == "after\n"


def test_a_real_process_prints_one_line(tmp_path):
    path = mutated(tmp_path, '<box size="0.15 0.02 0.03"/>', '<capsule radius="0.1" length="1"/>')
    proc = run_cli("info", str(path))
    assert proc.returncode == 2, proc.stderr
    assert one_line(proc.stderr).startswith(f"robodyn info: error: {path}: urdfdom reported an error")


# --------------------------------------------------------------------------- 2. structure


@pytest.mark.parametrize(
    ("case", "old", "new", "message"),
    [
        ("root", BASE, f"{BASE}{inertial('-3.164')}", "link 'base': <mass value='-3.164'> is negative"),
        ("welded", TIP, f'<link name="tip">{inertial("-0.1")}</link>', "link 'tip': <mass value='-0.1'> is negative"),
    ],
)
def test_a_negative_mass_is_refused_on_the_root_and_on_a_welded_link(tmp_path, capfd, case, old, new, message):
    line = refused(mutated(tmp_path, old, new), capfd)
    assert f"{message} (expected 0 or a mass between 1e-12 and 1e+06 kg)" in line, line


def test_an_impossible_inertia_hidden_by_the_merge_or_on_a_moving_root_is_refused(tmp_path, capfd):
    """Pinocchio's body 'link2' (link2 + tip) is positive definite; the tip alone is not. The root is no joint's body.

    On a fixed base the root is welded to the world: its inertia never enters the dynamics, so it is
    a note there (issue 21: anymal's placeholder ``base``), and refused once a free flyer moves it.
    """
    hidden = mutated(tmp_path, TIP, f'<link name="tip">{inertial("0.01", ixx="-1e-6", iyy="1e-6", izz="1e-6")}</link>')
    root = mutated(tmp_path, BASE, f"{BASE}{inertial('1', ixx='1e-3', iyy='1e-3', izz='3e-3')}", "root.urdf")
    triangle = "base: principal moments of inertia 0.001, 0.001, 0.003 kg m^2 break the triangle inequality"
    for path, message, options in (
        (hidden, "tip: inertia not positive semi-definite", {}),
        (root, triangle, {"free_flyer": True}),
    ):
        with pytest.raises(ModelError, match="physically impossible model: " + message.replace("^", r"\^")):
            robodyn.load(path, **options)
        if not options:
            line = refused(path, capfd, command="check")
            assert message in line and "--no-physics-check" in line, line
        assert main(["info", str(path), *(["--free-flyer"] if options else [])]) == 0  # info reports what is refused
        assert message in capfd.readouterr().out
    robodyn.load(root)  # fixed base: the root is the world
    assert main(["info", str(root)]) == 0
    assert f"welded_root       {triangle}" in capfd.readouterr().out


# --------------------------------------------------------------------------- 3. physics


def test_the_triangle_inequality_is_tested_on_the_principal_moments(tmp_path, capfd):
    """Diagonal (1, 2, 2)e-3 with iyz = -1e-3: each diagonal triangle holds, the principal moments are (1, 1, 3)e-3."""
    path = mutated(tmp_path, INERTIA1, '<inertia ixx="1e-3" iyy="2e-3" izz="2e-3" ixy="0" ixz="0" iyz="-1e-3"/>')
    line = refused(path, capfd, command="check")
    assert "link1: principal moments of inertia 0.001, 0.001, 0.003 kg m^2 break the triangle inequality" in line


def test_an_inertial_without_inertia_is_a_point_mass_never_refused_where_it_cannot_move(tmp_path, capfd):
    """Seven files of airo-models and others: ``<inertial>`` with a mass and no ``<inertia>`` (urdfdom refuses it).

    On a fixed base the root is the world (loaded, a ``welded_root`` note); where the link moves, a
    refusal naming the way past, which loads it as a point mass at the written centre of mass.
    """
    root = mutated(tmp_path, BASE, f'{BASE}<inertial><mass value="2"/></inertial>', "root.urdf")
    moving = mutated(tmp_path, INERTIA1, "", "moving.urdf")
    robodyn.load(root)
    assert capfd.readouterr().err == ""  # urdfdom never saw the incomplete inertial
    assert main(["check", str(root), "--samples", "3"]) == 0
    assert main(["info", str(root)]) == 0
    out = capfd.readouterr().out
    assert "welded_root       base: <inertial> has a mass of 2 kg but no <inertia> (read as a point mass" in out, out
    with pytest.raises(ModelError, match="base: <inertial> has a mass of 2 kg but no <inertia>"):
        robodyn.load(root, free_flyer=True)  # the base moves
    line = refused(moving, capfd, command="check")
    assert "link1: <inertial> has a mass of 1.336 kg but no <inertia>" in line and "--no-physics-check" in line, line
    inertia = robodyn.load(moving, check_physics=False).model.inertias[1]
    assert capfd.readouterr().err == ""
    assert inertia.mass == 1.336
    np.testing.assert_allclose(inertia.lever, [0.10, 0.0, 0.0], rtol=0, atol=ONE_ROUNDING)
    np.testing.assert_allclose(inertia.inertia, np.zeros((3, 3)), rtol=0, atol=ONE_ROUNDING)  # a point mass


@pytest.mark.parametrize(
    ("case", "old", "new", "message"),
    [
        ("huge mass", MASS1, '<mass value="1e308"/>', "<mass value='1e308'> is out of range (expected 0 or a mass"),
        ("subnormal mass", MASS1, '<mass value="1e-310"/>', "<mass value='1e-310'> is out of range"),
        ("tiny mass", MASS1, '<mass value="1e-13"/>', "<mass value='1e-13'> is out of range"),
        ("huge inertia", 'ixx="4.0e-4"', 'ixx="1e308"', "<inertia ixx='1e308'> is out of range (expected 0 or a"),
        ("subnormal inertia", 'izz="6.0e-3"', 'izz="5e-324"', "<inertia izz='5e-324'> is out of range"),
        ("far origin", INERTIAL1, '<origin xyz="1e300 0 0" rpy="0 0 0"/>', "<origin xyz='1e300 0 0'> is out of range"),
        ("tiny axis", '<axis xyz="0 -1 0"/>', '<axis xyz="0 -1e-310 0"/>', "<axis xyz='0 -1e-310 0'> has length"),
    ],
)
def test_magnitudes_beyond_the_limits_are_refused_at_load(tmp_path, capfd, case, old, new, message):
    line = refused(mutated(tmp_path, old, new), capfd)
    assert message in line, line


def test_the_limits_let_every_library_magnitude_through():
    """Dust inertias (iCub writes 2.4e-35 kg m^2) and the lightest link (so101, 1e-9 kg) stay loadable."""
    for name in ("icub", "so101"):
        assert robodyn.load(name, check_physics=False).nv > 0


# --------------------------------------------------------------------------- 4. unreadable files


DRAKE = '<drake:collision_filter_group name="g"><drake:member link="link1"/></drake:collision_filter_group>'


def test_a_prefix_used_without_its_namespace_is_read_as_urdfdom_reads_it(tmp_path, capfd):
    """airo-models' UR arms write ``<limit drake:acceleration=...>`` and Drake elements, never declaring ``drake``."""
    text = PENDUBOT.replace(LIMIT1, LIMIT1.replace("<limit ", '<limit drake:acceleration="2.5" '), 1)
    path = tmp_path / "drake.urdf"
    path.write_text(text.replace("</robot>", DRAKE + "</robot>"), encoding="utf-8")
    read, plain = robodyn.load(path).model, robodyn.load("pendubot").model
    q = np.array([0.3, -0.7])
    np.testing.assert_array_equal(pin.crba(read, read.createData(), q), pin.crba(plain, plain.createData(), q))
    assert main(["check", str(path), "--samples", "3"]) == 0
    assert capfd.readouterr().err == ""
    document = urdf.read_document(path)  # yourdfpy and lxml, as an edited robot is written
    assert [j.name for j in document.urdf.robot.joints] == ["joint1", "joint2", "tip_joint"]


def test_unreadable_files_are_one_line(tmp_path, capfd):
    text = PENDUBOT.encode()
    cases = {
        "bogus.urdf": (
            text.replace(b'<?xml version="1.0"?>', b'<?xml version="1.0" encoding="bogus"?>'),
            "the XML declaration names an unknown encoding: bogus (expected UTF-8)",
        ),
        "latin.urdf": (text.replace(b'name="link1"', b'name="l\xe9nk1"'), "malformed URDF XML: not well-formed"),
        "junk.urdf": (bytes(np.random.default_rng(3).integers(0, 256, 4096, dtype=np.uint8)), "malformed URDF XML"),
        "empty.urdf": (b"", "the URDF file is empty (expected XML with a <robot> element)"),
        "blank.urdf": (b"  \n\t\n", "the URDF file is empty"),
    }
    for name, (data, message) in cases.items():
        path = tmp_path / name
        path.write_bytes(data)
        assert message in refused(path, capfd), name
    folder = tmp_path / "folder.urdf"
    folder.mkdir()
    assert "is a directory (expected a path to a .urdf file or a model name)" in refused(folder, capfd)


@pytest.mark.parametrize("encoding", ["ISO-8859-1", "UTF-16"])
def test_a_declared_encoding_is_decoded_before_pinocchio_sees_the_text(tmp_path, encoding):
    """urdfdom reads UTF-8 only; it is handed robodyn's reading, so a Latin-1 or UTF-16 link name survives."""
    text = PENDUBOT.replace('<?xml version="1.0"?>', f'<?xml version="1.0" encoding="{encoding}"?>')
    path = tmp_path / "p.urdf"
    path.write_bytes(text.replace("link1", "lénk1").encode(encoding.lower()))
    robot = robodyn.load(path)
    assert {f.name for f in robot.model.frames} >= {"lénk1", "link2"}
    assert robot.model.inertias[1].mass == 1.336


# --------------------------------------------------------------------------- 5. big models


def _chain(links: int, *, moving: int | None = None) -> str:
    """A URDF chain of ``links`` links after a root; the first ``moving`` joints revolute, the others fixed."""
    moving = links if moving is None else moving
    parts = ['<robot name="chain"><link name="l0"/>']
    for i in range(1, links + 1):
        kind = "revolute" if i <= moving else "fixed"
        parts.append(f'<link name="l{i}">{inertial("0.1")}</link>')
        parts.append(
            f'<joint name="j{i}" type="{kind}"><parent link="l{i - 1}"/><child link="l{i}"/>'
            '<origin xyz="0 0 -0.1"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
        )
    return "".join(parts) + "</robot>"


def test_a_chain_that_crashes_pinocchio_is_refused_before_it_in_a_real_process(tmp_path):
    """5,000 links, 10 of them moving: Pinocchio's parser overflows the stack (SIGSEGV); robodyn refuses first."""
    path = tmp_path / "chain.urdf"
    path.write_text(_chain(5000, moving=10))
    proc = run_cli("info", str(path))
    assert proc.returncode == 2, (proc.returncode, proc.stderr[-500:])
    line = one_line(proc.stderr)
    assert f"5001 <link> elements (expected at most {urdf.MAX_LINKS}" in line, line


def test_link_and_dof_limits_are_refused_in_one_line(tmp_path, capfd):
    links = tmp_path / "links.urdf"
    links.write_text(_chain(urdf.MAX_LINKS, moving=1))  # MAX_LINKS + 1 links with the root
    assert f"{urdf.MAX_LINKS + 1} <link> elements (expected at most {urdf.MAX_LINKS}" in refused(links, capfd)
    dof = tmp_path / "dof.urdf"
    dof.write_text(_chain(urdf.MAX_DOF + 1))
    assert f"{urdf.MAX_DOF + 1} degrees of freedom (expected at most {urdf.MAX_DOF}" in refused(dof, capfd)
    flyer = ET.fromstring(_chain(urdf.MAX_DOF - 5))  # checked only: a Data of nv = 195 takes 0.55 GB
    urdf.validate_urdf(flyer, dof)
    with pytest.raises(ModelError, match=f"{urdf.MAX_DOF + 1} degrees of freedom"):
        urdf.validate_urdf(flyer, dof, free_flyer=True)


def test_size_and_depth_limits_are_refused_in_one_line(tmp_path, capfd):
    big = mutated(tmp_path, "<robot", f"<!-- {'x' * files.MAX_FILE_BYTES} -->\n<robot", "big.urdf")
    assert "the URDF is larger than 8 MiB" in refused(big, capfd)
    nested = "<g>" * files.MAX_XML_DEPTH + "</g>" * files.MAX_XML_DEPTH
    deep = mutated(tmp_path, '<robot name="pendubot">', f'<robot name="pendubot">{nested}', "deep.urdf")
    line = refused(deep, capfd)
    assert f"<g> is nested {files.MAX_XML_DEPTH + 1} elements deep (expected at most {files.MAX_XML_DEPTH}" in line


_XML_PARSER = ET.XMLParser


class _CountingParser:
    """ElementTree's XMLParser, recording the size of each piece it is fed."""

    fed: ClassVar[list[int]] = []

    def __init__(self, **kwargs: object) -> None:
        self._parser = _XML_PARSER(**kwargs)  # type: ignore[arg-type]

    def feed(self, data: bytes) -> None:
        type(self).fed.append(len(data))
        self._parser.feed(data)

    def close(self) -> ET.Element:
        return self._parser.close()


def test_expat_gets_the_file_in_one_piece(tmp_path, monkeypatch):
    """Fed in 64 KiB chunks (ET.parse), expat 2.5 rescans a long comment at each chunk: 4.6 s for 20 MB."""
    path = mutated(tmp_path, "<robot", f"<!-- {'x' * 2**20} -->\n<robot", "comment.urdf")
    monkeypatch.setattr(ET, "XMLParser", _CountingParser)
    _CountingParser.fed = []
    files.read_xml(path, "URDF")
    assert _CountingParser.fed == [path.stat().st_size]
