"""Rows a logger sent twice (graybox.telemetry.resent): dropped and counted; a timestamp
repeated with other readings stays an error at its row."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from graybox.exceptions import TelemetryError
from graybox.telemetry import GridPolicy, read_window, to_grid, write_telemetry
from graybox.telemetry.resent import resent_rows
from graybox.telemetry.rows import Rows

POLICY = GridPolicy(min_duration="100s", stuck_after="200s", max_gap="40s")
T0 = pd.Timestamp("2024-03-01", tz="UTC")


def frame(n=200):
    k = np.arange(n)
    return pd.DataFrame({"timestamp": T0 + pd.to_timedelta(k * 10.0, unit="s"),
                         "a": np.sin(k / 7.0) + 0.01 * k, "b": 2.0 * k + 1.0})


def assert_same_grid(window, clean):
    pd.testing.assert_frame_equal(window.frame, clean.frame)
    assert window.filled_samples == clean.filled_samples


def test_a_resent_tail_reads_as_the_rows_sent_once(tmp_path):
    """A reconnecting gateway sends the last 30 rows again after row 149: times go back at
    row 150 and the readings are the same; the window is the clean one, 30 rows counted."""
    clean_root, root = tmp_path / "clean", tmp_path / "resent"
    rows = frame()
    write_telemetry(clean_root, "T-1", rows)
    write_telemetry(root, "T-1", pd.concat([rows.iloc[:150], rows.iloc[120:150],
                                            rows.iloc[150:]], ignore_index=True))
    clean = read_window(clean_root, "T-1", ["a", "b"], policy=POLICY)
    window = read_window(root, "T-1", ["a", "b"], policy=POLICY)
    assert_same_grid(window, clean)
    assert (window.resent, clean.resent) == (30, 0)


def test_a_file_that_repeats_the_previous_files_tail(tmp_path):
    """Rotation: the day's second file starts with the first file's last 5 rows."""
    rows = frame()
    write_telemetry(tmp_path, "T-1", rows.iloc[:100], file_name="part-0.parquet")
    write_telemetry(tmp_path, "T-1", rows.iloc[95:], file_name="part-1.parquet")
    window = read_window(tmp_path, "T-1", ["a", "b"], policy=POLICY)
    assert window.resent == 5 and len(window.frame) == 200
    np.testing.assert_array_equal(window.frame["b"].to_numpy(), rows["b"].to_numpy())


def test_the_frame_path_drops_them_too():
    rows = frame()
    sent_twice = pd.concat([rows.iloc[:60], rows.iloc[50:60], rows.iloc[60:]],
                           ignore_index=True)
    window = to_grid(sent_twice, "T-1", POLICY)
    assert_same_grid(window, to_grid(rows, "T-1", POLICY))
    assert window.resent == 10


def test_a_repeated_timestamp_with_other_readings_is_still_an_error(tmp_path):
    """Which of two readings at one time is true is unknown: not a re-sent row."""
    rows = frame()
    again = rows.iloc[[41]].assign(a=rows["a"].iloc[41] + 0.5)
    write_telemetry(tmp_path, "T-1", pd.concat([rows.iloc[:42], again, rows.iloc[42:]],
                                               ignore_index=True))
    with pytest.raises(TelemetryError) as raised:
        read_window(tmp_path, "T-1", ["a", "b"], policy=POLICY)
    assert raised.value.kind == "duplicate_timestamp" and raised.value.row == 42


def test_resent_rows_known_answer():
    """The second of two equal rows is re-sent, wherever it comes; a missing reading equals a
    missing one, -0.0 equals 0.0; another reading or another time is not."""
    ts = np.array([0, 10, 20, 10, 30, 20, 20, 40, 30], dtype=np.int64)
    a = np.array([1.0, 2.0, np.nan, 2.0, 0.0, np.nan, 5.0, 6.0, -0.0])
    rows = Rows(ts, a[None, :], ("a",))
    assert resent_rows(rows).tolist() == [False, False, False, True, False, True, False,
                                          False, True]
    increasing = Rows(np.arange(5, dtype=np.int64), np.ones((1, 5)), ("a",))
    assert not resent_rows(increasing).any()       # equal readings at new times: not re-sent
