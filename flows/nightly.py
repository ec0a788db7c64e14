"""The nightly fleet run: every asset's new telemetry against its baseline.

For every asset with whole windows past its watermark (see :mod:`flows.fleet`): read and
validate each window, refit the tiers with the baseline's frozen structure (all of a batch's
networks in one batched computation), record the candidate in the registry with its drift,
write the alerts, then advance the watermark. Per batch of assets the order is

1. record every candidate run and version (idempotent on asset, window, role, data hash),
2. append the batch's alerts to the JSON-lines file (idempotent on asset, window, channel,
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
failed (the return value still holds the whole summary).
"""
from __future__ import annotations

import logging
from dataclasses import asdict
from typing import Sequence

import pandas as pd
from prefect import flow, task
from prefect.cache_policies import NO_CACHE

from flows import progress
from flows.alerts import AlertLog, alerts_from_drift
from flows.config import FleetConfig, load_config
from flows.fitting import (baseline_model, fit_candidates, grid_for, max_ratio,
                           read_windows)
from flows.fleet import AssetRef, batches, discover, pending_windows, utc
from flows.hooks import notify_hook
from flows.report import flow_result
from flows.results import (FAILED, NO_BASELINE, NO_TELEMETRY, OK, UP_TO_DATE, AssetResult,
                           RunSummary, TransientError, WindowResult, describe_error,
                           is_transient, now_iso)

logger = logging.getLogger(__name__)


# -- the plain functions ----------------------------------------------------------------------

def _failed(ref: AssetRef, error: BaseException, window_start=None, **fields) -> AssetResult:
    return AssetResult(ref.asset_id, ref.vehicle_class, FAILED,
                       error=describe_error(error, window_start), **fields)


def guard_asset_error(error: BaseException, ref: AssetRef, what: str) -> None:
    """Re-raise transient errors (the batch is retried); log the unexpected."""
    if is_transient(error):
        raise TransientError(f"asset {ref.asset_id}: {what}: {type(error).__name__}: "
                             f"{error}") from error
    from graybox.exceptions import GrayBoxError
    from registry.exceptions import RegistryError

    if not isinstance(error, (GrayBoxError, RegistryError)):
        logger.exception("asset %s: unexpected error while %s", ref.asset_id, what)


def _plots(policy: str, alarmed: bool) -> bool:
    return policy == "all" or (policy == "alarms" and alarmed)


def process_batch(config: FleetConfig, refs: Sequence[AssetRef], as_of,
                  registry=None) -> list[AssetResult]:
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
    from graybox.drift import compute_drift
    from graybox.estimator import FitRequest
    from graybox.exceptions import GrayBoxError
    from graybox.telemetry import list_dates

    registry = registry or config.registry()
    as_of = utc(as_of)
    window = config.nightly.window_delta
    results: dict[str, AssetResult] = {}
    work = []        # (ref, loaded baseline, ReadResult, watermark)
    for ref in refs:
        asset = ref.asset_id
        try:
            watermark = registry.watermark(asset)
            before = None if watermark is None else watermark.isoformat()
            if watermark is not None and not pending_windows(
                    list_dates(config.telemetry_root, asset), watermark, as_of, window):
                # nothing new: no need to load the baseline
                results[asset] = AssetResult(asset, ref.vehicle_class, UP_TO_DATE,
                                             watermark_before=before, watermark_after=before)
                continue
            loaded = registry.baseline(asset)
        except Exception as error:  # noqa: BLE001 - one asset never stops the batch
            guard_asset_error(error, ref, "loading its baseline")
            results[asset] = _failed(ref, error)
            continue
        if loaded is None:
            results[asset] = AssetResult(asset, ref.vehicle_class, NO_BASELINE,
                                         watermark_before=before, watermark_after=before,
                                         note="no baseline: fit and promote one "
                                              "(fleet-health baseline fit ... --promote)")
            continue
        version = loaded.version
        start_after = watermark if watermark is not None else utc(loaded.info.window_end)
        try:
            dates = list_dates(config.telemetry_root, asset)
            pending = pending_windows(dates, start_after, as_of, window)
            vehicle_class = config.classes[ref.vehicle_class]
            model = baseline_model(loaded.signature)
            read = read_windows(config.telemetry_root, asset, model.required_columns,
                                grid_for(vehicle_class.grid, loaded.signature), pending)
        except Exception as error:  # noqa: BLE001
            guard_asset_error(error, ref, "reading its telemetry")
            results[asset] = _failed(ref, error, watermark_before=before,
                                     watermark_after=before, baseline_version=version)
            continue
        if not read.windows and read.error is None:
            results[asset] = AssetResult(asset, ref.vehicle_class, UP_TO_DATE,
                                         watermark_before=before, watermark_after=before,
                                         baseline_version=version)
            continue
        work.append((ref, loaded, model, read, before))

    # one batched fit for every pending window of every asset of the batch
    requests = [((ref.asset_id, i), FitRequest(model, [tw], baseline=loaded.signature,
                                               asset_id=ref.asset_id))
                for ref, loaded, model, read, _ in work
                for i, (_, _, tw) in enumerate(read.windows)]
    fits = fit_candidates(requests) if requests else {}

    # 1. record every candidate
    log = AlertLog(config.alerts.jsonl)
    committed: dict[str, pd.Timestamp] = {}
    batch_alerts = []
    for ref, loaded, model, read, before in work:
        asset = ref.asset_id
        result = AssetResult(asset, ref.vehicle_class, OK, watermark_before=before,
                             baseline_version=loaded.version)
        results[asset] = result
        stop = read.error
        stop_start = read.error_start
        for i, (start, end, tw) in enumerate(read.windows):
            signature = fits[(asset, i)]
            if isinstance(signature, GrayBoxError):
                stop, stop_start = signature, start
                break
            try:
                drift = compute_drift(signature, loaded.signature, loaded.calibration)
                from registry.submission import FitSubmission
                record = registry.record_fit(FitSubmission(
                    asset, ref.vehicle_class, signature, role="candidate", drift=drift,
                    window=tw, window_start=start, window_end=end,
                    baseline_version=loaded.version,
                    plots=_plots(config.nightly.plots, drift.alarmed)))
            except Exception as error:  # noqa: BLE001
                guard_asset_error(error, ref, f"recording the window from {start.isoformat()}")
                stop, stop_start = error, start
                break
            alerts = alerts_from_drift(
                drift, asset_id=asset, vehicle_class=ref.vehicle_class,
                window_start=record.window_start, window_end=record.window_end,
                version=record.version, baseline_version=loaded.version, run_id=record.run_id,
                major_ratio=config.alerts.major_ratio,
                critical_ratio=config.alerts.critical_ratio)
            batch_alerts += alerts
            result.alerts += [a.to_dict() for a in alerts]
            result.windows.append(WindowResult(record.window_start, record.window_end,
                                               record.version, record.run_id, drift.alarmed,
                                               max_ratio(drift), record.created))
            committed[asset] = end
        if stop is not None:
            result.status = FAILED
            result.error = describe_error(stop, stop_start)

    # 2. the alerts file, once for the batch
    try:
        log.append(batch_alerts)
    except Exception as error:  # noqa: BLE001
        if is_transient(error):
            raise TransientError(f"alerts file {log.path}: {error}") from error
        raise

    # 3. watermarks, only now that runs, versions and alerts are committed
    for ref, _, _, _, before in work:
        asset = ref.asset_id
        result = results[asset]
        if asset in committed:
            try:
                result.watermark_after = registry.commit_watermark(asset,
                                                                   committed[asset]).isoformat()
            except Exception as error:  # noqa: BLE001
                guard_asset_error(error, ref, "advancing its watermark")
                result.status = FAILED
                result.error = describe_error(error)
                result.watermark_after = before
        else:
            result.watermark_after = before
        if result.status == OK and not result.windows:
            result.status = UP_TO_DATE
    out = [results[ref.asset_id] for ref in refs]
    for result in out:
        progress.advance(1, _progress_text(result))
    return out


def _progress_text(result: AssetResult) -> str:
    if result.status == FAILED:
        return f"{result.asset_id} FAILED"
    alarms = sum(1 for w in result.windows if w.alarm)
    return f"{result.asset_id} {result.status}" + (f", {alarms} alarmed" if alarms else "")


def batch_failed(refs: Sequence[AssetRef], error: BaseException | str,
                 attempts: int) -> list[AssetResult]:
    """Results for a batch whose task failed after its retries."""
    text = error if isinstance(error, str) else f"{type(error).__name__}: {error}"
    message = (f"the batch failed after {attempts} attempt(s): {text}; windows committed "
               f"before the error are kept, the rest are retried by the next run")
    out = []
    for ref in refs:
        result = AssetResult(ref.asset_id, ref.vehicle_class, FAILED)
        result.error = describe_error(RuntimeError(message))
        out.append(result)
        progress.advance(1, f"{ref.asset_id} FAILED")
    return out


# -- Prefect ---------------------------------------------------------------------------------

def retry_transient(task_, task_run, state) -> bool:
    """``retry_condition_fn``: retry a batch only after a transient error."""
    try:
        state.result()
    except BaseException as error:  # noqa: BLE001
        return is_transient(error)
    return False


@task(name="nightly-batch", cache_policy=NO_CACHE, retries=2, retry_delay_seconds=30,
      retry_condition_fn=retry_transient,
      task_run_name="nightly {label}")
def nightly_batch(config_path: str, tracking_uri: str | None, refs: list[dict], as_of: str,
                  label: str) -> list[dict]:
    """One batch of assets (a Prefect task: retried on transient errors)."""
    config = load_config(config_path).with_tracking_uri(tracking_uri)
    results = process_batch(config, [AssetRef(**r) for r in refs], as_of)
    return [r.to_dict() for r in results]


def run_batches(task_fn, config: FleetConfig, refs: Sequence[AssetRef], args: tuple,
                on_failure) -> list[AssetResult]:
    """Call a batch task for each batch (sequentially: each batch already uses all cores);
    a batch that still fails after its retries is reported through ``on_failure``."""
    out: list[AssetResult] = []
    configured = task_fn.with_options(retries=config.nightly.retries,
                                      retry_delay_seconds=config.nightly.retry_delay_seconds)
    for batch in batches(list(refs), config.nightly.batch_size):
        payload = [asdict(r) for r in batch]
        label = (f"{batch[0].asset_id}..{batch[-1].asset_id} ({len(batch)} assets)"
                 if len(batch) > 1 else batch[0].asset_id)
        state = configured(*args[:2], payload, *args[2:], label=label, return_state=True)
        if state.is_completed():
            out += [AssetResult.from_dict(d) for d in state.result()]
        else:
            error = state.result(raise_on_failure=False)
            reason = error if isinstance(error, BaseException) else (state.message or
                                                                     state.name)
            out += on_failure(batch, reason, config.nightly.retries + 1)
    return out


def run_nightly(config: FleetConfig, config_path: str, tracking_uri: str | None = None,
                as_of=None, assets: Sequence[str] | None = None,
                vehicle_class: str | None = None) -> RunSummary:
    """The nightly pass as plain Python calling the batch task (the flow's body)."""
    as_of_ts = utc(as_of) if as_of is not None else pd.Timestamp.now(tz="UTC")
    summary = RunSummary("nightly", now_iso(), as_of=as_of_ts.isoformat(),
                         config=str(config.path), tracking_uri=config.tracking_uri)
    fleet = discover(config, assets, vehicle_class)
    summary.unmatched = list(fleet.unmatched)
    progress.start(f"nightly run (as of {as_of_ts:%Y-%m-%d %H:%M} UTC)", len(fleet.assets))
    summary.assets = run_batches(nightly_batch, config, fleet.assets,
                                 (config_path, tracking_uri, as_of_ts.isoformat()),
                                 batch_failed)
    summary.assets += [AssetResult(r.asset_id, r.vehicle_class, NO_TELEMETRY,
                                   note="no telemetry in the store")
                       for r in fleet.without_telemetry]
    summary.finished = now_iso()
    return summary


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
    summary = run_nightly(config, config_path, tracking_uri, as_of, assets, vehicle_class)
    names = ", ".join(a.asset_id for a in summary.failed[:10])
    return flow_result(summary, config, f"{len(summary.failed)} of {len(summary.assets)} assets "
                                        f"failed: {names}")
