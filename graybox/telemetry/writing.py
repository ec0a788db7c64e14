"""Writing telemetry in the store layout (tests, the simulator, the demo)."""
from __future__ import annotations

import datetime
import os
import pathlib

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from graybox.telemetry.layout import (ASSET_PREFIX, DATE_PREFIX, FILE_NAME_RE, NS_PER_DAY,
                                      validate_asset_id)
from graybox.telemetry.rows import RESERVED, timestamps_ns

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
    if not isinstance(file_name, str) or FILE_NAME_RE.fullmatch(file_name) is None:
        raise ValueError(f"file_name {file_name!r} must be a plain name ending in .parquet")
    if "timestamp" not in frame.columns:
        if isinstance(frame.index, pd.DatetimeIndex) and frame.index.name == "timestamp":
            frame = frame.reset_index()
        else:
            raise ValueError("frame needs a 'timestamp' column or a DatetimeIndex named timestamp")
    ts = timestamps_ns(frame)
    if (ts == np.iinfo(np.int64).min).any():
        raise ValueError("frame has missing (NaT) timestamps")
    channels = [c for c in frame.columns if c not in RESERVED]
    arrays = {}
    for name in channels:
        column = frame[name]
        if not pd.api.types.is_numeric_dtype(column) or pd.api.types.is_bool_dtype(column):
            raise ValueError(f"channel {name!r} has dtype {column.dtype}, expected numbers")
        arrays[name] = column.to_numpy(dtype=np.float64)
    asset_dir = pathlib.Path(root) / f"{ASSET_PREFIX}{asset_id}"
    days = np.floor_divide(ts, NS_PER_DAY)
    written = []
    for day in np.unique(days):
        rows = np.flatnonzero(days == day)
        table = pa.table({"timestamp": pa.array(ts[rows], type=pa.timestamp("ns", tz="UTC")),
                          **{name: pa.array(arrays[name][rows]) for name in channels}})
        date = datetime.date(1970, 1, 1) + datetime.timedelta(days=int(day))
        directory = asset_dir / f"{DATE_PREFIX}{date.isoformat()}"
        directory.mkdir(parents=True, exist_ok=True)
        path = directory / file_name
        temporary = directory / f".{file_name}.{os.getpid()}.tmp"
        pq.write_table(table, temporary)
        os.replace(temporary, path)
        written.append(path)
    return written
