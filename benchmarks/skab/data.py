"""Reading SKAB's CSV files into telemetry the project can use.

SKAB writes one ``;``-separated CSV per experiment with a ``datetime`` column
(``2020-02-08 13:30:47``, no offset) and its own column names. The file is read through the
product's own export reader (:func:`graybox.telemetry.exports.read_export`, the reader behind
``fleet-health import``), so the rows here are exactly what an import would write into the
telemetry layout; :func:`to_one_second_grid` then puts them on the uniform grid with the
product's :func:`graybox.telemetry.to_grid`, as :func:`graybox.read_window` would.

Time zone (an assumption): the testbed is at Skoltech, Moscow, and the logger wrote the
local time of the testbed, Moscow time (``Europe/Moscow``, UTC+3 all year since 2014, so no
daylight-saving change falls inside the data). The timestamps are converted to UTC;
``2020-02-08 13:30:47`` is ``10:30:47`` UTC. Nothing in the data or SKAB's README states the
zone; if it were UTC, every timestamp would shift by 3 h and nothing else would change.

Grid: the logger samples at 1 Hz nominally, about 6 % of the steps are 2 s and a few gaps
last 33-247 s. The grid step is fixed at 1 s (a median step would also give 1 s); a 2-s step
gets its missing sample by linear interpolation, as the product does for any short gap.
Gaps up to ``max_gap`` (4 minutes, the product's default) are interpolated too; a longer
pause ends an operating period (``intermittent``), so that the fits never bridge it.

Electrical inputs: the logger's 1-s current and voltage readings scatter by about 20 % (the
power's standard deviation is 122 W around 551 W, its lag-1 autocorrelation 0.13): they are
snapshots, not the mean power that heats the motor and turns the pump. Fed raw, that scatter
enters every one-step prediction and the white box loses to plain differences on the
motor temperature and the flow. :func:`average_inputs` replaces them with their trailing
(causal, so usable live) mean over :data:`INPUT_AVERAGING` seconds, a signal conditioning a
user applies before importing.
"""
from __future__ import annotations

import pathlib

import numpy as np
import pandas as pd

from benchmarks.skab.white_box import SKAB_COLUMNS
from graybox.telemetry import GridPolicy, TelemetryWindow, to_grid, validate
from graybox.telemetry.exports import ExportFormat, read_export

#: the IANA zone of SKAB's ``datetime`` column (see the module docstring)
TESTBED_TIMEZONE = "Europe/Moscow"
#: the last rows of anomaly-free.csv, identical to the first rows of other/5.csv
HEALTHY_OVERLAP_ROWS = 572
#: the healthy file, relative to the dataset folder
HEALTHY_FILE = pathlib.Path("data") / "anomaly-free" / "anomaly-free.csv"
#: SKAB's label columns, kept beside the channels where a file has them
LABEL_COLUMNS = ("anomaly", "changepoint")
#: how SKAB's 1-Hz rows go on the grid: 1 s, short gaps filled, long pauses end a period
INPUT_AVERAGING = 60
SKAB_GRID = GridPolicy(sample_interval="1s", max_gap="4min", min_duration="5min",
                       intermittent=True)


def dataset_dir(repo_root) -> pathlib.Path:
    """Where the SKAB copy lives for a checkout at ``repo_root``: ``../shared/datasets/skab``."""
    return pathlib.Path(repo_root).resolve().parent / "shared" / "datasets" / "skab"


def skab_format(asset_id: str, labels: bool = False) -> ExportFormat:
    """The export format of a SKAB CSV: ``;``, ``datetime`` in Moscow time, SKAB's names
    mapped to the white box's (and the labels kept under their own names if ``labels``)."""
    column_map = dict(SKAB_COLUMNS)
    if labels:
        column_map.update({name: name for name in LABEL_COLUMNS})
    return ExportFormat(timestamp_column="datetime", timestamp_format="%Y-%m-%d %H:%M:%S",
                        timezone=TESTBED_TIMEZONE, asset_id=asset_id, column_map=column_map,
                        delimiter=";")


def read_skab_csv(path, asset_id: str = "skab", drop_last: int = 0) -> pd.DataFrame:
    """One SKAB CSV as raw telemetry rows: ``timestamp`` (UTC) and the white box's channels.

    Parameters
    ----------
    path : str or path-like
        A SKAB CSV.
    asset_id : str, default "skab"
        The asset the rows belong to (one testbed).
    drop_last : int, default 0
        Rows to drop at the end of the file (:data:`HEALTHY_OVERLAP_ROWS` for the healthy
        file).

    Returns
    -------
    pandas.DataFrame
        In file order: ``timestamp`` (tz UTC), the channels named as in :data:`SKAB_COLUMNS`'s
        values, then ``anomaly`` and ``changepoint`` where the file has them.

    Raises
    ------
    ValueError
        If a row cannot be read (named with file and line).
    """
    path = pathlib.Path(path)
    header = pd.read_csv(path, sep=";", nrows=0).columns
    labels = all(name in header for name in LABEL_COLUMNS)
    read = read_export(path, skab_format(asset_id, labels))
    if read.bad_rows:
        raise ValueError(f"{len(read.bad_rows)} unreadable row(s), the first: {read.bad_rows[0]}")
    (rows,) = read.assets
    stop = len(rows) - drop_last
    frame = pd.DataFrame({"timestamp": pd.DatetimeIndex(rows.ts[:stop].view("M8[ns]"))
                          .tz_localize("UTC")})
    for channel, values in zip(rows.channels, rows.values):
        frame[channel] = values[:stop]
    return frame


def read_healthy(data_dir, asset_id: str = "skab") -> pd.DataFrame:
    """The healthy file's raw rows without its last :data:`HEALTHY_OVERLAP_ROWS` (which are
    the start of ``other/5.csv``, a test experiment)."""
    return read_skab_csv(pathlib.Path(data_dir) / HEALTHY_FILE, asset_id,
                         drop_last=HEALTHY_OVERLAP_ROWS)


def to_one_second_grid(raw: pd.DataFrame, asset_id: str = "skab",
                       policy: GridPolicy = SKAB_GRID, inputs=("current", "voltage")
                       ) -> TelemetryWindow:
    """Validate raw rows and put them on the 1-s grid (the product's own checks and grid).

    Label columns are left out (they are not telemetry). ``inputs`` are exempt from the
    stuck-channel check, as ``model.input_columns`` are in the product.
    """
    channels = [c for c in raw.columns if c not in LABEL_COLUMNS]
    raw = raw[channels]
    validate(raw, asset_id, policy, inputs=inputs)
    return to_grid(raw, asset_id, policy)


def average_inputs(frame: pd.DataFrame, seconds: int = INPUT_AVERAGING,
                   inputs=("current", "voltage")) -> pd.DataFrame:
    """A copy of a 1-s grid frame with ``inputs`` replaced by their trailing mean over
    ``seconds`` samples (the first samples average what came before them)."""
    averaged = frame.copy()
    for column in inputs:
        averaged[column] = frame[column].rolling(seconds, min_periods=1).mean()
    return averaged


def healthy_window(data_dir, asset_id: str = "skab") -> TelemetryWindow:
    """The healthy file, cut, on the 1-s grid (inputs as logged)."""
    return to_one_second_grid(read_healthy(data_dir, asset_id), asset_id)


def healthy_frame(data_dir, asset_id: str = "skab") -> pd.DataFrame:
    """The healthy file, cut, on the 1-s grid, with the electrical inputs averaged."""
    return average_inputs(healthy_window(data_dir, asset_id).frame)


def step_counts(raw: pd.DataFrame) -> dict[float, int]:
    """How many raw steps of each length (s) a file has: the 1-s and 2-s steps and gaps."""
    steps = np.diff(pd.DatetimeIndex(raw["timestamp"]).as_unit("ns").asi8) / 1e9
    values, counts = np.unique(steps, return_counts=True)
    return {float(v): int(c) for v, c in zip(values, counts)}
