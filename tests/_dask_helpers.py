"""A real Dask cluster on this machine for the sweep tests: two worker processes on localhost."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import distributed


@contextlib.contextmanager
def two_workers() -> Iterator[distributed.Client]:
    """A client of a LocalCluster of 2 single-threaded worker processes, closed on exit."""
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address="127.0.0.1:0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        yield client
