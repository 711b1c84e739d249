"""The documentation runs: every command and Python snippet of README.md and docs/, as a reader would.

Each page runs in a temporary folder of its own, holding copies of ``examples/``, ``models/`` and
``benchmarks/`` (the paths the pages name; and ``tests/fixtures/``), in page order, so that a file one block writes is there
for the next. What a page shows is what is checked:

* a ``bash`` block: each command (a line, with ``\\`` continuations) must exit 0;
* a ``console`` block: each ``$ `` command must exit 0, and its output (stdout and stderr, as a
  terminal shows them) must match the lines below it, where a line ``...`` stands for any lines and
  ``...`` inside a line for any text;
* a ``python`` block: runs in one namespace per page, in the page's folder; a ``text`` block right
  after a ``python`` or ``bash`` block is its expected output, matched the same way.

An HTML comment right before a block changes how it runs, never what it checks:

* ``<!-- doc-test: exit=1 -->`` (or ``exit=0,1``): the exit codes the block's commands may end with;
* ``<!-- doc-test: replace=OLD => NEW -->``: run the block with OLD replaced by NEW (long runs at a
  reduced size, the install command on the environment already installed);
* ``<!-- doc-test: interrupt-after=TEXT -->``: commands that serve until Ctrl-C get SIGINT once
  their output shows TEXT, and must then exit 0;
* ``<!-- doc-test: not-run: REASON -->``: only for the blocks listed in :data:`NOT_RUN`.

Nothing may write into the checkout: ``git status`` (ignored files included, caches aside) is the
same before and after each page. This is a collector of its own rather than Sybil or
pytest-examples: neither reads shell sessions, Ctrl-C or reduced sizes without a parser of its own.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted(
    [ROOT / "README.md", *(ROOT / "docs").rglob("*.md")],
    key=lambda p: str(p.relative_to(ROOT)),
)
# Saved benchmark output shown by the site, not pages written by hand.
PAGES = [p for p in PAGES if not p.relative_to(ROOT).as_posix().startswith(("docs/figures/", "docs/benchmarks/fuzz/"))]
RUNNABLE = {"bash", "console", "python"}
KNOWN = RUNNABLE | {"text", "toml", "json", "diff"}
# The only blocks shown and not run, each with the reason its page gives.
NOT_RUN = {
    ("README.md", "bash scripts/test.sh"),  # the test run itself
    ("docs/contributing.md", "bash scripts/test.sh --quick\nbash scripts/test.sh"),  # the test runs themselves
    (  # needs the mujoco extra
        "docs/guides/bench.md",
        "python benchmarks/bench_mujoco.py --out bench-out/normal\n"
        "python benchmarks/bench_mujoco.py --busy --out bench-out/busy\n"
        "python benchmarks/bench_mujoco.py --systems pendubot,panda --out bench-out/two",
    ),
}
COPIED = ("examples", "models", "benchmarks", "tests/fixtures")
TIMEOUT = 600  # [s] per command
STOP_TIMEOUT = (
    180  # [s] for a served command to stop after Ctrl-C: 60 s ran out twice at a load average of 24 on 2 cores
)
PAGE_TIMEOUT = 1800  # [s] per page (pytest-timeout): a page runs several commands, a bench or a first numba compile
CACHES = ("__pycache__/", ".pytest_cache/", ".mypy_cache/", ".ruff_cache/", ".hypothesis/", ".venv/")
MARKER = re.compile(r"^<!-- doc-test: (?P<body>.*) -->$")
FENCE = re.compile(r"^```(?P<lang>\S*)\s*$")


@dataclass
class Block:
    """A fenced block of a page, with the markers before it and the output shown after it."""

    page: str
    line: int
    lang: str
    text: str
    markers: list[str] = field(default_factory=list)
    expected: str | None = None

    def where(self) -> str:
        return f"{self.page}:{self.line}"

    def option(self, key: str) -> list[str]:
        """The values of every ``key=value`` marker."""
        return [m.split("=", 1)[1] for m in self.markers if m.startswith(f"{key}=")]

    def not_run(self) -> str | None:
        """The reason given for not running the block, or None."""
        reasons = [m.split(":", 1)[1].strip() for m in self.markers if m.startswith("not-run:")]
        return reasons[0] if reasons else None

    def exits(self) -> set[int]:
        values = self.option("exit")
        return {int(x) for v in values for x in v.split(",")} if values else {0}

    def run_text(self) -> str:
        """The block's text with its ``replace`` markers applied (each must apply)."""
        text = self.text
        for rule in self.option("replace"):
            old, new = (part.strip() for part in rule.split("=>", 1))
            assert old in text, f"{self.where()}: replace marker {old!r} is not in the block"
            text = text.replace(old, new)
        return text


def parse(path: Path) -> list[Block]:
    """The fenced blocks of a page, in order."""
    page = path.relative_to(ROOT).as_posix()
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks: list[Block] = []
    markers: list[str] = []
    since_block = None  # lines since the last block closed, when only blank lines came since
    i = 0
    while i < len(lines):
        line = lines[i]
        fence = FENCE.match(line)
        marker = MARKER.match(line)
        if marker:
            markers.append(marker.group("body").strip())
            since_block = None
        elif fence:
            lang = fence.group("lang")
            start = i
            body = []
            i += 1
            while i < len(lines) and lines[i].rstrip() != "```":
                body.append(lines[i])
                i += 1
            assert i < len(lines), f"{page}:{start + 1}: a fence that is never closed"
            text = "\n".join(body) + "\n"
            previous = blocks[-1] if blocks else None
            if lang == "text" and since_block is not None and previous and previous.lang in ("python", "bash"):
                previous.expected = text
            else:
                blocks.append(Block(page, start + 1, lang, text, markers))
            markers = []
            since_block = 0
        elif line.strip():
            assert not markers, f"{page}:{i + 1}: a doc-test marker must come right before its block"
            since_block = None
        i += 1
    return blocks


def _pattern(expected: str) -> re.Pattern[str]:
    parts = []
    for line in expected.rstrip("\n").splitlines():
        if line.strip() == "...":
            parts.append(r"(?:[^\n]*\n)*?")
        else:
            chunks = [re.escape(c) for c in line.rstrip().split("...")]
            parts.append(r"[^\n]*?".join(chunks) + r"[ \t]*\n")
    return re.compile("".join(parts))


def assert_output(block: Block, command: str, expected: str, actual: str) -> None:
    """``actual`` matches ``expected`` line by line, with ``...`` wildcards."""
    cleaned = "\n".join(line.rstrip() for line in actual.replace("\r", "\n").rstrip().splitlines()) + "\n"
    if not _pattern(expected).fullmatch(cleaned):
        pytest.fail(
            f"{block.where()}: the output of {command!r} differs from the page.\n--- page:\n{expected}"
            f"--- actual:\n{cleaned}",
            pytrace=False,
        )


def environment() -> dict[str, str]:
    """The reader's shell: the test's own Python first on PATH, no display, unbuffered output."""
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env.pop("DISPLAY", None)
    env.pop("WAYLAND_DISPLAY", None)
    env.update(PYTHONUNBUFFERED="1", MPLBACKEND="Agg", BROWSER="true", COLUMNS="120", PYTHONWARNINGS="ignore")
    return env


def commands(block: Block) -> list[tuple[str, str | None]]:
    """(command, expected output or None) of a bash or console block."""
    text = block.run_text()
    out: list[tuple[str, str | None]] = []
    if block.lang == "bash":
        pending = ""
        for line in text.splitlines():
            if not pending and (not line.strip() or line.lstrip().startswith("#")):
                continue
            pending += line.rstrip("\\") + (" " if line.endswith("\\") else "")
            if not line.endswith("\\"):
                out.append((pending.strip(), None))
                pending = ""
        if block.expected is not None:
            assert len(out) == 1, f"{block.where()}: an output block follows a bash block of several commands"
            out[0] = (out[0][0], block.expected)
        return out
    current: list[str] = []
    for line in text.splitlines():
        if line.startswith("$ "):
            if current:
                out.append((current[0], "\n".join(current[1:]) + "\n" if len(current) > 1 else None))
            current = [line[2:]]
        else:
            assert current, f"{block.where()}: console output before any '$ ' command"
            current.append(line)
    if current:
        out.append((current[0], "\n".join(current[1:]) + "\n" if len(current) > 1 else None))
    return out


def run_command(block: Block, command: str, cwd: Path) -> tuple[int, str]:
    """Run one command in bash; Ctrl-C it once its output shows the block's interrupt-after text."""
    interrupt = block.option("interrupt-after")
    if not interrupt:
        done = subprocess.run(
            ["bash", "-o", "pipefail", "-c", command],
            cwd=cwd,
            env=environment(),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            timeout=TIMEOUT,
            check=False,
        )
        return done.returncode, done.stdout
    # bash execs the last command, so the SIGINT reaches robodyn itself.
    process = subprocess.Popen(
        ["bash", "-c", command],
        cwd=cwd,
        env=environment(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    assert process.stdout is not None
    seen: list[str] = []
    deadline = time.monotonic() + 180
    try:
        for line in process.stdout:
            seen.append(line)
            if interrupt[0] in line:
                os.killpg(process.pid, signal.SIGINT)
                break
            if time.monotonic() > deadline:
                break
        else:
            pytest.fail(f"{block.where()}: {command!r} ended without printing {interrupt[0]!r}:\n{''.join(seen)}")
        rest, _ = process.communicate(timeout=STOP_TIMEOUT)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    return process.returncode, "".join(seen) + rest


def run_python(block: Block, namespace: dict[str, object], cwd: Path) -> None:
    """Execute a snippet in the page's namespace, in the page's folder; compare what it prints."""
    code = compile(block.run_text(), block.where(), "exec")
    captured = io.StringIO()
    previous = Path.cwd()
    os.chdir(cwd)
    try:
        with contextlib.redirect_stdout(captured):
            exec(code, namespace)
    finally:
        os.chdir(previous)
    if block.expected is not None:
        assert_output(block, "the Python snippet", block.expected, captured.getvalue())


def checkout_state() -> set[str] | None:
    """``git status`` of the checkout, ignored files included and caches aside (None without git)."""
    try:
        listed = subprocess.run(
            ["git", "status", "--porcelain", "--ignored", "--untracked-files=all"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    if listed.returncode != 0:
        return None
    return {line for line in listed.stdout.splitlines() if not any(cache in line for cache in CACHES)}


def not_ignored(names: list[str]) -> list[str]:
    """Those of ``names`` (files a page wrote, as if at the checkout's root) that .gitignore does not cover."""
    if not names or shutil.which("git") is None:
        return []
    checked = subprocess.run(
        ["git", "check-ignore", "--no-index", "--stdin"],
        cwd=ROOT,
        input="\n".join(names) + "\n",
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    if checked.returncode not in (0, 1):
        return []
    ignored = set(checked.stdout.splitlines())
    return [name for name in names if name not in ignored]


def all_blocks() -> list[Block]:
    return [block for page in PAGES for block in parse(page)]


@pytest.mark.timeout(PAGE_TIMEOUT)
@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(ROOT).as_posix() for p in PAGES])
def test_page_runs_as_written(page: Path, tmp_path: Path) -> None:
    """Every runnable block of the page, in order, in a folder of its own; the checkout stays as it was."""
    for name in COPIED:
        shutil.copytree(ROOT / name, tmp_path / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    copied = {name.split("/")[0] for name in COPIED}
    before = checkout_state()
    namespace: dict[str, object] = {"__name__": "__docs__"}
    ran = 0
    for block in parse(page):
        if block.lang not in RUNNABLE or block.not_run() is not None:
            continue
        ran += 1
        if block.lang == "python":
            run_python(block, namespace, tmp_path)
            continue
        for command, expected in commands(block):
            code, output = run_command(block, command, tmp_path)
            if code not in block.exits():
                pytest.fail(
                    f"{block.where()}: {command!r} exited {code}, expected {sorted(block.exits())}:\n{output}",
                    pytrace=False,
                )
            if expected is not None:
                assert_output(block, command, expected, output)
    after = checkout_state()
    if before is not None:
        assert after == before, f"{page.name} changed the checkout: {sorted(after ^ before)}"
    written = sorted(p.name + ("/" if p.is_dir() else "") for p in tmp_path.iterdir() if p.name not in copied)
    assert not_ignored(written) == [], f"{page.name}: outputs that .gitignore does not cover when run in a checkout"
    if page.name != "index.md" or page.parent.name != "benchmarks":
        assert ran or not any(b.lang in RUNNABLE for b in parse(page))


def test_every_block_names_its_language() -> None:
    """A fence without a language would hide a command from this test; each must name one it knows."""
    unknown = [(b.where(), b.lang) for b in all_blocks() if b.lang not in KNOWN]
    assert not unknown, unknown


def test_only_the_listed_blocks_are_not_run() -> None:
    """Blocks shown but not run are exactly :data:`NOT_RUN`, each with a reason."""
    skipped = {(b.page, b.text.strip()) for b in all_blocks() if b.not_run() is not None}
    assert skipped == NOT_RUN


def test_readme_keeps_the_two_set_up_commands_and_ci_runs_the_test_one() -> None:
    """The README's set-up commands are unchanged, and CI runs exactly its test command."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    main = (
        "python3 -m venv .venv && .venv/bin/pip install . && "
        ".venv/bin/robodyn check geared_arm cart_pole pendubot --formula auto"
    )
    assert f"```bash\n{main}\n```" in readme
    assert "```bash\nbash scripts/test.sh\n```" in readme
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert "\nbash scripts/test.sh\n" in ci


# Words from how the project was made, which mean nothing to a reader.
PROCESS_WORDS = [
    r"\bissues?\b",
    r"\bbriefs?\b",
    r"\bsessions?\b",
    r"\bhouse\b",
    r"shared/seed",
    r"\bseed(?:'s)?\s+(?:example|notes?|kinds?|systems?|formulas?|files?)\b",
    r"\bthe seed's\b",
    r"\bseed's\b",
    r"\bthe seed\b(?!\s+(?:of|is|=))",
    r"listed by the project",
]


def test_no_page_speaks_of_the_making() -> None:
    """README, every page, the generated CLI reference and the model descriptions are free of process words."""
    sys.path.insert(0, str(ROOT / "docs" / "hooks"))
    try:
        import robodyn_docs
    finally:
        sys.path.pop(0)
    texts = {p.relative_to(ROOT).as_posix(): p.read_text(encoding="utf-8") for p in PAGES}
    texts["docs/reference/cli.md (generated)"] = robodyn_docs.cli_reference(None, "reference")
    listed = subprocess.run(
        ["robodyn", "info", "--list"], env=environment(), capture_output=True, text=True, check=True
    )
    texts["robodyn info --list"] = listed.stdout
    found = [
        (name, match.group(0), text[: match.start()].count("\n") + 1)
        for name, text in texts.items()
        for pattern in PROCESS_WORDS
        for match in re.finditer(pattern, text, flags=re.IGNORECASE)
    ]
    assert not found, found


def test_the_output_matcher_can_fail() -> None:
    """``...`` stands for any lines or any text, and nothing else is lenient."""
    block = Block("page.md", 1, "console", "")
    assert_output(block, "c", "a\n...\nd ... f\n", "a\nb\nc\nd e f\n")
    assert_output(block, "c", "a\n...\n", "a\n")
    with pytest.raises(pytest.fail.Exception):
        assert_output(block, "c", "a\nd\n", "a\nb\nd\n")
    with pytest.raises(pytest.fail.Exception):
        assert_output(block, "c", "x = 1\n", "x = 2\n")


def _hook():  # the documentation build's hook module, loaded as MkDocs loads it
    sys.path.insert(0, str(ROOT / "docs" / "hooks"))
    try:
        import robodyn_docs
    finally:
        sys.path.pop(0)
    return robodyn_docs


def test_every_saved_benchmark_json_is_shown_and_renders() -> None:
    """Each JSON under docs/benchmarks/ is asked for by a benchmarks page, and renders with its run's facts."""
    hook = _hook()
    page = "".join(p.read_text(encoding="utf-8") for p in sorted((ROOT / "docs" / "benchmarks").glob("*.md")))
    for path in sorted((ROOT / "docs" / "benchmarks").glob("*.json")):
        marker = f"<!-- generated: bench benchmarks/{path.name} -->"
        assert marker in page, f"{path.name} is saved but no benchmarks page shows it"
        rendered = hook.render_page(marker + "\n", "benchmarks")
        assert rendered.startswith("*Measured"), path.name


def test_mujoco_goals_are_judged_from_the_numbers() -> None:
    """A ratio below its goal reads "not met", one above it "met", computed from the JSON's timings."""
    import json

    hook = _hook()
    data = json.loads((ROOT / "docs" / "benchmarks" / "bench_mujoco.json").read_text(encoding="utf-8"))
    paths = data["systems"]["panda"]["single"]["paths"]
    mine = paths["robodyn_simulate_compiled"]["us_per_step"]
    row = "| Panda single trajectory vs MuJoCo RK4, equal error | off | – | ≥ 2× | {} | {} |"
    paths["mujoco_rk4_c_loop"]["us_per_step"] = 1.5 * mine
    assert row.format("1.5×", "**not met**") in hook._mujoco(data)
    paths["mujoco_rk4_c_loop"]["us_per_step"] = 2.5 * mine
    assert row.format("2.5×", "met") in hook._mujoco(data)
    overhead = data["systems"]["talos"]["single"]
    overhead["simulate_call_over_compiled_loop"] = 1.4
    text = hook._mujoco(data)
    assert (
        "| talos: `robodyn.simulate` with the ledger vs its own compiled loop | off | – | ≤ 1.3× | 1.4× | **not met** |"
        in text
    )
    assert "not met: " in text.splitlines()[-1]


def test_the_readmes_speed_table_is_the_saved_benchmarks() -> None:
    """The README's speed table is what docs/benchmarks/bench_mujoco*.json give, verdicts computed."""
    import json

    hook = _hook()
    match = hook.README_SPEED.search((ROOT / "README.md").read_text(encoding="utf-8"))
    assert match is not None, "README.md has lost its speed-table block"
    assert match.group(2) == hook.readme_speed_block(), (
        "README.md's speed table differs from the saved benchmarks: python docs/hooks/robodyn_docs.py readme-speed"
    )
    data = json.loads((ROOT / "docs" / "benchmarks" / "bench_mujoco.json").read_text(encoding="utf-8"))
    paths = data["systems"]["panda"]["single"]["paths"]
    paths["mujoco_rk4_c_loop"]["us_per_step"] = 1.5 * paths["robodyn_simulate_compiled"]["us_per_step"]
    text = hook.readme_speed(data, data)
    assert (
        "| Panda single trajectory vs MuJoCo RK4, equal error | off | – | ≥ 2× | 1.5× (**not met**) "
        "| 1.5× (**not met**) |" in text
    )
    assert "figures with a target miss it" in text.splitlines()[-1]


def test_the_speed_table_shows_the_stops_on_run_beside_the_stops_off_one() -> None:
    """Each robot's stops-on row: its own timings (not the stops-off ones), robodyn's impacts and MuJoCo's
    limit activations; a file without that run says so rather than borrow a figure."""
    import copy
    import json

    hook = _hook()
    data = json.loads((ROOT / "docs" / "benchmarks" / "bench_mujoco.json").read_text(encoding="utf-8"))
    label = "Panda single trajectory vs MuJoCo RK4 with its limits"
    for system in data["systems"].values():  # a file saved before the stops-on runs were measured
        system.pop("single_stops_on", None)
    without = hook.readme_speed(data, data)
    assert f"| {label} | on | – | ≥ 2× | not measured | not measured |" in without
    panda = data["systems"]["panda"]
    on = copy.deepcopy(panda["single"])  # a stops-on run four times slower than the stops-off one, 0.5× MuJoCo
    on["paths"]["robodyn_simulate_compiled"]["us_per_step"] *= 4.0
    on["paths"]["mujoco_rk4_c_loop"]["us_per_step"] = 2.0 * on["paths"]["robodyn_simulate_compiled"]["us_per_step"]
    on["paths"]["mujoco_rk4_c_loop"]["us_per_step"] /= 4.0
    on |= {"stops": "on", "impacts": 29, "mujoco_limit_activations": 31}
    panda["single_stops_on"] = on
    text = hook.readme_speed(data, data)
    assert f"| {label} | on | 29 / 31 | ≥ 2× | 0.5× (**not met**) | 0.5× (**not met**) |" in text
    assert "| Panda single trajectory vs MuJoCo RK4, equal error | off | – | ≥ 2× |" in text
