"""Baselines: fit a calibrated baseline from a healthy range, per asset, list or class.

For each asset, the whole windows (``[nightly] window``, one UTC day by default) inside
``[start, end)`` are read and validated; any bad telemetry fails the asset (bad data never
enters a baseline), and windows without any data are left out. At least three windows are
needed: epsilon is calibrated from them at ``[alerts] false_alarm_rate``. All the batch's
assets are fitted together (:func:`graybox.estimator.fit_baselines`), each recorded as a
``role=baseline`` fit with its calibration, which takes the ``candidate`` alias. With
``promote`` (``fleet-health baseline fit ... --promote --reason TEXT``) it becomes the
``baseline`` at once; otherwise review it in the MLflow UI and promote it with
``fleet-health baseline promote``.

Recording is idempotent: fitting the same range again (same data) returns the same version.
Watermarks are not moved: a new asset's first nightly run starts at the end of its
baseline's window.
"""
from __future__ import annotations

from typing import Sequence

import pandas as pd
from prefect import flow, task
from prefect.cache_policies import NO_CACHE

from flows import progress
from flows.config import FleetConfig, load_config
from flows.fitting import fit_baseline_requests, read_windows
from flows.fleet import AssetRef, UsageError, discover, range_windows, utc
from flows.hooks import notify_hook
from flows.nightly import batch_failed, guard_asset_error, retry_transient, run_batches
from flows.report import flow_result
from flows.results import (FAILED, NO_TELEMETRY, OK, AssetResult, RunSummary, TransientError,
                           WindowResult, describe_error, is_transient, now_iso)

MIN_WINDOWS = 3


def baseline_windows(config: FleetConfig, start, end) -> list[tuple[pd.Timestamp, pd.Timestamp]]:
    """The whole windows of ``[start, end)``; at least :data:`MIN_WINDOWS` of them.

    Raises
    ------
    UsageError
    """
    windows = range_windows(utc(start), utc(end), config.nightly.window_delta, whole_only=True)
    if len(windows) < MIN_WINDOWS:
        raise UsageError(f"a baseline needs at least {MIN_WINDOWS} whole windows of "
                         f"{config.nightly.window} (to calibrate epsilon); "
                         f"[{utc(start):%Y-%m-%d %H:%M}, {utc(end):%Y-%m-%d %H:%M}) holds "
                         f"{len(windows)}")
    return windows


def process_baseline_batch(config: FleetConfig, refs: Sequence[AssetRef], start, end,
                           promote: bool = False, reason: str | None = None,
                           registry=None) -> list[AssetResult]:
    """Fit, record and optionally promote baselines for one batch of assets.

    Raises
    ------
    TransientError
        When the registry failed transiently (the batch can be retried: recorded fits are
        found again, not duplicated).
    """
    from graybox.estimator import FitRequest
    from graybox.exceptions import GrayBoxError, InsufficientDataError

    registry = registry or config.registry()
    windows = baseline_windows(config, start, end)
    results: dict[str, AssetResult] = {}
    items, reads = [], {}
    for ref in refs:
        asset = ref.asset_id
        vehicle_class = config.classes[ref.vehicle_class]
        try:
            model = vehicle_class.load_model()
            read = read_windows(config.telemetry_root, asset, model.required_columns,
                                vehicle_class.grid, windows)
        except Exception as error:  # noqa: BLE001
            if is_transient(error):
                raise TransientError(f"asset {asset}: reading: {error}") from error
            results[asset] = AssetResult(asset, ref.vehicle_class, FAILED,
                                         error=describe_error(error))
            continue
        if read.error is not None:
            results[asset] = AssetResult(asset, ref.vehicle_class, FAILED,
                                         error=describe_error(read.error, read.error_start),
                                         note="bad telemetry never enters a baseline")
            continue
        if len(read.windows) < MIN_WINDOWS:
            error = InsufficientDataError(
                f"asset {asset!r}: only {len(read.windows)} window(s) with telemetry in the "
                f"range; a baseline needs at least {MIN_WINDOWS}")
            results[asset] = AssetResult(asset, ref.vehicle_class, FAILED,
                                         error=describe_error(error))
            continue
        reads[asset] = read
        items.append((asset, FitRequest(model, [tw for _, _, tw in read.windows],
                                        asset_id=asset), vehicle_class.settings))
    fits = fit_baseline_requests(items, config.alerts.false_alarm_rate) if items else {}
    for ref in refs:
        asset = ref.asset_id
        if asset in results:
            continue
        fit = fits[asset]
        if isinstance(fit, GrayBoxError):
            results[asset] = AssetResult(asset, ref.vehicle_class, FAILED,
                                         error=describe_error(fit))
            continue
        signature, calibration = fit
        read = reads[asset]
        first, last = read.windows[0], read.windows[-1]
        try:
            from registry.submission import FitSubmission
            record = registry.record_fit(FitSubmission(
                asset, ref.vehicle_class, signature, role="baseline", calibration=calibration,
                window=[tw for _, _, tw in read.windows], window_start=first[0],
                window_end=last[1], plots=config.nightly.plots != "none"))
            version = None
            if promote:
                info = registry.promote(asset, record.version, reason=reason)
                note = f"v{info.version} promoted to baseline"
                version = info.version
            else:
                model = registry.backend.registered_model(asset)
                aliases = {k: int(v) for k, v in ((model.aliases or {}) if model else {}).items()}
                if aliases.get("baseline") == record.version:
                    note = f"v{record.version} (recorded before) is already the baseline"
                    version = record.version
                elif aliases.get("candidate") == record.version:
                    note = (f"v{record.version} is the candidate; review it, then "
                            f"`fleet-health baseline promote {asset} --version "
                            f"{record.version} --reason ...`")
                else:
                    note = (f"v{record.version} (recorded before); promote it with "
                            f"`fleet-health baseline promote {asset} --version "
                            f"{record.version} --reason ...`")
        except Exception as error:  # noqa: BLE001
            guard_asset_error(error, ref, "recording")
            results[asset] = AssetResult(asset, ref.vehicle_class, FAILED,
                                         error=describe_error(error))
            continue
        windows_used = ", ".join(f"{s:%Y-%m-%d}" for s, _, _ in read.windows)
        results[asset] = AssetResult(
            asset, ref.vehicle_class, OK, baseline_version=version,
            windows=[WindowResult(record.window_start, record.window_end, record.version,
                                  record.run_id, False, None, record.created)],
            note=f"{note} (windows {windows_used})")
    out = [results[ref.asset_id] for ref in refs]
    for result in out:
        progress.advance(1, f"{result.asset_id} {result.status}")
    return out


@task(name="baseline-batch", cache_policy=NO_CACHE, retries=2, retry_delay_seconds=30,
      retry_condition_fn=retry_transient,
      task_run_name="baseline {label}")
def baseline_batch(config_path: str, tracking_uri: str | None, refs: list[dict], start: str,
                   end: str, promote: bool, reason: str | None, label: str) -> list[dict]:
    """One batch of baseline fits (a Prefect task: retried on transient errors)."""
    config = load_config(config_path).with_tracking_uri(tracking_uri)
    results = process_baseline_batch(config, [AssetRef(**r) for r in refs], start, end,
                                     promote, reason)
    return [r.to_dict() for r in results]


def run_baseline(config: FleetConfig, config_path: str, start, end,
                 tracking_uri: str | None = None, assets: Sequence[str] | None = None,
                 vehicle_class: str | None = None, promote: bool = False,
                 reason: str | None = None) -> RunSummary:
    """The baseline flow's body (plain Python calling the batch task)."""
    if promote and not (reason and reason.strip()):
        raise UsageError("--promote needs --reason (it is recorded with the promotion)")
    baseline_windows(config, start, end)   # fail early on a too-short range
    summary = RunSummary("baseline", now_iso(), config=str(config.path),
                         tracking_uri=config.tracking_uri,
                         extra={"start": utc(start).isoformat(), "end": utc(end).isoformat(),
                                "promote": promote})
    fleet = discover(config, assets, vehicle_class)
    summary.unmatched = list(fleet.unmatched)
    progress.start(f"baseline fits ({utc(start):%Y-%m-%d} → {utc(end):%Y-%m-%d})",
                   len(fleet.assets))
    summary.assets = run_batches(baseline_batch, config, fleet.assets,
                                 (config_path, tracking_uri, utc(start).isoformat(),
                                  utc(end).isoformat(), promote, reason), batch_failed)
    summary.assets += [AssetResult(r.asset_id, r.vehicle_class,
                                   FAILED if assets else NO_TELEMETRY,
                                   error=describe_error(RuntimeError("no telemetry in the store"))
                                   if assets else None,
                                   note=None if assets else "no telemetry in the store")
                       for r in fleet.without_telemetry]
    summary.finished = now_iso()
    return summary


@flow(name="fleet-health-baseline", on_completion=[notify_hook], on_failure=[notify_hook],
      on_crashed=[notify_hook])
def baseline(start: str, end: str, config_path: str = "fleet.toml",
             assets: list[str] | None = None, vehicle_class: str | None = None,
             promote: bool = False, reason: str | None = None,
             tracking_uri: str | None = None):
    """Fit calibrated baselines from the healthy range ``[start, end)``.

    Parameters
    ----------
    start, end : str
        The healthy range (dates or ISO timestamps, UTC; end exclusive).
    config_path : str
    assets : list of str, optional
        Only these assets (default: every asset of the fleet, or of ``vehicle_class``).
    vehicle_class : str, optional
    promote : bool
        Make each new fit the baseline at once (needs ``reason``).
    reason : str, optional
    tracking_uri : str, optional

    Returns
    -------
    dict
        The run summary; the flow run ends Failed when an asset failed.
    """
    config = load_config(config_path).with_tracking_uri(tracking_uri)
    summary = run_baseline(config, config_path, start, end, tracking_uri, assets,
                           vehicle_class, promote, reason)
    return flow_result(summary, config,
                       f"{len(summary.failed)} of {len(summary.assets)} baselines failed")
