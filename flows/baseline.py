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

Assets are read and fitted in groups within ``[nightly] memory_budget`` (:mod:`flows.memory`).

Recording is idempotent: fitting the same range again (same data) returns the same version.
Watermarks are not moved: a new asset's first nightly run starts at the end of its
baseline's window.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Iterator, Sequence

import pandas as pd
from prefect import flow

from graybox.exceptions import GrayBoxError
from graybox.operating_conditions import covered
from graybox.stage_clock import StageClock, timed
from graybox.telemetry.policy import format_duration

from flows.batch_job import BatchJob
from flows.batching import guard_asset_error, run_over_fleet
from flows.config import DEFAULT_CONFIG, FleetConfig, load_config
from flows.discovery import AssetRef, range_windows, utc
from flows.errors import UsageError
from flows.hooks import notify_hook
from flows.pipeline import (MIN_WINDOWS, AssetJob, BatchPlan, CommitPolicy, PendingAsset,
                            WindowJob)
from flows.run_tables import flow_result
from flows.run_guard import exclusive_run
from flows.results import (FAILED, OK, AssetResult, RunSummary, WindowResult,
                           describe_error, now_iso)
from registry import FitSubmission



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


def plan_asset(config: FleetConfig, ref: AssetRef, windows) -> AssetJob:
    """An asset's baseline job: its healthy windows, each one night, with its class's white
    box and grid (nothing to do, and the asset failed, when the white box cannot be loaded).
    Reading them decides whether it can have a baseline (:func:`flows.pipeline.read`)."""
    vehicle_class = config.classes[ref.vehicle_class]
    result = AssetResult(ref.asset_id, ref.vehicle_class, OK)
    try:
        model = vehicle_class.load_model()
    except Exception as error:  # noqa: BLE001
        guard_asset_error(error, ref, "loading its white box")
        result.status, result.error = FAILED, describe_error(error)
        return AssetJob(ref, result)
    return AssetJob(ref, result, model, grid=vehicle_class.grid, stop_at_error=True,
                    windows=tuple(WindowJob(((start, end),)) for start, end in windows))


def record_baseline(registry, config: FleetConfig, pending: PendingAsset, fit, promote: bool,
                    reason: str | None, clock: StageClock | None = None) -> None:
    """Record a fitted baseline (and promote it with ``promote``); fills the asset's result."""
    asset, result = pending.asset_id, pending.result
    if isinstance(fit, GrayBoxError):
        pending.fail(fit)
        return
    signature, calibration = fit
    windows = pending.windows
    try:
        with timed(clock, "registry"):
            record = registry.record_fit(FitSubmission(
                asset, pending.ref.vehicle_class, signature, role="baseline",
                calibration=calibration, window=[w.telemetry for w in windows],
                window_start=windows[0].start, window_end=windows[-1].end,
                plots=config.nightly.plots != "none"))
            version, note = _promotion(registry, asset, record.version, promote, reason)
    except Exception as error:  # noqa: BLE001
        guard_asset_error(error, pending.ref, "recording")
        pending.fail(error)
        return
    result.baseline_version = version
    result.windows = [WindowResult(record.window_start, record.window_end, record.version,
                                   record.run_id, False, None, record.created)]
    left = [pd.Timestamp(t) for t in signature.left_out or ()]
    used = ", ".join(f"{w.start:%Y-%m-%d}" for w in windows
                     if not any(w.start <= t < w.end for t in left))
    parts = [f"{note} (windows {used})"]
    ranges = covered(signature.conditions)
    if ranges:
        # what its nights are judged against: a night driven beyond says so in its alert
        parts.append(f"its days' conditions: {', '.join(ranges)} (a night beyond them is "
                     f"judged by extrapolation, and its alert says so)")
    if result.note:
        # what the reading noted (windows without rows or too short to read, left out)
        parts.append(result.note)
    result.note = "; ".join(parts)
    if left:
        # the fit left them out (graybox.calibration.fit_baselines): too little operation
        result.note += (f"; left out, too little operation to fit: "
                        f"{', '.join(f'{t:%Y-%m-%d %H:%M}' for t in left)}")
    if signature.holds:
        # a coarse reading of a steady plant: the nights may hold a value twice as long
        nights = config.classes[pending.ref.vehicle_class].grid.with_holds(signature.holds)
        alike: dict[tuple[float, float], list[str]] = {}
        for channel, seconds in signature.holds.items():
            alike.setdefault((seconds, nights.stuck_limit(channel)), []).append(channel)
        result.note += "; held one value with nothing to explain it: " + ", ".join(
            f"{', '.join(channels)} {format_duration(seconds)} (nights may hold "
            f"{format_duration(limit)})" for (seconds, limit), channels in alike.items())


def _promotion(registry, asset: str, version: int, promote: bool,
               reason: str | None) -> tuple[int | None, str]:
    """Promote the new version, or say where it stands and how to promote it."""
    if promote:
        info = registry.promote(asset, version, reason=reason)
        return info.version, f"v{info.version} promoted to baseline"
    aliases = registry.aliases(asset)
    command = f"`fleet-health baseline promote {asset} --version {version} --reason ...`"
    if aliases.get("baseline") == version:
        return version, f"v{version} (recorded before) is already the baseline"
    if aliases.get("candidate") == version:
        return None, f"v{version} is the candidate; review it, then {command}"
    return None, f"v{version} (recorded before); promote it with {command}"


def plan_baseline_batch(config: FleetConfig, refs: Sequence[AssetRef], start, end,
                        promote: bool = False, reason: str | None = None,
                        registry=None, clock: StageClock | None = None) -> BatchPlan:
    """The baselines of one batch of assets from ``[start, end)``: each asset's job
    (:func:`plan_asset`), committed by :class:`RecordAndPromote`.

    Raises
    ------
    UsageError
        When the range holds fewer than :data:`MIN_WINDOWS` whole windows.
    """
    registry = registry or config.registry()
    windows = baseline_windows(config, start, end)
    return BatchPlan([plan_asset(config, ref, windows) for ref in refs],
                     RecordAndPromote(config, registry, clock, promote, reason))


@dataclass
class RecordAndPromote(CommitPolicy):
    """The baseline commit: each asset's new baseline recorded (alias ``candidate``), and
    promoted to ``baseline`` with ``promote``."""

    promote: bool = False
    reason: str | None = None
    fits_baselines: ClassVar[bool] = True

    def commit(self, group: list[PendingAsset]) -> Iterator[PendingAsset]:
        for pending in group:
            record_baseline(self.registry, self.config, pending, pending.baseline_fit,
                            self.promote, self.reason, self.clock)
            yield pending


@flow(name="fleet-health-baseline", on_completion=[notify_hook], on_failure=[notify_hook],
      on_crashed=[notify_hook])
def baseline(start: str, end: str, config_path: str = DEFAULT_CONFIG,
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
        The run summary; the flow run ends Failed (message: the coverage line)
        when an asset's baseline was not fitted.
    """
    config = load_config(config_path).with_tracking_uri(tracking_uri)
    with exclusive_run(config, "baseline") as guarded:
        if promote and not (reason and reason.strip()):
            raise UsageError("--promote needs --reason (it is recorded with the promotion)")
        baseline_windows(config, start, end)   # fail early on a too-short range
        summary = RunSummary("baseline", now_iso(), config=str(config.path),
                             tracking_uri=config.tracking_uri,
                             extra={"start": utc(start).isoformat(),
                                    "end": utc(end).isoformat(), "promote": promote})
        job = BatchJob.for_fleet("baseline", config, tracking_uri,
                                 start=utc(start).isoformat(), end=utc(end).isoformat(),
                                 promote=promote, reason=reason)
        summary = guarded.annotate(run_over_fleet(
            summary, job, config,
            f"baseline fits ({utc(start):%Y-%m-%d} → {utc(end):%Y-%m-%d})", assets,
            vehicle_class, missing_fails=bool(assets)))   # asked for by name: a failure
    return flow_result(summary, config)
