"""Ad-hoc reanalysis: any assets and time range against the baseline or a named version.

The range ``[start, end)`` is cut at window boundaries (``[nightly] window``, aligned to UTC
midnight; partial windows at the edges are kept, and their epsilon is scaled up for their
fewer samples). Each window is refitted with the reference version's frozen structure and
compared with it, exactly as the nightly run does, and recorded as a **reanalysis run**
(MLflow run tagged ``fleet_health.reanalysis=true``, linked to the reference version): no
model version is registered, no alias moves, no watermark moves, and neither the nightly
alert file nor :meth:`registry.Registry.alerts` sees it. Running the same reanalysis again
finds the same runs.

A bad window (bad telemetry, failed fit) is reported with its reason and the other windows
go on; the asset then counts as failed (exit status 1).
"""
from __future__ import annotations

import logging
from typing import Sequence

from prefect import flow, task
from prefect.cache_policies import NO_CACHE

from flows import progress
from flows.alerts import alerts_from_drift
from flows.config import FleetConfig, load_config
from flows.fitting import baseline_model, fit_candidates, grid_for, max_ratio
from flows.fleet import AssetRef, discover, range_windows, utc
from flows.hooks import notify_hook
from flows.nightly import batch_failed, retry_transient, run_batches
from flows.report import flow_result
from flows.results import (FAILED, NO_TELEMETRY, OK, AssetResult, RunSummary, TransientError,
                           WindowResult, describe_error, is_transient, now_iso)

logger = logging.getLogger(__name__)


def _reference(version):
    """A version number or alias as given on the command line (default: the baseline)."""
    if version is None or version == "":
        return "baseline"
    text = str(version)
    return int(text) if text.isdigit() else text


def process_reanalysis_batch(config: FleetConfig, refs: Sequence[AssetRef], start, end,
                             version=None, registry=None) -> list[AssetResult]:
    """Reanalyse one batch of assets over ``[start, end)`` against ``version``."""
    from graybox.drift import compute_drift
    from graybox.estimator import FitRequest
    from graybox.exceptions import GrayBoxError, TelemetryError
    from graybox.telemetry import read_window

    registry = registry or config.registry()
    windows = range_windows(utc(start), utc(end), config.nightly.window_delta, whole_only=False)
    results: dict[str, AssetResult] = {}
    work = []
    for ref in refs:
        asset = ref.asset_id
        try:
            loaded = registry.load_version(asset, _reference(version))
        except Exception as error:  # noqa: BLE001
            if is_transient(error):
                raise TransientError(f"asset {asset}: loading version {version}: {error}") \
                    from error
            results[asset] = AssetResult(asset, ref.vehicle_class, FAILED,
                                         error=describe_error(error))
            continue
        result = AssetResult(asset, ref.vehicle_class, OK, baseline_version=loaded.version)
        if loaded.calibration is None:
            result.note = (f"v{loaded.version} has no calibration: zeta is reported without "
                           f"epsilon (no alarms)")
        model = baseline_model(loaded.signature)
        grid = grid_for(config.classes[ref.vehicle_class].grid, loaded.signature)
        read = []
        for s, e in windows:
            try:
                read.append((s, e, read_window(config.telemetry_root, asset,
                                               model.required_columns, start=s, end=e,
                                               policy=grid)))
            except TelemetryError as error:
                if error.kind == "no_data":
                    continue
                if result.error is None:
                    result.status = FAILED
                    result.error = describe_error(error, s)
        results[asset] = result
        work.append((ref, loaded, model, read))
    requests = [((ref.asset_id, i), FitRequest(model, [tw], baseline=loaded.signature,
                                               asset_id=ref.asset_id))
                for ref, loaded, model, read in work for i, (_, _, tw) in enumerate(read)]
    fits = fit_candidates(requests) if requests else {}
    for ref, loaded, model, read in work:
        asset = ref.asset_id
        result = results[asset]
        for i, (s, e, tw) in enumerate(read):
            signature = fits[(asset, i)]
            if isinstance(signature, GrayBoxError):
                if result.error is None:
                    result.status = FAILED
                    result.error = describe_error(signature, s)
                continue
            try:
                drift = compute_drift(signature, loaded.signature, loaded.calibration)
                from registry.submission import FitSubmission
                record = registry.record_fit(FitSubmission(
                    asset, ref.vehicle_class, signature, role="candidate", drift=drift,
                    window=tw, window_start=s, window_end=e, baseline_version=loaded.version,
                    plots=config.nightly.plots == "all"
                    or (config.nightly.plots == "alarms" and drift.alarmed),
                    reanalysis=True))
            except Exception as error:  # noqa: BLE001
                if is_transient(error):
                    raise TransientError(f"asset {asset}: recording: {error}") from error
                if result.error is None:
                    result.status = FAILED
                    result.error = describe_error(error, s)
                continue
            alerts = alerts_from_drift(
                drift, asset_id=asset, vehicle_class=ref.vehicle_class,
                window_start=record.window_start, window_end=record.window_end, version=None,
                baseline_version=loaded.version, run_id=record.run_id,
                major_ratio=config.alerts.major_ratio,
                critical_ratio=config.alerts.critical_ratio, source="reanalysis")
            result.alerts += [a.to_dict() for a in alerts]
            result.windows.append(WindowResult(record.window_start, record.window_end, None,
                                               record.run_id, drift.alarmed, max_ratio(drift),
                                               record.created))
    out = [results[ref.asset_id] for ref in refs]
    for result in out:
        progress.advance(1, f"{result.asset_id} {result.status}")
    return out


@task(name="reanalysis-batch", cache_policy=NO_CACHE, retries=2, retry_delay_seconds=30,
      retry_condition_fn=retry_transient,
      task_run_name="reanalyze {label}")
def reanalysis_batch(config_path: str, tracking_uri: str | None, refs: list[dict], start: str,
                     end: str, version: str | None, label: str) -> list[dict]:
    config = load_config(config_path).with_tracking_uri(tracking_uri)
    results = process_reanalysis_batch(config, [AssetRef(**r) for r in refs], start, end,
                                       version)
    return [r.to_dict() for r in results]


def run_reanalysis(config: FleetConfig, config_path: str, start, end,
                   tracking_uri: str | None = None, assets: Sequence[str] | None = None,
                   vehicle_class: str | None = None, version=None) -> RunSummary:
    """The reanalysis flow's body."""
    range_windows(utc(start), utc(end), config.nightly.window_delta, whole_only=False)
    summary = RunSummary("reanalyze", now_iso(), config=str(config.path),
                         tracking_uri=config.tracking_uri,
                         extra={"start": utc(start).isoformat(), "end": utc(end).isoformat(),
                                "version": str(_reference(version))})
    fleet = discover(config, assets, vehicle_class)
    summary.unmatched = list(fleet.unmatched)
    progress.start(f"reanalysis ({utc(start):%Y-%m-%d %H:%M} → {utc(end):%Y-%m-%d %H:%M})",
                   len(fleet.assets))
    summary.assets = run_batches(reanalysis_batch, config, fleet.assets,
                                 (config_path, tracking_uri, utc(start).isoformat(),
                                  utc(end).isoformat(),
                                  None if version is None else str(version)), batch_failed)
    summary.assets += [AssetResult(r.asset_id, r.vehicle_class, NO_TELEMETRY,
                                   note="no telemetry in the store")
                       for r in fleet.without_telemetry]
    summary.finished = now_iso()
    return summary


@flow(name="fleet-health-reanalyze", on_completion=[notify_hook], on_failure=[notify_hook],
      on_crashed=[notify_hook])
def reanalyze(start: str, end: str, assets: list[str] | None = None,
              config_path: str = "fleet.toml", vehicle_class: str | None = None,
              version: str | None = None, tracking_uri: str | None = None):
    """Reanalyse assets over ``[start, end)`` against their baseline or a named version.

    Parameters
    ----------
    start, end : str
        Dates or ISO timestamps (UTC; end exclusive).
    assets : list of str, optional
        The assets (default: every asset, or every asset of ``vehicle_class``).
    config_path : str
    vehicle_class : str, optional
    version : str, optional
        A version number or alias (default ``baseline``).
    tracking_uri : str, optional

    Returns
    -------
    dict
        The run summary; the flow run ends Failed when an asset failed.
    """
    config = load_config(config_path).with_tracking_uri(tracking_uri)
    summary = run_reanalysis(config, config_path, start, end, tracking_uri, assets,
                             vehicle_class, version)
    return flow_result(summary, config,
                       f"{len(summary.failed)} of {len(summary.assets)} assets failed")
