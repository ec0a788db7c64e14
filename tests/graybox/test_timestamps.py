import datetime

import pandas as pd
import pytest

from graybox.timestamps import utc


def test_naive_is_taken_as_utc_and_aware_is_converted():
    assert utc("2026-01-05") == pd.Timestamp("2026-01-05", tz="UTC")
    assert str(utc("2026-01-05T01:00+01:00")) == "2026-01-05 00:00:00+00:00"
    assert utc(datetime.datetime(2026, 1, 5)).tz is not None


def test_an_index_stays_an_index():
    index = pd.DatetimeIndex(["2026-01-05", "NaT"])
    out = utc(index)
    assert isinstance(out, pd.DatetimeIndex) and str(out.tz) == "UTC" and out.isna()[1]
    assert utc(out.tz_convert("Europe/Berlin")).equals(out)


@pytest.mark.parametrize("value", [None, "NaT", "not a time"])
def test_nat_and_garbage_raise(value):
    with pytest.raises(ValueError):
        utc(value)
