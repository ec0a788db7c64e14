"""A batch's plan -> execute -> commit with the compute in a :class:`flows.compute_pool.ComputePool`
(``[nightly] processes`` > 1): the workers plan, read, fit and compare the batch's assets in
chunks, the flow's process commits them in the plan's order.

Worker side, :func:`compute_chunk`: the flow's planner plans the chunk (its registry
look-ups: the watermark, the reference's load and verification), then :func:`flows.pipeline.read`,
:func:`~graybox.signature_fit.fit_signatures` of :func:`~flows.pipeline.candidate_requests`
and :func:`~flows.pipeline.compare`, in groups within the worker's share of ``[nightly]
memory_budget``. Before a fitted asset goes back, each
window's data hash is taken (what the registry would hash) and its telemetry is dropped
unless the window's plots need it: what travels is the fits, drifts and diagnoses.

Flow side, :func:`execute_pooled`: the chunks' outcomes are taken in order; each run of
consecutive finished chunks is one commit group of the flow's policy (the registry record
in one transaction, the watermarks), as :func:`flows.pipeline.execute` commits a memory
group. Every function called on either side is the sequential path's, on the same inputs:
the records, results and alerts are those of ``processes = 1``
(``tests/flows/test_pooled_execute.py``). Only candidate flows (the nightly run, a
reanalysis) use the pool; a baseline's commit draws its telemetry, and runs as before.

Failures: an asset's own failure is reported in its result, as in the sequential path. A
transient error in a worker stops the batch (:class:`~flows.errors.TransientError`: the
batch task is retried). A worker that dies (its pool is broken) is replaced, and its
chunk's assets are computed again one at a time with nothing else in the pool: one that
kills its worker again is failed, named, and the others go on; the later chunks the dead
pool took with it are submitted again. Any other error of a chunk (e.g. a result that cannot travel)
runs that chunk in the flow's own process, the sequential way.

Transport: the chunk's job goes as the :class:`flows.batch_job.BatchJob` dict Dask and
Prefect carry; the results come back through ``concurrent.futures``' private pipe to the
process that started the worker (pickled in memory, like Dask's results): nothing stored or
received from outside is ever unpickled (docs/design.md section 5.6).
"""
from __future__ import annotations

import functools
import json
import logging
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool
from typing import Sequence

from graybox.signature_fit import fit_signatures
from graybox.stage_clock import StageClock, timed

from flows.batch_job import BatchJob
from flows.compute_pool import ComputePool
from flows.config import FleetConfig, load_config
from flows.discovery import AssetRef
from flows.errors import TransientError
from flows.memory import MemoryBudget
from flows.pipeline import (PendingAsset, candidate_requests, compare, execute, memory_groups,
                            read, report_result, travelling)
from flows.results import FAILED, AssetResult, describe_error, is_transient
from flows.run_logger import run_logger

logger = logging.getLogger(__name__)

#: the stage of the flow's process waiting for a chunk (its wall seconds: how long the
#: commits waited for the workers; the workers' own stages are added under their names)
WAIT_STAGE = "pool_wait"
#: assets a worker plans, reads and fits at once (one batched fit, one commit group at least)
MAX_CHUNK = 32


def chunk_size(assets: int, processes: int) -> int:
    """Assets per chunk: a batch shared among the workers, at most :data:`MAX_CHUNK`.

    Larger chunks cost less per asset (a worker's numpy temporaries are reused across more
    assets: at 1 Hz a chunk of 8 took about 4 ms more CPU per asset-night in the residual
    than one of 48); the chunks of the next batches are queued before their tasks run
    (:func:`compute_ahead`), so the workers do not wait for the commits.

    Examples
    --------
    >>> chunk_size(64, 2), chunk_size(6, 2), chunk_size(1, 2), chunk_size(200, 2)
    (32, 3, 1, 32)
    """
    return max(1, min(MAX_CHUNK, -(-assets // processes)))


@functools.lru_cache(maxsize=4)
def _worker_state(config_path: str, tracking_uri: str | None):
    """A worker's configuration and registry for the night (one per fleet it serves)."""
    config = load_config(config_path).with_tracking_uri(tracking_uri)
    return config, config.registry()


def compute_chunk(job: dict, processes: int) -> tuple[list, dict]:
    """A worker's chunk: the job's assets planned, read, fitted and compared.

    Parameters
    ----------
    job : dict
        A :class:`~flows.batch_job.BatchJob` on the chunk's assets (:meth:`~flows.batch_job.BatchJob.to_dict`).
    processes : int
        The pool's workers: each takes this share of ``[nightly] memory_budget``.

    Returns
    -------
    items : list
        Per asset, in order: its :class:`~flows.results.AssetResult` when it is final (nothing
        to fit), else its :class:`~flows.pipeline.PendingAsset` ready to commit
        (:func:`flows.pipeline.travelling`).
    stages : dict
        The seconds of the chunk's stages (:meth:`graybox.stage_clock.StageClock.to_dict`).
    """
    batch = BatchJob.from_dict(job)
    config, registry = _worker_state(batch.config_path, batch.tracking_uri)
    clock = StageClock()
    plan = batch.planner()(config, list(batch.refs), **batch.options, registry=registry,
                           clock=clock)
    if plan.commit.fits_baselines:
        raise ValueError("a baseline's commit draws its telemetry: not computed in a pool")
    budget = MemoryBudget.for_batch(config.nightly.memory_budget // processes, baseline=False)
    pending: dict[str, PendingAsset] = {}
    for group in memory_groups((read(config, j, clock) for j in plan.jobs), budget):
        compare(group, fit_signatures(candidate_requests(group), clock=clock), clock)
        for asset in group:
            pending[asset.asset_id] = travelling(asset, config.nightly.plots)
    items = [pending.get(j.ref.asset_id, j.result) for j in plan.jobs]
    return items, clock.to_dict()


def execute_pooled(job: BatchJob, pool: ComputePool, clock: StageClock
                   ) -> list[AssetResult]:
    """Run a candidate batch's ``job`` with ``pool`` computing it: see the module docstring.

    Returns
    -------
    list of AssetResult
        One per asset, in the job's order.

    Raises
    ------
    TransientError
        When the registry or file system failed transiently (retry the batch: everything
        committed so far is kept and not repeated).
    """
    config, plan = job.for_batch(()).plan(clock)        # the flow's commit policy
    commit = plan.commit
    chunks, futures = pool.ahead.pop(_key(job), None) or _submit_batch(pool, job)
    results: list[AssetResult] = []
    index = 0
    try:
        while index < len(chunks):
            group: list[PendingAsset] = []
            while True:     # the next chunk, and those after it that are done already
                for item in _items(config, job, chunks, futures, index, pool, commit, clock):
                    if isinstance(item, PendingAsset):
                        group.append(item)
                        results.append(item.result)
                    else:
                        results.append(item)
                        report_result(item, commit)
                index += 1
                if index >= len(chunks) or not futures[index].done():
                    break
            for pending in commit.commit(group) if group else ():
                report_result(pending.result, commit)
    finally:
        for future in futures[index:]:
            future.cancel()
    return results


def compute_ahead(pool: ComputePool, job: BatchJob) -> None:
    """Submit ``job``'s chunks now, before its batch task runs (:func:`execute_pooled` takes
    them): the workers go on from one batch to the next while the flow's process commits
    the one before and Prefect starts the next task."""
    pool.ahead[_key(job)] = _submit_batch(pool, job)


def _key(job: BatchJob) -> str:
    return json.dumps(job.to_dict(), sort_keys=True, default=str)


def _submit_batch(pool: ComputePool, job: BatchJob) -> tuple[list, list[Future]]:
    """The job's chunks (:func:`chunk_size`) and their futures."""
    size = chunk_size(len(job.refs), pool.processes)
    chunks = [job.refs[i:i + size] for i in range(0, len(job.refs), size)]
    return chunks, [_submit(pool, job, chunk) for chunk in chunks]


def _submit(pool: ComputePool, job: BatchJob, refs: Sequence[AssetRef]) -> Future:
    return pool.submit(compute_chunk, job.for_batch(refs).to_dict(), pool.processes)


def _items(config: FleetConfig, job: BatchJob, chunks: list, futures: list[Future], index: int,
           pool: ComputePool, commit, clock: StageClock) -> list:
    """Chunk ``index``'s items (its stages added to ``clock``), whatever became of its
    worker: see the module docstring's failures."""
    chunk = chunks[index]
    try:
        with timed(clock, WAIT_STAGE):
            items, stages = futures[index].result()
    except BrokenProcessPool as error:
        run_logger(logger).warning("a compute worker died while computing %s (%s); computing "
                                   "them again one at a time",
                                   ", ".join(r.asset_id for r in chunk), error)
        pool.restart()      # the chunk's assets alone, with nothing else in the new pool
        items = [item for ref in chunk for item in _alone(pool, job, ref, error, clock)]
        for later in range(index + 1, len(chunks)):     # those the dead pool took with it
            if not futures[later].done() or futures[later].exception() is not None:
                futures[later] = _submit(pool, job, chunks[later])
        return items
    except Exception as error:  # noqa: BLE001 - transient: retried; else computed here
        if is_transient(error):
            raise TransientError(f"computing {', '.join(r.asset_id for r in chunk)}: "
                                 f"{type(error).__name__}: {error}") from error
        run_logger(logger).warning("computing %s in a worker failed (%s: %s); computing them "
                                   "in the flow's process",
                                   ", ".join(r.asset_id for r in chunk),
                                   type(error).__name__, error)
        here = job.planner()(config, list(chunk), **job.options, registry=commit.registry,
                             clock=clock)
        execute(config, here, clock)
        return [j.result for j in here.jobs]
    clock.add(stages)
    return items


def _alone(pool: ComputePool, job: BatchJob, ref: AssetRef, first: BaseException,
           clock: StageClock) -> list:
    """One asset of a chunk whose worker died, computed alone in a new worker: its items,
    or its failed result when its worker dies again."""
    try:
        items, stages = _submit(pool, job, [ref]).result()
    except BrokenProcessPool as error:
        pool.restart()
        failed = AssetResult(ref.asset_id, ref.vehicle_class, FAILED, error=describe_error(
            RuntimeError(f"asset {ref.asset_id!r}: its compute worker died twice "
                         f"({type(first).__name__}: {first}; then {error}): not analysed, "
                         f"its watermark kept")))
        return [failed]
    clock.add(stages)
    return items
