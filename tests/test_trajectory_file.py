"""A trajectory file is checked before it is read and played (robodyn.sim.trajectory_file): one line, exit 2."""

from __future__ import annotations

import io
import json
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robodyn.cli import main
from robodyn.cli._output import refuse_clobbering, same_file
from robodyn.errors import InputError
from robodyn.sim.trajectory import Trajectory


@pytest.fixture(scope="module")
def saved(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The arrays of a real saved run (pendubot, 0.2 s from rest at q = (0.3, -0.2)): name -> array."""
    path = tmp_path_factory.mktemp("run") / "t.npz"
    assert main(["simulate", "pendubot", "--q0", "0.3,-0.2", "--duration", "0.2", "--out", str(path)]) == 0
    with np.load(path) as npz:
        return {k: npz[k] for k in npz.files}


def write(tmp_path: Path, arrays: dict[str, Any], **changes: Any) -> Path:
    """``arrays`` with ``changes`` (None removes one) saved as tmp_path/x.npz."""
    merged = {**arrays, **changes}
    path = tmp_path / "x.npz"
    np.savez(path, **{k: v for k, v in merged.items() if v is not None})
    return path


def refusal(path: Path) -> str:
    with pytest.raises(InputError) as caught:
        Trajectory.load(path)
    message = str(caught.value)
    assert "\n" not in message and message.startswith(str(path)), message
    return message


def test_the_saved_run_loads_as_it_was(saved: dict[str, Any], tmp_path: Path) -> None:
    run = Trajectory.load(write(tmp_path, saved))
    np.testing.assert_array_equal(run.q, saved["q"])  # identical arithmetic: the same numbers
    assert run.meta["joint_names"] == ["joint1", "joint2"]


@pytest.mark.parametrize(
    ("name", "shape_of", "message"),
    [
        ("kinetic", lambda x: x[:, None], "array 'kinetic' has shape (201, 1); expected (201,), one per t"),
        ("work_input", lambda x: x[:, None, None], "array 'work_input' has shape (201, 1, 1)"),
        ("q", lambda x: x[0], "array 'q' has shape (2,); expected (201, columns)"),
        ("v", lambda x: np.float64(1.0), "array 'v' has shape (); expected (201, columns)"),
        ("t", lambda x: np.float64(0.0), "array 't' has shape (); expected (n,)"),
        ("tau", lambda x: x[:-1], "array 'tau' has shape (200, 2)"),
        ("a", lambda x: x[:, :1], "array 'a' has 1 columns but 'v' has 2"),
    ],
    ids=["n-by-1-energy", "3-D-work", "q-one-row", "v-scalar", "t-scalar", "tau-short", "a-narrow"],
)
def test_arrays_of_the_wrong_rank_or_length_are_one_line(
    saved: dict[str, Any], tmp_path: Path, name: str, shape_of: Any, message: str
) -> None:
    assert message in refusal(write(tmp_path, saved, **{name: shape_of(saved[name])}))


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (lambda x: x.astype(object), "array 'q' holds Python objects"),
        (lambda x: x * (1 + 1e-3j), "array 'q' holds complex numbers"),
        (lambda x: x.astype(str), "array 'q' holds <U32"),
        (lambda x: x != 0, "array 'q' holds bool"),
    ],
    ids=["object", "complex", "strings", "bool"],
)
def test_arrays_that_are_not_real_numbers_are_refused_by_their_dtype(
    saved: dict[str, Any], tmp_path: Path, value: Any, message: str
) -> None:
    assert message in refusal(write(tmp_path, saved, q=value(saved["q"])))


def test_a_huge_declared_shape_is_refused_before_anything_is_allocated(saved: dict[str, Any], tmp_path: Path) -> None:
    path = tmp_path / "x.npz"
    with zipfile.ZipFile(path, "w") as archive:
        for key, value in saved.items():
            member = io.BytesIO()
            if key == "t":  # 8 TB declared, 64 bytes stored: np.load would try to allocate the 8 TB
                np.lib.format.write_array_header_1_0(
                    member, {"descr": "<f8", "fortran_order": False, "shape": (10**12,)}
                )
                member.write(b"\0" * 64)
            else:
                np.lib.format.write_array(member, value)
            archive.writestr(f"{key}.npy", member.getvalue())
    assert "array 't' declares shape (1000000000000,) of float64 (8,000,000,000,000 bytes) but stores 64" in refusal(
        path
    )


@pytest.mark.parametrize(
    ("t_of", "message"),
    [
        (lambda t: np.zeros_like(t), "'t' repeats at sample 1 (t = 0 s, then 0 s)"),
        (lambda t: np.where(np.arange(len(t)) == 5, t[4], t), "'t' repeats at sample 5"),
        (lambda t: t[::-1].copy(), "'t' goes back at sample 1"),
        (lambda t: np.where(np.arange(len(t)) == 7, np.nan, t), "array 't' is not finite (NaN or infinite) at 1 of"),
    ],
    ids=["constant", "duplicated", "reversed", "nan"],
)
def test_times_must_be_finite_and_strictly_increasing(
    saved: dict[str, Any], tmp_path: Path, t_of: Any, message: str
) -> None:
    assert message in refusal(write(tmp_path, saved, t=t_of(saved["t"])))


@pytest.mark.parametrize("name", ["v", "tau", "kinetic", "work_damping"])
def test_non_finite_samples_are_named(saved: dict[str, Any], tmp_path: Path, name: str) -> None:
    message = refusal(write(tmp_path, saved, **{name: np.full_like(saved[name], np.nan)}))
    assert f"array {name!r} is not finite (NaN or infinite) at 201 of 201 samples (the first: sample 0, t = 0 s)" in (
        message
    )


def test_torques_whose_power_overflows_are_refused(saved: dict[str, Any], tmp_path: Path) -> None:
    # 1e308 is a float, but tau * v is not: the power chart would be NaN, the page blank
    message = refusal(write(tmp_path, saved, tau=np.full_like(saved["tau"], 1e308)))
    assert "the power tau * v overflows float64 at" in message


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("status", "bogus", "metadata 'status' is 'bogus'; expected one of ok, diverged, interrupted"),
        ("meta", [1, 2], "metadata 'meta' is [1, 2]; expected a JSON object"),
        ("evaluations", True, "metadata 'evaluations' is True; expected a whole number >= 0"),
        ("wall_time_s", "fast", "metadata 'wall_time_s' is 'fast'"),
    ],
)
def test_metadata_of_the_wrong_types_is_one_line(
    saved: dict[str, Any], tmp_path: Path, key: str, value: Any, message: str
) -> None:
    info = json.loads(str(saved["metadata"]))
    info[key] = value
    assert message in refusal(write(tmp_path, saved, metadata=np.array(json.dumps(info))))


def test_joint_names_must_be_a_list_of_names(saved: dict[str, Any], tmp_path: Path) -> None:
    info = json.loads(str(saved["metadata"]))
    info["meta"]["joint_names"] = [1, 2]
    assert "meta.joint_names is [1, 2]; expected a list of joint names" in refusal(
        write(tmp_path, saved, metadata=np.array(json.dumps(info)))
    )


def test_view_refuses_in_one_line_and_writes_no_page(
    saved: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write(tmp_path, saved, v=np.full_like(saved["v"], np.nan))
    html = tmp_path / "v.html"
    assert main(["view", "pendubot", str(path), "--html", str(html)]) == 2
    captured = capsys.readouterr()
    assert len(captured.err.splitlines()) == 1 and "array 'v' is not finite" in captured.err
    assert "wrote" not in captured.out and not html.exists()


def test_view_checks_the_columns_against_the_model(
    saved: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    grown = {k: np.concatenate([saved[k], saved[k][:, :1]], axis=1) for k in ("q", "v", "a", "tau")}
    path = write(tmp_path, saved, **grown)
    assert main(["view", "pendubot", str(path), "--html", str(tmp_path / "v.html")]) == 2
    assert "q has 3 and v 3 columns but model 'pendubot' has nq = 2, nv = 2" in capsys.readouterr().err


def test_a_link_loop_is_no_file_to_clobber(tmp_path: Path) -> None:
    # Path.resolve raises RuntimeError on a link loop (before Python 3.13): it was a traceback of view --html
    loop = tmp_path / "loop.html"
    os.symlink(loop, loop)
    assert not same_file(loop, tmp_path / "t.npz")
    refuse_clobbering([("--html", loop)], [("a trajectory", tmp_path / "t.npz")])
