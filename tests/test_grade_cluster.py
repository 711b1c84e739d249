"""robodyn grade --scheduler: a class graded on a real Dask cluster, interrupted, and resumed without regrading.

The cluster is a LocalCluster of one worker process on this machine; ``--scheduler`` reaches it by address,
as a teacher's larger cluster would be reached. Its scheduler runs in this process, so the test reads there
which submissions the cluster itself graded.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from robodyn.cli import main
from robodyn.errors import RobodynError
from robodyn.grade import load_assignment
from robodyn.grade.grading import SubmissionResult
from robodyn.grade.outputs import TASK_PREFIX, Submission, find_submissions, grade_class

distributed = pytest.importorskip("distributed", reason="--scheduler needs Dask (the sweep extra)")

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples/grading/double_pendulum"


@pytest.fixture(scope="module")
def cluster() -> Iterator[object]:
    """One single-threaded worker process on localhost; the scheduler in this process."""
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address="127.0.0.1:0"
    ) as c:
        yield c


def _graded_by(cluster: object) -> int:
    """How many grading tasks the cluster's scheduler has seen finish (reach its workers' memory)."""
    prefix = cluster.scheduler.task_prefixes.get(TASK_PREFIX)  # type: ignore[attr-defined]
    return 0 if prefix is None else int(prefix.state_counts["memory"])


class Stop(KeyboardInterrupt):
    """The teacher's Ctrl-C, after the first submission graded."""


def test_interrupted_on_the_cluster_then_resumed_through_it(
    cluster: object, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assignment = load_assignment(EXAMPLE / "assignment.toml")
    subs = find_submissions(EXAMPLE / "submissions", assignment)
    out = tmp_path / "out"
    address = cluster.scheduler_address  # type: ignore[attr-defined]

    def stop_after_first(result: SubmissionResult, resumed: bool) -> None:
        raise Stop

    with pytest.raises(Stop):
        grade_class(assignment, subs, out, scheduler=address, on_result=stop_after_first)
    saved = sorted(p.stem for p in (out / "results").glob("*.json"))
    assert len(saved) == 1  # the one it finished is kept
    before = _graded_by(cluster)
    assert before >= 1  # the cluster graded it, not this process

    capsys.readouterr()
    args = ["grade", str(EXAMPLE / "assignment.toml"), str(EXAMPLE / "submissions"), "--out", str(out)]
    assert main([*args, "--scheduler", address]) == 0
    lines = capsys.readouterr().out.splitlines()
    resumed = [line.split(":")[0] for line in lines if "(graded before: resumed)" in line]
    assert resumed == saved  # not graded again
    assert _graded_by(cluster) - before == len(subs) - 1  # the others, each once, on the cluster
    local = tmp_path / "local"
    assert main([*args[:-1], str(local)]) == 0  # the same class graded here, in this process
    for s in subs:
        on_cluster = json.loads((out / "results" / f"{s.student}.json").read_text())
        here = json.loads((local / "results" / f"{s.student}.json").read_text())
        assert (on_cluster["score"], on_cluster["feedback"]) == (here["score"], here["feedback"]), s.student


def test_a_file_the_workers_cannot_read_is_one_line(cluster: object, tmp_path: Path) -> None:
    assignment = load_assignment(EXAMPLE / "assignment.toml")
    ghost = Submission("ghost", tmp_path / "ghost.py", "ghost.py")  # not on the workers' disk (nor on this one)
    address = cluster.scheduler_address  # type: ignore[attr-defined]
    with pytest.raises(RobodynError, match=r"^ghost.py: a worker of the cluster cannot read .*ghost.py: the workers"):
        grade_class(assignment, [ghost], tmp_path / "out", scheduler=address)


def test_scheduler_refusals_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["grade", str(EXAMPLE / "assignment.toml"), str(EXAMPLE / "submissions"), "--out", str(tmp_path)]
    assert main([*args, "--scheduler", "localhost"]) == 2
    assert "not a Dask scheduler address" in capsys.readouterr().err
    assert main([*args, "--scheduler", "tcp://127.0.0.1:8786", "--jobs", "2"]) == 2
    assert "--jobs and --scheduler: give one" in capsys.readouterr().err
    assert not (tmp_path / "results").exists()
