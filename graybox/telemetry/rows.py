"""Raw telemetry rows as plain arrays, tagged with the file and row each came from.

``read_window`` passes :class:`Rows` from reading through validation to gridding without
building a DataFrame; the public functions that take or return DataFrames (``read_raw``,
``validate``, ``to_grid``) convert at their boundary.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from graybox.timestamps import utc

RESERVED = ("timestamp", "_file", "_row")
"""Column names of a raw frame that are not channels."""


@dataclass(frozen=True, eq=False)
class Rows:
    """Raw rows of one asset.

    Attributes
    ----------
    ts : numpy.ndarray
        int64 ns since the epoch, UTC, shape (n,); NaT is ``iinfo(int64).min``.
    values : numpy.ndarray
        float64, shape (n_channels, n): one contiguous row per channel.
    channels : tuple of str
    files : tuple of str
        The files the rows came from (empty when untagged).
    file_index : numpy.ndarray or None
        Per row, its index into ``files``; None when untagged.
    file_row : numpy.ndarray or None
        Per row, its 0-based row in its file; None when untagged (errors give the position).
    missing : numpy.ndarray or None
        Per row, True where a channel's value was missing (NaN) and has been interpolated
        (:func:`graybox.telemetry.validation.validate_rows`); None: none was.
    after_hold : numpy.ndarray or None
        Per row, True where held rows were dropped just before it
        (:func:`graybox.telemetry.holds.drop_held_rows`): a step from the previous row longer
        than ``max_gap`` there separates two operating periods; None: no row was held.
    unread : tuple of (str, int)
        Per channel, the rows left out because its value was missing: for longer than
        ``max_gap`` (:func:`graybox.telemetry.validation.fill_missing`), or at all in a
        ``running`` channel (:func:`graybox.telemetry.validation.running_rows`); empty: none.
        Kept by :meth:`take` and :meth:`slice` (the window's count so far).
    resent : int
        Rows left out because a logger sent them twice (the same timestamp and readings as a
        row before them; :func:`graybox.telemetry.resent.drop_resent_rows`). Kept by
        :meth:`take` and :meth:`slice`.
    """

    ts: np.ndarray
    values: np.ndarray
    channels: tuple[str, ...]
    files: tuple[str, ...] = ()
    file_index: np.ndarray | None = None
    file_row: np.ndarray | None = None
    missing: np.ndarray | None = None
    after_hold: np.ndarray | None = None
    unread: tuple[tuple[str, int], ...] = ()
    resent: int = 0

    def __len__(self) -> int:
        return len(self.ts)

    def where(self, i: int) -> tuple[str | None, int]:
        """(file, row in file) of positional row ``i``; untagged: (None, ``i``)."""
        file = None if self.file_index is None else self.files[int(self.file_index[i])]
        return file, int(i) if self.file_row is None else int(self.file_row[i])

    def take(self, index: np.ndarray, channels: tuple[str, ...] | None = None) -> "Rows":
        """The rows at ``index`` (positions or a mask), with only ``channels`` if given."""
        keep = list(range(len(self.channels))) if channels is None else \
            [self.channels.index(c) for c in channels]
        return Rows(self.ts[index], self.values[keep][:, index],
                    self.channels if channels is None else tuple(channels), self.files,
                    None if self.file_index is None else self.file_index[index],
                    None if self.file_row is None else self.file_row[index],
                    None if self.missing is None else self.missing[index],
                    None if self.after_hold is None else self.after_hold[index], self.unread,
                    self.resent)

    def slice(self, start: int, stop: int) -> "Rows":
        """Rows ``start`` to ``stop - 1``, still tagged against all of ``files``."""
        part = np.s_[start:stop]
        return Rows(self.ts[part], self.values[:, part], self.channels, self.files,
                    None if self.file_index is None else self.file_index[part],
                    None if self.file_row is None else self.file_row[part],
                    None if self.missing is None else self.missing[part],
                    None if self.after_hold is None else self.after_hold[part], self.unread,
                    self.resent)

    @classmethod
    def from_frame(cls, raw: pd.DataFrame) -> "Rows":
        """Rows of a frame as :func:`read_raw` returns it (``_file``/``_row`` optional)."""
        channels = tuple(c for c in raw.columns if c not in RESERVED)
        ts = timestamps_ns(raw)
        # a copy: the window built from these values must not share the caller's memory
        values = (np.array(raw[list(channels)].to_numpy(dtype=np.float64).T, order="C")
                  if channels else np.empty((0, len(ts))))
        if "_file" in raw.columns:
            codes, uniques = pd.factorize(raw["_file"], sort=False)
            rows = (raw["_row"].to_numpy(dtype=np.int64) if "_row" in raw.columns
                    else np.arange(len(ts), dtype=np.int64))
            return cls(ts, values, channels, tuple(str(f) for f in uniques), codes, rows)
        rows = raw["_row"].to_numpy(dtype=np.int64) if "_row" in raw.columns else None
        return cls(ts, values, channels, file_row=rows)

    def to_frame(self) -> pd.DataFrame:
        """The rows as a frame: ``timestamp`` (UTC), the channels, ``_file``, ``_row``."""
        data = {"timestamp": pd.DatetimeIndex(self.ts.view("M8[ns]")).tz_localize("UTC")}
        for j, name in enumerate(self.channels):
            data[name] = self.values[j]
        if self.file_index is not None:
            data["_file"] = np.array(self.files, dtype=object)[self.file_index]
            data["_row"] = self.file_row
        return pd.DataFrame(data)


def timestamps_ns(frame: pd.DataFrame) -> np.ndarray:
    """A frame's ``timestamp`` column as int64 ns UTC (naive taken as UTC)."""
    return utc(pd.DatetimeIndex(frame["timestamp"])).as_unit("ns").asi8


def check_columns(columns) -> list[str]:
    """Requested channel names, deduplicated in order; reserved or empty names refused."""
    if isinstance(columns, str):
        columns = [columns]
    channels = []
    for name in columns:
        if not isinstance(name, str) or not name:
            raise ValueError(f"column names must be non-empty strings, got {name!r}")
        if name in RESERVED:
            raise ValueError(f"{name!r} cannot be a channel column (reserved)")
        if name not in channels:
            channels.append(name)
    return channels
