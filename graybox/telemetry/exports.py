"""Reading a user's export (CSV or Parquet) into telemetry rows per asset, in UTC.

An export is what a historian or data logger writes: one file per machine or one file for
many (an asset column), local or UTC timestamps, column names of its own. :func:`read_export`
turns one file into :class:`AssetRows` (UTC timestamps, float channels named as the white box
expects) and names every row it cannot read as a :class:`BadRow` with the file and its
position: ``line N`` for CSV (1-based, the header is line 1; a quoted field holding a line
break would shift the count) and ``row N`` for Parquet (0-based, as the telemetry errors
name Parquet rows). Nothing here writes: :mod:`graybox.telemetry.merging` does.

A row is bad when its timestamp does not parse (or is a local time that a daylight-saving
change makes ambiguous or non-existent), when a channel value is empty, not a number or not
finite, or when its asset id is invalid.
"""
from __future__ import annotations

import pathlib
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np
import pandas as pd
import pyarrow.parquet as pq

from graybox.exceptions import InvalidAssetIdError
from graybox.telemetry.layout import validate_asset_id
from graybox.telemetry.rows import check_columns

#: ``ExportFormat.timestamp_format`` values for numeric epoch timestamps (always UTC)
EPOCH_UNITS = {"unix": "s", "unix_ms": "ms"}

_NAT = np.iinfo(np.int64).min


class ExportError(ValueError):
    """An export that cannot be imported at all (unreadable, a column missing); names the file."""


@dataclass(frozen=True)
class ExportFormat:
    """How to read an export.

    Attributes
    ----------
    timestamp_column : str
        The column holding the time of each row.
    timestamp_format : str or None
        A :func:`~datetime.datetime.strptime` format (``"%d.%m.%Y %H:%M:%S"``), ``"unix"`` or
        ``"unix_ms"`` (epoch seconds or milliseconds, UTC); None reads ISO 8601.
    timezone : str
        The IANA zone of timestamps without an offset (``"Europe/Berlin"``); converted to
        UTC. Timestamps with an offset (``+01:00``) are converted by their offset.
    asset_column : str or None
        The column naming each row's asset (one file for many assets).
    asset_id : str or None
        The asset of every row (one asset per file); with neither this nor
        ``asset_column`` the asset id is the file name without its suffix.
    column_map : mapping of str to str
        Export column -> channel name. When given, only these columns are imported; when
        empty, every column but the timestamp and asset columns is a channel of its own name.
    delimiter, decimal : str
        CSV field separator and decimal mark (``";"`` and ``","`` in many European exports).
    """

    timestamp_column: str = "timestamp"
    timestamp_format: str | None = None
    timezone: str = "UTC"
    asset_column: str | None = None
    asset_id: str | None = None
    column_map: Mapping[str, str] = field(default_factory=dict)
    delimiter: str = ","
    decimal: str = "."

    def __post_init__(self):
        if self.asset_column is not None and self.asset_id is not None:
            raise ValueError("give an asset column or an asset id, not both")
        if self.asset_id is not None:
            validate_asset_id(self.asset_id)
        if self.delimiter == self.decimal:
            raise ValueError(f"the CSV delimiter and the decimal mark are both "
                             f"{self.delimiter!r}")
        targets = list(self.column_map.values())
        check_columns(targets)
        repeated = sorted({t for t in targets if targets.count(t) > 1})
        if repeated:
            raise ValueError(f"several export columns map to the channel(s) "
                             f"{', '.join(map(repr, repeated))}")
        try:
            pd.Timestamp("2000-01-01").tz_localize(self.timezone)
        except Exception:  # noqa: BLE001 - pytz and zoneinfo raise different errors
            raise ValueError(f"unknown time zone {self.timezone!r} (an IANA name such as "
                             f"'Europe/Berlin' or 'UTC')") from None


@dataclass(frozen=True)
class BadRow:
    """A row of an export that cannot be imported, and why."""

    file: str
    position: int
    unit: str
    reason: str

    def __str__(self) -> str:
        return f"{self.file}, {self.unit} {self.position}: {self.reason}"


@dataclass(frozen=True, eq=False)
class AssetRows:
    """One asset's rows of one export, in file order.

    Attributes
    ----------
    asset_id : str
    file : str
        The export they came from.
    unit : str
        ``"line"`` (CSV) or ``"row"`` (Parquet): what ``positions`` count.
    ts : numpy.ndarray
        int64 ns since the epoch, UTC.
    values : numpy.ndarray
        float64, shape (n_channels, n), all finite.
    channels : tuple of str
    positions : numpy.ndarray
        Each row's line (CSV) or row (Parquet) in ``file``.
    """

    asset_id: str
    file: str
    unit: str
    ts: np.ndarray
    values: np.ndarray
    channels: tuple[str, ...]
    positions: np.ndarray

    def __len__(self) -> int:
        return len(self.ts)

    def where(self, i: int) -> str:
        """``"<file>, line N"`` of positional row ``i``."""
        return f"{self.file}, {self.unit} {int(self.positions[i])}"


@dataclass(frozen=True)
class ExportRead:
    """What :func:`read_export` made of one file: the good rows per asset and the bad rows."""

    file: str
    assets: list[AssetRows]
    bad_rows: list[BadRow]
    rows: int


def read_export(path, fmt: ExportFormat) -> ExportRead:
    """Read one export into UTC rows per asset, naming the rows that cannot be read.

    Parameters
    ----------
    path : str or path-like
        A ``.csv`` file (any other suffix but ``.parquet`` is read as CSV too) or a
        ``.parquet`` file.
    fmt : ExportFormat
        Its columns, time zone and separators.

    Returns
    -------
    ExportRead
        The good rows of each asset (sorted by asset id) and every bad row.

    Raises
    ------
    ExportError
        If the file cannot be read, or lacks the timestamp, asset or a mapped column, or its
        name is not a valid asset id when it has to be one.
    """
    path = pathlib.Path(path)
    file = str(path)
    parquet = path.suffix.lower() == ".parquet"
    frame = _read_parquet(path) if parquet else _read_csv(path, fmt)
    unit = "row" if parquet else "line"
    positions = np.arange(len(frame), dtype=np.int64) + (0 if parquet else 2)
    sources, channels = _channels(frame, fmt, file)
    bad = np.zeros(len(frame), dtype=bool)
    reasons: dict[int, str] = {}

    def flag(mask: np.ndarray, why) -> None:
        for i in np.flatnonzero(mask & ~bad):
            reasons[int(i)] = why(int(i))
        bad[mask] = True

    ts, ts_reasons = _timestamps(frame[fmt.timestamp_column], fmt)
    flag(ts == _NAT, lambda i: ts_reasons[i])
    values = np.empty((len(channels), len(frame)), dtype=np.float64)
    for j, (source, channel) in enumerate(zip(sources, channels)):
        values[j], text = _numbers(frame[source], fmt.decimal)
        flag(~np.isfinite(values[j]),
             lambda i, s=source, t=text: (f"column {s!r} is empty" if t[i] == "" else
                                          f"column {s!r} value {t[i]!r} is not a finite number"))
    assets = _asset_ids(frame, fmt, path)
    invalid = {a for a in set(assets) if not _valid_id(a)}
    if invalid:
        flag(np.isin(assets, list(invalid)),
             lambda i: f"asset id {assets[i]!r} is invalid ([A-Za-z0-9_.-], at most 64)")
    bad_rows = [BadRow(file, int(positions[i]), unit, reasons[i]) for i in sorted(reasons)]
    good = ~bad
    out = []
    for asset_id in sorted(set(assets[good])):
        keep = good & (assets == asset_id)
        out.append(AssetRows(asset_id, file, unit, ts[keep], values[:, keep], tuple(channels),
                             positions[keep]))
    return ExportRead(file, out, bad_rows, len(frame))


def _read_csv(path: pathlib.Path, fmt: ExportFormat) -> pd.DataFrame:
    try:
        frame = pd.read_csv(path, sep=fmt.delimiter, dtype=str, keep_default_na=False,
                            skip_blank_lines=False, encoding="utf-8-sig")
    except (OSError, ValueError, pd.errors.ParserError) as error:
        raise ExportError(f"{path}: cannot read as CSV (delimiter {fmt.delimiter!r}): "
                          f"{error}") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    return frame


def _read_parquet(path: pathlib.Path) -> pd.DataFrame:
    try:
        return pq.read_table(path).to_pandas()
    except Exception as error:  # noqa: BLE001 - arrow raises many kinds
        raise ExportError(f"{path}: cannot read as Parquet: {error}") from None


def _channels(frame: pd.DataFrame, fmt: ExportFormat, file: str
              ) -> tuple[list[str], list[str]]:
    """(export columns, channel names) to import."""
    needed = [fmt.timestamp_column, *([fmt.asset_column] if fmt.asset_column else []),
              *fmt.column_map]
    missing = [c for c in needed if c not in frame.columns]
    if missing:
        raise ExportError(f"{file}: no column(s) {', '.join(map(repr, missing))}; the file has "
                          f"{', '.join(map(repr, frame.columns)) or 'none'}")
    if fmt.column_map:
        return list(fmt.column_map), list(fmt.column_map.values())
    sources = [c for c in frame.columns if c not in (fmt.timestamp_column, fmt.asset_column)]
    if not sources:
        raise ExportError(f"{file}: no channel column besides {fmt.timestamp_column!r}")
    try:
        check_columns(sources)
    except ValueError as error:
        raise ExportError(f"{file}: {error}; rename it with a column map") from None
    return sources, sources


def _timestamps(column: pd.Series, fmt: ExportFormat) -> tuple[np.ndarray, dict[int, str]]:
    """int64 ns UTC per row (``_NAT`` where bad) and, per bad row, why."""
    text = column.astype(str).to_numpy() if not pd.api.types.is_datetime64_any_dtype(column) \
        else None
    if fmt.timestamp_format in EPOCH_UNITS:
        numbers = pd.to_numeric(column, errors="coerce")
        parsed = pd.DatetimeIndex(pd.to_datetime(numbers, unit=EPOCH_UNITS[fmt.timestamp_format],
                                                 utc=True, errors="coerce"))
    elif text is None:
        parsed = pd.DatetimeIndex(column)
    else:
        parsed = _parse_text(column, fmt.timestamp_format)
    reasons: dict[int, str] = {}
    what = fmt.timestamp_format or "ISO 8601"
    for i in np.flatnonzero(parsed.isna()):
        reasons[int(i)] = (f"timestamp {text[i]!r} is not a time ({what})" if text is not None
                           else "timestamp is empty")
    if parsed.tz is None:
        parsed, local = _localize(parsed, fmt.timezone)
        for i in np.flatnonzero(local):
            reasons[int(i)] = (f"local time {text[i] if text is not None else parsed[i]!r} is "
                               f"ambiguous or does not exist in {fmt.timezone} (a daylight-"
                               f"saving change): export in UTC or with offsets")
    ns = parsed.tz_convert("UTC").as_unit("ns").asi8.copy()
    ns[parsed.isna()] = _NAT
    return ns, reasons


def _parse_text(column: pd.Series, timestamp_format: str | None) -> pd.DatetimeIndex:
    """Strings to times; mixed UTC offsets are converted to UTC."""
    strings = column.astype(str).str.strip()
    form = timestamp_format or "ISO8601"
    try:
        parsed = pd.to_datetime(strings, format=form, errors="coerce")
    except ValueError:      # mixed offsets: one zone cannot hold them
        parsed = pd.to_datetime(strings, format=form, errors="coerce", utc=True)
    return pd.DatetimeIndex(parsed)


def _localize(parsed: pd.DatetimeIndex, zone: str) -> tuple[pd.DatetimeIndex, np.ndarray]:
    """Naive local times to aware ones; the second value marks times that a daylight-saving
    change made ambiguous (not inferable from the order) or non-existent."""
    known = ~parsed.isna()
    try:
        aware = parsed.tz_localize(zone, ambiguous="infer", nonexistent="NaT")
    except Exception:  # noqa: BLE001 - the repeated hour cannot be told from the order
        aware = parsed.tz_localize(zone, ambiguous="NaT", nonexistent="NaT")
    return aware, known & aware.isna()


def _numbers(column: pd.Series, decimal: str) -> tuple[np.ndarray, np.ndarray]:
    """float64 per row (NaN where not a number) and the text of each cell."""
    if pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column):
        values = column.to_numpy(dtype=np.float64, na_value=np.nan)
        return values, np.where(np.isnan(values), "", column.astype(str).to_numpy())
    text = column.astype(str).str.strip().to_numpy(dtype=object)
    text[pd.isna(column).to_numpy()] = ""
    normal = pd.Series(text, dtype=object)
    if decimal != ".":
        normal = normal.str.replace(decimal, ".", regex=False)
    values = pd.to_numeric(normal, errors="coerce").to_numpy(dtype=np.float64, na_value=np.nan)
    return values, text


def _asset_ids(frame: pd.DataFrame, fmt: ExportFormat, path: pathlib.Path) -> np.ndarray:
    if fmt.asset_column is not None:
        return frame[fmt.asset_column].astype(str).str.strip().to_numpy(dtype=object)
    asset_id = fmt.asset_id if fmt.asset_id is not None else path.stem
    if not _valid_id(asset_id):
        raise ExportError(f"{path}: the file name {path.stem!r} is not a valid asset id: give "
                          f"the asset (--asset ID) or an asset column")
    return np.full(len(frame), asset_id, dtype=object)


def _valid_id(asset_id: str) -> bool:
    try:
        validate_asset_id(asset_id)
    except InvalidAssetIdError:
        return False
    return True
