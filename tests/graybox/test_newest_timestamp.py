"""An asset's newest sample: from the Parquet footer's statistics when they say it, else read."""
import datetime

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from graybox.telemetry import newest_timestamp
from graybox.telemetry.reading import _UNKNOWN, _newest_by_statistics

DAY = datetime.date(2026, 1, 4)
MIDNIGHT = pd.Timestamp("2026-01-04", tz="UTC")


def write_day(root, stamps, unit="ns", tz="UTC", day=DAY, name="part-0.parquet", **options):
    """One partition file of asset T-01 with these timestamps (pandas values or None)."""
    folder = root / "asset_id=T-01" / f"date={day.isoformat()}"
    folder.mkdir(parents=True, exist_ok=True)
    kind = pa.timestamp(unit, tz=tz)
    table = pa.table({"timestamp": pa.array(stamps, type=kind),
                      "omega": pa.array(np.arange(len(stamps), dtype=float))})
    path = folder / name
    pq.write_table(table, path, **options)
    return path


def seconds(*values):
    return [MIDNIGHT.tz_localize(None) + pd.Timedelta(seconds=v) for v in values]


def test_the_footer_gives_the_newest_sample_of_a_day(tmp_path):
    path = write_day(tmp_path, seconds(0, 86_399.5, 7), row_group_size=2)
    expected = MIDNIGHT + pd.Timedelta(seconds=86_399.5)
    assert _newest_by_statistics(path, DAY) == expected.value
    assert newest_timestamp(tmp_path, "T-01") == expected


@pytest.mark.parametrize("unit", ["s", "ms", "us"])
def test_coarser_units_and_naive_timestamps_are_the_same_instant(tmp_path, unit):
    path = write_day(tmp_path, seconds(3, 3600), unit=unit, tz=None)
    assert _newest_by_statistics(path, DAY) == (MIDNIGHT + pd.Timedelta(hours=1)).value
    assert newest_timestamp(tmp_path, "T-01") == MIDNIGHT + pd.Timedelta(hours=1)


def test_without_statistics_the_file_is_read(tmp_path):
    path = write_day(tmp_path, seconds(5, 10), write_statistics=False)
    assert _newest_by_statistics(path, DAY) is _UNKNOWN
    assert newest_timestamp(tmp_path, "T-01") == MIDNIGHT + pd.Timedelta(seconds=10)


def test_the_newest_of_several_files_and_an_empty_newer_day_is_passed_over(tmp_path):
    write_day(tmp_path, seconds(100), name="a.parquet")
    write_day(tmp_path, seconds(50, 200), name="b.parquet", write_statistics=False)
    empty = write_day(tmp_path, [], day=DAY + datetime.timedelta(days=1))
    assert _newest_by_statistics(empty, DAY + datetime.timedelta(days=1)) is None
    assert newest_timestamp(tmp_path, "T-01") == MIDNIGHT + pd.Timedelta(seconds=200)


def test_a_null_or_a_sample_outside_its_day_counts_as_data_up_to_midnight(tmp_path):
    # as before: the reading's error, and the day's midnight as a lower bound
    path = write_day(tmp_path, [*seconds(5), None])
    assert _newest_by_statistics(path, DAY) is _UNKNOWN
    assert newest_timestamp(tmp_path, "T-01") == MIDNIGHT
    path.unlink()
    path = write_day(tmp_path, seconds(5, 86_400 + 5))
    assert _newest_by_statistics(path, DAY) is _UNKNOWN
    assert newest_timestamp(tmp_path, "T-01") == MIDNIGHT


def test_a_file_that_is_not_parquet_counts_as_data_up_to_midnight(tmp_path):
    folder = tmp_path / "asset_id=T-01" / f"date={DAY.isoformat()}"
    folder.mkdir(parents=True)
    (folder / "part-0.parquet").write_bytes(b"not parquet")
    assert _newest_by_statistics(folder / "part-0.parquet", DAY) is _UNKNOWN
    assert newest_timestamp(tmp_path, "T-01") == MIDNIGHT
    assert newest_timestamp(tmp_path / "nowhere", "T-01") is None
