"""The engine: Dask ``distributed`` runs the chunks (a LocalCluster by default, or a scheduler's address).

Each pending chunk is one task (``client.submit`` of :func:`robodyn.sweep.chunk.execute`, keyed
by the chunk's id); results are written to the store as they finish (``as_completed``), so an
interrupted sweep keeps every chunk it finished. A worker that dies takes its running task
with it and the scheduler runs it again elsewhere; nothing here retries or queues by hand.

The default cluster is ``LocalCluster(n_workers=N, threads_per_worker=1, processes=True)`` on
127.0.0.1 without a dashboard: one process per core, since each chunk is single-threaded numerics.
Its log lines are silenced (``silence_logs``): what goes wrong is robodyn's one line. A run that
raises in a worker ends the sweep with that error (a robodyn error as it is, anything else named
with its chunk); a scheduler that goes away mid-sweep ends it with :class:`UnavailableError`
(exit 5) saying how many chunks are written and that the same command resumes from them.

A ``device = "cuda"`` sweep without ``--scheduler`` starts no cluster: this process runs its chunks
one after the other on its GPU (each chunk is one kernel launch over all its runs). With a
scheduler, each chunk goes to a worker as arrays (:func:`robodyn.sweep.cuda_chunk.device_task`): the
worker runs the kernels (:func:`robodyn.engine.cuda.sweep.run_task`, NumPy and numba alone, no
Pinocchio) and sends the measures back (a tree robot's chunk, which the compiled tree kernels run, goes
as a whole: its worker needs robodyn); the columns, and the few runs the device flagged for
``simulate``, are made here.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import uuid
from collections.abc import Callable, Iterator
from typing import Any, TextIO

from robodyn.engine.cuda.sweep import run_task
from robodyn.errors import InputError, MissingDependencyError, RobodynError, SweepInterrupted, UnavailableError
from robodyn.fileio import pause_for_test
from robodyn.sweep import lifetime
from robodyn.sweep.chunk import Job, execute
from robodyn.sweep.cuda_chunk import device_task, finish_device, on_arrays
from robodyn.sweep.plan import Chunk, Plan
from robodyn.sweep.progress import Progress
from robodyn.sweep.store import Store

# Seconds to wait for a scheduler given by address before giving up.
CONNECT_TIMEOUT_S = 20
# Local worker processes at most, per CPU core: each holds a Python with numpy, Pinocchio and its models
# (~150 MB), and a chunk is single-threaded numerics, so more processes than this only share the cores.
WORKERS_PER_CORE = 4
# A scheduler's address: PROTOCOL://HOST:PORT (an IPv6 host in brackets).
_ADDRESS = re.compile(r"(tcp|tls|ws|wss)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+):([0-9]{1,5})/?")


def max_workers() -> int:
    """The most local worker processes a sweep starts on this machine: :data:`WORKERS_PER_CORE` per CPU core."""
    return WORKERS_PER_CORE * (os.cpu_count() or 1)


def check_cluster(*, scheduler: str | None, workers: int | None) -> None:
    """Refuse a malformed scheduler address or more local workers than :func:`max_workers`, before any work.

    Raises:
        InputError: naming the address or the number, and what is expected.
    """
    if scheduler is not None:
        m = _ADDRESS.fullmatch(scheduler) if isinstance(scheduler, str) else None
        if m is None or not 1 <= int(m.group(3)) <= 65535:
            raise InputError(
                f"--scheduler {scheduler!r}: not a Dask scheduler address (expected PROTOCOL://HOST:PORT, "
                "e.g. tcp://127.0.0.1:8786)"
            )
    if workers is not None and not 1 <= workers <= max_workers():
        raise InputError(
            f"--workers {workers}: at most {max_workers()} local worker processes on this machine "
            f"({WORKERS_PER_CORE} per CPU core, {os.cpu_count() or 1} cores)"
        )


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
        check_cluster(scheduler=scheduler, workers=None)
        try:
            client = dd.Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError, AssertionError) as exc:
            raise UnavailableError(f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({exc})") from None
        with client:
            yield client
        return
    n = workers or os.cpu_count() or 1
    check_cluster(scheduler=None, workers=n)
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
                silence_logs=logging.CRITICAL + 1,  # the workers' and scheduler's logs: nothing reaches stderr
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


@contextlib.contextmanager
def quiet_dask() -> Iterator[None]:
    """Silence distributed's loggers in this process while a sweep runs; robodyn says what went wrong.

    A client reconnecting to a dead scheduler logs tracebacks, and a Client that failed to connect complains
    as the garbage collector takes it: both are silenced.
    """
    import gc
    import sys

    loggers = [
        logging.getLogger(name) for name in list(logging.root.manager.loggerDict) if name.startswith("distributed")
    ]
    loggers.append(logging.getLogger("distributed"))
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        hook = sys.unraisablehook
        sys.unraisablehook = lambda unraisable: None
        try:
            gc.collect()
        finally:
            sys.unraisablehook = hook
        for logger, level in zip(loggers, levels, strict=True):
            logger.setLevel(level)


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
        if pending and job.device == "cuda" and client is None and scheduler is None:
            _in_process(pending, job, store, bar, on_chunk)
        elif pending:
            with quiet_dask(), contextlib.ExitStack() as stack:
                if client is None:
                    client = stack.enter_context(client_for(scheduler=scheduler, workers=workers))
                _submit_and_collect(client, pending, job, store, bar, on_chunk, local=local)
    except RobodynError:
        store.discard_if_empty()  # a refusal found only once the sweep ran: no folder of nothing left behind
        raise
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


def _in_process(
    pending: list[Chunk], job: Job, store: Store, bar: Progress, on_chunk: Callable[[Chunk], None] | None
) -> None:
    """Run the chunks one after the other in this process: a GPU sweep's chunks share the one GPU, no cluster."""
    for chunk in pending:
        store.write(chunk.id, execute(chunk, job))
        bar.update(chunk.runs.size)
        if on_chunk is not None:
            on_chunk(chunk)
        pause_for_test("chunk")


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
    shipped = {chunk.id for chunk in pending if on_arrays(chunk, job)}  # a built-in kind's cuda chunks
    for chunk in pending:
        key = f"robodyn-sweep-{chunk.id}-{run_tag}"
        if chunk.id in shipped:  # the worker gets arrays and runs the kernels: it needs no Pinocchio
            future = client.submit(run_task, device_task(chunk, job), key=key, pure=False)
        else:
            future = client.submit(execute, chunk, job, key=key, pure=False)
        by_key[future.key] = chunk
        futures.append(future)
    try:
        for future in dd.as_completed(futures):
            chunk = by_key[future.key]
            columns = _result(dd, future, chunk, store)
            if chunk.id in shipped:  # the columns, and the runs the device flagged, on this side
                columns = finish_device(chunk, job, columns)
            store.write(chunk.id, columns)
            future.release()
            bar.update(chunk.runs.size)
            if on_chunk is not None:
                on_chunk(chunk)
            pause_for_test("chunk")
    except (OSError, TimeoutError, dd.client.FutureCancelledError, dd.CancelledError) as exc:
        raise _lost(exc, store) from None
    except BaseException:
        if local:
            with lifetime.sigint_ignored(), lifetime.logging_off():
                lifetime.kill_local_workers()
                for future in futures:
                    future.cancel()
        raise
    finally:
        for future in futures:
            with contextlib.suppress(Exception):  # a client whose scheduler is gone cannot cancel: nothing runs
                future.cancel()


def _result(dd: Any, future: Any, chunk: Chunk, store: Store) -> Any:
    """The chunk's columns; an error raised in its worker becomes robodyn's one line."""
    try:
        return future.result()
    except RobodynError:
        raise  # robodyn's own line, from the worker
    except (OSError, TimeoutError, dd.client.FutureCancelledError, dd.CancelledError) as exc:
        raise _lost(exc, store) from None
    except dd.KilledWorker:  # its workers died running it: os._exit in a user's file, a crash, memory
        raise RobodynError(
            f"chunk {chunk.index} (runs {chunk.runs[0]}-{chunk.runs[-1]}) ended every worker that ran it "
            f"(os._exit in a measure or controller file, a crash, or the memory's end?); {_kept(store)}"
        ) from None
    except MemoryError:
        raise UnavailableError(
            f"chunk {chunk.index} (runs {chunk.runs[0]}-{chunk.runs[-1]}) ran out of memory in its worker; "
            f"{_kept(store)}; fewer runs a chunk (chunk = ...) or fewer workers"
        ) from None
    except Exception as exc:  # anything else a worker raised: named with its chunk, as one line
        first = str(exc).strip().splitlines()[0][:300] if str(exc).strip() else ""
        raise RobodynError(
            f"chunk {chunk.index} (runs {chunk.runs[0]}-{chunk.runs[-1]}) failed in its worker: "
            f"{type(exc).__name__}{': ' + first if first else ''}; {_kept(store)}"
        ) from None


def _lost(exc: BaseException, store: Store) -> UnavailableError:
    """The error for a scheduler (or its connection) that went away mid-sweep."""
    again = "; run the same command again to resume from them" if store.chunks else ""
    return UnavailableError(f"the Dask scheduler went away mid-sweep ({type(exc).__name__}); {_kept(store)}{again}")


def _kept(store: Store) -> str:
    """What is left of the sweep's folder after a failure (:meth:`Store.discard_if_empty` removes a fresh empty one)."""
    n = len(store.chunks)
    if n == 0 and store.fresh:
        return f"no chunk was written, and {store.folder}, made by this sweep, is removed"
    return f"{n} chunk{'s' if n != 1 else ''} written in {store.results} are kept"
