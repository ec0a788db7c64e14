"""Ad-hoc reanalysis: any assets and time range against the baseline or a named version.

The range ``[start, end)`` is cut at window boundaries (``[nightly] window``, aligned to UTC
midnight; partial windows at the edges are kept, and their epsilon is scaled up for their
fewer samples). Each window is refitted with the reference version's frozen structure and
compared with it, exactly as the nightly run does (with ``--candidate-nights N``, default
``[nightly] candidate_nights``, each window's candidate also holds the N - 1 windows before
it, never before the reference's window end, and is keyed by the whole span), and recorded as a **reanalysis run**
(MLflow run tagged ``fleet_health.reanalysis=true``, linked to the reference version): no
model version is registered, no alias moves, no watermark moves, and neither the nightly
alert file nor :meth:`registry.Registry.alerts` sees it. Running the same reanalysis again
finds the same runs.

A bad window (bad telemetry, failed fit) is reported with its reason and the other windows
go on; the asset then counts as failed (exit status 1). A reference version that cannot be
used (no calibration, so nothing could alarm; artifacts that fail verification; another model
than the class's configured one) makes the asset "unusable baseline" (exit status 1), with
the version and the fix in its note.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator, Sequence

from prefect import flow

from graybox.alert import REANALYSIS
from graybox.stage_clock import StageClock, timed

from flows.batch_job import BatchJob
from flows.batching import guard_asset_error, run_over_fleet
from flows.config import DEFAULT_CONFIG, FleetConfig, load_config
from flows.discovery import AssetRef, range_windows, utc
from flows.hooks import notify_hook
from flows.pipeline import (AssetJob, BatchPlan, CommitPolicy, PendingAsset, candidate_job,
                            configured_models, record_group)
from flows.run_tables import flow_result
from flows.results import (FAILED, OK, UNUSABLE_BASELINE, AssetResult, RunSummary,
                           describe_error, now_iso)
from registry import NotFoundError, UnusableBaselineError
from flows.run_guard import exclusive_run


def _reference(version):
    """A version number or alias as given on the command line (default: the baseline)."""
    if version is None or version == "":
        return "baseline"
    text = str(version)
    return int(text) if text.isdigit() else text


def plan_asset(config: FleetConfig, registry, ref: AssetRef, windows, version,
               clock: StageClock | None = None, nights: int = 1) -> AssetJob:
    """An asset's reanalysis job: the windows of the range against the reference version
    (nothing to do when the version cannot be loaded or used). When read, bad windows are
    reported and skipped, and the others go on."""
    asset = ref.asset_id
    try:
        with timed(clock, "registry"):
            loaded = registry.reference(asset, _reference(version),
                                        models=configured_models(config, ref))
        if loaded is None:
            raise NotFoundError(f"asset {asset!r} has no baseline version")
    except UnusableBaselineError as error:
        return AssetJob(ref, AssetResult(asset, ref.vehicle_class, UNUSABLE_BASELINE,
                                         note=str(error)))
    except Exception as error:  # noqa: BLE001
        guard_asset_error(error, ref, f"loading version {version}")
        return AssetJob(ref, AssetResult(asset, ref.vehicle_class, FAILED,
                                         error=describe_error(error)))
    result = AssetResult(asset, ref.vehicle_class, OK, baseline_version=loaded.version)
    return candidate_job(config, ref, result, loaded, windows, nights, stop_at_error=False,
                         source=REANALYSIS,
                         idle_note=f"0 windows: no telemetry in [{windows[0][0]:%Y-%m-%d %H:%M}, "
                                   f"{windows[-1][1]:%Y-%m-%d %H:%M}) UTC")


def _nights(config: FleetConfig, candidate_nights: int | None) -> int:
    """``candidate_nights`` when given (>= 1), else ``[nightly] candidate_nights``."""
    if candidate_nights is None:
        return config.nightly.candidate_nights
    if isinstance(candidate_nights, bool) or int(candidate_nights) != candidate_nights \
            or candidate_nights < 1:
        raise ValueError(f"candidate_nights must be an integer >= 1, got {candidate_nights!r}")
    return int(candidate_nights)


def plan_reanalysis_batch(config: FleetConfig, refs: Sequence[AssetRef], start, end,
                          version=None, candidate_nights: int | None = None,
                          registry=None, clock: StageClock | None = None) -> BatchPlan:
    """The reanalysis of one batch of assets over ``[start, end)`` against ``version``, each
    candidate on ``candidate_nights`` windows (default ``[nightly] candidate_nights``):
    each asset's job (:func:`plan_asset`), committed by :class:`RecordOnly`."""
    registry = registry or config.registry()
    windows = range_windows(utc(start), utc(end), config.nightly.window_delta, whole_only=False)
    nights = _nights(config, candidate_nights)
    return BatchPlan([plan_asset(config, registry, ref, windows, version, clock, nights)
                      for ref in refs], RecordOnly(config, registry, clock))


@dataclass
class RecordOnly(CommitPolicy):
    """The reanalysis commit: each asset's windows recorded as reanalysis runs (no version,
    no alias, no watermark moves)."""

    def commit(self, group: list[PendingAsset]) -> Iterator[PendingAsset]:
        record_group(self.config, self.registry, group, reanalysis=True, clock=self.clock)
        yield from group


@flow(name="fleet-health-reanalyze", on_completion=[notify_hook], on_failure=[notify_hook],
      on_crashed=[notify_hook])
def reanalyze(start: str, end: str, assets: list[str] | None = None,
              config_path: str = DEFAULT_CONFIG, vehicle_class: str | None = None,
              version: str | None = None, tracking_uri: str | None = None,
              candidate_nights: int | None = None):
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
    candidate_nights : int, optional
        Windows each candidate is fitted on (default ``[nightly] candidate_nights``).

    Returns
    -------
    dict
        The run summary; the flow run ends Failed (message: the coverage line)
        when an asset was not reanalysed.
    """
    config = load_config(config_path).with_tracking_uri(tracking_uri)
    with exclusive_run(config, "reanalyze") as guarded:
        range_windows(utc(start), utc(end), config.nightly.window_delta, whole_only=False)
        nights = _nights(config, candidate_nights)
        summary = RunSummary("reanalyze", now_iso(), config=str(config.path),
                             tracking_uri=config.tracking_uri,
                             extra={"start": utc(start).isoformat(),
                                    "end": utc(end).isoformat(),
                                    "version": str(_reference(version)),
                                    "candidate_nights": nights})
        job = BatchJob.for_fleet("reanalysis", config, tracking_uri,
                                 start=utc(start).isoformat(), end=utc(end).isoformat(),
                                 version=None if version is None else str(version),
                                 candidate_nights=nights)
        summary = guarded.annotate(run_over_fleet(
            summary, job, config,
            f"reanalysis ({utc(start):%Y-%m-%d %H:%M} → {utc(end):%Y-%m-%d %H:%M})", assets,
            vehicle_class))
    return flow_result(summary, config)
