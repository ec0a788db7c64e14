"""Where a flow's batch tasks run: ``[nightly] task_runner``.

``"sequential"`` (the default) runs each batch task in the flow's own process, one after
another: each batch already uses the process's cores through its BLAS and torch thread
pools. ``"dask"`` submits every batch at once to a Dask cluster through prefect-dask's
``DaskTaskRunner`` (``[dask] address`` of a running scheduler, or else a ``LocalCluster``
started for the run with ``[dask] workers`` processes of ``threads_per_worker`` threads).
Dask starts its worker processes with one BLAS/OpenMP thread each (its
``distributed.nanny.pre-spawn-environ``), so one thread per worker and one worker per core
keep the cores busy without oversubscribing them. The same setting also gives them
``MALLOC_TRIM_THRESHOLD_=65536``, which a ``LocalCluster`` started here leaves out
(:data:`LOCAL_WORKER_CONFIG`): a fixed trim threshold turns off glibc's adaptive mmap
threshold, so every array above 128 kB (a day of 1-Hz samples is 691 kB) is a fresh mmap
whose pages fault in and are zeroed again at each allocation; a night's compute on such a
worker took about twice the time it takes in the flow's own process (docs/performance.md,
"Dask workers").

Both are used the same way by :func:`flows.batching.run_over_fleet`: :meth:`submit` every
batch, then take the outcomes from :meth:`completed`, which yields ``(index, outcome)`` in
the order the batches finish; an outcome is the task's final Prefect state, or the error
that kept the task from reporting one (a Dask worker that died).

Workers need what the task needs: the same fleet-health installed (a ``LocalCluster``'s
workers get this process's import path), the Prefect API (an ephemeral API's address is
handed to them explicitly), and the configuration, telemetry, alerts file and tracking URI
at the same absolute paths (the caller ships absolute ones).
"""
from __future__ import annotations

import contextlib
import functools
import operator
import os
import pathlib
from typing import Any, Iterator

from flows.config import DaskSettings, FleetConfig


#: Dask configuration in effect while a run's ``LocalCluster`` starts: its workers get the
#: malloc of an ordinary process (the flow's, the sequential runner's), not Dask's
#: ``MALLOC_TRIM_THRESHOLD_`` (None removes a variable from the pre-spawn environment). A
#: cluster of ``[dask] address`` is started by its operator (docs/operations.md).
LOCAL_WORKER_CONFIG = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}


#: batches each of a cluster's task slots gets at least, where ``batch_size`` would leave
#: fewer: with one batch per slot the night lasts as long as the slowest batch (96 assets at
#: the default 64 were 64 + 32, so two workers could not beat 1.5x one); a Dask batch costs
#: about 0.2 s (docs/performance.md, "Dask workers")
BATCHES_PER_SLOT = 4


class SequentialBatches:
    """Batch tasks run in this process, one after another, as :meth:`completed` is read.

    Their progress reaches this process's reporter directly (``in_process``); one batch
    runs at a time (``slots``).
    """

    in_process = True
    slots = 1

    def __init__(self):
        self._submitted: list[functools.partial] = []

    def __enter__(self) -> "SequentialBatches":
        return self

    def __exit__(self, *exc) -> None:
        self._submitted = []

    def submit(self, task, parameters: dict) -> None:
        """Queue ``task(**parameters)``."""
        self._submitted.append(functools.partial(task, **parameters, return_state=True))

    def completed(self) -> Iterator[tuple[int, Any]]:
        """Run the queued tasks in order as the caller reads them; yield ``(index, final
        state)``. Each task is called by the iterator itself (``map``), so the task's frame
        sits right under the caller's: nothing of the runner between the flow and its batch
        (docs/design.md 2.5)."""
        return enumerate(map(operator.call, self._submitted))


class DaskBatches:
    """Batch tasks run concurrently on a Dask cluster (prefect-dask ``DaskTaskRunner``).

    Their progress is reported in worker processes, out of this process's sight
    (``in_process`` is False): the caller advances per completed batch. ``slots``, the
    batches that run at once, is the LocalCluster's workers times their threads; for a
    cluster of ``[dask] address``, whose size its operator sets, 1 (``batch_size`` is
    used as it is).

    Parameters
    ----------
    settings : DaskSettings
    """

    in_process = False

    def __init__(self, settings: DaskSettings):
        self.settings = settings
        self.slots = 1 if settings.address else (
            (settings.workers or os.cpu_count() or 1) * settings.threads_per_worker)
        self._stack: contextlib.ExitStack | None = None
        self._runner = None
        self._futures: list = []

    def __enter__(self) -> "DaskBatches":
        from prefect_dask import DaskTaskRunner

        with contextlib.ExitStack() as stack:
            stack.enter_context(api_for_workers())
            if not self.settings.address:
                # the LocalCluster starts at the first submit: its nannies read this then
                import dask

                stack.enter_context(environment_restored())
                stack.enter_context(dask.config.set(LOCAL_WORKER_CONFIG))
            self._runner = stack.enter_context(DaskTaskRunner(**runner_options(self.settings)))
            self._stack = stack.pop_all()
        return self

    def __exit__(self, *exc) -> None:
        stack, self._stack, self._futures = self._stack, None, []
        if stack is not None:
            stack.__exit__(*exc)

    def submit(self, task, parameters: dict) -> None:
        """Submit ``task(**parameters)`` to the cluster."""
        self._futures.append(self._runner.submit(task, parameters))

    def completed(self) -> Iterator[tuple[int, Any]]:
        """Yield ``(index, final state or error)`` as the batches finish."""
        from distributed import as_completed

        index = {future.wrapped_future.key: i for i, future in enumerate(self._futures)}
        for done in as_completed([future.wrapped_future for future in self._futures],
                                 loop=self._runner.client.loop):
            try:
                outcome = done.result()   # the task's final state (prefect-dask returns it)
            except Exception as error:  # noqa: BLE001 - e.g. KilledWorker: the batch failed
                outcome = error
            yield index[done.key], outcome


@contextlib.contextmanager
def environment_restored() -> Iterator[None]:
    """This process's environment as it was on entry, again on exit. A Dask nanny writes its
    workers' pre-spawn variables (``OMP_NUM_THREADS=1`` and the other thread counts,
    ``PYTHONHASHSEED``, ``MALLOC_TRIM_THRESHOLD_``) into the parent's own ``os.environ``
    before it spawns them: without this, every process the caller starts after a Dask night
    would run its BLAS on one thread."""
    saved = dict(os.environ)
    try:
        yield
    finally:
        for name in set(os.environ) - set(saved):
            del os.environ[name]
        for name, value in saved.items():
            if os.environ.get(name) != value:
                os.environ[name] = value


def batch_runner(config: FleetConfig) -> SequentialBatches | DaskBatches:
    """The runner of ``[nightly] task_runner`` (a context manager)."""
    if config.nightly.task_runner == "dask":
        return DaskBatches(config.dask)
    return SequentialBatches()


def batch_size_for(assets: int, batch_size: int, slots: int) -> int:
    """Assets per batch: ``batch_size``, or fewer where that leaves a runner's ``slots``
    fewer than :data:`BATCHES_PER_SLOT` batches each (never below 1).

    Examples
    --------
    >>> batch_size_for(96, 64, 1), batch_size_for(96, 64, 2), batch_size_for(1000, 64, 2)
    (64, 12, 64)
    """
    if slots <= 1:
        return batch_size
    return max(1, min(batch_size, -(-assets // (BATCHES_PER_SLOT * slots))))


def runner_options(settings: DaskSettings) -> dict:
    """``DaskTaskRunner`` keyword arguments for ``[dask]``: the scheduler's address, or a
    ``LocalCluster`` whose workers import fleet-health from where this process does."""
    if settings.address:
        return {"address": settings.address}
    return {"cluster_kwargs": {"n_workers": settings.workers,
                               "threads_per_worker": settings.threads_per_worker,
                               "processes": True, "env": worker_environment()}}


def worker_environment() -> dict[str, str]:
    """``PYTHONPATH`` for local worker processes: the directory this ``flows`` package was
    imported from first, so workers run the same code as the flow."""
    source = str(pathlib.Path(__file__).resolve().parents[1])
    paths = [source] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep)
                        if p and p != source]
    return {"PYTHONPATH": os.pathsep.join(paths)}


@contextlib.contextmanager
def api_for_workers() -> Iterator[None]:
    """Make the Prefect API address explicit while tasks are submitted.

    prefect-dask ships the settings in effect to the workers. Without ``PREFECT_API_URL``,
    Prefect serves this process from a temporary local server whose address is not a
    setting: each worker would start a server of its own on the same database.
    """
    from prefect.client.orchestration import get_client
    from prefect.settings import PREFECT_API_URL, temporary_settings

    if PREFECT_API_URL.value():
        yield
        return
    url = str(get_client(sync_client=True).api_url).rstrip("/")
    with temporary_settings(updates={PREFECT_API_URL: url}):
        yield
