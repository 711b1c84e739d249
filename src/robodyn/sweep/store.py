"""Where a sweep's results land: one Parquet file per chunk in ``DIR/results/`` and a manifest of them.

Each finished chunk is written atomically as ``results/chunk-<id>.parquet`` (pyarrow), and then
recorded in ``manifest.json`` (also rewritten atomically), so the manifest never names a file
that is not whole. A chunk counts as done when the manifest names it *and* its file is there;
resuming skips exactly those. The folder is one Parquet dataset: :meth:`Store.table` reads it
back in run order. The manifest also holds the sweep's digest: a folder written by another
sweep (other model, duration, measures or files) is refused rather than mixed.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import IO, Any

from robodyn.errors import InputError
from robodyn.fileio import write_atomically, write_text_atomically

MANIFEST = "manifest.json"
RESULTS = "results"


def _read_manifest(path: Path) -> dict[str, Any]:
    """The manifest: {"digest": str, "chunks": {id: {"file": NAME.parquet, "runs": n}}}, or one line saying why not."""
    fix = "remove the folder or choose another --out"
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError) as exc:
        raise InputError(f"{path}: unreadable sweep manifest ({type(exc).__name__}); {fix}") from None
    chunks = manifest.get("chunks", {}) if isinstance(manifest, dict) else None
    entries_ok = isinstance(chunks, dict) and all(
        isinstance(k, str)
        and isinstance(e, dict)
        and isinstance(e.get("file"), str)
        and Path(e["file"]).name == e["file"]
        and isinstance(e.get("runs"), int)
        for k, e in chunks.items()
    )
    if not isinstance(manifest, dict) or not isinstance(manifest.get("digest"), str) or not entries_ok:
        raise InputError(f"{path}: not a sweep manifest (expected a digest and the chunks written); {fix}")
    return manifest


class Store:
    """The results folder of one sweep (``digest``); created if missing."""

    def __init__(self, folder: Path, digest: str, source: str, *, fresh: bool = False) -> None:
        """Open (or create) the results folder ``folder``; ``fresh``: this sweep made ``folder`` (it had none)."""
        self.folder = Path(folder)
        self.fresh = fresh
        self.results = self.folder / RESULTS
        self.digest = digest
        try:
            self.results.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"{self.results}: cannot be made a results folder ({exc.strerror or exc})") from None
        path = self.folder / MANIFEST
        if path.is_file():
            manifest = _read_manifest(path)
            if manifest["digest"] != digest:
                raise InputError(
                    f"{self.folder} holds the results of another sweep (manifest digest differs): "
                    "choose another --out, or remove it to start again"
                )
            self.chunks: dict[str, dict[str, Any]] = dict(manifest["chunks"])
        else:
            self.chunks = {}
            self._write_manifest(source)
        self.source = source

    def discard_if_empty(self) -> None:
        """Remove the folder when this sweep made it and wrote no chunk into it (models, manifest and all)."""
        if self.fresh and not self.chunks:
            shutil.rmtree(self.folder, ignore_errors=True)

    def done(self, chunk_id: str) -> bool:
        """True when the chunk is in the manifest and its file exists."""
        entry = self.chunks.get(chunk_id)
        return entry is not None and (self.results / entry["file"]).is_file()

    def write(self, chunk_id: str, columns: Mapping[str, Any]) -> Path:
        """Write a chunk's columns as its Parquet file, then record it in the manifest."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.table(dict(columns))
        name = f"chunk-{chunk_id}.parquet"

        def write(fh: IO[bytes]) -> None:
            pq.write_table(table, fh)

        path = write_atomically(self.results / name, write)
        self.chunks[chunk_id] = {"file": name, "runs": table.num_rows}
        self._write_manifest(self.source)
        return path

    def table(self) -> Any:
        """Every written chunk as one pyarrow Table, sorted by run number."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        tables = [pq.read_table(self.results / e["file"]) for e in self.chunks.values()]
        if not tables:
            return pa.table({})
        return pa.concat_tables(tables, promote_options="default").sort_by("run")

    def _write_manifest(self, source: str) -> None:
        text = json.dumps({"digest": self.digest, "sweep": source, "chunks": self.chunks}, indent=1, sort_keys=True)
        write_text_atomically(self.folder / MANIFEST, text + "\n")
