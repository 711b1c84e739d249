"""Fuzz families of the side files a user hands robodyn: scene files, sweep files, parameter files, constraint JSON.

Registered by ``benchmarks/fuzz.py`` (``families(fuzz)``). Every case starts from a file shipped under
``examples/`` (each scene with the files of its folder, each sweep with the scene it names, the parameters
``robodyn params`` prints, the constraint tables of the shipped scenes as ``--constraints`` JSON) and applies up
to three hostile edits: a value replaced by a hostile one (400-digit integers, 1e308, NaN, wrong types, empty
lists, names with NUL bytes, missing files), a key or a table removed, an unknown key added, or the file made a
FIFO, a folder or a link to ``/dev/zero``. Runs are shortened to at most :data:`MAX_DURATION` seconds and grids
to a few points first, so that a case takes about a second.

Sweep cases run against one Dask scheduler and worker started for the campaign (``--scheduler``), a few with
``--workers`` (hostile values, refused before a cluster starts, or one worker). Their oracle compares every row's
``status`` with what :func:`robodyn.simulate` says of the same run (the sweep's ``simulate`` path, run by run in
the case's process): a diverged run labelled ``ok`` is silently wrong. A scene's oracle: an exit 1 must be a
finite mismatch, never a NaN reported as one.
"""

from __future__ import annotations

import atexit
import copy
import json
import math
import os
import re
import shutil
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
# Every shipped run is cut to this many seconds [s] (and each axis of a sweep to 2 points): one case, a second or so.
MAX_DURATION = 0.1
MAX_POINTS = 2

HOSTILE: list[Any] = [
    10**400, -(10**400), 2**63, 2**64, -(2**63) - 1, 1e308, -1e308, 1e-320, 0, -1, 0.0, -0.0, 1e9, 1.5,
    float("nan"), float("inf"), float("-inf"), True, "abc", "", "a\u0000b", "x" * 5000, [], [[]], {}, [1e308],
    [float("nan"), 0.0], {"nope": 1}, "nope.py", "nope.toml", "../../../etc/passwd", "/dev/zero",
]  # fmt: skip
SPECIAL = ["fifo", "folder", "dev-zero link", "empty", "not UTF-8", "not TOML", "huge"]


def toml_value(value: Any) -> str:
    """``value`` as a TOML value (nan and inf as TOML writes them; tables inline)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{json.dumps(str(k))} = {toml_value(v)}" for k, v in value.items()) + "}"


def toml_bytes(doc: dict[str, Any]) -> bytes:
    """TOML text of ``doc``: top-level values first, then each table (its tables inline)."""
    lines = [f"{json.dumps(k)} = {toml_value(v)}" for k, v in doc.items() if not isinstance(v, dict)]
    for table, body in doc.items():
        if isinstance(body, dict):
            lines.append(f"[{json.dumps(table)}]")
            lines += [f"{json.dumps(str(k))} = {toml_value(v)}" for k, v in body.items()]
    return ("\n".join(lines) + "\n").encode()


def _paths(doc: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every key path of a nested document (dicts and lists), leaves and containers alike."""
    out = []
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else []
    for key, value in items:
        out.append((*prefix, key))
        out += _paths(value, (*prefix, key))
    return out


def _set(doc: Any, path: tuple[Any, ...], value: Any) -> None:
    for key in path[:-1]:
        doc = doc[key]
    doc[path[-1]] = value


def _delete(doc: Any, path: tuple[Any, ...]) -> None:
    for key in path[:-1]:
        doc = doc[key]
    del doc[path[-1]]


# Keys whose values a valid edit leaves alone: a sweep's duration must stay a whole number of its steps.
KEPT = ("dt", "duration", "n", "chunk", "seed", "samples", "repeat", "port")


def valid_edit(doc: dict[str, Any], pick: Any) -> tuple[dict[str, Any], list[str]]:
    """``doc`` (a deep copy) as it is, or with numbers moved by up to 10 % or its tables in another order."""
    doc = json.loads(json.dumps(doc, allow_nan=True))
    op = pick.integer(0, 2)
    if op == 0:
        return doc, ["valid: as shipped"]
    if op == 1:
        leaves = [p for p in _paths(doc) if not isinstance(p[-1], int) or len(p) > 1]
        numbers = [p for p in leaves if p[-1] not in KEPT and _is_float(doc, p)]
        if numbers:
            path = pick.choice(numbers)
            target = doc
            for key in path:
                target = target[key]
            _set(doc, path, float(target) * pick.real(0.9, 1.1))
            return doc, [f"valid: {'.'.join(str(k) for k in path)} moved"]
    return dict(reversed(list(doc.items()))), ["valid: tables reordered"]


def _is_float(doc: Any, path: tuple[Any, ...]) -> bool:
    for key in path:
        doc = doc[key]
    return isinstance(doc, float)


def edit(doc: dict[str, Any], pick: Any, extra_keys: list[str]) -> tuple[dict[str, Any], list[str]]:
    """``doc`` (a deep copy) with 1 to 3 hostile edits (or, 1 in 4, a valid one), and what each was."""
    if pick.integer(0, 3) == 0:
        return valid_edit(doc, pick)
    doc = json.loads(json.dumps(doc, allow_nan=True))
    done = []
    for _ in range(pick.integer(1, 3)):
        paths = _paths(doc)
        op = pick.integer(0, 9)
        if not paths or op == 0:
            table = pick.choice([k for k, v in doc.items() if isinstance(v, dict)] or [None])
            key = pick.choice([*extra_keys, "nope"])
            (doc[table] if table is not None else doc)[key] = pick.choice([*HOSTILE[:20], "x"])
            done.append(f"added {key}")
            continue
        path = pick.choice(paths)
        where = ".".join(str(p) for p in path)
        if op == 1:
            _delete(doc, path)
            done.append(f"removed {where}")
        elif op == 2:  # a list emptied, or a value listed
            target = doc
            for key in path:
                target = target[key]
            _set(doc, path, [] if isinstance(target, list) else [target, target])
            done.append(f"listed {where}")
        else:
            _set(doc, path, copy.deepcopy(pick.choice(HOSTILE)))  # a copy: later edits must not reach the list
            done.append(f"{where} hostile")
    return doc, done


def _shorten(doc: dict[str, Any]) -> dict[str, Any]:
    """A shipped scene or sweep cut to :data:`MAX_DURATION` and grids of :data:`MAX_POINTS` points."""
    doc = json.loads(json.dumps(doc))
    for table in (doc, doc.get("simulate", {})):
        if isinstance(table.get("duration"), (int, float)):
            dt = table.get("dt", 1e-3)
            dts = dt if isinstance(dt, list) else [dt]
            step = max(float(x) for x in dts)
            table["duration"] = max(step, round(MAX_DURATION / step) * step)
    for axis in ("q0", "v0", "params"):
        for name, value in doc.get(axis, {}).items():
            if isinstance(value, dict) and "n" in value:
                value["n"] = min(int(value["n"]), MAX_POINTS)
            elif isinstance(value, list):
                doc[axis][name] = value[:MAX_POINTS]
    if "chunk" in doc:
        doc["chunk"] = min(int(doc["chunk"]), 4)
    return doc


def _toml(path: Path) -> dict[str, Any]:
    import tomllib

    return tomllib.loads(path.read_text(encoding="utf-8"))


def scene_bases() -> list[tuple[str, dict[str, Any], dict[str, bytes]]]:
    """(name, the scene shortened, the other files of its folder) of every shipped scene."""
    out = []
    for scene in sorted([*EXAMPLES.glob("*.toml"), *EXAMPLES.glob("textbook/*/*.toml")]):
        files = {p.name: p.read_bytes() for p in scene.parent.iterdir() if p.is_file() and p.suffix != ".toml"}
        if scene.parent == EXAMPLES:
            files = {}
        out.append((scene.stem, _shorten(_toml(scene)), files))
    return out


def sweep_bases() -> list[tuple[str, dict[str, Any], dict[str, bytes]]]:
    """(name, the sweep shortened, the files it names, as placed beside it) of every shipped sweep, and the
    Pendubot run that ``robodyn simulate`` calls diverged (issue 28) as a sweep."""
    out = []
    for sweep in sorted(EXAMPLES.glob("sweeps/*.toml")):
        doc = _shorten(_toml(sweep))
        files: dict[str, bytes] = {}
        if "scene" in doc:
            scene = (sweep.parent / doc["scene"]).resolve()
            files["scene.toml"] = toml_bytes(_shorten(_toml(scene)))
            doc["scene"] = "scene.toml"
        out.append((sweep.stem, doc, files))
    diverging = {"model": "pendubot", "duration": 3.0, "dt": 0.1, "measure": ["final_state", "energy_drift"],
                 "q0": {"joint1": [1.2, 0.3], "joint2": 0.9}}  # fmt: skip
    out.append(("pendubot_diverging", diverging, {}))
    out.append(("pendubot_diverging_lqr", {**diverging, "controller": "lqr"}, {}))
    return out


def constraint_bases() -> list[tuple[str, dict[str, Any], dict[str, bytes]]]:
    """(name, {"constraints": .., "springs": ..}, the model's files) from every shipped scene with such tables."""
    out = []
    for scene in sorted(EXAMPLES.glob("textbook/*/*.toml")):
        doc = _toml(scene)
        if ("constraints" not in doc and "springs" not in doc) or "urdf" not in doc.get("model", {}):
            continue
        tables = {k: doc[k] for k in ("constraints", "springs") if k in doc}
        files = {"model.urdf": (scene.parent / doc["model"]["urdf"]).read_bytes()}
        out.append((scene.stem, tables, files))
    return out


def params_printed() -> dict[str, Any]:
    """What ``robodyn params pendubot`` prints (the file ``check --params`` reads back)."""
    import contextlib
    import io

    from robodyn.cli import main

    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        main(["params", "pendubot"])
    return dict(json.loads(text.getvalue()))


def _family(special: str, done: list[str]) -> str:
    return "special" if special else "valid" if done[0].startswith("valid") else "edited"


def _special(name: str, kind: str) -> Callable[[Path], None]:
    """Make ``name`` in the case's folder a FIFO, a folder or a link to /dev/zero (before the child starts)."""

    def setup(work: Path) -> None:
        target = work / name
        if target.exists() or target.is_symlink():
            target.unlink()
        if kind == "fifo":
            os.mkfifo(target)
        elif kind == "folder":
            target.mkdir()
        else:
            target.symlink_to("/dev/zero")

    return setup


def _unreadable(kind: str, text: bytes) -> bytes:
    return {
        "empty": b"",
        "not UTF-8": text[:40] + b"\xff\xfe" + text[40:],
        "not TOML": text.replace(b"=", b"", 1),
        "huge": b"# " + b"x" * (2**20 + 10) + b"\n" + text,
    }[kind]


class Families:
    """The four families, made from the shipped examples once, and the Dask scheduler the sweep cases share."""

    def __init__(self, fuzz: ModuleType) -> None:
        self.fuzz = fuzz
        self.scenes = scene_bases()
        self.sweeps = sweep_bases()
        self.constraints = constraint_bases()
        self._scheduler: str | None = None
        self.shipped_params = params_printed()

    # ------------------------------------------------------------------ shared
    def _case(self, index: int, family: str, label: str, command: str, files: dict[str, bytes], argv: list[str],
              **extra: Any) -> Any:  # fmt: skip
        return self.fuzz.Case(index, family, label.split(":")[0], label, command, files, argv, False, **extra)

    def _file(self, pick: Any, name: str, text: bytes) -> tuple[bytes, Callable[[Path], None] | None, str]:
        """(bytes, setup, label) of the file under test: its text, or one of the :data:`SPECIAL` forms (1 in 8)."""
        if pick.integer(0, 7):
            return text, None, ""
        kind = pick.choice(SPECIAL)
        if kind in ("fifo", "folder", "dev-zero link"):
            return text, _special(name, kind), kind
        return _unreadable(kind, text), None, kind

    # ------------------------------------------------------------------ scenes
    def scene(self, index: int, pick: Any, inputs: Any) -> Any:
        name, doc, files = pick.choice(self.scenes)
        doc, done = edit(doc, pick, ["torque", "duration", "closed_form", "loops", "q", "nope"])
        data, setup, special = self._file(pick, "scene.toml", toml_bytes(doc))
        label = f"{_family(special, done)}: {name}: {special or ', '.join(done)}"
        argv = ["run", "scene.toml", "--no-view", "--out", "out"]
        return self._case(index, "scene file", label, "run", {**files, "scene.toml": data}, argv, setup=setup,
                          oracle=_scene_oracle)  # fmt: skip

    # ------------------------------------------------------------------ sweeps
    def sweep(self, index: int, pick: Any, inputs: Any) -> Any:
        name, doc, files = pick.choice(self.sweeps)
        doc, done = edit(doc, pick, ["dt", "integrator", "controller", "measure", "chunk", "duration", "nope"])
        data, setup, special = self._file(pick, "sweep.toml", toml_bytes(doc))
        label = f"{_family(special, done)}: {name}: {special or ', '.join(done)}"
        argv = ["sweep", "sweep.toml", "--out", "out", "--quiet"]
        if pick.integer(0, 19) == 0:
            argv += ["--workers", pick.choice(["100000", "0", "-1", "1", "abc", "1e3"])]
        else:
            argv += ["--scheduler", self.scheduler()]
        if pick.integer(0, 29) == 0:
            argv[-1] = pick.choice(["tcp://a:b:c", "nope://x", "tcp://127.0.0.1:99999", "", "x" * 300])
        return self._case(index, "sweep file", label, "sweep", {**files, "sweep.toml": data}, argv, setup=setup,
                          oracle=_sweep_oracle)  # fmt: skip

    def scheduler(self) -> str:
        """The address of the campaign's Dask scheduler (two single-threaded workers), started on first use."""
        if self._scheduler is None:
            self._scheduler = start_cluster()
        return self._scheduler

    # ------------------------------------------------------------------ parameters
    def params(self, index: int, pick: Any, inputs: Any) -> Any:
        shipped = self.shipped_params
        doc: dict[str, Any] = shipped if pick.integer(0, 1) else dict(shipped["params"])
        doc, done = edit(doc, pick, ["m1", "params", "nope"])
        text = json.dumps(doc, allow_nan=True).encode()
        data, setup, special = self._file(pick, "p.json", text)
        label = f"{_family(special, done)}: params: {special or ', '.join(done)}"
        argv = ["check", "pendubot", "--formula", "pendubot", "--params", "p.json", "--samples", "2"]
        return self._case(index, "params file", label, "check", {"p.json": data}, argv, setup=setup)

    # ------------------------------------------------------------------ constraints
    def constraints_file(self, index: int, pick: Any, inputs: Any) -> Any:
        name, doc, files = pick.choice(self.constraints)
        doc, done = edit(doc, pick, ["loops", "couplings", "limits", "springs", "nope"])
        if pick.integer(0, 1) and "constraints" in doc and isinstance(doc["constraints"], dict):
            doc = {**doc["constraints"], **({"springs": doc["springs"]} if "springs" in doc else {})}  # flat form
        text = json.dumps(doc, allow_nan=True).encode()
        data, setup, special = self._file(pick, "c.json", text)
        label = f"{_family(special, done)}: {name}: {special or ', '.join(done)}"
        argv = ["simulate", "model.urdf", "--constraints", "c.json", "--duration", "0.05", "--out", "t.npz"]
        return self._case(index, "constraints file", label, "simulate", {**files, "c.json": data}, argv,
                          setup=setup)  # fmt: skip


def _scene_oracle(code: int) -> list[str]:
    """An exit 1 is a finite mismatch: a NaN or inf reported as a failed check is an overflow that says otherwise."""
    out = Path("../stdout.txt").read_text(errors="replace") if Path("../stdout.txt").exists() else ""
    failed = [line for line in out.splitlines() if "FAIL" in line]
    if code == 1 and any(re.search(r"\b(nan|inf)\b", line) for line in failed):
        return [f"a non-finite value reported as a check failure: {failed[0][:160]}"]
    return []


def _sweep_oracle(code: int) -> list[str]:
    """Every row's status is what ``robodyn.simulate`` says of the same run (its sweep path, run by run)."""
    if code != 0:
        return []
    import pyarrow.parquet as pq

    import robodyn.sweep as sweep
    from robodyn.scene import read_scene
    from robodyn.sweep import runs as runs_module

    table = pq.read_table("out/results").to_pydict()
    status = dict(zip(table["run"], table["status"], strict=True))
    prepared = sweep.prepare("sweep.toml", "oracle-out", read_scene=read_scene)
    wrong = []
    for c in prepared.plan.chunks:
        for k in range(c.runs.size):
            alone = runs_module.one_run(c, prepared.job, k, "simulate")["status"]
            run = int(c.runs[k])
            if status.get(run) != alone:
                wrong.append(f"run {run}: status {status.get(run)!r} in the sweep, {alone!r} from simulate")
    shutil.rmtree("oracle-out", ignore_errors=True)
    return wrong[:3]


def start_cluster() -> str:
    """Start ``dask scheduler`` and two single-threaded workers as processes of their own; the scheduler's address.

    They are stopped when the campaign ends. Processes, not threads of the campaign: it forks its cases.
    """
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    dask = str(Path(sys.executable).with_name("dask"))
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "start_new_session": True}
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    scheduler = subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                                 env=env, **quiet)  # type: ignore[call-overload]  # fmt: skip
    time.sleep(3)
    worker = subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--nworkers", "2", "--no-dashboard"],
                              env=env, **quiet)  # type: ignore[call-overload]  # fmt: skip
    time.sleep(5)
    for process in (worker, scheduler):
        atexit.register(_stop, process)
    return address


def _stop(process: subprocess.Popen[bytes]) -> None:
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()


def families(fuzz: ModuleType) -> list[Any]:
    """The families of this module, as ``fuzz.Family`` entries."""
    made = Families(fuzz)
    return [
        fuzz.Family("scene file", 4, made.scene),
        fuzz.Family("sweep file", 3, made.sweep),
        fuzz.Family("params file", 2, made.params),
        fuzz.Family("constraints file", 2, made.constraints_file),
    ]
