"""The processes that compute a night's candidates beside the flow's own: ``[nightly]
processes`` (default 1: none, everything in the flow's process).

With the sequential task runner a night's batches run in the flow's process, and most of a
candidate's time (planning's look-ups, reading, the residual, the tiers, the drift) is its
own, independent of every other asset's; only the registry's writes must stay in order in
one process. A :class:`ComputePool` is a small pool of worker processes started once for
the flow's run (``concurrent.futures`` on the ``forkserver`` context: the server imports
the pipeline once, each worker is forked from it, and each keeps its registry connection
for the night). :mod:`flows.pooled_execute` sends it the batch's assets in chunks and
commits what comes back in the plan's order.

The pool of the running flow is found through a context variable that :func:`compute_pool`
sets for the flow's batches (never a module global): a batch task run anywhere else (a Dask
worker, a test calling it directly) sees none and runs as before.

Workers run their numerical libraries on one thread each (``threadpoolctl``), as Dask's
workers do: the cores are shared by processes, not by threads.
"""
from __future__ import annotations

import contextlib
import contextvars
import multiprocessing
from concurrent.futures import Future, ProcessPoolExecutor
from typing import Callable, Iterator

#: the modules each worker has imported before its first chunk (the forkserver's preload)
PRELOAD = ["flows.pooled_execute", "flows.nightly", "flows.reanalyze"]

_ACTIVE: contextvars.ContextVar["ComputePool | None"] = contextvars.ContextVar(
    "fleet_health_compute_pool", default=None)


def _start_worker() -> None:
    """A worker's start: one thread for BLAS and OpenMP (the cores are the pool's)."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)


class ComputePool:
    """Worker processes for the flow's run (a context manager).

    Parameters
    ----------
    processes : int
        Worker processes (>= 2; 1 is the flow's process alone and needs no pool).
    """

    def __init__(self, processes: int):
        if processes < 2:
            raise ValueError(f"a compute pool needs at least 2 processes, got {processes}")
        self.processes = processes
        self._executor: ProcessPoolExecutor | None = None
        #: work submitted ahead of the batch task that takes it, by the task's job
        #: (:func:`flows.pooled_execute.compute_ahead`)
        self.ahead: dict = {}

    def __enter__(self) -> "ComputePool":
        self._executor = self._new_executor()
        return self

    def __exit__(self, *exc) -> None:
        executor, self._executor = self._executor, None
        self.ahead = {}
        if executor is not None:
            executor.shutdown(wait=True, cancel_futures=True)

    def _new_executor(self) -> ProcessPoolExecutor:
        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload(PRELOAD)
        return ProcessPoolExecutor(self.processes, mp_context=context,
                                   initializer=_start_worker)

    def submit(self, function: Callable, *args) -> Future:
        """``function(*args)`` in a worker (both must pickle: plain data in and out)."""
        return self._executor.submit(function, *args)

    def restart(self) -> None:
        """New workers after one died (its pool is broken: every future of it failed)."""
        if self._executor is not None:
            self._executor.shutdown(wait=False, cancel_futures=True)
        self._executor = self._new_executor()


def start_forkserver() -> None:
    """Start the workers' forkserver now, without waiting for it: it imports :data:`PRELOAD`
    in its own process while the command starts its Prefect server and loads the flow, and
    the pool's first worker (forked from it) is ready sooner. A pool started later uses this
    server; if none is, the server exits with this process."""
    from multiprocessing import forkserver

    multiprocessing.get_context("forkserver").set_forkserver_preload(PRELOAD)
    forkserver.ensure_running()


def active_pool() -> ComputePool | None:
    """The pool of the flow run this batch belongs to (None: compute in this process)."""
    return _ACTIVE.get()


@contextlib.contextmanager
def compute_pool(processes: int) -> Iterator[ComputePool | None]:
    """A :class:`ComputePool` of ``processes`` workers for the batches run inside the block
    (:func:`active_pool`), or None when ``processes`` is 1."""
    if processes <= 1:
        yield None
        return
    with ComputePool(processes) as pool:
        token = _ACTIVE.set(pool)
        try:
            yield pool
        finally:
            _ACTIVE.reset(token)
