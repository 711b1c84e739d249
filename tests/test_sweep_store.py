"""The sweep's results folder: a chunk counts as done only when the manifest names it and its file is there."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robodyn.sweep.store import RESULTS, Store


def _write_two(folder: Path) -> Store:
    store = Store(folder, "digest-1", "sweep.toml")
    store.write("0000", {"run": np.arange(3), "x": np.zeros(3)})
    store.write("0001", {"run": np.arange(3, 6), "x": np.ones(3)})
    return store


def test_a_chunk_whose_file_is_missing_is_computed_again(tmp_path: Path) -> None:
    store = _write_two(tmp_path)
    assert store.done("0000") and store.done("0001")
    (tmp_path / RESULTS / "chunk-0001.parquet").unlink()  # lost after the manifest named it
    assert store.done("0000") and not store.done("0001")
    resumed = Store(tmp_path, "digest-1", "sweep.toml")  # a resume reads the manifest afresh
    assert resumed.done("0000") and not resumed.done("0001") and not resumed.done("0002")
    resumed.write("0001", {"run": np.arange(3, 6), "x": np.ones(3)})
    assert resumed.done("0001")
    np.testing.assert_array_equal(resumed.table().column("run").to_numpy(), np.arange(6))
