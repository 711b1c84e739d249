"""Properties of robodyn under hostile input, drawn by Hypothesis: no crash, no lost file, no silently wrong robot.

The inputs are the fuzz campaign's (``benchmarks/fuzz.py``, loaded here from the source tree):
URDFs mutated from the Pendubot and the cart-pole (numbers and vectors in every form urdfdom and
robodyn might read differently, the tree's structure, inertia tensors, the XML layer, and rewrites
that keep the file valid), command lines for simulate, info, check, view and run built from each
parser's own flags, and TOML scenes. Hypothesis makes every draw through the campaign's
``Chooser``, so a failure shrinks to a small mutation. Every run is in process (``main([...])``,
file descriptors captured by ``capfd``) in a fresh folder. The invariants:

* the exit is 0 or 2 (1 only from ``check``, with a mismatch in its table; 3 only from a run);
* a refusal (exit 2) is exactly one stderr line, with no traceback, that names one of its inputs
  (the file, the flag or the value), and leaves every file of the folder as it was (hashed);
* a URDF that loads (``robodyn.load``, or a command that exits 0 on it) is the robot of the file,
  as :func:`fuzz.model_differences` reads it independently (lxml and a strict number grammar,
  each Pinocchio body's mass, first moment and inertia in the world frame at q = 0).

Deterministic: ``derandomize=True`` and no example database, so CI runs the same examples every
time; the examples per test are sized to keep the file under a minute on two cores.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import sys
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, TypeVar

import pinocchio as pin
import pytest
from hypothesis import HealthCheck, given, note, settings
from hypothesis import strategies as st

import robodyn
from robodyn.cli import main
from robodyn.errors import RobodynError

ROOT = Path(__file__).resolve().parents[1]
_SPEC = importlib.util.spec_from_file_location("robodyn_fuzz", ROOT / "benchmarks" / "fuzz.py")
assert _SPEC is not None and _SPEC.loader is not None
fuzz: Any = importlib.util.module_from_spec(_SPEC)
sys.modules["robodyn_fuzz"] = fuzz  # dataclasses look their module up
_SPEC.loader.exec_module(fuzz)

T = TypeVar("T")
BASES = {name: (ROOT / "models" / f"{name}.urdf").read_text(encoding="utf-8") for name in ("pendubot", "cart_pole")}


def examples(n: int) -> settings:
    """Hypothesis settings: ``n`` examples, the same ones every run, no deadline (a shared machine)."""
    return settings(
        max_examples=n,
        derandomize=True,
        database=None,
        deadline=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.data_too_large],
    )


class Draw:
    """The campaign's ``Chooser`` over Hypothesis's ``data.draw`` (so failures shrink)."""

    def __init__(self, data: st.DataObject) -> None:
        self.data = data

    def choice(self, options: Sequence[T]) -> T:
        return self.data.draw(st.sampled_from(list(options)))

    def integer(self, low: int, high: int) -> int:
        return self.data.draw(st.integers(low, high))

    def real(self, low: float, high: float) -> float:
        return self.data.draw(st.floats(low, high, allow_nan=False))


@contextlib.contextmanager
def folder(files: dict[str, bytes]) -> Iterator[Path]:
    """A fresh working folder holding ``files``, made the current directory for the block."""
    with tempfile.TemporaryDirectory(prefix="robodyn-prop-") as name:
        path = Path(name)
        for relative, data in files.items():
            (path / relative).parent.mkdir(parents=True, exist_ok=True)
            (path / relative).write_bytes(data)
        with contextlib.chdir(path):
            yield path


def run(argv: list[str], capfd: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """``main(argv)`` in process: (exit code, stdout, stderr), argparse's SystemExit included."""
    capfd.readouterr()
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 2
    out, err = capfd.readouterr()
    return code, out, err


def assert_invariants(
    command: str, argv: list[str], where: Path, before: dict[str, str], result: tuple[int, str, str]
) -> None:
    """Exit codes, one line per refusal naming its input, no traceback, no file changed by a refusal."""
    files = fuzz.given_names({name: (where / name).read_bytes() for name in before if before[name] != "folder"})
    code, out, err = result
    assert "Traceback" not in err, err
    assert code in fuzz.ALLOWED_EXITS[command], (argv, code, err)
    lines = fuzz.refusal_lines(err)  # an explicit --no-physics-check's own warning is not part of a refusal
    if code in (2, 3):
        assert len(lines) == 1, (argv, err)
        assert lines[0].startswith("robodyn "), (argv, err)
    if code == 2:
        assert fuzz.names_an_input(lines[0], argv, files), (argv, lines[0])
        assert fuzz.snapshot(where) == before, (argv, lines[0])
    if code == 1:
        assert "FAIL" in out, (argv, out)


def assert_loads_as_written(path: Path, **options: bool) -> None:
    """``path`` loads (robodyn.load, physics unchecked) as the robot the file describes."""
    robot = robodyn.load(path, check_physics=False, **options)
    assert fuzz.model_differences(robot.model, path) == []


def check_urdf(data: bytes, command: str, capfd: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """robodyn.load and ``robodyn <command>`` on a URDF: the invariants; returns the command's (exit, stderr)."""
    with folder({"model.urdf": data}) as where:
        path = where / "model.urdf"
        capfd.readouterr()
        try:
            robot = robodyn.load(path)
        except RobodynError as exc:
            assert "\n" not in str(exc) and str(exc).startswith(f"{path}: "), str(exc)
        else:
            assert fuzz.model_differences(robot.model, path) == []
        assert capfd.readouterr().err == ""  # urdfdom's own lines never reach the terminal
        argv = [command, "model.urdf", *(["--samples", "2"] if command == "check" else [])]
        before = fuzz.snapshot(where)
        code, out, err = run(argv, capfd)
        assert_invariants(command, argv, where, before, (code, out, err))
        if code == 0:
            assert_loads_as_written(path)
        return code, err


def urdf_property(mutation: Callable[[str, Draw], tuple[str, str | bytes]], n: int) -> Callable[..., None]:
    """A Hypothesis test of ``n`` examples: ``mutation`` of a base model through the API and info or check."""

    @examples(n)
    @given(data=st.data())
    def prop(data: st.DataObject, capfd: pytest.CaptureFixture[str]) -> None:
        draw = Draw(data)
        text = BASES[draw.choice(sorted(BASES))]
        label, mutated = mutation(text, draw)
        note(label)
        check_urdf(
            mutated if isinstance(mutated, bytes) else mutated.encode("utf-8"), draw.choice(["info", "check"]), capfd
        )

    return prop


# --------------------------------------------------------------------------- URDF mutations, one test per kind


@pytest.mark.parametrize("form", fuzz.NUMBER_FORMS, ids=[f[0] for f in fuzz.NUMBER_FORMS])
def test_a_number_in_any_form_loads_as_written_or_is_refused_in_one_line(form, capfd):
    urdf_property(lambda text, draw: fuzz.mutate_number(text, draw, [form]), 5)(capfd=capfd)


@pytest.mark.parametrize("form", fuzz.SEPARATOR_FORMS, ids=[f[0] for f in fuzz.SEPARATOR_FORMS])
def test_a_vector_with_any_separator_loads_as_written_or_is_refused_in_one_line(form, capfd):
    def mutation(text: str, draw: Draw) -> tuple[str, str]:
        m = fuzz._attribute(text, draw, vector=True)
        return form[0], fuzz._replaced(text, m, form[1](fuzz._pieces(m)))

    urdf_property(mutation, 5)(capfd=capfd)


@pytest.mark.parametrize("op", sorted(set(fuzz.STRUCTURE_OPS)))
def test_a_changed_tree_loads_as_written_or_is_refused_in_one_line(op, capfd):
    urdf_property(lambda text, draw: fuzz.mutate_structure(text, draw, op=op), 6)(capfd=capfd)


@pytest.mark.parametrize("moments", fuzz.PRINCIPAL_MOMENTS, ids=[m[0] for m in fuzz.PRINCIPAL_MOMENTS])
def test_a_rotated_inertia_loads_as_written_or_is_refused_in_one_line(moments, capfd):
    urdf_property(lambda text, draw: fuzz.mutate_inertia(text, draw, moments=moments), 6)(capfd=capfd)


@pytest.mark.parametrize("op", fuzz.XML_OPS)
def test_any_xml_loads_as_written_or_is_refused_in_one_line(op, capfd):
    urdf_property(lambda text, draw: fuzz.mutate_xml(text, draw, op=op), 5)(capfd=capfd)


@examples(100)
@given(data=st.data())
def test_a_valid_rewrite_loads_as_written(data, capfd):
    draw = Draw(data)
    text = BASES[draw.choice(sorted(BASES))]
    label, mutated = fuzz.mutate_valid(text, draw)
    note(label)
    code, err = check_urdf(mutated if isinstance(mutated, bytes) else mutated.encode("utf-8"), "info", capfd)
    # a number scaled x2 may break an inertia's triangle inequality: refused, and only for that
    assert code == 0 or "physically impossible" in err or "is out of range" in err, (label, err)


# --------------------------------------------------------------------------- command lines and scenes


class Files(dict[str, bytes]):
    """File name -> content, shown by its names only (Hypothesis prints the arguments of a failing example)."""

    def __repr__(self) -> str:
        return f"Files({', '.join(self)})"


@pytest.fixture(scope="module")
def fixtures(tmp_path_factory: pytest.TempPathFactory) -> Files:
    """The files a command line finds in its folder: model.urdf, t.npz (good, bad, shadowed), params files."""
    with contextlib.redirect_stdout(io.StringIO()):
        return Files(fuzz.fixtures(tmp_path_factory.mktemp("fixtures")))


@pytest.fixture(scope="module")
def options() -> dict[str, list[tuple[str, Any]]]:
    return {command: fuzz._options(command) for command in ("simulate", "info", "check", "view")}


def check_command(argv: list[str], command: str, files: dict[str, bytes], capfd: pytest.CaptureFixture[str]) -> None:
    with folder(files) as where:
        before = fuzz.snapshot(where)
        code, out, err = run(argv, capfd)
        assert_invariants(command, argv, where, before, (code, out, err))
        if code == 0 and argv[1:2] == ["model.urdf"] and not {"--lock", "--keep"} & set(argv):
            assert_loads_as_written(where / "model.urdf", free_flyer="--free-flyer" in argv, mimic="--mimic" in argv)


@examples(200)
@given(data=st.data())
def test_any_command_line_exits_0_or_refuses_in_one_line(data, fixtures, options, capfd):
    draw = Draw(data)
    command, argv = fuzz.command_line(draw, options)
    files = dict(fixtures)
    if command == "run":
        files["scene.toml"] = fuzz.scene_text(draw)[1]
    check_command(argv, command, files, capfd)


@examples(120)
@given(data=st.data())
def test_any_scene_runs_or_is_refused_in_one_line(data, fixtures, capfd):
    draw = Draw(data)
    label, text = fuzz.scene_text(draw)
    note(label)
    argv = ["run", "scene.toml", "--no-view", *draw.choice([[], ["--out", "out"], ["--out", "model.urdf"]])]
    check_command(argv, "run", {**fixtures, "scene.toml": text}, capfd)


PARAMS = ["p.json", "deep.json", "zero.json", "bad.json", "model.urdf", "t.npz"]
FILE_RUNS = [
    *(["check", "pendubot", "--formula", "pendubot", "--samples", "2", "--params", name] for name in PARAMS),
    *(["check", "pendubot", "--samples", "2", "--srdf", name] for name in ("x.srdf", "deep.json", "model.urdf")),
    *(["view", "pendubot", name, "--html", "v.html"] for name in ("t.npz", "bad.npz", "shadow.npz", "deep.json")),
    *(["simulate", name, "--duration", "0.05"] for name in ("model.urdf", "deep.json", "t.npz", "x.srdf")),
    *(["run", f"scene:{label}", "--no-view"] for label, _ in fuzz.UNREADABLE_SCENES),
    *(["run", f"scene:{k}", "--no-view"] for k in range(len(fuzz.VALID_SCENES))),
]


@pytest.mark.parametrize("template", FILE_RUNS, ids=[" ".join(t[:1] + t[-3:]) for t in FILE_RUNS])
def test_every_kind_of_hostile_file_through_its_flag(template, fixtures, options, capfd):
    """Each hostile file (params, SRDF, trajectory, model, scene) where a command takes it, with drawn extra flags."""
    files = dict(fixtures)
    argv = list(template)
    if argv[0] == "run":
        key = argv[1].removeprefix("scene:")
        unreadable = dict(fuzz.UNREADABLE_SCENES)
        scene = unreadable[key] if key in unreadable else fuzz.scene_bytes(fuzz.VALID_SCENES[int(key)])
        files["scene.toml"], argv[1] = scene, "scene.toml"

    @examples(4)
    @given(data=st.data())
    def prop(data: st.DataObject) -> None:
        draw = Draw(data)
        extra: list[str] = []
        if argv[0] != "run":
            usable = [(f, a) for f, a in options[argv[0]] if f not in fuzz.FORBIDDEN_FLAGS and f not in argv]
            for _ in range(draw.integer(0, 2)):
                flag, action = draw.choice(usable)
                values = list(action.choices or []) + fuzz.FLAG_VALUES.get(flag, [])
                extra += [flag] if action.nargs == 0 else [flag, draw.choice(values or fuzz.HOSTILE_VALUES)]
        check_command([*argv, *extra], argv[0], files, capfd)

    prop()


# --------------------------------------------------------------------------- the oracle can fail


def test_the_independent_reading_agrees_with_every_built_in_model(tmp_path):
    for stem in fuzz.BUILTIN_FILES:
        for free_flyer in (False, True):
            assert_loads_as_written(ROOT / "models" / f"{stem}.urdf", free_flyer=free_flyer)


@pytest.mark.parametrize(
    ("old", "new", "found"),
    [
        ('<mass value="1.336"/>', '<mass value=" 1.336 "/>', "mass 0.0 in the model, 1.336 in the file"),
        ('<mass value="1.336"/>', '<mass value="1.3361"/>', "mass 1.3361 in the model, 1.336 in the file"),
        ('<origin xyz="0.10 0 0" rpy="0 0 0"/>', '<origin xyz="0.10 0 1e-6" rpy="0 0 0"/>', "first moment"),
        ('izz="6.0e-3"', 'izz="6.1e-3"', "inertia differs"),
        ('name="joint2"', 'name="joint3"', "joints: model has ['joint2', 'joint3'] differently"),
    ],
)
def test_the_independent_reading_sees_a_model_that_is_not_its_file(old, new, found):
    # urdfdom's own reading of a changed text, compared with the Pendubot file: the check must see it
    text = BASES["pendubot"]
    assert old in text
    with fuzz_quiet():
        model = pin.buildModelFromXML(text.replace(old, new, 1))
    differences = fuzz.model_differences(model, ROOT / "models" / "pendubot.urdf")
    assert any(found in d for d in differences), differences


def test_the_independent_reading_refuses_what_urdfdom_would_read_otherwise(tmp_path):
    text = BASES["pendubot"].replace('<mass value="1.336"/>', '<mass value="&m;"/>', 1)
    path = tmp_path / "dtd.urdf"
    path.write_text(text.replace("<robot ", '<!DOCTYPE robot [<!ENTITY m "1.336">]>\n<robot ', 1))
    with fuzz_quiet():
        model = pin.buildModelFromXML(BASES["pendubot"])
    assert fuzz.model_differences(model, path) == [
        "accepted a file that an independent reading refuses: the file declares a DTD: urdfdom expands no "
        "entity, so it reads other numbers"
    ]


@contextlib.contextmanager
def fuzz_quiet() -> Iterator[None]:
    """Keep urdfdom's console lines (printed on file descriptor 2) out of the test's output."""
    from robodyn.model.load import native_stderr

    with native_stderr():
        yield
