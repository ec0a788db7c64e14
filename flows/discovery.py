"""Which assets, which windows.

Assets
    The telemetry root's ``asset_id=<id>`` directories, each assigned to the vehicle class
    whose ``assets`` ids or patterns match it (two matching classes are a configuration
    error). Assets in the telemetry that no class claims are reported and left alone. An id
    listed explicitly in a class but without telemetry is reported as "no telemetry".
    Nothing in the root is skipped silently: a folder whose id is invalid (``asset_id=T 007``),
    a directory or Parquet file outside the layout, and a symbolic link resolving outside the
    root (never followed) are listed in ``Fleet.skipped`` with why, and so in the run summary
    and the command's output. A root that holds Parquet files but no asset in the layout is a
    configuration error (exit status 2) naming the layout expected and the files found: a
    run over "0 assets" that exits 0 would hide a fleet that is not monitored at all. An
    empty root (no Parquet file at all) is an empty fleet.

Windows
    Consecutive periods of ``[nightly] window`` (default one UTC day) aligned to UTC midnight.
    The nightly run takes, per asset, every whole window that starts at or after the asset's
    watermark (or, before its first nightly run, the end of its baseline's window) and ends
    at or before the run's as-of time, in the date partitions present. A window still being
    filled (ending after as-of) waits for the next run. With ``[nightly] candidate_nights =
    N`` the candidate of a window is fitted on it and the N - 1 windows before it
    (:func:`trailing_nights`); its window is that whole span.
"""
from __future__ import annotations

import datetime
from dataclasses import dataclass, field
from typing import Iterable, Sequence

import pandas as pd

from flows.config import ConfigError, FleetConfig
from graybox import timestamps
from graybox.exceptions import InvalidAssetIdError
from graybox.telemetry import validate_asset_id
from graybox.telemetry.layout import EXPECTED_LAYOUT, Skipped, scan
from flows.errors import UsageError

DAY = pd.Timedelta(days=1)
#: how far past the machine's clock an --as-of or --start may lie (clock skew between hosts)
CLOCK_SKEW = pd.Timedelta(minutes=5)


@dataclass(frozen=True)
class AssetRef:
    """An asset and its vehicle class."""

    asset_id: str
    vehicle_class: str


@dataclass(frozen=True)
class Fleet:
    """The assets a run covers.

    Attributes
    ----------
    assets : list of AssetRef
        With telemetry, sorted by id.
    without_telemetry : list of AssetRef
        Listed explicitly (in fleet.toml or on the command line) but with no telemetry.
    unmatched : list of str
        In the telemetry but claimed by no vehicle class.
    skipped : list of Skipped
        Entries of the telemetry root not read, with why.
    """

    assets: list[AssetRef]
    without_telemetry: list[AssetRef]
    unmatched: list[str]
    skipped: list[Skipped] = field(default_factory=list)


def utc(value) -> pd.Timestamp:
    """A timestamp in UTC (naive values are taken as UTC); see :func:`graybox.timestamps.utc`.

    Raises
    ------
    ValueError
        When ``value`` is not a timestamp or is NaT (:func:`parse_time` turns this into a
        :class:`UsageError`).
    """
    return timestamps.utc(value)


def parse_time(text: str, what: str = "time") -> pd.Timestamp:
    """A command-line date or timestamp (``2026-01-05`` or ISO 8601; naive is UTC).

    Raises
    ------
    UsageError
    """
    try:
        return utc(text)
    except (ValueError, TypeError):
        raise UsageError(f"{what} {text!r} is not a date (YYYY-MM-DD) or ISO timestamp") from None


def not_in_future(when: pd.Timestamp, what: str, now: pd.Timestamp | None = None
                  ) -> pd.Timestamp:
    """``when``, unless it lies more than :data:`CLOCK_SKEW` after ``now`` (default: the
    clock): telemetry from the future cannot exist, so such a time is a mistake.

    Raises
    ------
    UsageError
    """
    now = pd.Timestamp.now(tz="UTC") if now is None else utc(now)
    when = utc(when)
    if when > now + CLOCK_SKEW:
        raise UsageError(f"{what} {when.isoformat()} is in the future (now is "
                         f"{now.isoformat(timespec='seconds')}); give a time up to now")
    return when


def discover(config: FleetConfig, assets: Sequence[str] | None = None,
             vehicle_class: str | None = None) -> Fleet:
    """The assets of the fleet, optionally only some ids or one class.

    Parameters
    ----------
    config : FleetConfig
    assets : sequence of str, optional
        Only these ids (each must belong to a configured class).
    vehicle_class : str, optional
        Only this class.

    Raises
    ------
    ConfigError
        If the telemetry root is not a directory, holds Parquet files but no asset in the
        layout, or an asset matches two classes.
    UsageError
        If a requested id is invalid or belongs to no class, or the class is unknown.
    """
    if vehicle_class is not None and vehicle_class not in config.classes:
        raise UsageError(f"unknown vehicle class {vehicle_class!r}; {config.path.name} defines "
                         f"{', '.join(config.classes)}")
    try:
        found = scan(config.telemetry_root)
    except FileNotFoundError as error:
        raise ConfigError(f"{config.path.name}: telemetry.root: {error}") from None
    if found.stray_parquet:
        raise ConfigError(
            f"{config.path.name}: telemetry.root {str(config.telemetry_root)!r} holds Parquet "
            f"files but no asset in the expected layout {EXPECTED_LAYOUT}; found e.g. "
            f"{', '.join(found.stray_parquet)}. Move the files into that layout (one "
            f"asset_id=<ID> directory per asset, one date=<YYYY-MM-DD> directory per UTC day)")
    present, skipped = found.assets, found.skipped
    present_set = set(present)
    if assets is not None:
        wanted = []
        for asset_id in assets:
            try:
                validate_asset_id(asset_id)
            except InvalidAssetIdError as error:
                raise UsageError(str(error)) from None
            found = config.class_of(asset_id)
            if found is None:
                raise UsageError(f"asset {asset_id!r} belongs to no vehicle class of "
                                 f"{config.path.name} (add it to a class's 'assets')")
            if vehicle_class is not None and found.name != vehicle_class:
                raise UsageError(f"asset {asset_id!r} is of class {found.name!r}, "
                                 f"not {vehicle_class!r}")
            if asset_id not in (r.asset_id for r in wanted):
                wanted.append(AssetRef(asset_id, found.name))
        with_data = sorted((r for r in wanted if r.asset_id in present_set),
                           key=lambda r: r.asset_id)
        return Fleet(with_data, [r for r in wanted if r.asset_id not in present_set], [],
                     skipped)
    refs, unmatched = [], []
    for asset_id in present:
        found = config.class_of(asset_id)
        if found is None:
            unmatched.append(asset_id)
        elif vehicle_class is None or found.name == vehicle_class:
            refs.append(AssetRef(asset_id, found.name))
    missing = []
    for cls in config.classes.values():
        if vehicle_class is not None and cls.name != vehicle_class:
            continue
        for asset_id in cls.explicit_assets():
            if asset_id not in present_set:
                missing.append(AssetRef(asset_id, cls.name))
    return Fleet(refs, missing, unmatched, skipped)


def batches(items: Sequence, size: int) -> list[list]:
    """``items`` cut into consecutive lists of at most ``size``."""
    return [list(items[i:i + size]) for i in range(0, len(items), size)]


def windows_in_dates(dates: Iterable[datetime.date], window: pd.Timedelta
                     ) -> list[tuple[pd.Timestamp, pd.Timestamp]]:
    """Every window of the given UTC dates (``window`` divides a day), in time order."""
    out = []
    per_day = int(DAY / window)
    for date in sorted(set(dates)):
        start = utc(pd.Timestamp(date))
        for k in range(per_day):
            out.append((start + k * window, start + (k + 1) * window))
    return out


def pending_windows(dates: Iterable[datetime.date], start_after: pd.Timestamp | None,
                    as_of: pd.Timestamp, window: pd.Timedelta
                    ) -> list[tuple[pd.Timestamp, pd.Timestamp]]:
    """Whole windows of ``dates`` starting at or after ``start_after`` and ending by ``as_of``."""
    as_of = utc(as_of)
    start_after = None if start_after is None else utc(start_after)
    return [(s, e) for s, e in windows_in_dates(dates, window)
            if (start_after is None or s >= start_after) and e <= as_of]


def range_windows(start: pd.Timestamp, end: pd.Timestamp, window: pd.Timedelta,
                  whole_only: bool) -> list[tuple[pd.Timestamp, pd.Timestamp]]:
    """``[start, end)`` cut at window boundaries (aligned to UTC midnight).

    With ``whole_only`` only the whole windows inside the range are kept (baselines: every
    window as long as a night); otherwise the partial windows at the edges are kept too
    (reanalysis of any range).
    """
    start, end = utc(start), utc(end)
    if not start < end:
        raise UsageError(f"empty range: start {start.isoformat()} is not before end "
                         f"{end.isoformat()}")
    first = start.floor("D")
    while first + window <= start:
        first += window
    out = []
    s = first
    while s < end:
        e = s + window
        if whole_only:
            if s >= start and e <= end:
                out.append((s, e))
        else:
            out.append((max(s, start), min(e, end)))
        s = e
    return out


def trailing_nights(start: pd.Timestamp, end: pd.Timestamp, nights: int, window: pd.Timedelta,
                    earliest: pd.Timestamp | None = None
                    ) -> list[tuple[pd.Timestamp, pd.Timestamp]]:
    """The windows a candidate of the night ``[start, end)`` is fitted on, oldest first.

    The night and the ``nights - 1`` windows before it (cut at window boundaries), none
    starting before ``earliest`` (the reference's window end; a night that itself starts
    before it is fitted alone). The candidate's window is ``(result[0][0], end)``.
    """
    if nights < 1:
        raise ValueError(f"nights must be >= 1, got {nights}")
    start, end = utc(start), utc(end)
    first = start - (nights - 1) * window
    if earliest is not None:
        first = max(first, min(utc(earliest), start))
    if first >= start:
        return [(start, end)]
    return range_windows(first, start, window, whole_only=False) + [(start, end)]
