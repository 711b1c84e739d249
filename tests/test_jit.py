"""How the kernels are compiled and cached (engine/jit.py), and ``robodyn warmup`` (sim/warmup.py, cli/warmup.py).

The subprocess tests run a copy of the package (or the package itself) with an empty
``NUMBA_CACHE_DIR`` of their own, so that what they see does not depend on an earlier compile.
"""

from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from robodyn.cli import _numeric_warnings, main
from robodyn.engine import jit
from robodyn.errors import CompileNotice

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "robodyn"
# A one-joint tree's energies from the compiled kinematics, which inlines tree.body.body (another
# file). Mass 2 kg at 0.5 m above the joint under g = 9.81 m/s^2: the potential is 9.81 J.
KINEMATICS = """
import numpy as np
from robodyn.sim import tree
from robodyn.engine import jit
from robodyn.engine.tree import algorithms as k
from robodyn.engine.tree.layout import F_LEVER, F_MASS, WCOLS
one = tree.one_joint()
itree, ftree, grav = one.itree, one.ftree, one.grav
ftree[0, F_MASS] = 2.0
ftree[0, F_LEVER + 2] = 0.5
cached = jit.is_cached(k.kinematics)
kin, pot = k.kinematics(itree, ftree, grav, None, np.zeros(1), np.ones(1), np.zeros((1, WCOLS)))
print(jit.current_key(), cached, repr(pot))
"""
POTENTIAL = 2.0 * 9.81 * 0.5  # [J], as computed in float64 by the kernel: m g h with these numbers
NOTICE = "compiling the closed-form kernels of the built-in kinds for this machine"


def _run(code: str, src: Path, cache: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(src), "NUMBA_CACHE_DIR": str(cache)}
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=False)


def _copy_package(tmp_path: Path) -> Path:
    copy = tmp_path / "src"
    shutil.copytree(PACKAGE, copy / "robodyn", ignore=shutil.ignore_patterns("__pycache__"))
    return copy


def test_the_key_changes_with_the_version_and_with_any_kernel_source(tmp_path: Path) -> None:
    root = _copy_package(tmp_path) / "robodyn"
    key = jit.cache_key("1.0", root)
    assert jit.cache_key("1.0", root) == key
    assert jit.cache_key("1.1", root) != key
    for name in jit.KERNEL_SOURCES:
        path = root / name
        text = path.read_text()
        path.write_text(text + "\n# edited\n")
        assert jit.cache_key("1.0", root) != key, name
        path.write_text(text)
    (root / "cli" / "info.py").write_text("# not a kernel's source\n")
    assert jit.cache_key("1.0", root) == key


def test_every_file_that_declares_or_feeds_a_kernel_is_hashed() -> None:
    hashed = {PACKAGE / name for name in jit.KERNEL_SOURCES}
    for path in PACKAGE.rglob("*.py"):
        text = path.read_text()
        assert "cache=True" not in text or path.name == "jit.py", f"{path}: declare kernels with jit.njit"
        if "jit.njit(" in text:
            assert path in hashed, f"{path} declares kernels but is not in jit.KERNEL_SOURCES"
            # the robodyn modules it imports from the kernels' folders hold callees or constants
            for node in ast.walk(ast.parse(text)):
                if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("robodyn.engine."):
                    assert (
                        PACKAGE.parent / (node.module.replace(".", "/") + ".py") in hashed
                        or node.module == "robodyn.engine.jit"
                    ), node.module
    for kind in ("pendubot", "cart_pole", "geared_arm", "formula"):  # the closed forms engine/closed_form.py compiles
        assert PACKAGE / "kinds" / f"{kind}.py" in hashed


@pytest.mark.timeout(900)
def test_a_changed_callee_reaches_its_callers_cached_code(tmp_path: Path) -> None:
    src, cache = _copy_package(tmp_path), tmp_path / "cache"
    first = _run(KINEMATICS, src, cache)
    assert first.returncode == 0, first.stderr
    key, cached, pot = first.stdout.split()
    assert (cached, float(pot)) == ("False", POTENTIAL)
    again = _run(KINEMATICS, src, cache)
    assert again.stdout.split() == [key, "True", pot]  # the same sources: loaded from the cache
    body = src / "robodyn" / "engine" / "tree" / "body.py"  # the callee, inlined into algorithms.kinematics
    text = body.read_text()
    assert text.count("m = ftree[i, F_MASS]") == 1
    body.write_text(text.replace("m = ftree[i, F_MASS]", "m = 2.0 * ftree[i, F_MASS]"))
    (old,) = cache.rglob(jit.PREFIX + "*")
    os.utime(old, (old.stat().st_atime, old.stat().st_mtime - 2 * jit.IN_USE_S))  # last used long ago
    edited = _run(KINEMATICS, src, cache)
    assert edited.returncode == 0, edited.stderr
    new_key, cached, pot = edited.stdout.split()
    assert float(pot) == 2.0 * POTENTIAL  # the caller runs the edited callee
    assert new_key != key and cached == "False"
    assert [p.name for p in cache.rglob(jit.PREFIX + "*")] == [jit.PREFIX + new_key]  # the old key's code is gone


@pytest.mark.timeout(900)
def test_a_first_compile_says_so_on_stderr_and_a_cached_run_does_not(tmp_path: Path) -> None:
    # closed_form.py's kernels are closures: numba would key them on their pickled cells, drawn anew per process
    code = "from robodyn.sim import fast; print(sum(fast.warm_up()['run'].stats.cache_hits.values()))"
    first = _run(code, SRC, tmp_path / "cache")
    assert first.returncode == 0 and first.stdout == "0\n", first.stderr
    notes = [line for line in first.stderr.splitlines() if "CompileNotice" in line]
    assert len(notes) == 1 and NOTICE in notes[0] and "robodyn warmup" in notes[0], first.stderr
    second = _run(code, SRC, tmp_path / "cache")
    assert second.returncode == 0 and "CompileNotice" not in second.stderr, second.stderr
    assert second.stdout == "1\n"  # loaded from the cache, not compiled again


@pytest.mark.filterwarnings("default::robodyn.errors.CompileNotice")
def test_the_command_line_shows_a_compile_notice_as_one_note_line(capsys: pytest.CaptureFixture[str]) -> None:
    with _numeric_warnings("simulate"):
        warnings.warn("compiling the kernels", CompileNotice, stacklevel=1)
    assert capsys.readouterr().err == "robodyn simulate: note: compiling the kernels\n"


def test_announce_says_each_thing_once() -> None:
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        jit.announce("the test kernels", "no time")
        jit.announce("the test kernels", "no time")
    assert [str(w.message) for w in seen] == [
        f"compiling the test kernels for this machine (no time, {jit.WARMUP_HINT})"
    ]


def test_a_long_compile_says_it_is_still_compiling() -> None:
    """A note every ``every`` s while numba compiles (however long), none once it has stopped."""
    import time

    compiling = jit.QUIET_S + 2.0  # [s] longer than the quiet spell that ends the watch
    watch = jit.CompileWatch("the test kernels", every=0.3)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        watch.start()
        jit._COMPILES.begin()  # as numba's compile event would
        time.sleep(compiling)
        jit._COMPILES.end()
        time.sleep(jit.QUIET_S + 1.0)  # the watch has ended: no more notes
        count = len(seen)
        time.sleep(0.7)
    notes = [str(w.message) for w in seen]
    assert len(seen) == count, notes
    said = [
        int(m.group(1)) for n in notes if (m := re.fullmatch(r"still compiling the test kernels: (\d+) s so far", n))
    ]
    assert len(said) == len(notes) and max(said) >= compiling, notes  # through the whole compile


def test_the_notes_come_out_while_numba_records_warnings() -> None:
    """numba compiles inside catch_warnings(record=True): a note warned then would wait for the compile's end."""
    import time

    printed: list[str] = []

    def show(
        message: object, category: object, filename: str, lineno: int, file: object = None, line: object = None
    ) -> None:
        printed.append(str(message))  # as the command line's hook prints a note line

    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = show
        watch = jit.CompileWatch("the test kernels", every=0.3)
        watch.start()
        jit._COMPILES.begin()
        with warnings.catch_warnings(record=True):  # what numba does around a compile
            time.sleep(1.2)
            during = list(printed)
        jit._COMPILES.end()
    assert during and during[0].startswith("still compiling the test kernels: "), during


def test_ignored_notes_stay_ignored() -> None:
    """PYTHONWARNINGS=ignore (or a filter on CompileNotice) silences the watch's notes as it does the first."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert jit._notice_printer("the test kernels") is None
        warnings.simplefilter("always", CompileNotice)
        assert jit._notice_printer("the test kernels") is not None


def test_the_compile_watch_hears_numba_compile() -> None:
    import numba

    jit.CompileWatch("the test kernels", every=60.0).start()
    started = jit._COMPILES.started
    numba.njit(lambda x: x + 1)(1)  # a fresh function: compiled now
    assert jit._COMPILES.started > started and not jit.compiling()


def test_no_note_once_the_compile_is_over() -> None:
    """A watch whose compile has ended (or never began) says nothing more, even before it ends itself."""
    import time

    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        jit.CompileWatch("the test kernels", every=0.2).start()
        time.sleep(1.0)  # no compile under way: no note
    assert seen == []


@pytest.mark.timeout(900)
def test_warmup_fills_the_cache_and_says_how_long(tmp_path: Path) -> None:
    code = "import sys; from robodyn.cli import main; sys.exit(main(['warmup', '--only', 'closed-forms']))"
    done = _run(code, SRC, tmp_path / "cache")
    assert done.returncode == 0, done.stderr
    out = done.stdout.splitlines()
    assert re.fullmatch(r"closed-forms: .* \.\.\. \d+\.\d s", out[0]), out
    assert re.fullmatch(r"warmup: 1 group compiled or loaded in \d+\.\d s", out[1]), out
    assert "note:" not in done.stderr  # its own lines say it
    # the closed-form run kernel is in the cache of this key: a later run loads it
    assert list((tmp_path / "cache").rglob(f"{jit.PREFIX}*/closed_form.kernels.locals.run-*.nbi")), done.stdout


def test_warmup_refuses_an_unknown_group_in_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["warmup", "--only", "closed-forms,tres"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "unknown kernel group 'tres'" in err[0] and "tree" in err[0]


def test_a_forked_child_counts_its_own_compiles() -> None:
    """A fork while the count's lock is held (by a watch thread) must not leave the child's compiles blocked."""
    with jit._COMPILES.lock:
        pid = os.fork()
        if pid == 0:  # the child: its first compile event takes the lock
            got = jit._COMPILES.lock.acquire(timeout=2.0)
            os._exit(0 if got and not jit.compiling() and jit._COMPILES.latest is None else 1)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0


def test_a_module_filter_on_the_first_notice_takes_the_notes_too(monkeypatch: pytest.MonkeyPatch) -> None:
    """The notes follow the first notice: a filter on the module it was warned from silences them as well."""
    with warnings.catch_warnings():
        warnings.simplefilter("always", CompileNotice)  # shown, as on a terminal, but...
        warnings.filterwarnings("ignore", category=CompileNotice, module="a_users_module")  # ...from there
        assert jit._notice_printer("the test kernels", "a_users_module") is None
        assert jit._notice_printer("the test kernels", "another_module") is not None
    watches: list[str] = []

    class Recorder:
        def __init__(self, what: str, *, module: str) -> None:
            watches.append(module)

        def start(self) -> None:
            pass

    monkeypatch.setattr(jit, "CompileWatch", Recorder)

    def kernels_loader() -> None:  # as robodyn.sim.tree's loaders call announce
        jit.announce("the module test's kernels", "about 0 s")

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        kernels_loader()  # the notice is warned from here (stacklevel 3): this test's module
    assert watches == [__name__]
