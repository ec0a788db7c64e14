"""Issue 20, item 1: a day that ``fleet-health import`` adds rows to after the nightly run
analysed it is re-analysed by the next run (not silently kept), then left alone."""
from __future__ import annotations

import datetime
import shutil

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from flows.changed_days import changed_windows, days_done_by
from flows.cli import main
from graybox.telemetry.changes import changed_days
from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, day
from flows.results import run_summary


def test_changed_windows_are_the_marked_days_before_the_watermark():
    marked = [datetime.date(2026, 1, 2), datetime.date(2026, 1, 5), datetime.date(2026, 1, 9)]
    dates = [datetime.date(2026, 1, d) for d in range(1, 10) if d != 5]
    watermark = pd.Timestamp("2026-01-07", tz="UTC")
    windows = changed_windows(marked, dates, watermark, pd.Timedelta(hours=12))
    assert windows == [(pd.Timestamp("2026-01-02 00:00", tz="UTC"),
                        pd.Timestamp("2026-01-02 12:00", tz="UTC")),
                       (pd.Timestamp("2026-01-02 12:00", tz="UTC"),
                        pd.Timestamp("2026-01-03 00:00", tz="UTC"))]
    assert days_done_by(marked, pd.Timestamp("2026-01-09 12:00", tz="UTC")) == marked[:2]


def _run(config, as_of):
    from flows.nightly import nightly

    state = nightly(config_path=str(config), as_of=as_of.isoformat(), return_state=True)
    return run_summary(state)


def test_a_day_changed_by_an_import_is_reanalysed_once(workspace, fleet, tmp_path, capsys,
                                                       count):
    """T-001's first nightly day holds only its first half when the run passes it; its second
    half is then imported from a CSV export: the next run re-analyses that day (and notes
    it), a third run adds nothing."""
    root = tmp_path / "telemetry"
    shutil.copytree(fleet.root, root)
    changed = day(BASELINE_DAYS)
    path = root / "asset_id=T-001" / f"date={changed:%Y-%m-%d}" / "part-0.parquet"
    frame = pq.read_table(path).to_pandas()
    half = len(frame) // 2
    pq.write_table(pa.Table.from_pandas(frame.iloc[:half], preserve_index=False), path)
    export = tmp_path / "T-001.csv"
    late = frame.iloc[half:].copy()
    late["timestamp"] = late["timestamp"].dt.strftime("%Y-%m-%dT%H:%M:%S.%f%z")
    late.to_csv(export, index=False)
    workspace.configure(telemetry=root)
    registry = workspace.registry()

    first = _run(workspace.config, day(DAYS))
    assert first["exit_status"] == 0
    assert registry.watermark("T-001") == day(DAYS)

    assert main(["import", str(export), "--root", str(root)]) == 0
    assert changed_days(root, "T-001") == [changed.date()]
    assert len(pq.read_table(path)) == len(frame)

    before = count(registry)
    second = _run(workspace.config, day(DAYS))
    assert second["exit_status"] == 0
    by_asset = {a["asset_id"]: a for a in second["assets"]}
    again = by_asset["T-001"]
    assert again["status"] == "ok"
    assert [w["window_start"] for w in again["windows"]] == [changed.isoformat()]
    assert "1 window(s) changed by an import re-analysed: " \
           f"{changed:%Y-%m-%d} 00:00" in again["note"]
    assert again["watermark_after"] == day(DAYS).isoformat()
    for asset in set(ASSETS) - {"T-001"}:
        assert by_asset[asset]["status"] == "up to date"
    assert count(registry) != before                # a new candidate, of the whole day
    assert changed_days(root, "T-001") == []

    after = count(registry)
    third = _run(workspace.config, day(DAYS))
    assert {a["status"] for a in third["assets"]} == {"up to date"}
    assert count(registry) == after
