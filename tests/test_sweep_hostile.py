"""Sweeps against hostile files and failures: simulate's divergence verdict on every path, bounds before any work,
and one line (with a documented exit) for whatever Dask, a worker or a scheduler does."""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import robodyn.errors
import robodyn.sweep as sweep
from robodyn.cli import main
from robodyn.errors import InputError
from robodyn.sweep import chunk as chunk_module
from robodyn.sweep import runs as runs_module
from robodyn.sweep.store import Store

# robodyn simulate pendubot --q0 1.2,0.9 --duration 3 --dt 0.1 exits 3 (issue 28): RK4 at 0.1 s is unstable there.
DIVERGING = {"duration": 3.0, "dt": 0.1, "q0": (1.2, 0.9)}
# The same step from the hanging-down start stays inside simulate's energy bound (exit 0).
STABLE_Q0 = (0.3, 0.9)
UPRIGHT = np.pi / 2


def _simulate_exit(q0: tuple[float, float], controller: str | None, duration: float, dt: float, capsys) -> int:
    argv = ["simulate", "pendubot", f"--q0={q0[0]!r},{q0[1]!r}", "--duration", str(duration), "--dt", str(dt)]
    code = main([*argv, *(["--controller", controller] if controller else [])])
    capsys.readouterr()
    return code


@pytest.mark.parametrize(
    ("controller", "path", "duration", "dt", "starts"),
    [
        (None, "fast", 3.0, 0.1, [DIVERGING["q0"], STABLE_Q0]),
        # Past the energy bound but not yet inf or NaN at the end: only the energy test can tell.
        ("lqr", "closed_loop", 0.6, 0.1, [DIVERGING["q0"], (UPRIGHT, 0.0)]),
        # The swing-up at dt = 0.3 s: from (1.2, 0.9) it diverges, from (2.5, 2.0) it ends without balancing.
        ("swing_up", "closed_loop", 0.9, 0.3, [(2.5, 2.0), DIVERGING["q0"]]),
    ],
)
def test_each_row_has_simulates_verdict_on_every_path(controller, path, duration, dt, starts, tmp_path, capsys):
    spec = {
        "model": "pendubot",
        "duration": duration,
        "dt": dt,
        "measure": ["final_state", "energy_drift"],
        "controller": controller or "none",
        "q0": {"joint1": sorted({s[0] for s in starts}), "joint2": sorted({s[1] for s in starts})},
    }
    prepared = sweep.prepare(spec, tmp_path)
    rows: dict[tuple[float, float], str] = {}
    for c in prepared.plan.chunks:
        assert chunk_module.path_of(c, prepared.job) == path  # the path under test computes it
        columns = chunk_module.execute(c, prepared.job)
        for k in range(c.runs.size):
            rows[(float(c.q0[k, 0]), float(c.q0[k, 1]))] = columns["status"][k]
    verdicts = {"diverged": 0, "ok": 0}
    for q0 in starts:
        code = _simulate_exit(q0, controller, duration, dt, capsys)
        # 6: ran to its end without balancing (a 0.9 s swing-up cannot): not diverged, the row's status is "ok"
        assert code in (0, 3, 6)
        expected = "diverged" if code == 3 else "ok"
        verdicts[expected] += 1
        assert rows[q0] == expected, (q0, rows)
    assert verdicts["diverged"] >= 1  # the test holds a run that simulate calls diverged


def test_a_batch_chunk_that_ends_past_the_energy_bound_is_diverged(tmp_path, monkeypatch):
    """The batch path keeps final states only: its test is the last sample's energy error."""
    spec = {"model": "pendubot", "duration": 0.5, "dt": 0.1, "integrator": "euler", "measure": ["final_state"],
            "q0": {"joint1": [1.2], "joint2": [0.9]}}  # fmt: skip
    prepared = sweep.prepare(spec, tmp_path)
    (c,) = prepared.plan.chunks
    monkeypatch.setattr(runs_module, "fast_of", lambda model: None)  # no compiled form: as a URDF of another lab
    columns = chunk_module._batch(c, prepared.job)
    assert columns[0]["status"] == "diverged"


@pytest.mark.parametrize(
    ("edit", "expected"),
    [
        ({"duration": 1e6, "dt": 1e-3}, r"1e\+09 steps a run; at most 5e\+07 \(as robodyn simulate\)"),
        ({"duration": 0.05, "dt": 0.03}, "not a whole number of steps"),
        ({"duration": 0.01, "dt": 0.03}, "longer than the duration"),
        ({"q0": {"joint1": {"from": 0, "to": 1, "n": 2000}, "joint2": {"from": 0, "to": 1, "n": 1000}}}, "at most 1e"),
        (  # 10^5 runs of 2 * 10^6 steps
            {
                "duration": 2000.0,
                "q0": {"joint1": {"from": 0, "to": 1, "n": 1000}, "joint2": {"from": 0, "to": 1, "n": 100}},
            },
            r"at most 1e\+11 in one sweep",
        ),
        ({"dt": []}, "dt lists no value"),
        ({"integrator": []}, "integrator lists no value"),
        ({"controller": []}, "controller lists no value"),
        # the first value sets' URDFs (and SRDFs) are written, then one is refused: those go again
        ({"params": {"m1": [1.0, 1e-320], "m2": [0.4, 0.5]}}, r"<mass value='1e-320'> is out of range"),
        # the file and key named; a long name by its start and length, not 5,000 characters
        ({"model": "x" * 5000}, r"sweep\.toml: model: unknown model 'x{30}'\.\.\. \(5,000 characters\); "),
    ],
)
def test_a_sweep_past_its_bounds_is_refused_before_anything_is_written(edit, expected, tmp_path, capsys):
    path = tmp_path / "sweep.toml"
    doc = {"model": "pendubot", "duration": 0.1, "dt": 1e-3, **edit}
    path.write_text(_toml(doc))
    code = main(["sweep", str(path), "--out", str(tmp_path / "out"), "--workers", "1"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert __import__("re").search(expected, err), err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("flags", "expected"),
    [
        (["--workers", "100000"], "--workers 100000: at most"),
        (["--scheduler", "tcp://a:b:c"], "not a Dask scheduler address"),
        (["--scheduler", "nope://x"], "not a Dask scheduler address"),
        (["--scheduler", "tcp://127.0.0.1:99999"], "not a Dask scheduler address"),
    ],
)
def test_a_cluster_option_out_of_bounds_is_one_line_before_any_work(flags, expected, tmp_path, capsys):
    path = tmp_path / "sweep.toml"
    path.write_text(_toml({"model": "pendubot", "duration": 0.1}))
    code = main(["sweep", str(path), "--out", str(tmp_path / "out"), *flags])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and expected in err, err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("body", "said"),
    [
        ("raise ValueError('no')", "{m}:boom: raised ValueError: no (line 3)"),
        ("raise KeyboardInterrupt", "{m}:boom: raised KeyboardInterrupt (line 3)"),  # hung past 180 s (issue 39)
        (
            "os._exit(3)",
            "chunk 0 (runs 0-1) ended every worker that ran it (os._exit in a measure or controller "
            "file, a crash, or the memory's end?); no chunk was written, and {out}, made by this "
            "sweep, is removed",
        ),
    ],
    ids=["raises", "keyboard_interrupt", "os_exit"],
)
def test_an_error_in_a_worker_is_robodyns_one_line_and_leaves_no_empty_folder(tmp_path, body, said):
    """A user measure that fails in its worker: robodyn's line alone, none of Dask's log lines around it.

    Nothing was written, so the results folder this sweep made (its manifest, the models of its
    ``[params]``) is removed: no folder that looks like a sweep's results but holds none.
    """
    (tmp_path / "m.py").write_text(f"import os\ndef boom(trajectory):\n    {body}\n")
    path = tmp_path / "sweep.toml"
    path.write_text(_toml({"model": "pendubot", "duration": 0.1, "dt": 0.01, "measure": ["final_state", "m.py:boom"],
                           "q0": {"joint1": [0.1, 0.2]}, "params": {"m1": [1.2, 1.3]}}))  # fmt: skip
    out = tmp_path / "out"
    # Dask retries a task whose worker died on 3 fresh workers (allowed-failures): once is enough to see it
    env = {**os.environ, "DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "0"}
    done = subprocess.run(
        [sys.executable, "-m", "robodyn", "sweep", str(path), "--out", str(out), "--workers", "1", "--quiet"],
        capture_output=True, text=True, timeout=300, env=env, check=False,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    expected = "robodyn sweep: error: " + said.format(m=tmp_path / "m.py", out=out)
    # which of the two chunks meets the dying worker first is the scheduler's choice: the line names that one
    chunk = re.compile(r"chunk \d+ \(runs \d+-\d+\)")
    got = [chunk.sub("chunk N (runs i-j)", line) for line in done.stderr.strip().splitlines()]
    assert got == [chunk.sub("chunk N (runs i-j)", expected)], done.stderr
    assert not out.exists()


def test_killing_the_scheduler_mid_sweep_is_one_line_exit_5_and_keeps_the_chunks(tmp_path):
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    dask = str(Path(sys.executable).with_name("dask"))
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "start_new_session": True}
    scheduler = subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                                 **quiet)  # fmt: skip
    worker = subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--no-dashboard"], **quiet)
    try:
        path = tmp_path / "sweep.toml"  # 400 one-run chunks of 20 s on the simulate path: minutes of work
        path.write_text(_toml({"model": "pendubot", "duration": 20.0, "dt": 1e-3, "integrator": "euler", "chunk": 1,
                               "q0": {"joint1": {"from": 0.1, "to": 0.5, "n": 400}}}))  # fmt: skip
        argv = [sys.executable, "-m", "robodyn", "sweep", str(path), "--out", str(tmp_path / "out"), "--quiet"]
        run = subprocess.Popen([*argv, "--scheduler", address], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)  # fmt: skip
        results = tmp_path / "out" / "results"
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline and not (results.is_dir() and len(list(results.glob("*.parquet"))) >= 2):
            time.sleep(0.5)
        assert run.poll() is None, run.communicate()
        os.kill(scheduler.pid, signal.SIGKILL)
        _, err = run.communicate(timeout=120)
    finally:
        for process in (worker, scheduler):
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    kept = len(json.loads((tmp_path / "out" / "manifest.json").read_text())["chunks"])
    assert run.returncode == 5, err
    assert err.strip().splitlines() == [
        f"robodyn sweep: error: the Dask scheduler went away mid-sweep ({err.split('(')[1].split(')')[0]}); "
        f"{kept} chunks written in {results} are kept; run the same command again to resume from them"
    ], err
    assert kept >= 2


@pytest.mark.parametrize("manifest", ["[]", '{"digest": 3}', '{"digest": "x", "chunks": {"a": {"file": 1}}}', "{"])
def test_a_broken_manifest_is_one_line(manifest, tmp_path):
    (tmp_path / "manifest.json").write_text(manifest)
    with pytest.raises(InputError, match="manifest"):
        Store(tmp_path, "x", "sweep.toml")


def test_a_results_folder_that_is_a_file_is_one_line(tmp_path):
    (tmp_path / "results").write_text("")
    with pytest.raises(InputError, match="cannot be made a results folder"):
        Store(tmp_path, "x", "sweep.toml")


def test_lqr_weights_and_user_measures_past_float64_are_one_line(tmp_path):
    from robodyn.control import lqr

    with pytest.raises(InputError, match="must be numbers"):
        lqr._weight([10**400, 1], 2, "Q", default=np.ones(2))
    from robodyn.sweep import measures

    with pytest.raises(InputError, match="expected a number"):
        measures._user_values(f"{tmp_path}/m.py:big", lambda trajectory: 10**400, None)  # type: ignore[arg-type]


def test_a_swing_up_whose_lqr_bounds_no_region_is_one_line(capsys):
    code = main(["simulate", "pendubot", "--controller", "swing_up", "--gains", '{"Q": 0}', "--duration", "0.1"])
    err = capsys.readouterr().err
    assert code == 2 and "is not positive definite" in err and len(err.strip().splitlines()) == 1, err


def _toml(doc: dict) -> str:
    def value(x) -> str:
        if isinstance(x, dict):
            return "{" + ", ".join(f"{k} = {value(v)}" for k, v in x.items()) + "}"
        return json.dumps(x)

    return "".join(f"{k} = {value(v)}\n" for k, v in doc.items())


def _robodyn(argv: list[str], *, timeout: float) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "robodyn", *argv], capture_output=True, text=True, timeout=timeout)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_an_unknown_parameter_names_the_sweep_file_and_its_table(tmp_path):
    path = tmp_path / "sweep.toml"
    path.write_text(_toml({"model": "pendubot", "duration": 0.1, "params": {"dt": [1.0]}}))
    with pytest.raises(robodyn.errors.UnknownNameError, match=r"sweep.toml: \[params\] unknown pendubot parameter"):
        sweep.prepare(path, tmp_path / "out")


def test_an_unknown_controller_names_the_sweep_file(tmp_path):
    path = tmp_path / "sweep.toml"
    path.write_text(_toml({"model": "pendubot", "duration": 0.1, "controller": "nope"}))
    with pytest.raises(robodyn.errors.UnknownNameError, match=r"sweep.toml: controller unknown controller 'nope'"):
        sweep.prepare(path, tmp_path / "out")
