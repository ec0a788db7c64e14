"""Which assets, which windows."""
from __future__ import annotations

import datetime

import pandas as pd
import pytest

from flows.config import ConfigError, load_config
from flows.discovery import discover, parse_time, pending_windows, range_windows, windows_in_dates
from flows.errors import UsageError

DAY = pd.Timedelta(days=1)
T0 = pd.Timestamp("2026-01-01", tz="UTC")


def dates(*days):
    return [datetime.date(2026, 1, d) for d in days]


def test_pending_windows_are_whole_days_after_the_watermark_before_as_of():
    available = dates(1, 2, 3, 5, 6)               # day 4 missing (the vehicle was idle)
    got = pending_windows(available, T0 + 2 * DAY, T0 + 5 * DAY + pd.Timedelta(hours=3), DAY)
    assert got == [(T0 + 2 * DAY, T0 + 3 * DAY), (T0 + 4 * DAY, T0 + 5 * DAY)]
    # day 6 is still being filled at as-of: it waits; nothing before the watermark again
    assert pending_windows(available, T0 + 6 * DAY, T0 + 9 * DAY, DAY) == []
    assert pending_windows(available, None, T0 + DAY, DAY) == [(T0, T0 + DAY)]


def test_sub_day_windows():
    windows = windows_in_dates(dates(1), pd.Timedelta(hours=6))
    assert [w[0].hour for w in windows] == [0, 6, 12, 18]
    got = pending_windows(dates(1), T0 + pd.Timedelta(hours=6), T0 + pd.Timedelta(hours=19),
                          pd.Timedelta(hours=6))
    assert got == [(T0 + pd.Timedelta(hours=6), T0 + pd.Timedelta(hours=12)),
                   (T0 + pd.Timedelta(hours=12), T0 + pd.Timedelta(hours=18))]


def test_range_windows():
    start, end = T0 + pd.Timedelta(hours=6), T0 + 3 * DAY + pd.Timedelta(hours=12)
    assert range_windows(start, end, DAY, whole_only=True) == [
        (T0 + DAY, T0 + 2 * DAY), (T0 + 2 * DAY, T0 + 3 * DAY)]
    partial = range_windows(start, end, DAY, whole_only=False)
    assert partial[0] == (start, T0 + DAY) and partial[-1] == (T0 + 3 * DAY, end)
    assert len(partial) == 4
    with pytest.raises(UsageError, match="empty range"):
        range_windows(end, start, DAY, whole_only=False)


def test_parse_time():
    assert parse_time("2026-01-05") == pd.Timestamp("2026-01-05", tz="UTC")
    assert parse_time("2026-01-05T01:00:00+01:00") == pd.Timestamp("2026-01-05", tz="UTC")
    with pytest.raises(UsageError, match="--as-of 'tomorrow'"):
        parse_time("tomorrow", "--as-of")


@pytest.fixture
def store(tmp_path):
    root = tmp_path / "telemetry"
    for asset in ("T-001", "T-002", "P-001", "X-9"):
        (root / f"asset_id={asset}" / "date=2026-01-01").mkdir(parents=True)
    (tmp_path / "fleet.toml").write_text('''
[telemetry]
root = "telemetry"
[classes.turbine]
model = "graybox.models:GasTurbineShaft"
assets = ["T-*", "T-404"]
columns = { omega = "shaft_speed" }
[classes.pump]
model = "graybox.models:LangevinShaft"
assets = ["P-*"]
''')
    return load_config(tmp_path / "fleet.toml")


def test_discover(store):
    fleet = discover(store)
    assert [(r.asset_id, r.vehicle_class) for r in fleet.assets] == [
        ("P-001", "pump"), ("T-001", "turbine"), ("T-002", "turbine")]
    assert [r.asset_id for r in fleet.without_telemetry] == ["T-404"]
    assert fleet.unmatched == ["X-9"]
    only = discover(store, vehicle_class="pump")
    assert [r.asset_id for r in only.assets] == ["P-001"] and not only.without_telemetry
    some = discover(store, assets=["T-002", "T-404", "T-002"])
    assert [r.asset_id for r in some.assets] == ["T-002"]
    assert [r.asset_id for r in some.without_telemetry] == ["T-404"]


def test_discover_refuses_bad_requests(store, tmp_path):
    with pytest.raises(UsageError, match="unknown vehicle class 'bus'"):
        discover(store, vehicle_class="bus")
    with pytest.raises(UsageError, match="belongs to no vehicle class"):
        discover(store, assets=["X-9"])
    with pytest.raises(UsageError, match="invalid asset id"):
        discover(store, assets=["../../etc"])
    with pytest.raises(UsageError, match="of class 'pump', not 'turbine'"):
        discover(store, assets=["P-001"], vehicle_class="turbine")
    import dataclasses

    missing = dataclasses.replace(store, telemetry_root=tmp_path / "nowhere")
    with pytest.raises(ConfigError, match="telemetry.root"):
        discover(missing)


@pytest.mark.parametrize("fails, status", [(False, "no telemetry"), (True, "failed")])
def test_an_asset_without_telemetry_is_reported_or_failed(store, fails, status):
    # the baseline flow fails an asset it was asked for by name (it cannot get its baseline);
    # the other runs report it
    from flows.batch_job import BatchJob
    from flows.batching import run_over_fleet
    from flows.results import RunSummary

    summary = run_over_fleet(RunSummary("baseline", "2026-01-05T00:00:00+00:00"),
                             BatchJob.for_fleet("baseline", store, None), store, "baseline",
                             ["T-404"], missing_fails=fails)
    [result] = summary.assets
    assert (result.asset_id, result.vehicle_class, result.status) == ("T-404", "turbine", status)
    said = result.error.message if fails else result.note
    assert said == "no telemetry in the store"
    assert (result.error is None) is (not fails) and (result.note is None) is fails
