"""The telemetry root's scan: assets, and every entry skipped with why."""
from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest

from graybox.telemetry import list_dates, read_raw, write_telemetry
from graybox.telemetry.layout import scan


def _frame(day: str) -> pd.DataFrame:
    ts = pd.date_range(day, periods=10, freq="10s", tz="UTC")
    return pd.DataFrame({"timestamp": ts, "x": np.arange(10.0)})


@pytest.fixture
def root(tmp_path):
    root = tmp_path / "telemetry"
    write_telemetry(root, "A-1", _frame("2026-01-04"))
    return root


def test_scan_of_a_clean_root(root):
    found = scan(root)
    assert found.assets == ["A-1"] and found.skipped == [] and found.stray_parquet == []


def test_fault_invalid_id_stray_folder_and_stray_parquet_are_named(root):
    (root / "asset_id=T 007").mkdir()
    (root / "misc").mkdir()
    (root / "notes.txt").write_text("ignored: not Parquet")
    (root / "asset_id=A-1" / "2026-01-05.parquet").write_bytes(b"")
    found = scan(root)
    reasons = {os.path.basename(s.path): s.reason for s in found.skipped}
    assert found.assets == ["A-1"]
    assert set(reasons) == {"asset_id=T 007", "misc", "2026-01-05.parquet"}
    assert "invalid asset id 'T 007'" in reasons["asset_id=T 007"]
    assert "asset_id=<ID>/date=<YYYY-MM-DD>" in reasons["misc"]


def test_fault_other_layout_names_the_parquet_found(tmp_path):
    root = tmp_path / "telemetry"
    (root / "T-001").mkdir(parents=True)
    _frame("2026-01-04").to_parquet(root / "T-001" / "2026-01-04.parquet")
    found = scan(root)
    assert found.assets == [] and found.stray_parquet == ["T-001/2026-01-04.parquet"]


def test_fault_links_out_of_the_root_are_not_followed(root, tmp_path):
    outside = tmp_path / "outside"
    write_telemetry(outside, "A-2", _frame("2026-01-05"))
    os.symlink(outside / "asset_id=A-2", root / "asset_id=A-2")
    os.symlink(outside / "asset_id=A-2" / "date=2026-01-05", root / "asset_id=A-1" / "date=2026-01-05")
    found = scan(root)
    assert found.assets == ["A-1"]
    assert {s.path for s in found.skipped} == {str(root / "asset_id=A-2"),
                                               str(root / "asset_id=A-1" / "date=2026-01-05")}
    assert all("outside the telemetry root" in s.reason for s in found.skipped)
    assert [str(d) for d in list_dates(root, "A-1")] == ["2026-01-04"]
    assert list_dates(root, "A-2") == []


def test_links_inside_the_root_are_followed(root):
    os.symlink(root / "asset_id=A-1", root / "asset_id=A-3")
    assert scan(root).assets == ["A-1", "A-3"]
    assert len(read_raw(root, "A-3", ["x"])) == 10
