"""The engine: Dask ``distributed`` runs the chunks (a LocalCluster by default, or a scheduler's address).

Each pending chunk is one task (``client.submit`` of :func:`robodyn.sweep.chunk.execute`, keyed
by the chunk's id); results are written to the store as they finish (``as_completed``), so an
interrupted sweep keeps every chunk it finished. A worker that dies takes its running task
with it and the scheduler runs it again elsewhere; nothing here retries or queues by hand.

The default cluster is ``LocalCluster(n_workers=N, threads_per_worker=1, processes=True)`` on
127.0.0.1 without a dashboard: one process per core, since each chunk is single-threaded numerics.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from collections.abc import Callable, Iterator
from typing import Any, TextIO

from robodyn.errors import MissingDependencyError, SweepInterrupted, UnavailableError
from robodyn.fileio import pause_for_test
from robodyn.sweep import lifetime
from robodyn.sweep.chunk import Job, execute
from robodyn.sweep.plan import Chunk, Plan
from robodyn.sweep.progress import Progress
from robodyn.sweep.store import Store

# Seconds to wait for a scheduler given by address before giving up.
CONNECT_TIMEOUT_S = 20


def distributed() -> Any:
    """The ``distributed`` module, or MissingDependencyError naming the extra to install."""
    try:
        import distributed as dd
    except ImportError:
        raise MissingDependencyError("robodyn sweep needs Dask: pip install 'robodyn[sweep]'") from None
    return dd


@contextlib.contextmanager
def client_for(*, scheduler: str | None, workers: int | None) -> Iterator[Any]:
    """A Client on ``scheduler`` (an address), or on a new LocalCluster of ``workers`` processes."""
    dd = distributed()
    if scheduler is not None:
        try:
            client = dd.Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError) as exc:
            raise UnavailableError(f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({exc})") from None
        with client:
            yield client
        return
    n = workers or os.cpu_count() or 1
    lifetime.quiet_resource_tracker()
    cluster = None
    try:
        with lifetime.sigint_blocked():  # the workers start deaf to Ctrl-C: the sweep ends them itself
            cluster = dd.LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address="127.0.0.1:0",
                preload=[lifetime.__name__],  # each worker dies with this process (lifetime.tie_to_parent)
                env={lifetime.PARENT_VARIABLE: str(os.getpid())},
            )
        with dd.Client(cluster) as client:
            yield client
    except BaseException:  # Ctrl-C included: kill the workers, then close without a word
        with lifetime.sigint_ignored(), lifetime.logging_off():
            lifetime.kill_local_workers()
            if cluster is not None:
                cluster.close()
        raise
    cluster.close()


def run_chunks(
    plan: Plan,
    job: Job,
    store: Store,
    *,
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: TextIO | None = None,
    on_chunk: Callable[[Chunk], None] | None = None,
) -> int:
    """Run every chunk the store does not have yet; return how many chunks were computed.

    ``client`` (a ``distributed.Client``) takes precedence over ``scheduler`` and ``workers``.
    ``on_chunk`` is called after each chunk is written (tests use it to kill a worker).
    """
    local = client is None and scheduler is None  # a cluster of this process's own: killed on any exception
    pending = [c for c in plan.chunks if not store.done(c.id)]
    skipped = [c for c in plan.chunks if store.done(c.id)]
    bar = Progress(
        progress,
        chunks=len(plan.chunks),
        runs=plan.n_runs,
        skipped_chunks=len(skipped),
        skipped_runs=sum(c.runs.size for c in skipped),
    )
    try:
        if pending:
            with contextlib.ExitStack() as stack:
                if client is None:
                    client = stack.enter_context(client_for(scheduler=scheduler, workers=workers))
                _submit_and_collect(client, pending, job, store, bar, on_chunk, local=local)
    except KeyboardInterrupt:
        written = sum(store.done(c.id) for c in plan.chunks)
        raise SweepInterrupted(
            f"interrupted; {written} of {len(plan.chunks)} chunks are written in {store.results}",
            written=written,
            chunks=len(plan.chunks),
            folder=store.folder,
        ) from None
    finally:
        bar.close()
    return len(pending)


def _submit_and_collect(
    client: Any,
    pending: list[Chunk],
    job: Job,
    store: Store,
    bar: Progress,
    on_chunk: Callable[[Chunk], None] | None,
    *,
    local: bool,
) -> None:
    """Submit every pending chunk and write each as it finishes.

    On any exception (Ctrl-C included) a ``local`` cluster's workers are killed first, before the
    futures are cancelled: a worker told of a cancelled task logs it, a killed one says nothing.
    """
    dd = distributed()
    run_tag = uuid.uuid4().hex[:8]  # a key of its own per submission: a cancelled earlier one cannot hit it
    by_key = {}
    futures = []
    for chunk in pending:
        future = client.submit(execute, chunk, job, key=f"robodyn-sweep-{chunk.id}-{run_tag}", pure=False)
        by_key[future.key] = chunk
        futures.append(future)
    try:
        for future in dd.as_completed(futures):
            chunk = by_key[future.key]
            columns = future.result()
            store.write(chunk.id, columns)
            future.release()
            bar.update(chunk.runs.size)
            if on_chunk is not None:
                on_chunk(chunk)
            pause_for_test("chunk")
    except BaseException:
        if local:
            with lifetime.sigint_ignored(), lifetime.logging_off():
                lifetime.kill_local_workers()
                for future in futures:
                    future.cancel()
        raise
    finally:
        for future in futures:
            future.cancel()
