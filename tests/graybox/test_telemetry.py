"""Telemetry store: layout, validation errors naming file and row, gridding, splitting."""
from __future__ import annotations

import datetime
import pathlib

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from graybox.exceptions import InvalidAssetIdError, TelemetryError
from graybox.telemetry import (ASSET_ID_PATTERN, GridPolicy, TelemetryWindow, list_assets,
                               list_dates, read_raw, read_window, to_grid, validate,
                               validate_asset_id, write_telemetry)

# at 10 s samples: 10 samples, 20 samples stuck, 3 missing samples filled
POLICY = GridPolicy(min_duration="100s", stuck_after="200s", max_gap="40s")
T0 = pd.Timestamp("2024-03-01", tz="UTC")


def make_frame(n=200, start=T0, step=10.0):
    """``n`` rows every ``step`` s: channel ``a`` varies (never stuck), ``b`` is a ramp."""
    k = np.arange(n)
    return pd.DataFrame({
        "timestamp": start + pd.to_timedelta(k * step, unit="s"),
        "a": np.sin(k / 7.0) + 0.01 * k,
        "b": 2.0 * k + 1.0,
    })


def write_table(path: pathlib.Path, **columns):
    path.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(pa.table(columns), path)
    return path


def arrow_ts(index: pd.DatetimeIndex, unit="ns", tz=None) -> pa.Array:
    """Arrow timestamps from a pandas index (tz-aware indexes are stored as UTC instants)."""
    values = index.tz_convert(None) if index.tz is not None else index
    return pa.array(values.to_numpy(), type=pa.timestamp(unit, tz=tz))


def day_dir(root, asset="T-1", day="2024-03-01"):
    return pathlib.Path(root) / f"asset_id={asset}" / f"date={day}"


def raises_telemetry(kind, func, *args, **kwargs) -> TelemetryError:
    with pytest.raises(TelemetryError) as info:
        func(*args, **kwargs)
    assert info.value.kind == kind, str(info.value)
    return info.value


def window_error(root, kind, columns) -> TelemetryError:
    """The error of ``kind`` that reading asset T-1's window of ``columns`` with
    :data:`POLICY` raises."""
    return raises_telemetry(kind, read_window, root, "T-1", columns, policy=POLICY)


# -- asset ids ------------------------------------------------------------------------------

@pytest.mark.parametrize("asset_id", ["T-1", "a", "pump_07.b", "x" * 64, "..a", "a..b"])
def test_valid_asset_ids(asset_id):
    assert validate_asset_id(asset_id) == asset_id
    assert ASSET_ID_PATTERN.fullmatch(asset_id)


@pytest.mark.parametrize("asset_id", ["", ".", "..", "../x", "a/b", "a\\b", "x" * 65, "a b",
                                      "T-1\n", "é", None, 7])
def test_invalid_asset_ids(asset_id):
    with pytest.raises(InvalidAssetIdError):
        validate_asset_id(asset_id)


@pytest.mark.parametrize("asset_id", ["../x", "..", "a/../../b"])
def test_invalid_asset_id_rejected_before_any_path(tmp_path, asset_id):
    root = tmp_path / "store"
    root.mkdir()
    with pytest.raises(InvalidAssetIdError):
        write_telemetry(root, asset_id, make_frame())
    for func in (read_raw, read_window):
        with pytest.raises(InvalidAssetIdError):
            func(root, asset_id, ["a"])
    with pytest.raises(InvalidAssetIdError):
        list_dates(root, asset_id)
    assert list(tmp_path.rglob("*")) == [root]


# -- round trip and layout ------------------------------------------------------------------

def test_round_trip(tmp_path):
    frame = make_frame(300)
    paths = write_telemetry(tmp_path, "T-1", frame)
    assert paths == [day_dir(tmp_path) / "part-0.parquet"]
    window = read_window(tmp_path, "T-1", ["a", "b"], policy=POLICY)
    assert isinstance(window, TelemetryWindow)
    assert window.asset_id == "T-1"
    assert window.sample_interval == 10.0
    assert window.filled_samples == 0
    assert window.n_samples == 300
    assert window.files == (str(paths[0]),)
    assert window.frame.index.name == "timestamp"
    assert str(window.frame.index.dtype) == "datetime64[ns, UTC]"
    assert list(window.frame.columns) == ["a", "b"]
    assert (window.frame.dtypes == np.float64).all()
    np.testing.assert_array_equal(window.frame.index, pd.DatetimeIndex(frame["timestamp"]))
    np.testing.assert_array_equal(window.frame.to_numpy(), frame[["a", "b"]].to_numpy())
    assert window.start == T0
    assert window.end == T0 + pd.Timedelta(seconds=3000)
    assert "n_samples=300" in repr(window)


def test_read_raw_columns_and_tags(tmp_path):
    write_telemetry(tmp_path, "T-1", make_frame(50))
    raw = read_raw(tmp_path, "T-1", ["b"])
    assert list(raw.columns) == ["timestamp", "b", "_file", "_row"]
    assert str(raw["timestamp"].dtype) == "datetime64[ns, UTC]"
    assert raw["b"].dtype == np.float64
    assert raw["_row"].tolist() == list(range(50))
    assert set(raw["_file"]) == {str(day_dir(tmp_path) / "part-0.parquet")}


def test_write_splits_by_utc_date_and_overwrites(tmp_path):
    frame = make_frame(100, start=pd.Timestamp("2024-03-01 23:50", tz="UTC"), step=60.0)
    paths = write_telemetry(tmp_path, "T-1", frame.set_index("timestamp"))  # index form
    assert [p.parent.name for p in paths] == ["date=2024-03-01", "date=2024-03-02"]
    assert pq.read_table(paths[0]).num_rows == 10
    write_telemetry(tmp_path, "T-1", frame.iloc[:5])
    assert pq.read_table(paths[0]).num_rows == 5
    assert not [p for p in tmp_path.rglob("*") if p.name.startswith(".")]
    assert list_dates(tmp_path, "T-1") == [datetime.date(2024, 3, 1), datetime.date(2024, 3, 2)]
    with pytest.raises(ValueError):
        write_telemetry(tmp_path, "T-1", frame, file_name="../evil.parquet")


def test_timestamps_naive_taken_as_utc_and_aware_converted(tmp_path):
    k = np.arange(40)
    naive = pd.Timestamp("2024-03-01 01:00") + pd.to_timedelta(k * 10, unit="s")
    write_table(day_dir(tmp_path) / "a.parquet", timestamp=arrow_ts(naive),
                a=np.sin(k / 3.0))
    paris = (pd.Timestamp("2024-03-01 12:00", tz="Europe/Paris")
             + pd.to_timedelta(k * 10, unit="s"))  # 11:00 UTC
    write_table(day_dir(tmp_path) / "b.parquet",
                timestamp=arrow_ts(paris, "ms", tz="Europe/Paris"),
                a=np.cos(k / 3.0))
    raw = read_raw(tmp_path, "T-1", ["a"])
    assert raw["timestamp"].iloc[0] == pd.Timestamp("2024-03-01 01:00", tz="UTC")
    assert raw["timestamp"].iloc[40] == pd.Timestamp("2024-03-01 11:00", tz="UTC")
    # naive bounds are UTC too
    raw = read_raw(tmp_path, "T-1", ["a"], start="2024-03-01 11:00", end="2024-03-01 11:01")
    assert len(raw) == 6 and raw["_file"].str.endswith("b.parquet").all()


def test_list_assets_skips_invalid_ids(tmp_path):
    for name in ["asset_id=T-2", "asset_id=T-1", "asset_id=bad id", "asset_id=..",
                 "asset_id=", "other"]:
        (tmp_path / name).mkdir()
    (tmp_path / "asset_id=file").write_text("not a directory")
    assert list_assets(tmp_path) == ["T-1", "T-2"]
    with pytest.raises(FileNotFoundError):
        list_assets(tmp_path / "missing")


def test_malformed_date_dir_is_unreadable(tmp_path):
    write_telemetry(tmp_path, "T-1", make_frame(20))
    bad = day_dir(tmp_path, day="2024-13-01")
    bad.mkdir()
    error = raises_telemetry("unreadable", list_dates, tmp_path, "T-1")
    assert error.file == str(bad)
    assert list_dates(tmp_path, "T-2") == []


def test_date_pruning(tmp_path):
    frame = make_frame(3 * 24 * 60, start=T0, step=60.0)  # three days at 1 min
    paths = write_telemetry(tmp_path, "T-1", frame)
    assert len(paths) == 3
    paths[0].write_bytes(b"corrupt")  # day 1 must not even be opened
    start, end = "2024-03-02 06:00", "2024-03-03 00:00"
    raw = read_raw(tmp_path, "T-1", ["a", "b"], start=start, end=end)
    assert raw["_file"].unique().tolist() == [str(paths[1])]
    assert raw["timestamp"].min() == pd.Timestamp(start, tz="UTC")
    assert raw["timestamp"].max() == pd.Timestamp(end, tz="UTC") - pd.Timedelta(minutes=1)
    assert raw["_row"].iloc[0] == 6 * 60
    window = read_window(tmp_path, "T-1", ["a"], start=start,
                         end=pd.Timestamp("2024-03-03 01:00", tz="UTC"), policy=POLICY)
    assert window.files == (str(paths[1]), str(paths[2]))
    assert window.n_samples == 19 * 60
    assert window.end == pd.Timestamp("2024-03-03 01:00", tz="UTC")
    raises_telemetry("unreadable", read_raw, tmp_path, "T-1", ["a"], end="2024-03-01 12:00")


# -- schema and store errors ----------------------------------------------------------------

def test_missing_column_is_schema_error(tmp_path):
    write_telemetry(tmp_path, "T-1", make_frame(30))
    error = window_error(tmp_path, "schema", ["a", "zz"])
    assert error.file.endswith("part-0.parquet") and "'zz'" in error.message
    assert "part-0.parquet" in str(error) and "T-1" in str(error)


def test_missing_timestamp_is_schema_error(tmp_path):
    write_table(day_dir(tmp_path) / "x.parquet", time=np.arange(5), a=np.arange(5.0))
    error = raises_telemetry("schema", read_raw, tmp_path, "T-1", ["a"])
    assert error.file.endswith("x.parquet") and "'timestamp'" in error.message


def test_string_channel_is_schema_error(tmp_path):
    stamps = pd.date_range(T0, periods=5, freq="10s")
    write_table(day_dir(tmp_path) / "s.parquet", timestamp=arrow_ts(stamps),
                a=["1", "2", "3", "4", "5"])
    error = raises_telemetry("schema", read_raw, tmp_path, "T-1", ["a"])
    assert error.file.endswith("s.parquet") and "'a'" in error.message


def test_non_datetime_timestamp_is_schema_error(tmp_path):
    write_table(day_dir(tmp_path) / "i.parquet", timestamp=np.arange(5) * 10, a=np.arange(5.0))
    error = raises_telemetry("schema", read_raw, tmp_path, "T-1", ["a"])
    assert error.file.endswith("i.parquet")


def test_integer_channel_is_read_as_float(tmp_path):
    write_table(day_dir(tmp_path) / "i.parquet",
                timestamp=arrow_ts(pd.date_range(T0, periods=5, freq="10s")), a=np.arange(5))
    assert read_raw(tmp_path, "T-1", ["a"])["a"].dtype == np.float64


def test_row_outside_partition_date_is_schema_error(tmp_path):
    stamps = pd.date_range("2024-03-01 23:59:30", periods=6, freq="10s", tz="UTC")
    write_table(day_dir(tmp_path) / "p.parquet", timestamp=arrow_ts(stamps), a=np.arange(6.0))
    error = raises_telemetry("schema", read_raw, tmp_path, "T-1", ["a"])
    assert error.row == 3 and "date=2024-03-01" in error.message


def test_unreadable_parquet(tmp_path):
    path = day_dir(tmp_path) / "junk.parquet"
    path.parent.mkdir(parents=True)
    path.write_bytes(b"this is not parquet")
    error = raises_telemetry("unreadable", read_raw, tmp_path, "T-1", ["a"])
    assert error.file == str(path)


def test_no_data(tmp_path):
    raises_telemetry("no_data", read_raw, tmp_path, "T-1", ["a"])
    write_telemetry(tmp_path, "T-1", make_frame(30))
    raises_telemetry("no_data", read_window, tmp_path, "T-1", ["a"], start="2024-04-01")
    raises_telemetry("no_data", read_raw, tmp_path, "T-1", ["a"],
                     start="2024-03-01 00:01", end="2024-03-01 00:01")
    # a partition holding only hidden or non-Parquet files is no data either
    other = day_dir(tmp_path, asset="T-2")
    other.mkdir(parents=True)
    (other / ".part-0.parquet.123.tmp").write_bytes(b"partial")
    raises_telemetry("no_data", read_raw, tmp_path, "T-2", ["a"])


def test_reserved_column_names_rejected(tmp_path):
    write_telemetry(tmp_path, "T-1", make_frame(30))
    with pytest.raises(ValueError):
        read_raw(tmp_path, "T-1", ["timestamp"])


# -- validation: the first bad row, by file and row -----------------------------------------

@pytest.mark.parametrize("bad, column", [(np.inf, "b"), (-np.inf, "a")])
def test_non_finite(tmp_path, bad, column):
    frame = make_frame(100)
    frame.loc[37, column] = bad
    frame.loc[80, "a"] = np.inf
    write_telemetry(tmp_path, "T-1", frame)
    error = window_error(tmp_path, "non_finite", ["a", "b"])
    assert error.file.endswith("part-0.parquet")
    assert error.row == 37
    assert f"{column!r}={bad!r}" in error.message
    assert error.asset_id == "T-1"


def test_a_missing_value_is_interpolated_like_a_missing_row(tmp_path):
    # a null (a missed reading) and a NaN, 10 s apart from their neighbours: filled in time
    stamps = pd.date_range(T0, periods=30, freq="10s")
    values = pa.array([float(i * i) if i != 12 else None for i in range(30)])
    other = pa.array([np.nan if i == 20 else 1.0 + i for i in range(30)])
    write_table(day_dir(tmp_path) / "n.parquet", timestamp=arrow_ts(stamps), a=values, b=other)
    window = read_window(tmp_path, "T-1", ["a", "b"], policy=POLICY)
    assert window.frame["a"].iloc[12] == (11 * 11 + 13 * 13) / 2
    assert window.frame["b"].iloc[20] == 21.0
    assert window.filled_samples == 2


def test_a_missing_value_at_an_operating_period_s_start_is_held_not_a_gap(tmp_path):
    # two runs an hour apart (intermittent): the second run's first reading is missing
    first = pd.date_range(T0, periods=20, freq="10s")
    second = pd.date_range(T0 + pd.Timedelta(hours=1), periods=20, freq="10s")
    values = pa.array([float(i) for i in range(20)] + [None] + [float(i) for i in range(1, 20)])
    write_table(day_dir(tmp_path) / "n.parquet", timestamp=arrow_ts(first.append(second)),
                a=values)
    policy = GridPolicy(min_duration="100s", stuck_after="200s", max_gap="40s",
                        intermittent=True)
    window = read_window(tmp_path, "T-1", ["a"], policy=policy)
    assert window.frame["a"].iloc[20] == 1.0 and window.filled_samples == 1


def test_values_missing_longer_than_max_gap_are_missing_rows(tmp_path):
    # 60 s between values, max_gap 40 s: the rows without them are left out, and the rows
    # on either side are two operating periods (as rows missing altogether are)
    stamps = pd.date_range(T0, periods=30, freq="10s")
    values = pa.array([float(i) if not 10 <= i < 15 else None for i in range(30)])
    write_table(day_dir(tmp_path) / "n.parquet", timestamp=arrow_ts(stamps),
                a=values, b=pa.array([float(-i) for i in range(30)]))
    window = read_window(tmp_path, "T-1", ["a", "b"], policy=POLICY)
    assert window.n_periods == 2 and window.filled_samples == 0
    assert window.unread == (("a", 5),)             # what the flows say
    first, second = window.periods()
    assert list(first["a"]) == [float(i) for i in range(10)]
    assert list(second["a"]) == [float(i) for i in range(15, 30)]
    assert list(second["b"]) == [float(-i) for i in range(15, 30)]
    # a channel missing where the other is not, and the reverse: no row has both
    write_table(day_dir(tmp_path) / "n.parquet", timestamp=arrow_ts(stamps),
                a=pa.array([float(i) if i < 15 else None for i in range(30)]),
                b=pa.array([float(i) if i >= 15 else None for i in range(30)]))
    error = window_error(tmp_path, "gap", ["a", "b"])
    assert "no row has every channel's value within max_gap=40s" in error.message
    assert "'a', 'b'" in error.message
    # a channel without any value while the other has one: a dead sensor, named
    empty = pa.array([None] * 30, type=pa.float64())
    write_table(day_dir(tmp_path) / "n.parquet", timestamp=arrow_ts(stamps), a=empty,
                b=pa.array([float(-i) for i in range(30)]))
    error = window_error(tmp_path, "silent_channel", ["a", "b"])
    assert "channel 'a' has no value in the window (5min) while the others have" in error.message
    assert (error.channel, error.excess) == ("a", (300.0, 40.0))
    # no channel with a value: a window without data
    write_table(day_dir(tmp_path) / "n.parquet", timestamp=arrow_ts(stamps), a=empty)
    window_error(tmp_path, "no_data", ["a"])


def test_duplicate_timestamp(tmp_path):
    frame = make_frame(100)
    frame.loc[42, "timestamp"] = frame.loc[41, "timestamp"]
    write_telemetry(tmp_path, "T-1", frame)
    error = window_error(tmp_path, "duplicate_timestamp", ["a"])
    assert error.file.endswith("part-0.parquet") and error.row == 42


def test_backward_timestamp(tmp_path):
    frame = make_frame(100)
    frame.loc[[60, 61], "timestamp"] = frame.loc[[61, 60], "timestamp"].to_numpy()
    write_telemetry(tmp_path, "T-1", frame)
    error = window_error(tmp_path, "backward_timestamp", ["a"])
    assert error.file.endswith("part-0.parquet") and error.row == 61
    assert "2024-03-01T00:10:00" in error.message and "2024-03-01T00:10:10" in error.message


def test_backward_timestamp_across_files(tmp_path):
    frame = make_frame(100)
    write_telemetry(tmp_path, "T-1", frame.iloc[:60], file_name="part-0.parquet")
    # overlaps with other readings (an overlap that repeats the rows is a re-sent tail, read
    # once: tests/graybox/test_telemetry_resent.py)
    later = frame.iloc[55:].copy()
    later.loc[55:59, "a"] += 0.5
    write_telemetry(tmp_path, "T-1", later, file_name="part-1.parquet")
    error = window_error(tmp_path, "backward_timestamp", ["a"])
    assert error.file.endswith("part-1.parquet") and error.row == 0
    assert "another file" in error.message and "part-0.parquet" in error.message


def test_stuck_channel(tmp_path):
    frame = make_frame(200)
    frame.loc[50:69, "b"] = 7.25            # 20 identical samples: stuck
    frame.loc[120:139, "a"] = 1.0           # a later stuck run is not the first
    write_telemetry(tmp_path, "T-1", frame)
    error = window_error(tmp_path, "stuck_channel", ["a", "b"])
    assert error.file.endswith("part-0.parquet") and error.row == 50
    assert "'b'" in error.message and "stuck at 7.25 for 20" in error.message
    # a machine that stands still is told the setting that helps
    assert "intermittent = true" in error.message
    # one sample shorter is fine, and stuck_after=0 disables the check
    frame.loc[69, "b"] = 8.0
    frame.loc[139, "a"] = 2.0
    write_telemetry(tmp_path, "T-1", frame)
    read_window(tmp_path, "T-1", ["a", "b"], policy=POLICY)
    constant = make_frame(200).assign(b=3.0)
    write_telemetry(tmp_path, "T-1", constant)
    read_window(tmp_path, "T-1", ["b"], policy=GridPolicy(min_duration="100s", stuck_after=0))


def test_gap_longer_than_max_gap_separates_two_periods(tmp_path):
    frame = make_frame(200).drop(index=range(100, 104))  # 4 missing samples
    write_telemetry(tmp_path, "T-1", frame)
    window = read_window(tmp_path, "T-1", ["a"], policy=POLICY)
    assert window.n_periods == 2 and window.filled_samples == 0
    first, second = window.periods()
    assert first.index[-1] == pd.Timestamp("2024-03-01T00:16:30", tz="UTC")
    assert second.index[0] == pd.Timestamp("2024-03-01T00:17:20", tz="UTC")
    assert len(first) + len(second) == 196
    # three missing samples (40 s between rows) are bridged
    write_telemetry(tmp_path, "T-1", make_frame(200).drop(index=range(100, 103)))
    bridged = read_window(tmp_path, "T-1", ["a"], policy=POLICY)
    assert bridged.n_periods == 1 and bridged.filled_samples == 3


def test_too_few_samples(tmp_path):
    write_telemetry(tmp_path, "T-1", make_frame(9))
    error = window_error(tmp_path, "too_few_samples", ["a"])
    assert error.row is None and "9" in error.message


def test_checks_run_in_documented_order(tmp_path):
    frame = make_frame(9)                      # too few samples ...
    frame.loc[5, "timestamp"] = frame.loc[4, "timestamp"]   # ... a duplicate ...
    frame.loc[7, "a"] = np.inf                 # ... and, later, an Inf: non-finite comes first
    write_telemetry(tmp_path, "T-1", frame)
    error = window_error(tmp_path, "non_finite", ["a"])
    assert error.row == 7


def test_validate_without_tags_reports_position():
    raw = make_frame(50)
    raw.loc[33, "b"] = np.inf
    with pytest.raises(TelemetryError) as info:
        validate(raw, "T-1", POLICY)
    assert info.value.row == 33 and info.value.file is None


# -- gridding and splitting -----------------------------------------------------------------

def test_short_gap_filled_linearly_and_counted(tmp_path):
    frame = make_frame(200).drop(index=range(100, 103))  # 3 missing samples: rows 40 s = max_gap apart
    write_telemetry(tmp_path, "T-1", frame)
    window = read_window(tmp_path, "T-1", ["a", "b"], policy=POLICY)
    assert window.n_samples == 200 and window.filled_samples == 3
    b = window.frame["b"].to_numpy()
    np.testing.assert_allclose(b, 2.0 * np.arange(200) + 1.0, rtol=0, atol=1e-9)  # a ramp
    a = window.frame["a"].to_numpy()
    np.testing.assert_allclose(a[100:103], np.interp([100, 101, 102], [99, 103],
                                                     [a[99], a[103]]), atol=1e-12)


def test_jittered_timestamps_land_on_grid():
    rng = np.random.default_rng(0)
    k = np.arange(500)
    seconds = 10.0 * k + rng.uniform(-2.0, 2.0, size=k.size)
    seconds[0] = 0.0
    stamps = T0 + pd.to_timedelta(seconds, unit="s")
    seconds = (stamps - T0).total_seconds().to_numpy()  # as stored: rounded to the ns
    raw = pd.DataFrame({"timestamp": stamps, "y": 3.0 + 0.5 * seconds})
    window = to_grid(raw, "T-1", GridPolicy(sample_interval=10.0, min_duration="100s"))
    assert window.filled_samples == 0
    assert window.sample_interval == 10.0
    grid_seconds = (window.frame.index - T0).total_seconds().to_numpy()
    np.testing.assert_array_equal(grid_seconds, 10.0 * np.arange(window.n_samples))
    assert window.n_samples in (499, 500)  # no extrapolation past the last raw sample
    np.testing.assert_allclose(window.frame["y"], 3.0 + 0.5 * grid_seconds, rtol=1e-13)


def test_inferred_interval_is_median_step():
    raw = make_frame(100, step=2.5)
    window = to_grid(raw, "T-1", POLICY)
    assert window.sample_interval == 2.5 and window.n_samples == 100


def test_policy_interval_resamples():
    raw = make_frame(100, step=5.0)
    window = to_grid(raw, "T-1", GridPolicy(sample_interval=10.0, min_duration="100s"))
    assert window.n_samples == 50 and window.filled_samples == 0
    np.testing.assert_allclose(window.frame["b"], raw["b"].to_numpy()[::2])


def test_split_by_day(tmp_path):
    start = pd.Timestamp("2024-03-01 18:00", tz="UTC")
    frame = make_frame(36 * 60, start=start, step=60.0)   # 18:00 day 1 -> 06:00 day 3
    frame = frame.drop(index=range(600, 602))             # short gap on day 2 (04:00)
    paths = write_telemetry(tmp_path, "T-1", frame)
    window = read_window(tmp_path, "T-1", ["a", "b"])     # the default fills 3 min at 60 s
    assert window.filled_samples == 2
    days = window.split("1D")
    assert [d.start for d in days] == [start, pd.Timestamp("2024-03-02", tz="UTC"),
                                       pd.Timestamp("2024-03-03", tz="UTC")]
    assert [d.end for d in days] == [pd.Timestamp("2024-03-02", tz="UTC"),
                                     pd.Timestamp("2024-03-03", tz="UTC"),
                                     pd.Timestamp("2024-03-03 06:00", tz="UTC")]
    assert [d.n_samples for d in days] == [6 * 60, 24 * 60, 6 * 60]
    assert [d.filled_samples for d in days] == [0, 2, 0]
    assert all(d.sample_interval == 60.0 for d in days)
    pd.testing.assert_frame_equal(pd.concat([d.frame for d in days]), window.frame)
    # each day's grid points lie on (or between) that day's raw rows only
    assert [d.files for d in days] == [(str(p),) for p in paths]
    assert len(window.split("1D", min_samples=7 * 60)) == 1
    assert [len(d.split("6h")) for d in days] == [1, 4, 1]


def test_grid_policy_rejects_bad_values():
    for kwargs in ({"sample_interval": 0}, {"sample_interval": float("nan")},
                   {"sample_interval": "10"}, {"max_gap": -1}, {"max_gap": "-5s"},
                   {"max_gap": "soon"}, {"max_gap": True}, {"stuck_after": float("inf")},
                   {"stuck_after": {"p": "x"}}, {"stuck_after": {"": "1min"}},
                   {"min_duration": 0}, {"min_duration": [1]}):
        with pytest.raises(ValueError):
            GridPolicy(**kwargs)


def test_a_file_the_file_system_cannot_deliver_is_an_io_error(tmp_path, monkeypatch):
    """A failing file system (EIO on a network share) is "io_error", which a caller may retry;
    a file that is not Parquet stays "unreadable"."""
    import pandas as pd
    import pyarrow.parquet as pq

    from graybox.exceptions import TelemetryError
    from graybox.telemetry import read_raw, write_telemetry

    frame = pd.DataFrame({"timestamp": pd.date_range("2026-01-01", periods=3, freq="10s",
                                                     tz="UTC"), "x": [1.0, 2.0, 3.0]})
    path = write_telemetry(tmp_path, "A", frame)[0]

    def failing_share(*args, **kwargs):
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(pq, "ParquetFile", failing_share)
    with pytest.raises(TelemetryError) as info:
        read_raw(tmp_path, "A", ["x"])
    assert info.value.kind == "io_error" and info.value.file == str(path)
    monkeypatch.undo()
    path.write_bytes(b"not parquet at all")
    with pytest.raises(TelemetryError) as info:
        read_raw(tmp_path, "A", ["x"])
    assert info.value.kind == "unreadable"
