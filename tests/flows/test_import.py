"""Issue 20, item 1: ``fleet-health import`` turns a user's CSV or Parquet exports into the
telemetry layout in UTC; a re-import adds nothing; bad rows are named with file and line;
``--dry-run`` writes nothing."""
from __future__ import annotations

import datetime

import numpy as np
import pandas as pd
import pytest

from flows.cli import main
from graybox.telemetry import list_assets, list_dates, read_raw
from graybox.telemetry.changes import changed_days

# Europe/Berlin in winter is UTC+1: 00:30 local on 03-02 is 23:30 UTC on 03-01
BERLIN_CSV = """Zeit;Druck bar;Temp °C
01.03.2026 23:00:00;1,50;20,0
01.03.2026 23:30:00;1,55;20,5
02.03.2026 00:30:00;1,60;21,0
02.03.2026 01:30:00;1,65;21,5
"""
BERLIN_OPTIONS = ["--asset", "P-7", "--timestamp-column", "Zeit",
                  "--timestamp-format", "%d.%m.%Y %H:%M:%S", "--timezone", "Europe/Berlin",
                  "--delimiter", ";", "--decimal", ",",
                  "--map", "Druck bar=pressure", "--map", "Temp °C=temperature"]


def run(capsys, *argv):
    status = main(["import", *map(str, argv)])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def snapshot(root):
    """Every file under the root (markers included) with its bytes."""
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


@pytest.fixture
def berlin_csv(tmp_path):
    path = tmp_path / "pump-7.csv"
    path.write_text(BERLIN_CSV, encoding="utf-8")
    return path


def test_local_time_csv_becomes_utc_days_and_a_reimport_adds_nothing(tmp_path, capsys,
                                                                     berlin_csv):
    root = tmp_path / "telemetry"
    status, out, err = run(capsys, berlin_csv, "--root", root, *BERLIN_OPTIONS)
    assert status == 0, err
    assert list_assets(root) == ["P-7"]
    assert list_dates(root, "P-7") == [datetime.date(2026, 3, 1), datetime.date(2026, 3, 2)]
    raw = read_raw(root, "P-7", ["pressure", "temperature"])
    assert [t.isoformat() for t in raw["timestamp"]] == [
        "2026-03-01T22:00:00+00:00", "2026-03-01T22:30:00+00:00",
        "2026-03-01T23:30:00+00:00", "2026-03-02T00:30:00+00:00"]
    np.testing.assert_array_equal(raw["pressure"], [1.5, 1.55, 1.6, 1.65])
    np.testing.assert_array_equal(raw["temperature"], [20.0, 20.5, 21.0, 21.5])
    assert "Added 4 rows to 2 asset-day(s)" in out
    assert changed_days(root, "P-7") == [datetime.date(2026, 3, 1), datetime.date(2026, 3, 2)]

    for day in changed_days(root, "P-7"):     # as the nightly run does once analysed
        (root / "asset_id=P-7" / ".changed" / day.isoformat()).unlink()
    before = snapshot(root)
    status, out, err = run(capsys, berlin_csv, "--root", root, *BERLIN_OPTIONS)
    assert status == 0, err
    assert snapshot(root) == before           # byte-identical, and no day marked changed
    assert "Added 0 rows to 0 asset-day(s)" in out and "2 asset-day(s) already held" in out


def test_new_rows_merge_into_their_day_and_mark_it_changed(tmp_path, capsys, berlin_csv):
    root = tmp_path / "telemetry"
    assert run(capsys, berlin_csv, "--root", root, *BERLIN_OPTIONS)[0] == 0
    (root / "asset_id=P-7" / ".changed" / "2026-03-01").unlink()
    (root / "asset_id=P-7" / ".changed" / "2026-03-02").unlink()
    later = tmp_path / "pump-7-later.csv"       # overlaps the first export by one row
    later.write_text("Zeit;Druck bar;Temp °C\n"
                     "02.03.2026 01:30:00;1,65;21,5\n"
                     "01.03.2026 22:00:00;1,45;19,5\n", encoding="utf-8")
    status, out, err = run(capsys, later, "--root", root, *BERLIN_OPTIONS)
    assert status == 0, err
    raw = read_raw(root, "P-7", ["pressure"])
    assert raw["timestamp"].is_monotonic_increasing and len(raw) == 5
    assert raw["timestamp"].iloc[0].isoformat() == "2026-03-01T21:00:00+00:00"
    assert len(list((root / "asset_id=P-7" / "date=2026-03-01").glob("*.parquet"))) == 1
    assert changed_days(root, "P-7") == [datetime.date(2026, 3, 1)]   # only the changed day


def test_a_conflicting_value_is_named_with_file_and_line(tmp_path, capsys, berlin_csv):
    root = tmp_path / "telemetry"
    assert run(capsys, berlin_csv, "--root", root, *BERLIN_OPTIONS)[0] == 0
    before = snapshot(root)
    other = tmp_path / "pump-7-fixed.csv"
    other.write_text("Zeit;Druck bar;Temp °C\n"
                     "02.03.2026 00:30:00;1,99;21,0\n", encoding="utf-8")
    status, _, err = run(capsys, other, "--root", root, *BERLIN_OPTIONS)
    assert status == 1
    assert f"{other}, line 2: 2026-03-01T23:30:00+00:00 is stored with other values" in err
    assert "pressure 1.6 vs 1.99" in err
    assert snapshot(root) == before


def test_bad_rows_are_named_with_file_and_line_and_nothing_is_written(tmp_path, capsys):
    export = tmp_path / "P-9.csv"
    export.write_text("time,speed\n"
                      "2026-01-05T10:00:00Z,1.0\n"
                      "yesterday,2.0\n"
                      "2026-01-05T10:00:02Z,fast\n"
                      "2026-01-05T10:00:03Z,\n"
                      "2026-01-05T10:00:04Z,5.0\n")
    root = tmp_path / "telemetry"
    status, _, err = run(capsys, export, "--root", root, "--timestamp-column", "time")
    assert status == 1
    assert f"{export}, line 3: timestamp 'yesterday' is not a time" in err
    assert f"{export}, line 4: column 'speed' value 'fast' is not a finite number" in err
    assert f"{export}, line 5: column 'speed' is empty" in err
    assert "3 bad row(s) in 1 file(s): nothing written" in err
    assert not root.exists()

    status, _, err = run(capsys, export, "--root", root, "--timestamp-column", "time",
                         "--skip-bad-rows")
    assert status == 0, err
    assert f"{export}, line 3" in err          # still named
    assert read_raw(root, "P-9", ["speed"])["speed"].tolist() == [1.0, 5.0]


def test_dry_run_shows_the_asset_days_and_writes_nothing(tmp_path, capsys, berlin_csv):
    root = tmp_path / "telemetry"
    status, out, err = run(capsys, berlin_csv, "--root", root, *BERLIN_OPTIONS, "--dry-run")
    assert status == 0, err
    assert not root.exists()
    assert "P-7" in out and "2026-03-01" in out and "2026-03-02" in out
    assert "Dry run: would add 4 rows to 2 asset-day(s)" in out and "nothing written" in out

    assert run(capsys, berlin_csv, "--root", root, *BERLIN_OPTIONS)[0] == 0
    before = snapshot(root)
    status, out, _ = run(capsys, berlin_csv, "--root", root, *BERLIN_OPTIONS, "--dry-run")
    assert status == 0 and snapshot(root) == before
    assert "unchanged" in out and "would add 0 rows" in out


def test_parquet_export_with_an_asset_column_for_several_assets(tmp_path, capsys):
    times = pd.date_range("2026-02-10 22:00", periods=6, freq="1h", tz="UTC")
    frame = pd.DataFrame({"ts": list(times) * 2,
                          "vehicle": ["T-001"] * 6 + ["T-002"] * 6,
                          "n1": np.arange(12, dtype=float),
                          "status": ["ok"] * 12})
    export = tmp_path / "fleet.parquet"
    frame.to_parquet(export)
    root = tmp_path / "telemetry"
    status, out, err = run(capsys, export, "--root", root, "--timestamp-column", "ts",
                           "--asset-column", "vehicle", "--map", "n1=shaft_speed")
    assert status == 0, err
    assert list_assets(root) == ["T-001", "T-002"]
    for asset, first in (("T-001", 0.0), ("T-002", 6.0)):
        assert list_dates(root, asset) == [datetime.date(2026, 2, 10),
                                           datetime.date(2026, 2, 11)]
        raw = read_raw(root, asset, ["shaft_speed"])
        assert raw["shaft_speed"].tolist() == [first + k for k in range(6)]
    assert "Added 12 rows to 4 asset-day(s)" in out


def test_help_has_examples(capsys):
    status, out, _ = run(capsys, "--help")
    assert status == 0
    for text in ("--dry-run", "--timezone", "--map COLUMN=CHANNEL", "examples:",
                 "Europe/Berlin"):
        assert text in out


@pytest.mark.parametrize("argv, message", [
    (["--timezone", "Mars/Olympus"], "unknown time zone 'Mars/Olympus'"),
    (["--map", "Druck"], "expected COLUMN=CHANNEL"),
    (["--map", "a=speed", "--map", "b=speed"], "several export columns map to"),
    (["--delimiter", ",", "--decimal", ","], "are both ','"),
])
def test_bad_options_exit_2(tmp_path, capsys, berlin_csv, argv, message):
    status, _, err = run(capsys, berlin_csv, "--root", tmp_path / "telemetry", *argv)
    assert status == 2 and message in err
    assert not (tmp_path / "telemetry").exists()


def test_a_missing_column_names_the_file_and_its_columns(tmp_path, capsys, berlin_csv):
    status, _, err = run(capsys, berlin_csv, "--root", tmp_path / "telemetry", "--delimiter",
                         ";", "--timestamp-column", "Time")
    assert status == 1
    assert f"{berlin_csv}: no column(s) 'Time'; the file has 'Zeit'" in err
