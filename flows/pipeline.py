"""The pipeline the three flows share: plan -> execute -> commit.

1. **Plan.** A flow plans a batch without reading any telemetry: a :class:`BatchPlan` is
   its list of :class:`AssetJob` s, one per asset in the batch's order (the asset, its white
   box and grid, its reference version or None for a new baseline, the
   :class:`WindowJob` s to fit with the nights each covers, and what the flow decided
   already: its result so far, e.g. a watermark, late windows, or a status that leaves
   nothing to do), and the flow's :class:`CommitPolicy`.
2. **Execute.** :func:`execute` reads the jobs one after another (:func:`read`, stage
   ``read``: validated and gridded :class:`PendingWindow` s of a :class:`PendingAsset`) in
   groups that fit the memory budget (:func:`memory_groups`), so a batch's peak memory does
   not grow with its size, and runs every group through the same stages:

   a. one batched fit of the group: :func:`graybox.signature_fit.fit_signatures` of its
      :func:`candidate_requests` against each reference's frozen structure, or
      :func:`fit_baselines` (stages ``residual``, ``stationarize_ar``, ``network``,
      ``noise``);
   b. :func:`compare` -- each candidate's drift against its reference (``drift``) and the
      physical diagnosis of an alarmed window (``diagnosis``);
3. **Commit.** The flow's policy: :func:`record_group` (the registry record, stage
   ``registry``, and the alerts of each window; the group's records written together, each
   asset on its own; :func:`record_candidates` is one asset's) and what the flow commits
   beyond it -- the watermarks for the nightly run, the promotion for the baseline flow,
   nothing for a reanalysis.

The flows differ only in their plan (which windows, against which version) and their commit.
"""
from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar, Iterable, Iterator, Mapping, Sequence

import numpy as np
import pandas as pd

from graybox.calibration import fit_baselines as fit_calibrated_baselines
from graybox.drift import Drift, compute_drift
from graybox.exceptions import (GrayBoxError, InsufficientDataError, ModelChangedError,
                                ShortWindowsError, TelemetryError)
from graybox.signature_fit import MIN_BASELINE_WINDOWS, FitRequest, fit_signatures
from graybox.models.base import WhiteBoxModel
from graybox.signature import Signature
from graybox.stage_clock import StageClock, timed
from graybox.telemetry import GridPolicy, list_dates, read_window
from graybox.telemetry.layout import outside_links
from graybox.telemetry.policy import format_duration

from flows import progress
from flows.batching import guard_asset_error
from flows.config import FleetConfig, VehicleClass
from flows.discovery import AssetRef, trailing_nights, utc
from flows.memory import MemoryBudget
from flows.errors import TransientError
from flows.results import (FAILED, NOT_OPERATING, STALE, UNUSABLE_BASELINE, AssetResult,
                           WindowResult, describe_error, is_transient)
from flows.run_logger import run_logger
from graybox.alert import NIGHTLY, REANALYSIS, Alert, alerts_from_drift, sensor_alert
from graybox.alert_diagnosis import DiagnosisFailure, alert_entries
from registry import FitRecord, FitSubmission, LoadedVersion, RegistryError

if TYPE_CHECKING:  # pragma: no cover
    from graybox.diagnosis import Diagnosis

logger = logging.getLogger(__name__)

DAY = pd.Timedelta(days=1)
#: windows a new baseline needs at the least (its calibration leaves each out in turn)
MIN_WINDOWS = MIN_BASELINE_WINDOWS


@dataclass(frozen=True)
class WindowJob:
    """One window to fit, as planned: the nights its telemetry comes from.

    Attributes
    ----------
    nights : tuple of (Timestamp, Timestamp)
        ``[start, end)`` of each night read for it, oldest first; the last is the window's
        own night, the ones before it the earlier nights of a multi-night candidate
        (:func:`flows.discovery.trailing_nights`; those without rows are left out when read).
    """

    nights: tuple[tuple[pd.Timestamp, pd.Timestamp], ...]

    @property
    def start(self) -> pd.Timestamp:
        """Start of the window: of its first night."""
        return self.nights[0][0]

    @property
    def end(self) -> pd.Timestamp:
        return self.nights[-1][1]

    @property
    def night(self) -> tuple[pd.Timestamp, pd.Timestamp]:
        """The window's own night (the last)."""
        return self.nights[-1]


@dataclass
class AssetJob:
    """An asset's planned work in a batch: what to read and against what, decided without
    reading any telemetry.

    Attributes
    ----------
    ref : AssetRef
    result : AssetResult
        Its entry in the run summary as planned (status, watermark, notes, alerts), updated
        by every later stage.
    model : WhiteBoxModel or None
        The white box its windows are fitted with; None when there is nothing to do (the
        result is final: up to date, no or an unusable baseline, a failed look-up).
    reference : LoadedVersion or None
        The version its candidates are compared with; None for a new baseline, which takes
        all of its windows or none (bad telemetry never enters a baseline) and needs at least
        :data:`MIN_WINDOWS` of them.
    grid : GridPolicy or None
        How its telemetry is gridded (a candidate's: at its reference's sample interval).
    windows : tuple of WindowJob
        In time order.
    stop_at_error : bool
        The first failed window stops the asset (the later ones wait for the next run).
    idle_status, idle_note : str, optional
        The status and note of a candidate asset none of whose windows has rows.
    changed_days : tuple of datetime.date
        Days marked changed by an import whose windows are planned: cleared once everything
        is committed (:mod:`flows.changed_days`).
    source : str
        ``nightly`` or ``reanalysis``: the source of the alerts of its candidates.
    """

    ref: AssetRef
    result: AssetResult
    model: WhiteBoxModel | None = None
    reference: LoadedVersion | None = None
    grid: GridPolicy | None = None
    windows: tuple[WindowJob, ...] = ()
    stop_at_error: bool = False
    idle_status: str | None = None
    idle_note: str | None = None
    changed_days: tuple = ()
    source: str = NIGHTLY


def candidate_job(config: FleetConfig, ref: AssetRef, result: AssetResult,
                  reference: LoadedVersion, bounds: Sequence[tuple[pd.Timestamp, pd.Timestamp]],
                  nights: int = 1, **decided) -> AssetJob:
    """The job of an asset's candidates of the nights ``bounds`` against ``reference``: its
    white box (whose spec must be one its class configures) and grid, and each night's
    candidate on ``nights`` windows, none before the reference's window end.

    ``decided``: the other :class:`AssetJob` fields the flow decided (``stop_at_error``,
    ``idle_status``, ...). When the white box cannot be loaded, the job has nothing to do and
    ``result`` is failed.
    """
    try:
        model = reference_model(reference, configured_models(config, ref))
        grid = candidate_grid(config.classes[ref.vehicle_class].grid, reference)
    except ModelChangedError as error:     # its white box was replaced since the fit
        result.status = UNUSABLE_BASELINE
        result.note = (f"version {reference.version}: {error}: fix: fleet-health baseline fit "
                       f"{ref.asset_id} --start DATE --end DATE --promote --reason TEXT (a "
                       f"healthy range)")
        return AssetJob(ref, result)
    except Exception as error:  # noqa: BLE001 - one asset never stops the batch
        guard_asset_error(error, ref, "loading the white box of its reference")
        result.status, result.error = FAILED, describe_error(error)
        return AssetJob(ref, result)
    earliest = None if reference.info.window_end is None else utc(reference.info.window_end)
    window = config.nightly.window_delta
    return AssetJob(ref, result, model, reference, grid,
                    tuple(WindowJob(tuple(trailing_nights(start, end, nights, window, earliest)))
                          for start, end in bounds), **decided)


@dataclass
class PendingWindow:
    """One window of an asset to process, and what became of it.

    With ``[nightly] candidate_nights`` > 1, ``start`` is the start of the whole span and
    ``earlier`` holds the telemetry of the nights before the last one (those with rows).
    """

    start: pd.Timestamp
    end: pd.Timestamp
    telemetry: object                     #: graybox.telemetry.TelemetryWindow (the last night)
    fit: Signature | GrayBoxError | None = None
    earlier: tuple = ()                   #: TelemetryWindows of the earlier nights, in order
    night_start: pd.Timestamp | None = None   #: start of the last night (None: ``start``)
    drift: Drift | None = None            #: against the reference (:func:`compare`)
    diagnosis: Diagnosis | DiagnosisFailure | None = None   #: of an alarmed window
    failure: Exception | None = None      #: what stopped its drift or diagnosis
    #: the registry's hash of :attr:`recorded_data`, when taken before its telemetry was
    #: dropped (:func:`travelling`); None: the registry hashes the telemetry
    data_hash: str | None = None

    @property
    def night(self) -> pd.Timestamp:
        """Start of the night the candidate is for (where a failure is reported)."""
        return self.start if self.night_start is None else self.night_start

    @property
    def parts(self) -> list:
        """The telemetry the candidate is fitted on, oldest first."""
        return [*self.earlier, self.telemetry]

    @property
    def recorded_data(self):
        """What the registry hashes: the night's telemetry, or the list of all nights."""
        return self.parts if self.earlier else self.telemetry

    @property
    def nbytes(self) -> int:
        # every candidate holds its nights while fitted, shared or not
        return int(sum(p.frame.memory_usage(index=True, deep=False).sum() for p in self.parts))


@dataclass
class PendingAsset:
    """An asset with work to do: its reference version, white box and windows.

    Attributes
    ----------
    ref : AssetRef
    result : AssetResult
        Its entry in the run summary, updated by every stage.
    model : WhiteBoxModel
    reference : LoadedVersion or None
        The version its candidates are compared with (None when fitting a new baseline).
    windows : list of PendingWindow
        Read and gridded, in time order.
    empty : int
        Windows without any row (the asset was idle), skipped.
    stop, stop_start : exception and timestamp, optional
        The telemetry error that stopped the reading, and the window it is in.
    stop_at_error : bool
        The first failed window stops the asset (the later ones wait for the next run).
    baseline_fit : tuple or GrayBoxError, optional
        A new baseline's fit: (Signature, Calibration), or the error that stopped it.
    committed_end : timestamp, optional
        End of the last window recorded.
    calm : list of (timestamp, timestamp)
        The nights (start, end of their window) not monitored because they ran too little:
        too short to read (the grid's ``min_duration``) or to fit (``ShortWindowsError``).
    changed_days : list of datetime.date
        Days marked changed by an import whose windows this run selected: their marks are
        cleared once everything is committed (:mod:`flows.changed_days`).
    idle_status : str, optional
        A candidate asset's status when none of its windows had telemetry to analyse (the
        job's ``idle_status``).
    """

    ref: AssetRef
    result: AssetResult
    model: WhiteBoxModel
    reference: LoadedVersion | None = None
    windows: list[PendingWindow] = field(default_factory=list)
    empty: int = 0
    stop: BaseException | None = None
    stop_start: pd.Timestamp | None = None
    stop_at_error: bool = False
    baseline_fit: tuple | GrayBoxError | None = None
    committed_end: pd.Timestamp | None = None
    calm: list = field(default_factory=list)
    changed_days: list = field(default_factory=list)
    idle_status: str | None = None

    @property
    def asset_id(self) -> str:
        return self.ref.asset_id

    @property
    def new_calm(self) -> list:
        """The nights of :attr:`calm` past its watermark (not late windows read again)."""
        before = self.result.watermark_before
        return [(start, end) for start, end in self.calm
                if before is None or start >= pd.Timestamp(before)]

    @property
    def watermark_end(self) -> pd.Timestamp | None:
        """Where its watermark moves: the end of the last window recorded, or of a later
        night that ran too little to monitor (it was looked at and named; read again only
        within the look-back); never past a failure."""
        past = [end for _, end in self.new_calm]
        if self.result.failed or self.stop is not None or not past:
            return self.committed_end
        return max(past + ([] if self.committed_end is None else [self.committed_end]))

    @property
    def nbytes(self) -> int:
        return sum(w.nbytes for w in self.windows)

    def fail(self, error: BaseException, window_start=None) -> None:
        """Mark the asset failed; the first error is the one reported, and a window's error
        is kept with every other window's (``AssetResult.window_errors``)."""
        described = describe_error(error, window_start)
        if window_start is not None:
            self.result.window_errors.append(described)
        if self.result.error is None:
            self.result.status = FAILED
            self.result.error = described


def travelling(asset: PendingAsset, plots: str) -> PendingAsset:
    """``asset``, fitted and compared, made light to send to the process that commits it
    (:mod:`flows.pooled_execute`): each window's data hash is taken
    (:func:`registry.data_hash`, what the registry would take) and its telemetry is
    dropped unless the ``[nightly] plots`` policy ``plots`` draws it."""
    from registry import data_hash

    for window in asset.windows:
        if window.drift is not None:        # only a compared window is recorded
            window.data_hash = data_hash(window.recorded_data)
        if window.drift is None or not _plots(plots, window.drift.alarmed):
            window.telemetry, window.earlier = None, ()
    return asset


def configured_models(config: FleetConfig, ref: AssetRef) -> frozenset[str]:
    """The model specs a version of the asset may name: its class's ``model`` from fleet.toml,
    as written and as the class's own spec (``graybox.models:X`` is
    ``graybox.models.gas_turbine:X``)."""
    vehicle_class = config.classes[ref.vehicle_class]
    return frozenset({vehicle_class.model, vehicle_class.load_model().spec()})


def reference_model(reference: LoadedVersion, allowed: frozenset[str]) -> WhiteBoxModel:
    """The white box a version was fitted with (its candidates must use the same); its spec
    must be ``allowed`` before anything is imported."""
    return reference.signature.model.load(allowed)


def candidate_grid(grid: GridPolicy, reference: LoadedVersion) -> GridPolicy:
    """The class's grid policy at the reference's sample interval (candidates share its grid),
    its channels allowed to hold a value as long as the reference saw them hold
    (:meth:`GridPolicy.with_holds`)."""
    signature = reference.signature
    return dataclasses.replace(grid, sample_interval=signature.sample_interval
                               ).with_holds(signature.holds)


def read(config: FleetConfig, job: AssetJob, clock: StageClock | None = None
         ) -> PendingAsset | None:
    """Read, validate and grid each planned window of the asset (stage ``read``); the asset
    ready to fit, or None when its result is final (nothing to fit).

    A window without any row is counted in ``empty`` and skipped; when a date partition is
    there without rows, the window is named in the result's note. Another telemetry error
    stops the reading when ``job.stop_at_error`` (the windows before it are kept: ``stop``);
    otherwise it fails the asset and the other windows go on. Each night is read once; a bad
    earlier night of a multi-night candidate is an error of its window, as above, and an idle
    one is left out. A candidate's window whose sensor was found stuck or out of range also
    gets a ``sensor`` alert (:func:`graybox.alert.sensor_alert`).

    A new baseline (no reference) is fitted on all of its windows or not at all: bad
    telemetry fails it (its note says why), and so do fewer than :data:`MIN_WINDOWS` windows
    with rows. A window with too little operation to read (``too_few_samples``: shorter than
    the grid's ``min_duration``) is not bad telemetry: a new baseline leaves it out, a
    candidate does not monitor it, and the note names it. A candidate asset none of whose
    windows has rows gets ``job.idle_status`` and ``job.idle_note``; one whose windows all
    ran too little is returned without windows, settled by :func:`settle_calm` (its
    watermark moves past them when committed). Anything but bad telemetry that stops the
    reading fails the asset.
    """
    if job.model is None:
        return None
    asset = PendingAsset(job.ref, job.result, job.model, job.reference,
                         stop_at_error=job.stop_at_error, changed_days=list(job.changed_days),
                         idle_status=job.idle_status)
    try:
        _read_windows(config, job, asset, clock)
    except Exception as error:  # noqa: BLE001 - one asset never stops the batch
        guard_asset_error(error, job.ref, "reading its telemetry")
        job.result.status, job.result.error = FAILED, describe_error(error)
        return None
    result = job.result
    if job.reference is None:            # a new baseline: all of its windows or none
        if asset.stop is not None:
            asset.fail(asset.stop, asset.stop_start)
            result.note = "bad telemetry never enters a baseline"
            return None
        if len(asset.windows) < MIN_WINDOWS:
            asset.fail(InsufficientDataError(
                f"asset {asset.asset_id!r}: only {len(asset.windows)} window(s) with telemetry "
                f"in the range; a baseline needs at least {MIN_WINDOWS}"))
            return None
    elif not asset.windows:
        if asset.stop is not None:
            asset.fail(asset.stop, asset.stop_start)
        elif asset.calm and not result.failed:
            settle_calm(asset)
            return asset
        elif not result.failed:
            result.status = job.idle_status or result.status
            if job.idle_note:
                result.note = (job.idle_note if not result.note
                               else f"{result.note}; {job.idle_note}")
        return None
    return asset


def _read_windows(config: FleetConfig, job: AssetJob, asset: PendingAsset,
                  clock: StageClock | None) -> None:
    """:func:`read`'s reading: the windows of ``job`` into ``asset``, and the notes."""
    empty = []
    short = []          # windows with too little operation to read (not bad telemetry)
    gapped = []         # (window start, gaps) of a continuous class's windows with gaps
    unread = []         # (window start, channel, seconds) of readings missing too long
    resent = []         # (window start, rows) a logger sent twice
    dates = None        # the asset's date partitions, listed when a window has no rows
    found: dict = {}
    spans = []          # the nights of the windows taken (the telemetry's days)

    def night(start, end):
        if (start, end) not in found:
            try:
                found[start, end] = read_window(config.telemetry_root, asset.asset_id,
                                                job.model.required_columns, start=start,
                                                end=end, policy=job.grid,
                                                inputs=job.model.input_columns,
                                                # a new baseline: how long a coarse reading
                                                # holds is learned (Signature.holds) and
                                                # allowed its candidates (candidate_grid)
                                                holds=job.reference is None)
            except TelemetryError as error:
                found[start, end] = error
        if isinstance(found[start, end], TelemetryError):
            raise found[start, end]
        return found[start, end]

    with timed(clock, "read"):
        for window in job.windows:
            start, end = window.night
            spans += window.nights
            try:
                telemetry = night(start, end)
                earlier = []
                for s, e in window.nights[:-1]:
                    try:
                        earlier.append(night(s, e))
                    except TelemetryError as error:
                        # an idle night, or one that ran too little to read, is left out
                        if error.kind not in ("no_data", "too_few_samples"):
                            raise
            except TelemetryError as error:
                if error.kind == "no_data":
                    asset.empty += 1
                    if dates is None:
                        dates = [pd.Timestamp(d, tz="UTC")
                                 for d in list_dates(config.telemetry_root, asset.asset_id)]
                    if any(start < d + DAY and d < end for d in dates):
                        empty.append(start)      # a partition is there, without rows
                    continue
                if error.kind == "too_few_samples":
                    # a day that ran too little to read (shorter than min_duration): left
                    # out of a new baseline, and a night not monitored, both named; never a
                    # failure that holds up the nights after it
                    short.append(start)
                    asset.calm.append((start, end))
                    continue
                if job.reference is not None:   # on the night whose telemetry it is
                    _alert_sensor(config, job, error, next(
                        (n for n in window.nights if found.get(n) is error), window.night))
                if job.stop_at_error:
                    asset.stop, asset.stop_start = error, start
                    break
                asset.fail(error, start)
                continue
            if telemetry.n_periods > 1 and not job.grid.intermittent:
                gapped.append((start, telemetry.n_periods - 1))
            unread += [(start, channel, rows * telemetry.sample_interval)
                       for channel, rows in telemetry.unread]
            if telemetry.resent:
                resent.append((start, telemetry.resent))
            asset.windows.append(PendingWindow(window.start, end, telemetry,
                                               earlier=tuple(earlier), night_start=start))
        links = outside_links(config.telemetry_root, asset.asset_id,
                              {day.date() for start, end in spans
                               for day in pd.date_range(start.floor("D"), end, freq="D")})
    notes = []
    if empty:   # a date partition without rows: said, never skipped silently
        notes.append(f"skipped {len(empty)} window(s) whose telemetry has no rows: "
                     f"{', '.join(start.isoformat() for start in empty)}")
    if short:
        notes.append(f"{'not monitored' if job.reference is not None else 'left out'} "
                     f"{len(short)} window(s) with too little operation to read (shorter "
                     f"than the grid's min_duration): "
                     f"{', '.join(start.isoformat() for start in short)}")
    if gapped:  # a logger's outage: analysed in parts, said
        notes.append(f"read {len(gapped)} window(s) in parts, split where rows were missing "
                     f"for longer than the grid's max_gap: " + ", ".join(
                         f"{start.isoformat()} ({gaps} gap{'s' if gaps > 1 else ''})"
                         for start, gaps in gapped))
    if unread:  # a sensor's dropout: its rows left out, said (a dead sensor at the end)
        notes.append("left out rows where a channel had no reading (longer than the grid's "
                     "max_gap, or a running channel's): " + ", ".join(
                         f"{start.isoformat()} {channel!r} {format_duration(seconds)}"
                         for start, channel, seconds in unread))
    if resent:  # a logger's re-sent batch: nothing new in it, said
        notes.append("left out rows sent twice (the timestamp and readings of a row before "
                     "them): " + ", ".join(f"{start.isoformat()} ({rows} row"
                                           f"{'s' if rows > 1 else ''})"
                                           for start, rows in resent))
    if links:
        notes.append(f"skipped {len(links)} symbolic link(s) out of the telemetry root: "
                     f"{', '.join(links)}")
    for note in notes:
        asset.result.note = note if not asset.result.note else f"{asset.result.note}; {note}"


def _alert_sensor(config: FleetConfig, job: AssetJob, error: TelemetryError,
                  night: tuple[pd.Timestamp, pd.Timestamp]) -> None:
    """A ``sensor`` alert in the job's result when ``error`` is a sensor's fault."""
    alert = sensor_alert(error, vehicle_class=job.ref.vehicle_class,
                         window_start=night[0].isoformat(), window_end=night[1].isoformat(),
                         scale=config.alerts.scale, source=job.source)
    if alert is not None:
        job.result.alerts.append(alert)


@dataclass
class CommitPolicy:
    """What a flow commits of a group of assets that :func:`execute` has fitted and
    compared: each flow's policy records them, and commits what else it owns (watermarks, a
    promotion).

    Attributes
    ----------
    config : FleetConfig
    registry : registry.Registry
    clock : StageClock, optional
    fits_baselines : bool
        The group is fitted as new baselines (:func:`fit_baselines`), not as candidates
        against a reference; a baseline fit needs more memory per asset.
    """

    config: FleetConfig
    registry: object
    clock: StageClock | None = None
    fits_baselines: ClassVar[bool] = False

    def commit(self, group: list[PendingAsset]) -> Iterator[PendingAsset]:
        """Commit the group; yield each asset as soon as it is done (its result final)."""
        raise NotImplementedError

    def progress_text(self, result: AssetResult) -> str:
        """An asset's final result on the progress line."""
        return f"{result.asset_id} {result.status}"


@dataclass
class BatchPlan:
    """A flow's work on one batch, as planned (no telemetry read yet).

    Attributes
    ----------
    jobs : list of AssetJob
        One per asset, in the batch's order.
    commit : CommitPolicy
    """

    jobs: list[AssetJob]
    commit: CommitPolicy


def execute(config: FleetConfig, plan: BatchPlan, clock: StageClock | None = None
            ) -> list[AssetResult]:
    """Run a batch's plan: read its jobs (:func:`read`) in groups within ``[nightly]
    memory_budget`` (:func:`memory_groups`), and per group fit (the
    :func:`candidate_requests` by :func:`graybox.signature_fit.fit_signatures`, or
    :func:`fit_baselines`), compare (:func:`compare`) and commit (``plan.commit``); each
    asset is reported on the progress line when its result is final.

    Returns
    -------
    list of AssetResult
        One per asset, in the plan's order.

    Raises
    ------
    TransientError
        When the registry or file system failed transiently (retry the batch: everything
        committed so far is kept and not repeated).
    """
    commit = plan.commit
    budget = MemoryBudget.for_batch(config.nightly.memory_budget,
                                    baseline=commit.fits_baselines)
    for group in memory_groups(_read_each(config, plan, clock), budget):
        if commit.fits_baselines:
            fits = fit_baselines(group, config.classes, config.alerts.false_alarm_rate, clock)
            for pending in group:
                pending.baseline_fit = fits[pending.asset_id]
        else:
            compare(group, fit_signatures(candidate_requests(group), clock=clock), clock)
        for pending in commit.commit(group):
            report_result(pending.result, commit)
    return [job.result for job in plan.jobs]


def _read_each(config: FleetConfig, plan: BatchPlan, clock: StageClock | None
               ) -> Iterator[PendingAsset]:
    """The plan's assets read one after another, as :func:`memory_groups` takes them; an
    asset whose result is final without a fit is reported on the progress line instead."""
    for job in plan.jobs:
        pending = read(config, job, clock)
        if pending is None:
            report_result(job.result, plan.commit)
        else:
            yield pending


def report_result(result: AssetResult, commit: CommitPolicy) -> None:
    """Advance the run's progress line by one asset whose ``result`` is final, in the words
    of the flow's ``commit`` policy (:meth:`CommitPolicy.progress_text`)."""
    progress.advance(1, commit.progress_text(result), failed=int(result.failed))


def memory_groups(assets: Iterable[PendingAsset | None], budget: MemoryBudget
                  ) -> Iterator[list[PendingAsset]]:
    """Take assets one after another (read lazily: each is read when taken); yield groups
    of them that fit ``budget``.

    None (an asset with nothing to fit) is passed over. Every asset is in exactly one group,
    in the order given.
    """
    group: list[PendingAsset] = []
    used = 0
    for asset in assets:
        if asset is None:
            continue
        need = budget.need(asset.nbytes)
        if budget.full(used, need):
            yield group
            group, used = [], 0
        group.append(asset)
        used += need
    if group:
        yield group


def candidate_requests(assets: Sequence[PendingAsset]) -> list[FitRequest]:
    """One fit request per window of every asset, in order: the window's telemetry against
    its reference's frozen structure (:func:`graybox.signature_fit.fit_signatures` fits them
    in one batched call; :func:`compare` takes its results in the same order)."""
    return [FitRequest(asset.model, window.parts, baseline=asset.reference.signature,
                       asset_id=asset.asset_id)
            for asset in assets for window in asset.windows]


def fit_baselines(assets: Sequence[PendingAsset], classes: Mapping[str, VehicleClass],
                  false_alarm_rate: float, clock: StageClock | None = None) -> dict:
    """Calibrated baselines of the assets (grouped by their class's settings; each tunes the
    white-box parameters its class names in ``estimate`` first).

    Parameters
    ----------
    assets : sequence of PendingAsset
    classes : mapping of str to VehicleClass
        The fleet's vehicle classes by name.
    false_alarm_rate : float
    clock : StageClock, optional

    Returns
    -------
    dict
        asset id -> (Signature, Calibration) or GrayBoxError.
    """
    groups: dict[object, list[PendingAsset]] = {}
    for asset in assets:
        groups.setdefault(classes[asset.ref.vehicle_class].settings, []).append(asset)
    out = {}
    for settings, members in groups.items():
        requests = [FitRequest(a.model, [w.telemetry for w in a.windows], asset_id=a.asset_id,
                               estimate=classes[a.ref.vehicle_class].estimate)
                    for a in members]
        try:
            results = fit_calibrated_baselines(requests, settings, false_alarm_rate,
                                               clock=clock)
        except Exception as error:  # noqa: BLE001 - isolated to its asset(s) below
            if is_transient(error):
                raise
            # an asset's fit does not depend on the others': alone, only the culprit fails
            results = [_fit_alone(request, settings, false_alarm_rate, clock)
                       for request in requests]
        out.update({a.asset_id: result for a, result in zip(members, results)})
    return out


def _fit_alone(request: FitRequest, settings, false_alarm_rate: float,
               clock: StageClock | None):
    try:
        return fit_calibrated_baselines([request], settings, false_alarm_rate, clock=clock)[0]
    except Exception as error:  # noqa: BLE001
        if is_transient(error):
            raise
        return GrayBoxError(f"asset {request.asset_id!r}: the baseline fit failed: "
                            f"{type(error).__name__}: {error}")


def compare(assets: Sequence[PendingAsset], fits: Sequence[Signature | GrayBoxError],
            clock: StageClock | None = None) -> None:
    """Each window's fit and its drift against its asset's reference (stage ``drift``) and,
    when it alarms, its physical diagnosis (:func:`diagnose_alarm`, stage ``diagnosis``);
    sets the window's ``fit``, ``drift`` and ``diagnosis``, or the ``failure`` that stopped
    them.

    ``fits``: the fit of every window of every asset, in order (a Signature or the
    GrayBoxError that stopped it), i.e. :func:`graybox.signature_fit.fit_signatures` of
    :func:`candidate_requests`. A window whose fit or comparison failed stops an asset that
    ``stop_at_error`` (its later windows are not compared: they wait for the next run);
    otherwise the others go on.
    """
    fitted = iter(fits)
    for asset in assets:
        for window in asset.windows:
            window.fit = next(fitted)
    for asset in assets:
        _leave_out_calm_nights(asset)
    for asset in assets:
        reference = asset.reference
        for window in asset.windows:
            if isinstance(window.fit, GrayBoxError):
                if asset.stop_at_error:
                    break
                continue
            try:
                with timed(clock, "drift"):
                    window.drift = compute_drift(window.fit, reference.signature,
                                                 reference.calibration)
                if window.drift.alarmed:
                    with timed(clock, "diagnosis"):
                        window.diagnosis = diagnose_alarm(asset, window)
            except Exception as error:  # noqa: BLE001 - reported when the window is recorded
                window.failure = error
                if asset.stop_at_error:
                    break


def _leave_out_calm_nights(asset: PendingAsset) -> None:
    """A candidate asset's windows whose own night ran too little to fit
    (:class:`ShortWindowsError`; an earlier night of the span is left out by the fit
    itself) are not monitored: named in the note and left out, so they never hold up the
    nights after them; an asset with no other window gets its idle status."""
    if asset.reference is None:
        return
    calm = [w for w in asset.windows if isinstance(w.fit, ShortWindowsError)]
    if not calm:
        return
    asset.windows = [w for w in asset.windows if not isinstance(w.fit, ShortWindowsError)]
    note = (f"not monitored {len(calm)} window(s) with too little operation to fit: "
            f"{', '.join(w.night.isoformat() for w in calm)}")
    result = asset.result
    result.note = note if not result.note else f"{result.note}; {note}"
    asset.calm += [(w.night, w.end) for w in calm]
    if not asset.windows and asset.stop is None and not result.failed:
        settle_calm(asset)


def settle_calm(asset: PendingAsset) -> None:
    """The status of a candidate asset left with no window to compare, only nights that ran
    too little (``asset.calm``): ``not operating`` when one of them is new (past its
    watermark), its idle status when all were read before (late windows looked at again),
    and ``stale`` stays stale."""
    if asset.new_calm and asset.idle_status != STALE:
        asset.result.status = NOT_OPERATING
    else:
        asset.result.status = asset.idle_status or asset.result.status


def record_candidates(config: FleetConfig, registry, asset: PendingAsset, *, reanalysis: bool,
                      clock: StageClock | None = None) -> list[Alert]:
    """Record and alert every compared window of an asset (:func:`compare`), in time order:
    the candidate run with its drift and diagnosis, whose alerts carry the diagnosis.

    A failed fit, comparison or recording fails the asset; when the asset ``stop_at_error``
    (the nightly run) the later windows wait for the next run, otherwise they go on.
    Transient errors are raised (the batch is retried; what was recorded is found again,
    not duplicated). :func:`record_group` does the same for a group of assets at once.

    Returns
    -------
    list of Alert
        The alerts of the recorded windows (also added to the asset's result).
    """
    stop_at_error = asset.stop_at_error
    out: list[Alert] = []
    for window in asset.windows:
        if isinstance(window.fit, GrayBoxError):
            asset.fail(window.fit, window.night)
            if stop_at_error:
                break
            continue
        error = window.failure
        if error is None:
            try:
                with timed(clock, "registry"):
                    record = registry.record_fit(_submission(config, asset, window,
                                                             reanalysis))
            except Exception as failure:  # noqa: BLE001 - one window never stops the batch
                error = failure
        if error is not None:
            _window_failed(asset, window, error)
            if stop_at_error:
                break
            continue
        out += _window_recorded(config, asset, window, record, reanalysis)
    if asset.stop is not None:
        asset.fail(asset.stop, asset.stop_start)
    return out


def record_group(config: FleetConfig, registry, assets: Sequence[PendingAsset], *,
                 reanalysis: bool, clock: StageClock | None = None) -> None:
    """:func:`record_candidates` of every asset of a group (a memory group), with the
    group's candidates recorded together: one :meth:`registry.Registry.record_group`, which
    shares the look-ups, the locks and (on SQLite or PostgreSQL) the transaction.

    Each asset stays on its own, as in :func:`record_candidates`: a window whose fit,
    comparison or recording failed fails its asset only (and, when the asset
    ``stop_at_error``, its later windows wait for the next run); its error is in the
    asset's result, named with the window. Transient errors are raised (the batch is
    retried; what was recorded is found again, not duplicated). Should the group's
    recording fail in another way, each asset is recorded alone
    (:func:`record_candidates`).
    """
    if len({asset.stop_at_error for asset in assets}) > 1:
        for asset in assets:     # one policy per group call; never the case in the flows
            record_candidates(config, registry, asset, reanalysis=reanalysis, clock=clock)
        return
    submissions: list[FitSubmission] = []
    steps: list[list[tuple[PendingWindow, int | BaseException]]] = []
    for asset in assets:
        planned: list[tuple[PendingWindow, int | BaseException]] = []
        for window in asset.windows:
            error = window.fit if isinstance(window.fit, GrayBoxError) else window.failure
            if error is None:
                try:
                    submissions.append(_submission(config, asset, window, reanalysis))
                    planned.append((window, len(submissions) - 1))
                    continue
                except Exception as failure:  # noqa: BLE001 - this window's own
                    error = failure
            planned.append((window, error))
            if asset.stop_at_error:
                break
        steps.append(planned)
    outcomes: list = []
    if submissions:
        try:
            with timed(clock, "registry"):
                outcomes = registry.record_group(
                    submissions, stop_at_error=bool(assets) and assets[0].stop_at_error)
        except Exception as error:  # noqa: BLE001
            if is_transient(error):
                raise TransientError(
                    f"recording the candidates of {len(assets)} asset(s) "
                    f"({', '.join(a.asset_id for a in assets)}): {type(error).__name__}: "
                    f"{error}") from error
            run_logger(logger).warning("recording a group of %d asset(s) together failed "
                                       "(%s: %s); recording each alone", len(assets),
                                       type(error).__name__, error)
            for asset in assets:
                record_candidates(config, registry, asset, reanalysis=reanalysis, clock=clock)
            return
    for asset, planned in zip(assets, steps):
        for window, step in planned:
            if isinstance(step, BaseException):
                error = step
            else:
                outcome = outcomes[step]
                if isinstance(outcome, FitRecord):
                    _window_recorded(config, asset, window, outcome, reanalysis)
                    continue
                error = outcome if outcome is not None else RegistryError(
                    "not recorded: an earlier window of the asset failed")
            if window.fit is error:
                asset.fail(error, window.night)
            else:
                _window_failed(asset, window, error)
            if asset.stop_at_error:
                break
        if asset.stop is not None:
            asset.fail(asset.stop, asset.stop_start)


def _submission(config: FleetConfig, asset: PendingAsset, window: PendingWindow,
                reanalysis: bool) -> FitSubmission:
    drift = window.drift
    return FitSubmission(
        asset.asset_id, asset.ref.vehicle_class, window.fit, role="candidate", drift=drift,
        window=window.recorded_data, window_start=window.start, window_end=window.end,
        baseline_version=asset.reference.version, data_hash=window.data_hash,
        plots=_plots(config.nightly.plots, drift.alarmed), reanalysis=reanalysis,
        diagnosis=window.diagnosis)


def _window_failed(asset: PendingAsset, window: PendingWindow, error: BaseException) -> None:
    guard_asset_error(error, asset.ref, f"recording the window from "
                                        f"{window.start.isoformat()}")
    asset.fail(error, window.night)


def _window_recorded(config: FleetConfig, asset: PendingAsset, window: PendingWindow,
                     record: FitRecord, reanalysis: bool) -> list[Alert]:
    """A recorded window's alerts and result."""
    drift, reference = window.drift, asset.reference
    alerts = alerts_from_drift(
        drift, asset_id=asset.asset_id, vehicle_class=asset.ref.vehicle_class,
        window_start=record.window_start, window_end=record.window_end,
        version=None if reanalysis else record.version, baseline_version=reference.version,
        run_id=record.run_id, scale=config.alerts.scale,
        source=REANALYSIS if reanalysis else NIGHTLY, diagnosis=alert_entries(window.diagnosis))
    asset.result.alerts += alerts
    nearest = drift.largest
    asset.result.windows.append(WindowResult(
        record.window_start, record.window_end, None if reanalysis else record.version,
        record.run_id, drift.alarmed, None if nearest is None else nearest.ratio,
        record.created, None if nearest is None else f"{nearest.channel} {nearest.tier}",
        drift.conditions))
    asset.committed_end = window.end
    return alerts


def diagnose_alarm(asset: PendingAsset, window: PendingWindow) -> Diagnosis | DiagnosisFailure:
    """The physical diagnosis of an alarmed window: its fault hypotheses fitted on the
    telemetry the candidate was fitted on, against the reference's level tiers, with the
    reference's white box (:func:`graybox.diagnosis.diagnose`).

    A diagnosis that cannot be made (a GrayBoxError, e.g. a baseline stored before level
    tiers existed, or a numerical failure) is returned as a :class:`DiagnosisFailure` with
    its reason: it is recorded and shown with the alerts, and neither the asset nor the
    alerts are lost.
    """
    from graybox.diagnosis import diagnose    # scipy.stats: imported when a window alarms

    try:
        return diagnose(asset.reference.signature, window.parts, asset.model)
    except (GrayBoxError, ArithmeticError, ValueError, np.linalg.LinAlgError) as error:
        return DiagnosisFailure(f"{type(error).__name__}: {error}")


def _plots(policy: str, alarmed: bool) -> bool:
    return policy == "all" or (policy == "alarms" and alarmed)
