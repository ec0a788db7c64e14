"""The nightly fleet run: every asset's new telemetry against its baseline.

For every asset with whole windows past its watermark (see :mod:`flows.discovery`): read and
validate each window, refit the tiers with the baseline's frozen structure (all of a batch's
networks in one batched computation), record the candidate in the registry with its drift
and alerts, then advance the watermark. Per group of assets the order is

1. record every candidate run and version, with its drift and alerts (idempotent on asset,
   window, role, data hash; the group's together, in one transaction on SQLite or
   PostgreSQL, each asset on its own: :func:`flows.pipeline.record_group`),
2. advance each asset's watermark to the end of its last committed window (the group's
   together, the same way),

so an interruption anywhere leaves the watermark before anything not fully committed, and the
rerun repeats it without duplicates. The registry is the alerts' system of record: the
batches (which may run on many hosts) write nothing else. After every batch,

3. the flow's own process exports the registry's alerts of the windows from the run's
   start (and from each asset's watermark minus ``[nightly] lookback``) onwards to the
   JSON-lines file (``[alerts] jsonl``; idempotent on asset, window, channel, tier;
   :func:`flows.alerts.export_alerts`),

so the file holds the run's alerts and those of an interrupted earlier run of the same
windows; a run interrupted after its last watermark and before the export (or whose export
failed: the flow run then fails, naming the file and ``fleet-health alerts --export``) leaves
the file behind the registry until the next run, which writes what was missed within the
look-back, or ``fleet-health alerts --export``.

With ``[nightly] candidate_nights = N`` (default 2) the candidate of each window is fitted
on it and the N - 1 windows before it that have telemetry (never before the baseline's
window end), and is recorded and alerted under the whole span ``(start of the first, end
of the night)``: each night still gives one candidate, a rerun finds it recorded, and the
watermark still advances one window at a time to the night's end. Epsilon is scaled to the
span's sample count (:mod:`graybox.epsilon_scaling`).

The watermark means "every window before it that had telemetry when a run passed it was
analysed"; it only moves forward. Telemetry that arrives later (a day's partition uploaded
after the run over the days around it) is found by the look-back: each run also takes the
whole windows starting in ``[watermark - [nightly] lookback, watermark)`` (default 7 days,
never before the baseline's window) that have a date partition but no recorded candidate,
and analyses them first, against the same baseline, with their alerts. Recording is
idempotent, so a rerun finds them recorded and adds nothing; a window arriving later than
the look-back is left alone (``fleet-health reanalyze`` covers any range). This costs one
registry query per asset and run (the asset's newest recorded windows). With
``candidate_nights`` > 1 the candidates of later nights already recorded are not refitted
with the late night (``fleet-health reanalyze --candidate-nights N`` does that). Days that
``fleet-health import`` added rows to are re-analysed whatever the look-back
(:mod:`flows.changed_days`).

Staleness: an asset whose newest sample is older than the as-of time minus ``[alerts]
stale_after`` (default 2 days, ``"off"`` to disable) gets the status ``stale`` (not
monitored: the run exits 1) and a ``stale`` alert (:func:`graybox.alert.stale_alert`) in its
result and the alerts file, one per (asset, newest sample), so it is not repeated nightly
while no new data arrives.

Dormancy: an asset whose new nights all ran too little to monitor is ``not operating`` (exit
status 0, its watermark moved past them); when its last monitored night (or its baseline,
when none since) ended longer than ``[alerts] not_operating_after`` before the as-of time
(default 7 days, ``"off"`` to disable) it is ``dormant`` instead: not monitored, the run
exits 1, its note says since when and what to check, and a ``dormant`` alert
(:func:`graybox.alert.dormant_alert`) goes into the alerts file once per last monitored
night (:mod:`flows.dormancy`).

Failures: an asset whose telemetry is bad (:class:`graybox.exceptions.TelemetryError`) or
whose fit fails stops at that window: the windows before it are committed, the watermark
stays at the start of the bad window, the error (asset, file, row) is in the run summary,
and the other assets go on. The next run retries the same window (fix the file, or move it
aside as ``.<name>``: dot-files are ignored). A night whose sensor reads stuck or out of range
(a sensor's fault, not the data's) also raises a ``sensor`` alert naming the channel
(:func:`graybox.alert.sensor_alert`), in the result and the alerts file, once per night. An
asset without a baseline is skipped as "no baseline". An asset whose baseline cannot be used (no calibration, e.g. the alias moved
by hand to a nightly candidate; artifacts that fail verification; another model than its
class's configured one, refused before anything is imported) is "unusable baseline": not
monitored, its watermark kept, the run's exit status 1, and its note names the version and
the command that fixes it. Transient errors (registry locked or unreachable, I/O) stop the
batch, which Prefect retries (``[nightly] retries``); after the last retry its unfinished assets are
reported failed and the other batches go on.

The Prefect flow :func:`nightly` is thin: one task per batch of ``[nightly] batch_size``
assets (not per asset: thousands of task runs overwhelm a Prefect server), a table
artifact of the night, the fleet heat map (:mod:`flows.fleet_publish`), and notification
hooks. Its final state is Failed when an asset that should be monitored was not
(failed, stale, without or with an unusable baseline, without telemetry, dormant; the
message is the run's coverage line; the return value still holds the whole summary). Inside
a batch, assets are read and fitted in groups within ``[nightly] memory_budget``
(:mod:`flows.memory`); the order above holds per group.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Iterator, Sequence

import pandas as pd
from prefect import flow

from graybox.stage_clock import StageClock, timed
from graybox.telemetry import list_dates, newest_timestamp
from graybox.telemetry.changes import changed_days, clear_changed
from graybox.alert import DORMANT as DORMANT_KIND, SENSOR as SENSOR_KIND, STALE as STALE_KIND
from graybox.alert import Alert, stale_alert

from flows.alerts import AlertLog, export_alerts
from flows.changed_days import changed_windows, days_done_by
from flows.batch_job import BatchJob
from flows.batching import guard_asset_error, run_over_fleet
from flows.errors import TransientError
from flows.config import DEFAULT_CONFIG, FleetConfig, load_config
from flows.discovery import AssetRef, not_in_future, pending_windows, utc, windows_in_dates
from flows.dormancy import settle_dormant
from flows.hooks import notify_hook
from flows.fleet_publish import publish_or_note  # noqa: I001 - apart from the line above
from flows.planning_reads import PlanningReads, versions_to_read
from flows.pipeline import (AssetJob, BatchPlan, CommitPolicy, PendingAsset, candidate_job,
                            configured_models, record_group)
from flows.run_tables import flow_result
from flows.results import (FAILED, NO_BASELINE, OK, STALE, UNUSABLE_BASELINE, UP_TO_DATE,
                           AssetResult, RunSummary, describe_error, is_transient, now_iso)
from registry import UnusableBaselineError, load_mlflow
from flows.run_guard import exclusive_run
from flows.run_logger import run_logger

# every nightly run opens the registry: its MLflow side loads with this module, so a served
# run's process, started ahead of its scheduled time (flows.serve), has it before it is due
load_mlflow()

logger = logging.getLogger(__name__)


def plan_asset(config: FleetConfig, registry, ref: AssetRef, as_of: pd.Timestamp,
               clock: StageClock | None = None, reads=None) -> AssetJob:
    """An asset's nightly job: its result so far and, when it has windows to process, those
    windows against its baseline (nothing to do when it is up to date or cannot be
    monitored). No telemetry is read: the windows come from its date partitions.

    The windows are the whole windows past its watermark and the late ones (see
    :func:`late_windows`); an asset whose newest telemetry is older than ``stale_after`` gets
    a stale alert (see :func:`staleness`). ``reads``: its batch's registry reads
    (:class:`flows.planning_reads.PlanningReads`; default: ``registry``'s, one asset at a
    time).
    """
    reads = reads or registry
    asset = ref.asset_id
    window = config.nightly.window_delta
    before = None
    try:
        with timed(clock, "registry"):
            watermark = reads.watermark(asset)
        before = None if watermark is None else watermark.isoformat()
        dates = list_dates(config.telemetry_root, asset)
        stale = staleness(config, ref, as_of)
        late = [] if watermark is None else late_windows(config, reads, asset, dates,
                                                         watermark, as_of, clock)
        marked = changed_days(config.telemetry_root, asset)
        changed = [] if watermark is None else changed_windows(marked, dates, watermark, window)
        late = sorted(set(late) | set(changed))
        if (watermark is not None and not pending_windows(dates, watermark, as_of, window)
                and (not late or (not marked and _inside_baseline(reads, asset, late,
                                                                  clock)))):
            # nothing new: no need to load the baseline
            return AssetJob(ref, _stale(AssetResult(asset, ref.vehicle_class, UP_TO_DATE,
                                                    watermark_before=before,
                                                    watermark_after=before), stale))
        with timed(clock, "registry"):
            loaded = registry.reference(asset, models=configured_models(config, ref))
    except UnusableBaselineError as error:
        return AssetJob(ref, AssetResult(asset, ref.vehicle_class, UNUSABLE_BASELINE,
                                         watermark_before=before, watermark_after=before,
                                         note=str(error)))
    except Exception as error:  # noqa: BLE001 - one asset never stops the batch
        guard_asset_error(error, ref, "looking up its watermark, telemetry and baseline")
        return AssetJob(ref, AssetResult(asset, ref.vehicle_class, FAILED,
                                         watermark_before=before, watermark_after=before,
                                         error=describe_error(error)))
    if loaded is None:
        return AssetJob(ref, _stale(AssetResult(asset, ref.vehicle_class, NO_BASELINE,
                                                watermark_before=before, watermark_after=before,
                                                note="no baseline: fit and promote one "
                                                     "(fleet-health baseline fit ... --promote)"),
                                    stale))
    result = AssetResult(asset, ref.vehicle_class, OK, watermark_before=before,
                         watermark_after=before, baseline_version=loaded.version)
    _stale(result, stale)
    baseline_end = utc(loaded.info.window_end)
    late = [(s, e) for s, e in late if s >= baseline_end]
    changed = [(s, e) for s, e in changed if s >= baseline_end]
    notes = []
    if set(late) - set(changed):
        notes.append(f"{len(set(late) - set(changed))} late window(s) before the watermark "
                     f"analysed: {_starts(sorted(set(late) - set(changed)))}")
    if changed:
        notes.append(f"{len(changed)} window(s) changed by an import re-analysed: "
                     f"{_starts(changed)}")
    in_baseline = days_done_by(marked, baseline_end)
    if in_baseline:
        clear_changed(config.telemetry_root, asset, in_baseline)
        notes.append(f"changed day(s) inside the baseline's window not re-analysed (refit the "
                     f"baseline to use them): {', '.join(map(str, in_baseline))}")
    result.note = "; ".join([*notes, *([result.note] if result.note else [])]) or None
    start_after = watermark if watermark is not None else baseline_end
    bounds = late + pending_windows(dates, start_after, as_of, window)
    return candidate_job(config, ref, result, loaded, bounds,
                         config.nightly.candidate_nights, stop_at_error=True,
                         idle_status=STALE if stale else UP_TO_DATE,
                         changed_days=tuple(days_done_by(set(marked) - set(in_baseline),
                                                         as_of)))


def _inside_baseline(registry, asset_id: str, late: list, clock: StageClock | None) -> bool:
    """Whether every late window starts before the end of the asset's baseline window (days
    the baseline was fitted on have no candidate, and are never analysed): read from the
    baseline's tags, so that an asset up to date in the first ``lookback`` after its baseline
    loads nothing (loading and verifying a baseline costs several times this look-up)."""
    with timed(clock, "registry"):
        end = registry.baseline_window_end(asset_id)
    return end is not None and all(start < utc(end) for start, _ in late)


def late_windows(config: FleetConfig, registry, asset_id: str, dates, watermark: pd.Timestamp,
                 as_of: pd.Timestamp, clock: StageClock | None = None
                 ) -> list[tuple[pd.Timestamp, pd.Timestamp]]:
    """Whole windows starting in ``[watermark - lookback, watermark)`` that have a date
    partition but no recorded candidate: telemetry that arrived after the run that moved the
    watermark past it. One registry query, only when such partitions exist.

    A night counts as recorded when a candidate ends with it and starts at most
    ``[nightly] candidate_nights - 1`` windows before it (the candidate of a multi-night
    span is keyed by the whole span)."""
    lookback = config.nightly.lookback_delta
    if lookback <= pd.Timedelta(0):
        return []
    window = config.nightly.window_delta
    earliest = watermark - lookback
    bounds = [(s, e) for s, e in windows_in_dates(dates, window)
              if earliest <= s and e <= watermark]
    if not bounds:
        return []
    with timed(clock, "registry"):
        recorded = registry.recorded_windows(asset_id, last=versions_to_read(config, watermark,
                                                                             as_of))
    starts: dict[pd.Timestamp, list[pd.Timestamp]] = {}
    for s, e in recorded:
        starts.setdefault(utc(e), []).append(utc(s))
    reach = (config.nightly.candidate_nights - 1) * window
    return [(s, e) for s, e in bounds
            if not any(s - reach <= first <= s for first in starts.get(e, ()))]


def staleness(config: FleetConfig, ref: AssetRef, as_of: pd.Timestamp) -> Alert | None:
    """A ``stale`` alert when the asset's newest sample is older than ``as_of`` minus
    ``[alerts] stale_after`` (None when it is recent, the check is off, or it has no rows)."""
    limit = config.alerts.stale_after_delta
    if limit is None:
        return None
    newest = newest_timestamp(config.telemetry_root, ref.asset_id)
    if newest is None or newest >= utc(as_of) - limit:
        return None
    day = pd.Timedelta(days=1)
    return stale_alert(asset_id=ref.asset_id, vehicle_class=ref.vehicle_class,
                       last_data=newest.isoformat(), age_days=(utc(as_of) - newest) / day,
                       stale_after_days=limit / day)


def _stale(result: AssetResult, alert: Alert | None) -> AssetResult:
    """Attach a stale alert to the result; an asset otherwise fine becomes ``stale``."""
    if alert is not None:
        result.alerts.append(alert)
        if result.status in (OK, UP_TO_DATE):
            result.status = STALE
        note = f"stale: {alert.hint()}"
        result.note = note if not result.note else f"{result.note}; {note}"
    return result


def plan_batch(config: FleetConfig, refs: Sequence[AssetRef], as_of, registry=None,
               clock: StageClock | None = None) -> BatchPlan:
    """The nightly work of one batch of assets up to ``as_of``: each asset's job
    (:func:`plan_asset`, its registry reads made for the whole batch at once:
    :class:`flows.planning_reads.PlanningReads`), committed by :class:`RecordThenAdvance`."""
    registry = registry or config.registry()
    as_of = utc(as_of)
    reads = PlanningReads.read(config, registry, [ref.asset_id for ref in refs], as_of, clock)
    return BatchPlan([plan_asset(config, registry, ref, as_of, clock, reads) for ref in refs],
                     RecordThenAdvance(config, registry, clock, as_of=as_of))


@dataclass
class RecordThenAdvance(CommitPolicy):
    """The nightly commit of a group: 1. every candidate recorded (with its alerts), then
    2. each asset's watermark advanced to the end of its last recorded window (and the
    changed-day marks of its windows cleared). In between, an asset ``not operating`` for
    longer than ``[alerts] not_operating_after`` before ``as_of`` becomes ``dormant``
    (:func:`flows.dormancy.settle_dormant`)."""

    as_of: pd.Timestamp = field(kw_only=True)

    def commit(self, group: list[PendingAsset]) -> Iterator[PendingAsset]:
        record_group(self.config, self.registry, group, reanalysis=False, clock=self.clock)
        settle_dormant(self.config, self.registry, group, self.as_of, self.clock)
        _commit_watermarks(self.registry, group, self.clock)
        for pending in group:
            if pending.changed_days and pending.result.status != FAILED:
                clear_changed(self.config.telemetry_root, pending.asset_id,
                              pending.changed_days)
            yield pending

    def progress_text(self, result: AssetResult) -> str:
        if result.status in (FAILED, UNUSABLE_BASELINE):
            return f"{result.asset_id} {result.status.upper()}"
        alarms = sum(1 for w in result.windows if w.alarm)
        return f"{result.asset_id} {result.status}" + (f", {alarms} alarmed" if alarms else "")


def _commit_watermarks(registry, group: list[PendingAsset], clock: StageClock | None) -> None:
    """Advance the watermarks of a group's assets together
    (:meth:`registry.Registry.commit_watermarks`: one transaction on SQLite or PostgreSQL),
    each asset on its own: one whose watermark is kept is failed with the error; should the
    shared commit fail in another way than a passing one, each asset is committed alone."""
    ends = {p.asset_id: end for p in group if (end := p.watermark_end) is not None}
    committed = None
    if ends:
        try:
            with timed(clock, "registry"):
                committed = registry.commit_watermarks(ends)
        except Exception as error:  # noqa: BLE001
            if is_transient(error):
                raise TransientError(f"advancing the watermarks of {len(ends)} asset(s) "
                                     f"({', '.join(ends)}): {type(error).__name__}: "
                                     f"{error}") from error
            run_logger(logger).warning("advancing %d watermarks together failed (%s: %s); "
                                       "advancing each alone", len(ends), type(error).__name__,
                                       error)
    for pending in group:
        if committed is None:
            _commit_watermark(registry, pending, clock)
            continue
        outcome = committed.get(pending.asset_id)
        if isinstance(outcome, BaseException):
            guard_asset_error(outcome, pending.ref, "advancing its watermark")
            pending.fail(outcome)
        elif outcome is not None:
            pending.result.watermark_after = outcome.isoformat()
        _settle(pending.result)


def _commit_watermark(registry, pending: PendingAsset, clock: StageClock | None) -> None:
    result, end = pending.result, pending.watermark_end
    if end is not None:
        try:
            with timed(clock, "registry"):
                result.watermark_after = registry.commit_watermark(pending.asset_id,
                                                                   end).isoformat()
        except Exception as error:  # noqa: BLE001
            guard_asset_error(error, pending.ref, "advancing its watermark")
            pending.fail(error)
    _settle(result)


def _settle(result: AssetResult) -> None:
    """An asset's final status once its watermark is committed."""
    if result.status == OK and not result.windows:
        result.status = UP_TO_DATE
    if result.status in (OK, UP_TO_DATE) and any(a.kind == STALE_KIND for a in result.alerts):
        result.status = STALE


def _starts(bounds) -> str:
    return ", ".join(f"{s:%Y-%m-%d %H:%M}" for s, _ in bounds)


# -- Prefect ---------------------------------------------------------------------------------

def export_since(summary: RunSummary, lookback: pd.Timedelta) -> pd.Timestamp | None:
    """Where the export starts: the earliest of the run's windows' starts and of the assets'
    watermarks minus ``lookback`` (None when no asset has either). Reaching back over the
    look-back makes an export that failed self-healing: the next run writes what it missed.
    """
    starts = [utc(w.window_start) for a in summary.assets for w in a.windows]
    starts += [utc(a.watermark_before) - max(lookback, pd.Timedelta(0))
               for a in summary.assets if a.watermark_before is not None]
    return min(starts) if starts else None


def export_night_alerts(config: FleetConfig, summary: RunSummary) -> None:
    """Step 3 of the module docstring: the registry's alerts since the run's start, and the
    run's staleness and sensor alerts (which are not recorded in the registry: every run finds
    them again from the telemetry, a sensor's night being read again until it is fixed or
    quarantined), into the JSON-lines file (in the flow's own process, after every batch).

    Raises
    ------
    RuntimeError
        When the export fails; the night itself is committed in the registry, and
        ``fleet-health alerts --export`` writes the file again.
    """
    since = export_since(summary, config.nightly.lookback_delta)
    unrecorded = [alert for a in summary.assets for alert in a.alerts
                  if alert.kind in (STALE_KIND, SENSOR_KIND, DORMANT_KIND)]
    if since is None and not unrecorded:
        return
    log = AlertLog(config.alerts.jsonl)
    try:
        written = []
        if since is not None:
            _, written = export_alerts(config.registry(), log, since=since,
                                       scale=config.alerts.scale)
        written = list(written) + log.append(unrecorded)
    except Exception as error:
        since_text = f" --since {since:%Y-%m-%d}" if since is not None else ""
        raise RuntimeError(f"the night is recorded in the registry, but exporting its alerts "
                           f"to {log.path} failed: {type(error).__name__}: {error}; run "
                           f"'fleet-health alerts --export{since_text}' to write "
                           f"them") from error
    summary.extra["alerts_exported"] = len(written)


@flow(name="fleet-health-nightly", on_completion=[notify_hook], on_failure=[notify_hook],
      on_crashed=[notify_hook])
def nightly(config_path: str = DEFAULT_CONFIG, as_of: str | None = None,
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
        Failed when an asset was not monitored; the summary is its result either way.
    """
    config = load_config(config_path).with_tracking_uri(tracking_uri)
    with exclusive_run(config, "nightly") as guarded:
        as_of_ts = (not_in_future(utc(as_of), "as_of") if as_of is not None
                    else pd.Timestamp.now(tz="UTC"))
        summary = RunSummary("nightly", now_iso(), as_of=as_of_ts.isoformat(),
                             config=str(config.path), tracking_uri=config.tracking_uri)
        job = BatchJob.for_fleet("nightly", config, tracking_uri, as_of=as_of_ts.isoformat())
        summary = run_over_fleet(summary, job, config,
                                 f"nightly run (as of {as_of_ts:%Y-%m-%d %H:%M} UTC)", assets,
                                 vehicle_class)
        export_night_alerts(config, summary)
        guarded.annotate(summary)
        publish_or_note(summary, config)      # the fleet heat map; never fails the night
    return flow_result(summary, config)
