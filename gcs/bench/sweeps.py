"""A bench's sweep: many independent runs, on Dask distributed, yielded as they finish.

Each run is ``function(job)``; the function must be importable by name (a module's
top-level function) and the job and its answer picklable. Where the runs go:

- one run at a time (``jobs`` 1, no scheduler): in this process, one after another;
- otherwise a local cluster: ``jobs`` worker processes on this machine, one run each at
  a time, listening on loopback only, no dashboard;
- or an existing cluster (``scheduler``: its address, e.g. ``tcp://127.0.0.1:8786``),
  whose workers run this same project.

A run that raises, or whose worker dies, is a ``Failed`` in its place (its traceback on
stderr), so that one failure loses none of the other runs. Dask is imported only here,
when a sweep starts; the client and the local cluster are closed when the sweep ends,
however it ends (the caller closes the generator: ``contextlib.closing``).
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import pickle
import traceback
from collections.abc import Callable, Generator, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from gcs.errors import UsageError
from planner.native import use_sources_if_stale

LOOPBACK_ANY_PORT = "127.0.0.1:0"
#: Seconds to wait for an existing cluster's scheduler to answer.
CONNECT_TIMEOUT_S = 10


@dataclass(frozen=True)
class Failed:
    """A run that raised, or whose worker died: the error, as ``Type: message``."""

    error: str


@dataclass(frozen=True)
class Where:
    """Where a sweep's runs go: ``jobs`` local workers, or an existing cluster."""

    jobs: int
    scheduler: str | None = None


def _error(exc: BaseException) -> Failed:
    name = type(exc).__name__
    if name == "KilledWorker":  # Dask's long message names its task's internal key
        return Failed(f"{name}: the worker running it died")
    traceback.print_exception(exc)
    return Failed(f"{name}: {exc}")


def _call(payload: bytes) -> Any:
    """One run in a worker. The job comes pickled so that it is unpickled (and the
    planner imported) only after the worker chose between the compiled planner and its
    sources, as the command line does."""
    use_sources_if_stale()
    function, job = pickle.loads(payload)
    return function(job)


def run_sweep(
    function: Callable[[Any], Any], jobs: Sequence[Any], where: Where
) -> Generator[tuple[int, Any]]:
    """``(index of the job, its answer or a Failed)`` for every job, as they finish."""
    if where.scheduler is None and where.jobs <= 1:
        for index, job in enumerate(jobs):
            try:
                yield index, function(job)
            except Exception as exc:
                yield index, _error(exc)
        return
    with _client(where, len(jobs)) as client:
        yield from _on_cluster(client, function, jobs)


def _on_cluster(
    client: Any, function: Callable[[Any], Any], jobs: Sequence[Any]
) -> Iterator[tuple[int, Any]]:
    """The runs on a cluster, no more at once than its workers have threads: a run then
    never waits on a worker behind another, so a run that kills its worker takes no
    other run with it. Each answer is released from its worker as soon as it is here
    (left there, it would be lost with that worker)."""
    from distributed import as_completed

    waiting = iter(enumerate(jobs))
    running: dict[Any, int] = {}
    finished = as_completed()

    def start_more() -> None:
        room = max(1, sum(client.nthreads().values())) - len(running)
        for index, job in itertools.islice(waiting, max(0, room)):
            future = client.submit(_call, pickle.dumps((function, job)), pure=False)
            running[future] = index
            finished.add(future)

    try:
        start_more()
        for future in finished:
            exc = future.exception()
            answer = future.result() if exc is None else _error(exc)
            index = running.pop(future)
            future.release()
            start_more()
            yield index, answer
    finally:
        client.cancel(list(running))


@contextlib.contextmanager
def _client(where: Where, runs: int) -> Iterator[Any]:
    """A client of the existing cluster, or of a local one made for this sweep."""
    try:
        import dask
        from distributed import Client, LocalCluster
    except ImportError:
        raise UsageError(
            "runs on Dask distributed: install it with pip install -e '.[sweeps]' "
            "(or run with --jobs 1)"
        ) from None

    if where.scheduler is not None:
        with Client(where.scheduler, timeout=CONNECT_TIMEOUT_S) as client:
            yield client
        return
    # A run whose worker dies fails at once rather than killing three more workers.
    with (
        dask.config.set({"distributed.scheduler.allowed-failures": 0}),
        LocalCluster(
            n_workers=min(where.jobs, runs),
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            # The scheduler's HTTP routes (health, metrics) listen even without the
            # dashboard: on a free loopback port rather than 8787.
            scheduler_kwargs={"dashboard_address": LOOPBACK_ANY_PORT},
            memory_limit=0,
            # Only critical lines from the cluster itself: a worker whose heartbeat meets
            # the scheduler closing after Ctrl-C logs a traceback, and a run that fails
            # is reported as its row in any case.
            silence_logs=logging.CRITICAL,
        ) as cluster,
        Client(cluster) as client,
    ):
        yield client
