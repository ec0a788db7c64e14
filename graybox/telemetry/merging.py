"""Merging imported rows into the store's day partitions, idempotently.

:func:`plan_import` compares the rows of one or more exports (:class:`AssetRows`) with what
each asset-day partition already holds and returns one :class:`DayImport` per asset-day the
import touches: the rows it adds and the rows already there. A row whose timestamp is already
stored (or repeated in the import) with the same values adds nothing, so re-importing an
export changes nothing; the same timestamp with another value is a :class:`ImportConflict`
naming the export's file and line and the partition file. :func:`write_day` rewrites a day
with new rows as one file, sorted by time: the existing file's name when there was one
(``part-0.parquet`` otherwise), written to a hidden temporary file and renamed into place;
the day's other Parquet files, whose rows it now holds, are then removed.

An asset-day's existing channels must be the imported ones (a partition with other columns
is a conflict, not a silent union that would leave gaps).
"""
from __future__ import annotations

import datetime
import pathlib
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from graybox.telemetry.exports import AssetRows
from graybox.telemetry.layout import (NS_PER_DAY, day_ns, parquet_files, partitions, stamp)
from graybox.telemetry.writing import write_telemetry

#: the file a day is written to when it had none
DEFAULT_FILE = "part-0.parquet"
#: conflicts named in one error (the count says how many more)
CONFLICTS_SHOWN = 20


class ImportConflict(ValueError):
    """Imported rows that contradict the store or each other.

    Attributes
    ----------
    conflicts : list of str
        One line per conflict: the export's file and line, the timestamp, what differs.
    """

    def __init__(self, conflicts: list[str]):
        self.conflicts = conflicts
        shown = conflicts[:CONFLICTS_SHOWN]
        more = len(conflicts) - len(shown)
        super().__init__("\n".join(shown + ([f"... and {more} more"] if more else [])))


@dataclass(frozen=True, eq=False)
class DayImport:
    """One asset-day an import touches.

    Attributes
    ----------
    asset_id : str
    day : datetime.date
        The UTC date of the partition.
    channels : tuple of str
    new_rows, existing_rows : int
        Rows the import adds; rows the partition held before.
    ts, values : numpy.ndarray
        The day after the import: int64 ns UTC sorted, and float64 (n_channels, n).
    files : tuple of pathlib.Path
        The partition's Parquet files before the import.
    """

    asset_id: str
    day: datetime.date
    channels: tuple[str, ...]
    new_rows: int
    existing_rows: int
    ts: np.ndarray
    values: np.ndarray
    files: tuple[pathlib.Path, ...]

    @property
    def changed(self) -> bool:
        """Whether the import adds rows to this day."""
        return self.new_rows > 0


def plan_import(root, imported: Sequence[AssetRows]) -> list[DayImport]:
    """What importing ``imported`` into the store at ``root`` would do, per asset-day.

    Parameters
    ----------
    root : str or path-like
        The telemetry root (need not exist yet).
    imported : sequence of AssetRows
        Rows of one or more exports; an asset may appear in several.

    Returns
    -------
    list of DayImport
        Sorted by asset and day; days whose rows are all stored already have ``new_rows``
        0.

    Raises
    ------
    ImportConflict
        If a timestamp has two different values (in the import, or in the import and the
        store), or an asset-day partition holds other channels than the import.
    TelemetryError
        If an existing partition cannot be read.
    """
    by_asset: dict[str, list[AssetRows]] = {}
    for rows in imported:
        by_asset.setdefault(rows.asset_id, []).append(rows)
    conflicts: list[str] = []
    out = []
    for asset_id in sorted(by_asset):
        parts = by_asset[asset_id]
        channels = parts[0].channels
        for rows in parts[1:]:
            if set(rows.channels) != set(channels):
                conflicts.append(f"{rows.file}: asset {asset_id} has channels "
                                 f"{_names(rows.channels)}, {parts[0].file} has "
                                 f"{_names(channels)}")
        if conflicts:
            continue
        ts, values, where = _unique_rows(parts, channels, conflicts)
        stored = dict(partitions(root, asset_id))
        days = np.floor_divide(ts, NS_PER_DAY)
        for day_number in np.unique(days):
            day = datetime.date(1970, 1, 1) + datetime.timedelta(days=int(day_number))
            rows = np.flatnonzero(days == day_number)
            files = tuple(parquet_files(stored[day], root)) if day in stored else ()
            out.append(_merge_day(asset_id, day, channels, ts[rows], values[:, rows],
                                  [where[i] for i in rows], files, conflicts))
    if conflicts:
        raise ImportConflict(conflicts)
    return out


def write_day(root, day: DayImport) -> pathlib.Path:
    """Write an asset-day after the import: one sorted file replacing the day's files.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    name = day.files[0].name if len(day.files) == 1 else DEFAULT_FILE
    frame = pd.DataFrame({"timestamp": pd.DatetimeIndex(day.ts.view("M8[ns]")).tz_localize("UTC"),
                          **{c: day.values[j] for j, c in enumerate(day.channels)}})
    [path] = write_telemetry(root, day.asset_id, frame, file_name=name)
    for old in day.files:
        if old.name != path.name:
            old.unlink(missing_ok=True)
    return path


def _names(channels) -> str:
    return ", ".join(sorted(channels))


def _unique_rows(parts: list[AssetRows], channels: tuple[str, ...], conflicts: list[str]):
    """An asset's imported rows sorted by time, repeated timestamps dropped (or conflicts)."""
    ts = np.concatenate([p.ts for p in parts])
    values = np.concatenate([p.values[[p.channels.index(c) for c in channels]] for p in parts],
                            axis=1)
    where = [p.where(i) for p in parts for i in range(len(p))]
    order = np.argsort(ts, kind="stable")
    ts, values, where = ts[order], values[:, order], [where[i] for i in order]
    repeat = np.flatnonzero(ts[1:] == ts[:-1]) + 1
    drop = np.zeros(len(ts), dtype=bool)
    for i in repeat:
        first = i - 1
        while drop[first]:
            first -= 1
        if not np.array_equal(values[:, i], values[:, first]):
            conflicts.append(f"{where[i]}: {stamp(ts[i])} has other values than at "
                             f"{where[first]} ({_differs(channels, values[:, first], values[:, i])})")
        drop[i] = True
    keep = ~drop
    return ts[keep], values[:, keep], [w for w, k in zip(where, keep) if k]


def _merge_day(asset_id: str, day: datetime.date, channels: tuple[str, ...], ts: np.ndarray,
               values: np.ndarray, where: list[str], files: tuple[pathlib.Path, ...],
               conflicts: list[str]) -> DayImport:
    old_ts, old_values = _stored(files, channels, asset_id, day, conflicts)
    order = np.argsort(old_ts, kind="stable")
    old_ts, old_values = old_ts[order], old_values[:, order]
    at = np.searchsorted(old_ts, ts)
    found = (at < len(old_ts)) & (old_ts[np.minimum(at, len(old_ts) - 1)] == ts) \
        if len(old_ts) else np.zeros(len(ts), dtype=bool)
    for i in np.flatnonzero(found):
        stored = old_values[:, at[i]]
        if not np.array_equal(stored, values[:, i]):
            conflicts.append(f"{where[i]}: {stamp(ts[i])} is stored with other values in "
                             f"{files[0].parent} ({_differs(channels, stored, values[:, i])})")
    new = ~found
    merged_ts = np.concatenate([old_ts, ts[new]])
    merged_values = np.concatenate([old_values, values[:, new]], axis=1)
    order = np.argsort(merged_ts, kind="stable")
    return DayImport(asset_id, day, channels, int(new.sum()), len(old_ts), merged_ts[order],
                     merged_values[:, order], files)


def _stored(files: tuple[pathlib.Path, ...], channels: tuple[str, ...], asset_id: str,
            day: datetime.date, conflicts: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """The rows a partition holds (timestamps ns, values in ``channels`` order)."""
    stamps, blocks = [np.empty(0, dtype=np.int64)], [np.empty((len(channels), 0))]
    for path in files:
        table = pq.read_table(path)
        held = [n for n in table.column_names if n != "timestamp"]
        if set(held) != set(channels):
            conflicts.append(f"{path}: asset {asset_id} day {day} holds channels "
                             f"{_names(held)}; the import has {_names(channels)}")
            continue
        column = table.column("timestamp")
        stamps.append(column.cast(pa.timestamp("ns", tz=column.type.tz)).cast(pa.int64())
                      .to_numpy())
        blocks.append(np.stack([table.column(c).cast(pa.float64()).to_numpy(
            zero_copy_only=False) for c in channels]))
    ts = np.concatenate(stamps)
    first = day_ns(day)
    if ((ts < first) | (ts >= first + NS_PER_DAY)).any():
        conflicts.append(f"{files[0].parent}: rows outside its date {day} (fix the partition "
                         f"first)")
    return ts, np.concatenate(blocks, axis=1)


def _differs(channels: tuple[str, ...], stored: np.ndarray, imported: np.ndarray) -> str:
    return ", ".join(f"{c} {a:g} vs {b:g}" for c, a, b in zip(channels, stored, imported)
                     if not a == b)
