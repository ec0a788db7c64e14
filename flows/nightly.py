"""The nightly fleet run: every asset's new telemetry against its baseline.

For every asset with whole windows past its watermark (see :mod:`flows.fleet`): read and
validate each window, refit the tiers with the baseline's frozen structure (all of a batch's
networks in one batched computation), record the candidate in the registry with its drift,
write the alerts, then advance the watermark. Per group of assets the order is

1. record every candidate run and version (idempotent on asset, window, role, data hash),
2. append the group's alerts to the JSON-lines file (idempotent on asset, window, channel,
   tier),
3. advance each asset's watermark to the end of its last committed window,

so an interruption anywhere leaves the watermark before anything not fully committed, and the
rerun repeats it without duplicates.

Failures: an asset whose telemetry is bad (:class:`graybox.exceptions.TelemetryError`) or
whose fit fails stops at that window: the windows before it are committed, the watermark
stays at the start of the bad window, the error (asset, file, row) is in the run summary,
and the other assets go on. The next run retries the same window (fix the file, or move it
aside as ``.<name>``: dot-files are ignored). An asset without a baseline is skipped as
"no baseline". Transient errors (registry locked or unreachable, I/O) stop the batch, which
Prefect retries (``[nightly] retries``); after the last retry its unfinished assets are
reported failed and the other batches go on.

The Prefect flow :func:`nightly` is thin: one task per batch of ``[nightly] batch_size``
assets (not per asset: thousands of task runs overwhelm a Prefect server), a table
artifact of the night, and notification hooks. Its final state is Failed when an asset
failed (the return value still holds the whole summary). Inside a batch, assets are read
and fitted in groups within ``[nightly] memory_budget`` (:mod:`flows.memory`); the order
above holds per group.
"""
from __future__ import annotations

from typing import Sequence

import pandas as pd
from prefect import flow, task
from prefect.cache_policies import NO_CACHE

from graybox.stage_clock import StageClock, timed
from graybox.telemetry import list_dates

from flows.alerts import AlertLog
from flows.batching import (batch_task_body, guard_asset_error, retry_transient,
                            run_over_fleet)
from flows.config import FleetConfig, NightlySettings, load_config
from flows.fleet import AssetRef, pending_windows, utc
from flows.hooks import notify_hook
from flows.memory import MemoryBudget
from flows.pipeline import (PendingAsset, asset_done, fit_candidates, loader, memory_groups,
                            read_against, record_candidates)
from flows.report import flow_result
from flows.run_guard import exclusive_run
from flows.results import (FAILED, NO_BASELINE, OK, UP_TO_DATE, AssetResult,
                           RunSummary, TransientError, describe_error, is_transient, now_iso)


def select(config: FleetConfig, registry, ref: AssetRef, as_of: pd.Timestamp,
           clock: StageClock | None = None) -> tuple[AssetResult, PendingAsset | None]:
    """An asset's result so far and, when it has whole windows past its watermark, those
    windows read against its baseline (None when there is nothing to fit)."""
    asset = ref.asset_id
    window = config.nightly.window_delta
    before = None
    try:
        with timed(clock, "registry"):
            watermark = registry.watermark(asset)
        before = None if watermark is None else watermark.isoformat()
        dates = list_dates(config.telemetry_root, asset)
        if watermark is not None and not pending_windows(dates, watermark, as_of, window):
            # nothing new: no need to load the baseline
            return AssetResult(asset, ref.vehicle_class, UP_TO_DATE, watermark_before=before,
                               watermark_after=before), None
        with timed(clock, "registry"):
            loaded = registry.baseline(asset)
    except Exception as error:  # noqa: BLE001 - one asset never stops the batch
        guard_asset_error(error, ref, "looking up its watermark, telemetry and baseline")
        return AssetResult(asset, ref.vehicle_class, FAILED, watermark_before=before,
                           watermark_after=before, error=describe_error(error)), None
    if loaded is None:
        return AssetResult(asset, ref.vehicle_class, NO_BASELINE, watermark_before=before,
                           watermark_after=before,
                           note="no baseline: fit and promote one "
                                "(fleet-health baseline fit ... --promote)"), None
    result = AssetResult(asset, ref.vehicle_class, OK, watermark_before=before,
                         watermark_after=before, baseline_version=loaded.version)
    start_after = watermark if watermark is not None else utc(loaded.info.window_end)
    bounds = pending_windows(dates, start_after, as_of, window)
    pending = read_against(config, ref, result, loaded, bounds, stop_at_error=True, clock=clock)
    if pending is None:
        return result, None
    if not pending.windows:
        if pending.stop is not None:
            pending.fail(pending.stop, pending.stop_start)
        else:
            result.status = UP_TO_DATE
        return result, None
    return result, pending


def process_batch(config: FleetConfig, refs: Sequence[AssetRef], as_of, registry=None,
                  clock: StageClock | None = None) -> list[AssetResult]:
    """Process one batch of assets up to ``as_of`` (see the module docstring).

    Returns
    -------
    list of AssetResult
        One per asset, in the order given.

    Raises
    ------
    TransientError
        When the registry or file system failed transiently (retry the batch: everything
        committed so far is kept and not repeated).
    """
    registry = registry or config.registry()
    as_of = utc(as_of)
    results: dict[str, AssetResult] = {}
    log = AlertLog(config.alerts.jsonl)
    load = loader(results, lambda ref: select(config, registry, ref, as_of, clock),
                  _progress_text)
    budget = MemoryBudget.for_batch(config.nightly.memory_budget, baseline=False)
    for group in memory_groups(refs, load, budget):
        fit_candidates(group, clock)
        # 1. every candidate recorded, 2. the group's alerts in the file, 3. watermarks
        alerts = [alert for pending in group for alert in record_candidates(
            config, registry, pending, reanalysis=False, stop_at_error=True, clock=clock)]
        try:
            with timed(clock, "alerts"):
                log.append(alerts)
        except Exception as error:  # noqa: BLE001
            if is_transient(error):
                raise TransientError(f"alerts file {log.path}: {error}") from error
            raise
        for pending in group:
            _commit_watermark(registry, pending, clock)
            asset_done(pending.result, _progress_text)
    return [results[ref.asset_id] for ref in refs]


def _commit_watermark(registry, pending: PendingAsset, clock: StageClock | None) -> None:
    result = pending.result
    if pending.committed_end is not None:
        try:
            with timed(clock, "registry"):
                result.watermark_after = registry.commit_watermark(
                    pending.asset_id, pending.committed_end).isoformat()
        except Exception as error:  # noqa: BLE001
            guard_asset_error(error, pending.ref, "advancing its watermark")
            pending.fail(error)
    if result.status == OK and not result.windows:
        result.status = UP_TO_DATE


def _progress_text(result: AssetResult) -> str:
    if result.status == FAILED:
        return f"{result.asset_id} FAILED"
    alarms = sum(1 for w in result.windows if w.alarm)
    return f"{result.asset_id} {result.status}" + (f", {alarms} alarmed" if alarms else "")


# -- Prefect ---------------------------------------------------------------------------------

@task(name="nightly-batch", cache_policy=NO_CACHE, retries=NightlySettings().retries,
      retry_delay_seconds=NightlySettings().retry_delay_seconds,
      retry_condition_fn=retry_transient,
      task_run_name="nightly {label}")
def nightly_batch(config_path: str, tracking_uri: str | None, refs: list[dict], as_of: str,
                  label: str) -> dict:
    """One batch of assets (a Prefect task: retried on transient errors)."""
    return batch_task_body(process_batch, config_path, tracking_uri, refs, as_of)


def run_nightly(config: FleetConfig, config_path: str, tracking_uri: str | None = None,
                as_of=None, assets: Sequence[str] | None = None,
                vehicle_class: str | None = None) -> RunSummary:
    """The nightly pass as plain Python calling the batch task (the flow's body)."""
    as_of_ts = utc(as_of) if as_of is not None else pd.Timestamp.now(tz="UTC")
    summary = RunSummary("nightly", now_iso(), as_of=as_of_ts.isoformat(),
                         config=str(config.path), tracking_uri=config.tracking_uri)
    return run_over_fleet(summary, nightly_batch, config,
                          (config_path, tracking_uri, as_of_ts.isoformat()),
                          f"nightly run (as of {as_of_ts:%Y-%m-%d %H:%M} UTC)", assets,
                          vehicle_class)


@flow(name="fleet-health-nightly", on_completion=[notify_hook], on_failure=[notify_hook],
      on_crashed=[notify_hook])
def nightly(config_path: str = "fleet.toml", as_of: str | None = None,
            assets: list[str] | None = None, vehicle_class: str | None = None,
            tracking_uri: str | None = None):
    """Nightly fleet run: every asset's new whole windows against its baseline.

    Parameters
    ----------
    config_path : str
        The fleet.toml (relative to the working directory).
    as_of : str, optional
        Process windows ending by this instant (default: now).
    assets : list of str, optional
        Only these assets.
    vehicle_class : str, optional
        Only this vehicle class.
    tracking_uri : str, optional
        Overrides ``[mlflow] tracking_uri``.

    Returns
    -------
    dict
        The run summary (:class:`flows.results.RunSummary` as a dict). The flow run ends
        Failed when an asset failed; the summary is its result either way.
    """
    config = load_config(config_path).with_tracking_uri(tracking_uri)
    with exclusive_run(config, "nightly") as guarded:
        summary = guarded.annotate(run_nightly(config, config_path, tracking_uri, as_of,
                                               assets, vehicle_class))
    names = ", ".join(a.asset_id for a in summary.failed[:10])
    return flow_result(summary, config, f"{len(summary.failed)} of {len(summary.assets)} assets "
                                        f"failed: {names}")
