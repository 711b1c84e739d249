"""robodyn sweep: chunks on a real 2-worker LocalCluster equal the runs one by one; workers die, sweeps resume."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import distributed
import numpy as np
import pytest

import robodyn
import robodyn.sweep as sweep
from robodyn.cli import main
from robodyn.sweep import chunk as chunk_module
from robodyn.sweep.plan import Chunk

from ._dask_helpers import two_workers

# The chunk path and the one-by-one path do the same arithmetic on each run's row: exact.
EXACT = 0.0
# The compiled closed form against Pinocchio's ABA, same RK4 steps: round-off over 2,000 steps.
FAST_VS_ABA_ATOL = 1e-9
# Columns that are not a run's numbers (its clock) and so are left out of the bit comparison.
NOT_NUMBERS = {"wall_time"}

PENDUBOT_UP = np.pi / 2
# A scene (examples/pendubot.toml): the Pendubot's shoulder locked, 2 s at 1 ms.
SCENE = Path(__file__).resolve().parents[1] / "examples" / "pendubot.toml"

LQR_SWEEP = {
    "model": "pendubot",
    "duration": 0.5,
    "dt": 1e-3,
    "controller": "lqr",
    "measure": ["final_state", "time_to_balance", "energy_drift", "wall_time"],
    "chunk": 7,
    "q0": {"joint1": {"from": PENDUBOT_UP - 0.1, "to": PENDUBOT_UP + 0.1, "n": 5}, "joint2": [-0.05, 0.0, 0.05]},
}
# The Pendubot's swing-up handing over to LQR: outside the region (hanging-ish) and inside it (near upright).
SWING_UP_SWEEP = {
    "model": "pendubot",
    "duration": 0.4,
    "dt": 1e-3,
    "controller": "swing_up",
    "measure": ["final_state", "time_to_balance", "energy_drift"],
    "chunk": 4,
    "q0": {"joint1": [-PENDUBOT_UP, -1.0, PENDUBOT_UP - 0.02, PENDUBOT_UP], "joint2": [0.0, 0.01, 0.3]},
}
CHAOS_SWEEP = {
    "model": "pendubot",
    "duration": 0.3,
    "dt": 1e-3,
    "measure": ["final_state", "lyapunov", "energy_drift"],
    "chunk": 3,
    "seed": 7,
    "q0": {"joint1": [-1.0, 0.0, 1.0, 2.0], "joint2": [0.5, 1.5]},
}


@pytest.fixture(scope="module")
def client():
    with two_workers() as c:
        yield c


def one_by_one(spec, out: Path, **options) -> dict[str, list]:
    """The oracle: every run of the plan alone (a chunk of one), in this process, in run order."""
    prepared = sweep.prepare(spec, out, **options)
    rows: dict[str, list] = {}
    for c in prepared.plan.chunks:
        for k in range(c.runs.size):
            single = Chunk(c.id, c.index, c.setting, c.model, c.runs[k : k + 1], c.q0[k : k + 1], c.v0[k : k + 1])
            for name, values in chunk_module.execute(single, prepared.job).items():
                rows.setdefault(name, []).extend(list(values))
    return rows


def assert_same(table, rows: dict[str, list]) -> None:
    got = table.to_pydict()
    assert set(got) == set(rows)
    for name in got:
        if name in NOT_NUMBERS:
            continue
        a, b = got[name], rows[name]
        if isinstance(a[0], str):
            assert a == b, name
        else:
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b), err_msg=name)


@pytest.mark.parametrize(
    "spec", [LQR_SWEEP, SWING_UP_SWEEP, CHAOS_SWEEP], ids=["lqr-closed-loop", "swing-up-closed-loop", "fast-lyapunov"]
)
def test_sweep_is_bit_identical_to_one_by_one(spec, client, tmp_path):
    result = sweep.run(spec, out=tmp_path / "dask", client=client)
    table = result.table()
    expected = "fast" if spec is CHAOS_SWEEP else "closed_loop"
    assert set(table.column("path").to_pylist()) == {expected}
    assert table.num_rows == result.plan.n_runs
    assert table.column("run").to_pylist() == list(range(result.plan.n_runs))
    assert result.computed == len(result.plan.chunks) > 2
    assert_same(table, one_by_one(spec, tmp_path / "serial"))


def test_lqr_sweep_balances_near_upright_and_fast_path_matches_aba(client, tmp_path):
    table = sweep.run(LQR_SWEEP, out=tmp_path, client=client).table().to_pydict()
    assert set(table["path"]) == {"closed_loop"}
    start = next(
        i
        for i, (a, b) in enumerate(zip(table["q0.joint1"], table["q0.joint2"], strict=True))
        if abs(a - PENDUBOT_UP) < 1e-12 and b == 0
    )
    assert table["time_to_balance"][start] == 0.0  # starts upright and stays
    chaos = sweep.run(CHAOS_SWEEP, out=tmp_path / "c", client=client).table().to_pydict()
    robot = robodyn.load("pendubot")
    for k in (0, 5):
        q0 = [chaos["q0.joint1"][k], chaos["q0.joint2"][k]]
        ref = robodyn.simulate(robot, q0, [0, 0], duration=0.3, dt=1e-3, integrator="rk4")
        got = [chaos["q.joint1"][k], chaos["q.joint2"][k]]
        np.testing.assert_allclose(got, ref.q[-1], rtol=0, atol=FAST_VS_ABA_ATOL)


def test_killing_a_worker_mid_sweep_loses_nothing(tmp_path):
    spec = {**CHAOS_SWEEP, "duration": 1.0, "chunk": 1}
    killed: list[int] = []
    with two_workers() as c:
        before = c.run(os.getpid)

        def kill_one(_chunk) -> None:
            if not killed:
                pid = sorted(before.values())[0]
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)

        result = sweep.run(spec, out=tmp_path / "dask", client=c, on_chunk=kill_one)
        c.wait_for_workers(2, timeout=30)
        after = set(c.run(os.getpid).values())
    assert killed and killed[0] not in after  # a worker really died (its nanny started a new one)
    assert result.computed == len(result.plan.chunks)
    assert_same(result.table(), one_by_one(spec, tmp_path / "serial"))


def test_resumed_sweep_recomputes_nothing(client, tmp_path):
    out = tmp_path / "out"
    seen: list[str] = []

    def stop_after_two(c) -> None:
        seen.append(c.id)
        if len(seen) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sweep.run(CHAOS_SWEEP, out=out, client=client, on_chunk=stop_after_two)
    manifest = json.loads((out / "manifest.json").read_text())
    assert set(manifest["chunks"]) == set(seen)
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "results").glob("*.parquet")}
    assert len(stamps) == 2

    again: list[str] = []
    resumed = sweep.run(CHAOS_SWEEP, out=out, client=client, on_chunk=lambda c: again.append(c.id))
    assert resumed.skipped == 2 and not set(again) & set(seen)
    assert len(again) == resumed.computed == len(resumed.plan.chunks) - 2
    assert {p.name: p.stat().st_mtime_ns for p in (out / "results").glob("*.parquet") if p.name in stamps} == stamps

    third: list[str] = []
    done = sweep.run(CHAOS_SWEEP, out=out, client=client, on_chunk=lambda c: third.append(c.id))
    assert done.computed == 0 and third == []
    assert_same(done.table(), one_by_one(CHAOS_SWEEP, tmp_path / "serial"))


def test_results_folder_of_another_sweep_is_refused(client, tmp_path):
    sweep.run(CHAOS_SWEEP, out=tmp_path, client=client)
    with pytest.raises(robodyn.errors.InputError, match="another sweep"):
        sweep.run({**CHAOS_SWEEP, "duration": 0.2}, out=tmp_path, client=client)


@pytest.mark.parametrize(
    ("edit", "expected"),
    [
        (
            {"q0": {"joint3": [0.0, 1.0]}},
            r"bad.toml: unknown joint in \[q0\] 'joint3'; did you mean 'joint2' or 'joint1'",
        ),
        ({"measure": ["lyapunof"]}, "bad.toml: unknown measure 'lyapunof'; did you mean 'lyapunov'"),
        ({"integrator": "rk5"}, "unknown integrator 'rk5'; did you mean"),
        ({"axes": 1}, "bad.toml: unknown key 'axes'"),
        ({"controller": "lqrr"}, "unknown controller 'lqrr'; did you mean 'lqr'"),
        ({"q0": {"joint1": {"from": 0, "to": 1}}}, r"q0.joint1: a grid is \{ from = A, to = B, n = N \}"),
        ({"params": {"m3": [1.0]}}, "unknown pendubot parameter 'm3'; did you mean"),
    ],
)
def test_bad_sweep_file_is_one_line_exit_2(edit, expected, tmp_path, capsys):
    import re

    spec = {**CHAOS_SWEEP, **edit}
    path = tmp_path / "bad.toml"
    path.write_text(_toml(spec))
    out = tmp_path / "out"
    code = main(["sweep", str(path), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("robodyn sweep: error: ")
    assert re.search(expected, err), err
    assert not out.exists()


def test_plots_write_maps_with_their_numbers(client, tmp_path):
    from robodyn.sweep import plots

    result = sweep.run(CHAOS_SWEEP, out=tmp_path, client=client)
    written = plots.draw(result.table(), result.plan.axes, tmp_path / "plots")
    names = {p.name for p in written}
    assert {"map-lyapunov.png", "map-lyapunov.csv"} <= names
    lines = (tmp_path / "plots" / "map-lyapunov.csv").read_text().splitlines()
    xs = [float(x) for x in lines[0].split(",")[1:]]
    assert xs == [0.5, 1.5]  # joint2 across, joint1 down
    table = result.table().to_pydict()
    grid = np.array([[float(x) for x in line.split(",")[1:]] for line in lines[1:]])
    np.testing.assert_array_equal(grid.reshape(-1), np.asarray(table["lyapunov"]))


def test_existing_cluster_recipe_scheduler_and_two_workers(tmp_path):
    """The README recipe: `dask scheduler` + 2 `dask worker`s as processes on 127.0.0.1, then --scheduler."""
    bin_dir = Path(sys.executable).parent
    info = tmp_path / "scheduler.json"
    procs = [
        subprocess.Popen(
            [
                str(bin_dir / "dask"),
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
                "--scheduler-file",
                str(info),
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    try:
        deadline = time.monotonic() + 30
        while not info.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        address = json.loads(info.read_text())["address"]
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [
                        str(bin_dir / "dask"),
                        "worker",
                        address,
                        "--host",
                        "127.0.0.1",
                        "--nthreads",
                        "1",
                        "--no-dashboard",
                    ],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )
            )
        with distributed.Client(address, timeout=30) as c:
            c.wait_for_workers(2, timeout=30)
        path = tmp_path / "chaos.toml"
        path.write_text(_toml(CHAOS_SWEEP))
        run = subprocess.run(
            [str(bin_dir / "robodyn"), "sweep", str(path), "--out", str(tmp_path / "out"), "--scheduler", address],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert run.returncode == 0, run.stderr
        assert "8 runs in 3 chunks (3 computed, 0 already written)" in run.stdout
        # A sweep over a scene: the scene travels to the separate workers inside each chunk.
        scene_sweep = tmp_path / "scene_sweep.toml"
        scene_sweep.write_text(f"scene = {json.dumps(str(SCENE))}\nchunk = 2\n[v0]\njoint2 = [0.0, 0.5, 1.0]\n")
        command = [str(bin_dir / "robodyn"), "sweep", str(scene_sweep), "--out", str(tmp_path / "scene")]
        run = subprocess.run(
            [*command, "--scheduler", address, "--quiet"],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert run.returncode == 0, run.stderr
        assert "3 runs in 2 chunks (2 computed, 0 already written)" in run.stdout
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            p.wait(timeout=30)
    import pyarrow.parquet as pq

    table = pq.read_table(tmp_path / "out" / "results").sort_by("run")
    assert_same(table, one_by_one(CHAOS_SWEEP, tmp_path / "serial"))
    from robodyn.scene import read_scene

    scene_table = pq.read_table(tmp_path / "scene" / "results").sort_by("run")
    expected = one_by_one(scene_sweep, tmp_path / "scene-serial", read_scene=read_scene)
    assert_same(scene_table, expected)
    assert expected["q0.joint2"] == [1.0, 1.0, 1.0]  # the scene's initial state, its shoulder locked


def _toml(spec: dict) -> str:
    def value(x) -> str:
        if isinstance(x, dict):
            return "{ " + ", ".join(f"{k} = {value(v)}" for k, v in x.items()) + " }"
        if isinstance(x, list):
            return "[" + ", ".join(value(v) for v in x) + "]"
        if isinstance(x, str):
            return json.dumps(x)
        return repr(x)

    top = [f"{k} = {value(v)}" for k, v in spec.items() if not (isinstance(v, dict) and k in ("q0", "v0", "params"))]
    tables = [
        f"[{k}]\n" + "\n".join(f"{j} = {value(v)}" for j, v in t.items())
        for k, t in spec.items()
        if k in ("q0", "v0", "params") and isinstance(t, dict)
    ]
    return "\n".join(top) + "\n\n" + "\n\n".join(tables) + "\n"
