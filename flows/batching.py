"""Batch plumbing the three flows share: one Prefect task per batch of assets, its retries,
and what a batch that still fails reports.

Every flow runs the same task (:func:`batch_task`) on a :class:`flows.batch_job.BatchJob`
naming the flow, its batch of assets and its own options. A batch task returns the job's
:class:`flows.batch_job.BatchOutput` as a dict: the assets' results and the seconds its
stages took (see :class:`graybox.stage_clock.StageClock`). Transient errors (registry locked
or unreachable, I/O) stop the batch and Prefect retries it (``[nightly] retries``); after the
last retry its assets are reported failed and the other batches go on.

Batches run one after another in the flow's process, or all at once on a Dask cluster
(``[nightly] task_runner``, :mod:`flows.task_runner`); either way the flow's results keep the
fleet's order and are the same.
"""
from __future__ import annotations

import json
import logging
from typing import Sequence

from prefect import Task, task
from prefect.cache_policies import NO_CACHE

from graybox.exceptions import GrayBoxError
from graybox.stage_clock import StageClock

from flows import progress
from flows.batch_job import BATCH_FLOWS, BatchJob, BatchOutput
from flows.config import FleetConfig, NightlySettings
from flows.discovery import AssetRef, batches, discover
from flows.results import (FAILED, NO_TELEMETRY, AssetResult, RunSummary, describe_error,
                           is_transient, now_iso)
from flows.errors import TransientError
from flows.compute_pool import active_pool, compute_pool
from flows.task_runner import SequentialBatches, batch_runner, batch_size_for
from flows.run_logger import run_logger
from registry import RegistryError

logger = logging.getLogger(__name__)

#: the flows whose batches a compute pool computes (``[nightly] processes``): those whose
#: commit needs no telemetry (a baseline's draws its plots from it)
POOLED_FLOWS = ("nightly", "reanalysis")
#: batches whose work a compute pool has before their tasks run (the running one's and the
#: next: the workers never wait for a batch task to start)
AHEAD = 2


def guard_asset_error(error: BaseException, ref: AssetRef, what: str) -> None:
    """Re-raise transient errors (the batch is retried); log the unexpected ones.

    An expected error (bad data, a failed fit, a registry refusal) is the asset's own and is
    reported in its result by the caller.
    """
    if is_transient(error):
        raise TransientError(f"asset {ref.asset_id}: {what}: {type(error).__name__}: "
                             f"{error}") from error
    if not isinstance(error, (GrayBoxError, RegistryError)):
        run_logger(logger).exception("asset %s: unexpected error while %s", ref.asset_id,
                                     what)


def retry_transient(task_, task_run, state) -> bool:
    """``retry_condition_fn``: retry a batch only after a transient error."""
    try:
        state.result()
    except BaseException as error:  # noqa: BLE001
        return is_transient(error)
    return False


def batch_task(flow: str) -> Task:
    """The Prefect task of ``flow``'s batches (:data:`flows.batch_job.BATCH_FLOWS` names it
    and its runs): it runs the :class:`~flows.batch_job.BatchJob` it is given (as a dict)
    and returns its :class:`~flows.batch_job.BatchOutput` as a dict. Never cached, retried
    only after a transient error (:func:`retry_transient`; :func:`run_over_fleet` sets the
    counts of ``[nightly] retries``)."""
    names = BATCH_FLOWS[flow]

    def run_batch(job: dict, label: str) -> dict:
        """One batch of assets (a Prefect task: retried on transient errors): its flow's
        planner plans it, :func:`flows.pipeline.execute` runs the plan."""
        from flows.pipeline import execute   # the pipeline imports this module

        clock = StageClock()
        batch = BatchJob.from_dict(job)
        pool = active_pool()
        if pool is not None and batch.flow in POOLED_FLOWS:
            from flows.pooled_execute import execute_pooled

            return BatchOutput(execute_pooled(batch, pool, clock), clock.to_dict()).to_dict()
        config, plan = batch.plan(clock)
        return BatchOutput(execute(config, plan, clock), clock.to_dict()).to_dict()

    # Dask names a task's keys after its function: one name per flow, e.g. nightly_batch
    run_batch.__name__ = run_batch.__qualname__ = f"{flow}_batch"
    return task(run_batch, name=names.task_name, cache_policy=NO_CACHE,
                retries=NightlySettings().retries,
                retry_delay_seconds=NightlySettings().retry_delay_seconds,
                retry_condition_fn=retry_transient, task_run_name=names.run_name)


def task_attempts(state, error: BaseException | str, retries: int) -> int:
    """How many times the batch task ran: its task run's ``run_count`` read from Prefect's
    API; if that cannot be read, 1 for an error that is not retried, else ``retries + 1``."""
    task_run_id = getattr(state.state_details, "task_run_id", None)
    if task_run_id is not None:
        try:
            from prefect.client.orchestration import get_client

            with get_client(sync_client=True) as client:
                return max(1, client.read_task_run(task_run_id).run_count)
        except Exception:  # noqa: BLE001 - the count is then inferred, as documented
            run_logger(logger).warning("could not read task run %s: its attempts are "
                                       "inferred", task_run_id, exc_info=True)
    transient = isinstance(error, BaseException) and is_transient(error)
    return retries + 1 if transient else 1


def batch_failed(refs: Sequence[AssetRef], error: BaseException | str,
                 attempts: int) -> list[AssetResult]:
    """Results for a batch whose task failed after ``attempts`` runs (1: not retried)."""
    text = error if isinstance(error, str) else f"{type(error).__name__}: {error}"
    how = (f"after {attempts} attempt(s)" if attempts > 1
           else "(not retried: not a transient error)")
    message = (f"the batch failed {how}: {text}; windows committed "
               f"before the error are kept, the rest are retried by the next run")
    out = []
    for ref in refs:
        out.append(AssetResult(ref.asset_id, ref.vehicle_class, FAILED,
                               error=describe_error(RuntimeError(message))))
        progress.advance(1, f"{ref.asset_id} FAILED", failed=1)
    return out


def batch_results(outcome, batch: Sequence[AssetRef], config: FleetConfig,
                  clock: StageClock, in_process: bool) -> list[AssetResult]:
    """The results of a batch whose task ended with ``outcome``: its final Prefect state, or
    the error that kept it from reporting one (its Dask worker was lost); its stage seconds
    are added to ``clock``. The progress is advanced here for a batch that ran out of this
    process (``in_process`` False: its worker's progress did not reach us) or failed."""
    if not isinstance(outcome, BaseException) and outcome.is_completed():
        output = BatchOutput.from_dict(outcome.result())
        clock.add(output.stages)
        if not in_process:
            failed = sum(1 for a in output.assets if a.status == FAILED)
            progress.advance(len(batch), f"batch {batch[0].asset_id}.."
                                         f"{batch[-1].asset_id} done", failed=failed)
        return output.assets
    if isinstance(outcome, BaseException):     # its Dask worker was lost
        return batch_failed(batch, outcome, config.nightly.retries + 1)
    error = outcome.result(raise_on_failure=False)           # a Failed state
    reason = error if isinstance(error, BaseException) else (outcome.message or outcome.name)
    return batch_failed(batch, reason, task_attempts(outcome, reason, config.nightly.retries))


def _compute_ahead(pool, job: BatchJob, parts: Sequence[Sequence[AssetRef]]) -> None:
    """Give a compute pool (if any) these batches' work before their tasks run
    (:func:`flows.pooled_execute.compute_ahead`)."""
    if pool is None:
        return
    from flows.pooled_execute import compute_ahead   # it imports the pipeline, which this

    for batch in parts:
        compute_ahead(pool, job.for_batch(batch))


def _processes(config: FleetConfig, runner, job: BatchJob, assets: int) -> int:
    """Worker processes of the run's compute pool (``[nightly] processes``; 1: none): only
    beside the sequential runner, for a flow of :data:`POOLED_FLOWS` with more than one
    asset (``"auto"``: enough of them, :meth:`NightlySettings.process_count`)."""
    if not isinstance(runner, SequentialBatches) or job.flow not in POOLED_FLOWS \
            or assets < 2:
        return 1
    return config.nightly.process_count(assets=assets)


def no_telemetry(ref: AssetRef, fails: bool = False) -> AssetResult:
    """The result of an asset listed in fleet.toml (or named by the run) without any
    telemetry in the store: ``no telemetry``, or failed when ``fails`` (a baseline asked for
    by name cannot be fitted)."""
    if fails:
        return AssetResult(ref.asset_id, ref.vehicle_class, FAILED,
                           error=describe_error(RuntimeError("no telemetry in the store")))
    return AssetResult(ref.asset_id, ref.vehicle_class, NO_TELEMETRY,
                       note="no telemetry in the store")


def run_over_fleet(summary: RunSummary, job: BatchJob, config: FleetConfig, description: str,
                   assets: Sequence[str] | None = None,
                   vehicle_class: str | None = None, missing_fails: bool = False
                   ) -> RunSummary:
    """A flow's body: discover the assets, run ``job`` on each batch of ``[nightly]
    batch_size`` of them (fewer where that leaves a cluster's slots idle,
    :func:`flows.task_runner.batch_size_for`) as a task of :func:`batch_task` with the
    runner of ``[nightly] task_runner`` (:mod:`flows.task_runner`: one after another in this
    process, or all at once on Dask), with progress, and complete ``summary``: the assets'
    results in the fleet's order whatever order the batches finish in (then the assets
    without telemetry: :func:`no_telemetry`, failed with ``missing_fails``), and the stages'
    seconds."""
    fleet = discover(config, assets, vehicle_class)
    summary.unmatched = list(fleet.unmatched)
    summary.skipped = [s.to_dict() for s in fleet.skipped]
    progress.start(description, len(fleet.assets))
    configured = batch_task(job.flow).with_options(
        retries=config.nightly.retries, retry_delay_seconds=config.nightly.retry_delay_seconds)
    clock = StageClock()
    with batch_runner(config) as runner:
        processes = _processes(config, runner, job, len(fleet.assets))
        summary.extra["processes"] = processes
        if processes > 1:
            progress.note(f"{description}: {processes} worker processes compute the "
                          f"candidates, this one records them ([nightly] processes = "
                          f"{json.dumps(config.nightly.processes)})")
        parts = batches(list(fleet.assets), batch_size_for(len(fleet.assets),
                                                           config.nightly.batch_size,
                                                           runner.slots))
        outputs: list[list[AssetResult]] = [[] for _ in parts]
        with compute_pool(processes) as pool:
            for batch in parts:
                label = (f"{batch[0].asset_id}..{batch[-1].asset_id} ({len(batch)} assets)"
                         if len(batch) > 1 else batch[0].asset_id)
                runner.submit(configured, {"job": job.for_batch(batch).to_dict(),
                                           "label": label})
            _compute_ahead(pool, job, parts[:AHEAD])
            for index, outcome in runner.completed():
                _compute_ahead(pool, job, parts[index + AHEAD:index + AHEAD + 1])
                outputs[index] = batch_results(outcome, parts[index], config, clock,
                                               runner.in_process)
    summary.assets = [result for output in outputs for result in output]
    summary.assets += [no_telemetry(ref, missing_fails) for ref in fleet.without_telemetry]
    summary.extra["stages"] = clock.to_dict()
    summary.finished = now_iso()
    return summary
