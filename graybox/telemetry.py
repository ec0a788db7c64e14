"""Telemetry store: reading, validating and gridding an asset's sensor data (DESIGN section 4).

Layout (hive-partitioned Parquet)::

    <root>/asset_id=<id>/date=<YYYY-MM-DD>/<any>.parquet

Each file has a ``timestamp`` column and one numeric column per channel. Timestamps are UTC:
tz-aware timestamps are converted to UTC and naive timestamps are *taken as* UTC. A file's
rows must lie in its partition's UTC date. Files whose name starts with ``.`` or does not end
in ``.parquet`` are ignored (temporary and hidden files).

The path from store to model input is::

    read_raw -> validate -> to_grid      (read_window does all three)

``read_raw`` returns the rows as stored, each tagged with its file and 0-based row, so that
``validate`` can name the file and row of the first bad sample (DESIGN section 5).
``to_grid`` puts the validated rows on the uniform grid the tiers assume.
"""
from __future__ import annotations

import datetime
import os
import pathlib
import re
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from graybox.exceptions import InvalidAssetIdError, TelemetryError

__all__ = ["ASSET_ID_PATTERN", "validate_asset_id", "GridPolicy", "TelemetryWindow",
           "list_assets", "list_dates", "read_raw", "validate", "to_grid", "read_window",
           "write_telemetry"]

ASSET_ID_PATTERN: re.Pattern = re.compile(r"[A-Za-z0-9_.-]{1,64}")
"""Valid asset ids (use with ``fullmatch``); ``"."`` and ``".."`` are rejected besides."""

_ASSET_PREFIX = "asset_id="
_DATE_PREFIX = "date="
_DATE_RE = re.compile(r"\d{4}-\d{2}-\d{2}")
_FILE_NAME_RE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*\.parquet")
_RESERVED = ("timestamp", "_file", "_row")
_NS_PER_SECOND = 1_000_000_000
_NS_PER_DAY = 86_400 * _NS_PER_SECOND


def validate_asset_id(asset_id: str) -> str:
    """Return ``asset_id`` if it is a valid asset id, else raise.

    A valid id matches ``[A-Za-z0-9_.-]{1,64}`` and is neither ``"."`` nor ``".."``, so it is
    safe to use as a path component and in registry names.

    Parameters
    ----------
    asset_id : str
        The id to check.

    Returns
    -------
    str
        ``asset_id`` unchanged.

    Raises
    ------
    InvalidAssetIdError
        If ``asset_id`` is not a string or is not a valid id.
    """
    if (not isinstance(asset_id, str) or ASSET_ID_PATTERN.fullmatch(asset_id) is None
            or asset_id in (".", "..")):
        raise InvalidAssetIdError(
            f"invalid asset id {asset_id!r}: must match [A-Za-z0-9_.-]{{1,64}} "
            f"and not be '.' or '..'")
    return asset_id


@dataclass(frozen=True)
class GridPolicy:
    """How raw telemetry is checked and put on a uniform grid.

    Parameters
    ----------
    sample_interval : float or None, default None
        Grid step in seconds. ``None`` infers it as the median step of the raw timestamps.
    max_fill : int, default 3
        Longest run of missing samples that is filled by linear interpolation; a longer gap
        is an error (kind ``"gap"``).
    stuck_samples : int, default 60
        This many identical consecutive values in a channel is an error (kind
        ``"stuck_channel"``). ``0`` disables the check.
    min_samples : int, default 500
        Fewer samples in the window is an error (kind ``"too_few_samples"``).

    Raises
    ------
    ValueError
        If a field is out of range.
    """

    sample_interval: float | None = None
    max_fill: int = 3
    stuck_samples: int = 60
    min_samples: int = 500

    def __post_init__(self):
        if self.sample_interval is not None:
            interval = float(self.sample_interval)
            if not (np.isfinite(interval) and interval > 0):
                raise ValueError(f"sample_interval must be a positive number of seconds or None, "
                                 f"got {self.sample_interval!r}")
        for name, low in (("max_fill", 0), ("stuck_samples", 0), ("min_samples", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
        if self.stuck_samples == 1:
            # a run of one identical value is every sample: the check would always fire
            raise ValueError("stuck_samples must be 0 (disabled) or at least 2")


@dataclass(frozen=True, eq=False, repr=False)
class TelemetryWindow:
    """A window of one asset's telemetry on a uniform time grid.

    Equality is identity (the frame is a DataFrame); compare ``frame`` explicitly. The repr
    is a one-line summary.

    Parameters
    ----------
    asset_id : str
        The asset.
    frame : pandas.DataFrame
        One float64 column per channel, indexed by a ``DatetimeIndex`` named ``"timestamp"``
        (tz UTC) on a uniform grid of step ``sample_interval``.
    sample_interval : float
        Grid step in seconds.
    filled_samples : int
        Grid points created by interpolation across short gaps (no raw sample within half a
        step). Points interpolated between jittered raw samples are not counted.
    files : tuple of str
        The files whose rows make up the window, in read order.
    """

    asset_id: str
    frame: pd.DataFrame
    sample_interval: float
    filled_samples: int
    files: tuple[str, ...]
    # per grid point: True where it was filled across a gap (lets split apportion the count)
    _filled_mask: np.ndarray | None = field(repr=False, compare=False, default=None)
    # per grid point: indexes into files of the raw samples bracketing it (lets split name
    # the files each sub-window was made from)
    _file_span: np.ndarray | None = field(repr=False, compare=False, default=None)

    def __post_init__(self):
        index = self.frame.index
        if not isinstance(index, pd.DatetimeIndex) or str(index.tz) != "UTC":
            raise ValueError("TelemetryWindow.frame needs a DatetimeIndex with tz UTC")
        if len(index) == 0:
            raise ValueError("TelemetryWindow.frame is empty")
        n = len(index)
        if self._filled_mask is None and self.filled_samples == 0:
            object.__setattr__(self, "_filled_mask", np.zeros(n, dtype=bool))
        if self._filled_mask is not None:
            if len(self._filled_mask) != n or int(self._filled_mask.sum()) != self.filled_samples:
                raise ValueError("_filled_mask does not match the frame or filled_samples")
        if self._file_span is not None and self._file_span.shape != (n, 2):
            raise ValueError("_file_span must have shape (n_samples, 2)")

    def __repr__(self) -> str:
        return (f"TelemetryWindow(asset_id={self.asset_id!r}, start={self.start.isoformat()!r}, "
                f"end={self.end.isoformat()!r}, n_samples={self.n_samples}, "
                f"channels={list(self.frame.columns)!r}, sample_interval={self.sample_interval:g}, "
                f"filled_samples={self.filled_samples}, files={len(self.files)})")

    @property
    def start(self) -> pd.Timestamp:
        """First grid timestamp (inclusive)."""
        return self.frame.index[0]

    @property
    def end(self) -> pd.Timestamp:
        """Last grid timestamp plus one sample interval (exclusive)."""
        return self.frame.index[-1] + pd.Timedelta(seconds=self.sample_interval)

    @property
    def n_samples(self) -> int:
        """Number of grid points."""
        return len(self.frame)

    def split(self, period: str = "1D", min_samples: int = 1) -> list["TelemetryWindow"]:
        """Cut the window into consecutive sub-windows aligned to ``period`` boundaries.

        Parameters
        ----------
        period : str, default "1D"
            A fixed-length pandas frequency (``"1D"``, ``"6h"``, ...). Boundaries are
            multiples of the period since the Unix epoch, so ``"1D"`` cuts at UTC midnight.
        min_samples : int, default 1
            Sub-windows with fewer grid points are dropped.

        Returns
        -------
        list of TelemetryWindow
            In time order. Each keeps the grid step; ``filled_samples`` counts the filled
            points inside it and ``files`` the files its samples were interpolated from.
        """
        if self._filled_mask is None:
            raise ValueError("this window has filled_samples > 0 but no _filled_mask; "
                             "cannot apportion filled samples")
        keys = self.frame.index.floor(period).asi8
        cuts = np.flatnonzero(keys[1:] != keys[:-1]) + 1
        bounds = np.concatenate([[0], cuts, [len(keys)]])
        windows = []
        for a, b in zip(bounds[:-1], bounds[1:]):
            if b - a < min_samples:
                continue
            mask = self._filled_mask[a:b]
            if self._file_span is None:
                files, span = self.files, None
            else:
                span = self._file_span[a:b]
                used = np.unique(span)
                files = tuple(self.files[i] for i in used)
                span = np.searchsorted(used, span)  # re-index into the sub-window's files
            windows.append(TelemetryWindow(
                asset_id=self.asset_id, frame=self.frame.iloc[a:b].copy(),
                sample_interval=self.sample_interval, filled_samples=int(mask.sum()),
                files=files, _filled_mask=mask.copy(), _file_span=span))
        return windows


# -- the store ------------------------------------------------------------------------------

def list_assets(root) -> list[str]:
    """Ids of the assets in the store.

    Parameters
    ----------
    root : str or path-like
        The telemetry root.

    Returns
    -------
    list of str
        Sorted ids of the ``asset_id=<id>`` directories. Directories whose id is not a valid
        asset id are skipped.

    Raises
    ------
    FileNotFoundError
        If ``root`` is not a directory (a misconfigured root should not look like an empty
        fleet).
    """
    root = pathlib.Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"telemetry root {str(root)!r} is not a directory")
    ids = []
    for entry in root.iterdir():
        if not entry.name.startswith(_ASSET_PREFIX) or not entry.is_dir():
            continue
        asset_id = entry.name[len(_ASSET_PREFIX):]
        try:
            ids.append(validate_asset_id(asset_id))
        except InvalidAssetIdError:
            continue
    return sorted(ids)


def list_dates(root, asset_id: str) -> list[datetime.date]:
    """Partition dates present for one asset.

    Parameters
    ----------
    root : str or path-like
        The telemetry root.
    asset_id : str
        The asset.

    Returns
    -------
    list of datetime.date
        Sorted dates of the ``date=<YYYY-MM-DD>`` directories; empty if the asset has none.

    Raises
    ------
    InvalidAssetIdError
        If ``asset_id`` is invalid.
    TelemetryError
        Kind ``"unreadable"``, naming the directory, if a ``date=`` directory name is not a
        valid ``YYYY-MM-DD`` date.
    """
    return [d for d, _ in _partitions(root, asset_id)]


def _partitions(root, asset_id: str) -> list[tuple[datetime.date, pathlib.Path]]:
    validate_asset_id(asset_id)
    asset_dir = pathlib.Path(root) / f"{_ASSET_PREFIX}{asset_id}"
    if not asset_dir.is_dir():
        return []
    found = []
    for entry in asset_dir.iterdir():
        if not entry.name.startswith(_DATE_PREFIX) or not entry.is_dir():
            continue
        text = entry.name[len(_DATE_PREFIX):]
        try:
            if _DATE_RE.fullmatch(text) is None:
                raise ValueError
            day = datetime.date.fromisoformat(text)
        except ValueError:
            raise TelemetryError(asset_id, "unreadable",
                                 f"partition directory name {entry.name!r} is not date=YYYY-MM-DD",
                                 file=str(entry)) from None
        found.append((day, entry))
    return sorted(found)


def _parquet_files(directory: pathlib.Path) -> list[pathlib.Path]:
    return sorted((p for p in directory.iterdir()
                   if p.name.endswith(".parquet") and not p.name.startswith(".") and p.is_file()),
                  key=lambda p: p.name)


def _utc_ns(value, what: str) -> int:
    """A bound as int64 ns since the epoch, UTC (naive taken as UTC)."""
    try:
        stamp = pd.Timestamp(value)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{what} {value!r} is not a timestamp: {error}") from None
    if stamp is pd.NaT:
        raise ValueError(f"{what} must not be NaT")
    stamp = stamp.tz_localize("UTC") if stamp.tz is None else stamp.tz_convert("UTC")
    return int(stamp.as_unit("ns").value)


def _day_ns(day: datetime.date) -> int:
    return (day - datetime.date(1970, 1, 1)).days * _NS_PER_DAY


def _stamp(ns: int) -> str:
    return pd.Timestamp(int(ns), unit="ns", tz="UTC").isoformat()


def _check_columns(columns) -> list[str]:
    if isinstance(columns, str):
        columns = [columns]
    channels = []
    for name in columns:
        if not isinstance(name, str) or not name:
            raise ValueError(f"column names must be non-empty strings, got {name!r}")
        if name in _RESERVED:
            raise ValueError(f"{name!r} cannot be a channel column (reserved)")
        if name not in channels:
            channels.append(name)
    return channels


def _read_error(asset_id: str, file: str, error: Exception) -> TelemetryError:
    """``"unreadable"`` for a file that is not valid Parquet; ``"io_error"`` when the file
    system failed (permissions, a network share), which a retry may cure."""
    if isinstance(error, OSError) and not isinstance(error, pa.ArrowException):
        return TelemetryError(asset_id, "io_error", f"cannot read the file: {error}", file=file)
    return TelemetryError(asset_id, "unreadable", f"cannot read Parquet: {error}", file=file)


def _read_file(path: pathlib.Path, day: datetime.date, asset_id: str, channels: list[str],
               lo: int, hi: int):
    """Read one file; return (timestamps ns, values (n, c), original rows) of rows in [lo, hi)."""
    file = str(path)
    try:
        handle = pq.ParquetFile(path)
        schema = handle.schema_arrow
    except (pa.ArrowException, OSError) as error:
        raise _read_error(asset_id, file, error) from None
    missing = [name for name in ["timestamp", *channels] if schema.get_field_index(name) < 0]
    if missing:
        raise TelemetryError(asset_id, "schema",
                             f"missing column(s) {', '.join(map(repr, missing))}; "
                             f"file has: {', '.join(schema.names) or '(none)'}", file=file)
    ts_type = schema.field("timestamp").type
    if not pa.types.is_timestamp(ts_type):
        raise TelemetryError(asset_id, "schema",
                             f"column 'timestamp' has type {ts_type}, expected a timestamp",
                             file=file)
    for name in channels:
        kind = schema.field(name).type
        if not (pa.types.is_integer(kind) or pa.types.is_floating(kind)
                or pa.types.is_decimal(kind)):
            raise TelemetryError(asset_id, "schema",
                                 f"channel column {name!r} has type {kind}, expected a number",
                                 file=file)
    try:
        table = handle.read(columns=["timestamp", *channels])
    except (pa.ArrowException, OSError) as error:
        raise _read_error(asset_id, file, error) from None
    ts_col = table.column("timestamp")
    if ts_col.null_count:
        row = int(np.flatnonzero(ts_col.is_null().to_numpy(zero_copy_only=False))[0])
        raise TelemetryError(asset_id, "non_finite", "timestamp is null", file=file, row=row)
    try:
        # tz-aware Arrow timestamps hold UTC epoch values, so the plain int is UTC either way
        ts = ts_col.cast(pa.timestamp("ns", tz=ts_type.tz)).cast(pa.int64()).to_numpy()
    except pa.ArrowInvalid as error:
        raise TelemetryError(asset_id, "schema", f"timestamps out of range: {error}",
                             file=file) from None
    day_ns = _day_ns(day)
    outside = np.flatnonzero((ts < day_ns) | (ts >= day_ns + _NS_PER_DAY))
    if outside.size:
        row = int(outside[0])
        raise TelemetryError(asset_id, "schema",
                             f"timestamp {_stamp(ts[row])} is outside the file's partition "
                             f"date={day.isoformat()} (partition dates are UTC dates)",
                             file=file, row=row)
    rows = np.flatnonzero((ts >= lo) & (ts < hi))
    values = np.empty((len(rows), len(channels)), dtype=np.float64)
    for j, name in enumerate(channels):
        column = table.column(name).cast(pa.float64()).to_numpy(zero_copy_only=False)
        values[:, j] = column[rows]
    return ts[rows], values, rows


def read_raw(root, asset_id: str, columns: Sequence[str], start=None, end=None) -> pd.DataFrame:
    """Read an asset's telemetry rows as stored, tagged with file and row.

    Only partitions whose date overlaps ``[start, end)`` are opened, and only the requested
    columns are read. Files are concatenated in (date, file name) order; rows keep their
    stored order (``validate`` checks it).

    Parameters
    ----------
    root : str or path-like
        The telemetry root.
    asset_id : str
        The asset.
    columns : sequence of str
        Channel columns to read (a repeated name is read once).
    start, end : timestamp-like, optional
        Half-open range ``[start, end)``; anything :class:`pandas.Timestamp` accepts. Naive
        values are taken as UTC. ``None`` leaves that side open.

    Returns
    -------
    pandas.DataFrame
        Columns ``"timestamp"`` (datetime64[ns, UTC]), the channels (float64), ``"_file"``
        (path of the file the row came from, as found under ``root``) and ``"_row"`` (0-based
        row in that file).

    Raises
    ------
    InvalidAssetIdError
        If ``asset_id`` is invalid.
    TelemetryError
        ``"schema"``: a file lacks ``timestamp`` or a requested column, has a non-numeric
        channel, a non-timestamp ``timestamp``, or a row outside its partition date.
        ``"non_finite"``: a null timestamp. ``"unreadable"``: a file that is not valid
        Parquet or a malformed partition name. ``"no_data"``: no partitions, or no rows in
        ``[start, end)``.
    ValueError
        If ``columns`` names a reserved column or ``start``/``end`` is not a timestamp.
    """
    validate_asset_id(asset_id)
    channels = _check_columns(columns)
    lo = np.iinfo(np.int64).min if start is None else _utc_ns(start, "start")
    hi = np.iinfo(np.int64).max if end is None else _utc_ns(end, "end")
    span = f"in [{start}, {end})"
    if lo >= hi:
        raise TelemetryError(asset_id, "no_data", f"empty time range [{start}, {end})")
    partitions = _partitions(root, asset_id)
    if not partitions:
        raise TelemetryError(asset_id, "no_data",
                             f"no telemetry partitions under {root}/{_ASSET_PREFIX}{asset_id}")
    stamps, blocks, rows, files, counts = [], [], [], [], []
    for day, directory in partitions:
        day_ns = _day_ns(day)
        if day_ns >= hi or day_ns + _NS_PER_DAY <= lo:
            continue
        for path in _parquet_files(directory):
            ts, values, kept = _read_file(path, day, asset_id, channels, lo, hi)
            if len(ts):
                stamps.append(ts)
                blocks.append(values)
                rows.append(kept)
                files.append(str(path))
                counts.append(len(ts))
    if not stamps:
        raise TelemetryError(asset_id, "no_data", f"no telemetry rows {span}")
    ts = np.concatenate(stamps)
    values = np.concatenate(blocks)
    data = {"timestamp": pd.DatetimeIndex(ts.view("M8[ns]")).tz_localize("UTC")}
    for j, name in enumerate(channels):
        data[name] = values[:, j]
    data["_file"] = np.repeat(np.array(files, dtype=object), counts)
    data["_row"] = np.concatenate(rows).astype(np.int64)
    return pd.DataFrame(data)


# -- validation -----------------------------------------------------------------------------

def _channels_of(raw: pd.DataFrame) -> list[str]:
    return [c for c in raw.columns if c not in _RESERVED]


def _timestamps_ns(raw: pd.DataFrame) -> np.ndarray:
    index = pd.DatetimeIndex(raw["timestamp"])
    index = index.tz_localize("UTC") if index.tz is None else index.tz_convert("UTC")
    return index.as_unit("ns").asi8


def _where(raw: pd.DataFrame, i: int) -> tuple[str | None, int]:
    """(file, row in file) of positional row ``i``; without tags, the position itself."""
    file = str(raw["_file"].iat[i]) if "_file" in raw.columns else None
    row = int(raw["_row"].iat[i]) if "_row" in raw.columns else int(i)
    return file, row


def _fail(raw, asset_id, kind, message, i):
    file, row = _where(raw, i)
    raise TelemetryError(asset_id, kind, message, file=file, row=row)


def _check_finite(raw, asset_id, ts, channels):
    bad_ts = np.flatnonzero(ts == np.iinfo(np.int64).min)  # NaT
    values = raw[channels].to_numpy(dtype=np.float64) if channels else np.empty((len(ts), 0))
    bad = ~np.isfinite(values)
    bad_rows = np.flatnonzero(bad.any(axis=1))
    first_ts = bad_ts[0] if bad_ts.size else len(ts)
    first_val = bad_rows[0] if bad_rows.size else len(ts)
    if first_ts < len(ts) and first_ts <= first_val:
        _fail(raw, asset_id, "non_finite", "timestamp is missing (NaT)", int(first_ts))
    if first_val < len(ts):
        i = int(first_val)
        names = [f"{channels[j]!r}={float(values[i, j])!r}" for j in np.flatnonzero(bad[i])]
        _fail(raw, asset_id, "non_finite", f"non-finite value in column {', '.join(names)}", i)
    return values


def _check_order(raw, asset_id, ts):
    steps = np.diff(ts)
    bad = np.flatnonzero(steps <= 0)
    if not bad.size:
        return
    i = int(bad[0]) + 1
    kind = "duplicate_timestamp" if steps[i - 1] == 0 else "backward_timestamp"
    word = "equals" if kind == "duplicate_timestamp" else "is earlier than"
    prev_file, prev_row = _where(raw, i - 1)
    file, _ = _where(raw, i)
    previous = "the previous row's"
    if prev_file is not None and prev_file != file:
        previous = f"the previous row's (row {prev_row} of another file, {prev_file})"
    _fail(raw, asset_id, kind,
          f"timestamp {_stamp(ts[i])} {word} {previous} timestamp {_stamp(ts[i - 1])}", i)


def _check_stuck(raw, asset_id, values, channels, stuck_samples):
    if stuck_samples == 0 or len(values) < stuck_samples:
        return
    best = None  # (start, column, length)
    for j in range(len(channels)):
        v = values[:, j]
        starts = np.concatenate([[0], np.flatnonzero(v[1:] != v[:-1]) + 1])
        lengths = np.diff(np.concatenate([starts, [len(v)]]))
        long = np.flatnonzero(lengths >= stuck_samples)
        if long.size and (best is None or starts[long[0]] < best[0]):
            best = (int(starts[long[0]]), j, int(lengths[long[0]]))
    if best is not None:
        i, j, length = best
        _fail(raw, asset_id, "stuck_channel",
              f"channel {channels[j]!r} stuck at {float(values[i, j])!r} for {length} consecutive "
              f"samples (stuck_samples={stuck_samples})", i)


def _interval_ns(ts: np.ndarray, policy: GridPolicy) -> int:
    if policy.sample_interval is not None:
        return max(1, int(round(float(policy.sample_interval) * _NS_PER_SECOND)))
    return max(1, int(round(float(np.median(np.diff(ts))))))


def _check_gaps(raw, asset_id, ts, dt_ns, max_fill):
    if len(ts) < 2:
        return
    missing = np.rint(np.diff(ts) / dt_ns).astype(np.int64) - 1
    bad = np.flatnonzero(missing > max_fill)
    if bad.size:
        i = int(bad[0]) + 1
        _fail(raw, asset_id, "gap",
              f"gap from {_stamp(ts[i - 1])} to {_stamp(ts[i])}: {int(missing[i - 1])} missing "
              f"samples at {dt_ns / _NS_PER_SECOND:g} s (max_fill={max_fill})", i)


def _check_count(asset_id, n, min_samples, what="samples"):
    if n < min_samples:
        raise TelemetryError(asset_id, "too_few_samples",
                             f"{n} {what} in the window, need at least {min_samples}")


def validate(raw: pd.DataFrame, asset_id: str, policy: GridPolicy = GridPolicy()) -> None:
    """Check raw telemetry rows; raise at the first bad row.

    Checks run in this order, each over the whole window, and the first failing check raises
    at its first offending row, naming the file and the 0-based row in that file:

    1. ``"non_finite"``: NaN or Inf in a channel (or a missing timestamp);
    2. ``"duplicate_timestamp"`` / ``"backward_timestamp"``: a timestamp equal to / earlier
       than the previous row's (which may be in the previous file);
    3. ``"stuck_channel"``: ``policy.stuck_samples`` identical consecutive values in a
       channel, reported at the first row of the run;
    4. ``"gap"``: more than ``policy.max_fill`` missing samples between two rows (missing =
       round(step / sample_interval) - 1), reported at the row after the gap;
    5. ``"too_few_samples"``: fewer than ``policy.min_samples`` rows (no file or row).

    Parameters
    ----------
    raw : pandas.DataFrame
        As returned by :func:`read_raw`. Every column other than ``timestamp``, ``_file``
        and ``_row`` is a channel. Without ``_file``/``_row``, errors give the position.
    asset_id : str
        The asset (for the error).
    policy : GridPolicy, optional
        The thresholds.

    Raises
    ------
    TelemetryError
        On the first problem found.
    """
    ts = _timestamps_ns(raw)
    channels = _channels_of(raw)
    values = _check_finite(raw, asset_id, ts, channels)
    _check_order(raw, asset_id, ts)
    _check_stuck(raw, asset_id, values, channels, policy.stuck_samples)
    if len(ts) >= 2:
        _check_gaps(raw, asset_id, ts, _interval_ns(ts, policy), policy.max_fill)
    _check_count(asset_id, len(ts), policy.min_samples)


# -- gridding -------------------------------------------------------------------------------

def to_grid(raw: pd.DataFrame, asset_id: str, policy: GridPolicy = GridPolicy()) -> TelemetryWindow:
    """Put validated raw rows on a uniform time grid.

    The grid is ``t0 + k * dt`` for the first raw timestamp ``t0`` and ``k = 0, 1, ...`` up
    to the last raw timestamp (no extrapolation). Values at grid points are interpolated
    linearly in time between the raw samples around them, which also absorbs timestamp
    jitter. Grid points with no raw sample within ``dt / 2`` lie in a (short) gap and are
    counted in ``filled_samples``.

    Parameters
    ----------
    raw : pandas.DataFrame
        Rows as returned by :func:`read_raw`, which should have passed :func:`validate`.
    asset_id : str
        The asset.
    policy : GridPolicy, optional
        ``sample_interval`` (``None``: median raw step) and ``min_samples`` are used.

    Returns
    -------
    TelemetryWindow

    Raises
    ------
    TelemetryError
        ``"no_data"`` if ``raw`` is empty; ``"duplicate_timestamp"``/``"backward_timestamp"``
        if timestamps are not increasing; ``"too_few_samples"`` if the interval cannot be
        inferred (one row) or the grid has fewer than ``policy.min_samples`` points.
    """
    ts = _timestamps_ns(raw)
    if len(ts) == 0:
        raise TelemetryError(asset_id, "no_data", "no telemetry rows to put on a grid")
    _check_order(raw, asset_id, ts)  # interpolation needs increasing times
    if len(ts) < 2 and policy.sample_interval is None:
        _check_count(asset_id, len(ts), 2, "sample(s) (two are needed to infer the interval)")
    dt_ns = _interval_ns(ts, policy)
    channels = _channels_of(raw)
    values = raw[channels].to_numpy(dtype=np.float64) if channels else np.empty((len(ts), 0))

    # relative ns fit exactly in float64 for ~100 days, so interpolation loses nothing
    rel = (ts - ts[0]).astype(np.float64)
    n_grid = int((ts[-1] - ts[0]) // dt_ns) + 1
    grid_rel = np.arange(n_grid, dtype=np.int64) * dt_ns
    grid_f = grid_rel.astype(np.float64)
    out = np.empty((n_grid, len(channels)), dtype=np.float64)
    for j in range(len(channels)):
        out[:, j] = np.interp(grid_f, rel, values[:, j])

    right = np.minimum(np.searchsorted(rel, grid_f, side="left"), len(ts) - 1)
    left = np.maximum(np.searchsorted(rel, grid_f, side="right") - 1, 0)
    nearest = np.minimum(np.abs(rel[right] - grid_f), np.abs(grid_f - rel[left]))
    filled = nearest > dt_ns / 2

    if "_file" in raw.columns:
        codes, uniques = pd.factorize(raw["_file"], sort=False)
        files = tuple(str(f) for f in uniques)
        span = np.stack([codes[left], codes[right]], axis=1)
    else:
        files, span = (), None
    _check_count(asset_id, n_grid, policy.min_samples, "grid samples")

    index = pd.DatetimeIndex((ts[0] + grid_rel).view("M8[ns]"), name="timestamp").tz_localize("UTC")
    frame = pd.DataFrame(out, index=index, columns=list(channels))
    return TelemetryWindow(asset_id=asset_id, frame=frame, sample_interval=dt_ns / _NS_PER_SECOND,
                           filled_samples=int(filled.sum()), files=files,
                           _filled_mask=filled, _file_span=span)


def read_window(root, asset_id: str, columns: Sequence[str], start=None, end=None,
                policy: GridPolicy = GridPolicy()) -> TelemetryWindow:
    """Read, validate and grid one asset's telemetry over ``[start, end)``.

    Parameters
    ----------
    root : str or path-like
        The telemetry root.
    asset_id : str
        The asset.
    columns : sequence of str
        Channel columns.
    start, end : timestamp-like, optional
        Half-open range; naive values are UTC.
    policy : GridPolicy, optional
        Validation thresholds and grid step.

    Returns
    -------
    TelemetryWindow

    Raises
    ------
    InvalidAssetIdError
        If ``asset_id`` is invalid (before any path is built).
    TelemetryError
        See :func:`read_raw`, :func:`validate` and :func:`to_grid`.
    """
    validate_asset_id(asset_id)
    raw = read_raw(root, asset_id, columns, start=start, end=end)
    validate(raw, asset_id, policy)
    return to_grid(raw, asset_id, policy)


# -- writing --------------------------------------------------------------------------------

def write_telemetry(root, asset_id: str, frame: pd.DataFrame,
                    file_name: str = "part-0.parquet") -> list[pathlib.Path]:
    """Write telemetry in the store layout, one file per UTC date.

    Rows keep their order within each date (so bad telemetry can be written for tests).
    Each file is written to a hidden temporary file and renamed into place, so readers never
    see a partial file; an existing file of the same name is replaced.

    Parameters
    ----------
    root : str or path-like
        The telemetry root (created if needed).
    asset_id : str
        The asset.
    frame : pandas.DataFrame
        A ``"timestamp"`` column (or a ``DatetimeIndex`` named ``"timestamp"``) and numeric
        channel columns. Naive timestamps are taken as UTC.
    file_name : str, default "part-0.parquet"
        File name inside each ``date=`` directory; a plain name ending in ``.parquet``.

    Returns
    -------
    list of pathlib.Path
        The files written, in date order.

    Raises
    ------
    InvalidAssetIdError
        If ``asset_id`` is invalid.
    ValueError
        If ``file_name`` is not a plain ``.parquet`` name, there is no timestamp, or a
        channel is not numeric.
    """
    validate_asset_id(asset_id)
    if not isinstance(file_name, str) or _FILE_NAME_RE.fullmatch(file_name) is None:
        raise ValueError(f"file_name {file_name!r} must be a plain name ending in .parquet")
    if "timestamp" not in frame.columns:
        if isinstance(frame.index, pd.DatetimeIndex) and frame.index.name == "timestamp":
            frame = frame.reset_index()
        else:
            raise ValueError("frame needs a 'timestamp' column or a DatetimeIndex named timestamp")
    ts = _timestamps_ns(frame)
    if (ts == np.iinfo(np.int64).min).any():
        raise ValueError("frame has missing (NaT) timestamps")
    channels = _channels_of(frame)
    arrays = {}
    for name in channels:
        column = frame[name]
        if not pd.api.types.is_numeric_dtype(column) or pd.api.types.is_bool_dtype(column):
            raise ValueError(f"channel {name!r} has dtype {column.dtype}, expected numbers")
        arrays[name] = column.to_numpy(dtype=np.float64)
    asset_dir = pathlib.Path(root) / f"{_ASSET_PREFIX}{asset_id}"
    days = np.floor_divide(ts, _NS_PER_DAY)
    written = []
    for day in np.unique(days):
        rows = np.flatnonzero(days == day)
        table = pa.table({"timestamp": pa.array(ts[rows], type=pa.timestamp("ns", tz="UTC")),
                          **{name: pa.array(arrays[name][rows]) for name in channels}})
        date = datetime.date(1970, 1, 1) + datetime.timedelta(days=int(day))
        directory = asset_dir / f"{_DATE_PREFIX}{date.isoformat()}"
        directory.mkdir(parents=True, exist_ok=True)
        path = directory / file_name
        temporary = directory / f".{file_name}.{os.getpid()}.tmp"
        pq.write_table(table, temporary)
        os.replace(temporary, path)
        written.append(path)
    return written
