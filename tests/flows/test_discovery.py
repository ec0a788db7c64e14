"""Issue 13, items 3 and 6: telemetry in another layout, invalid asset folders and symbolic
links out of the telemetry root are reported, never skipped silently."""
from __future__ import annotations

import json
import os
import shutil

from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, day


def test_fault_telemetry_in_another_layout_is_a_usage_error(harness, fleet, tmp_path, capsys):
    """T-001/2026-01-04.parquet: no asset in the layout, but Parquet files: exit 2, saying
    which layout was expected and what was found (not "0 assets: none.", exit 0)."""
    from flowtest_config import write_config
    from flows.cli import main

    root = tmp_path / "telemetry"
    (root / "T-001").mkdir(parents=True)
    shutil.copy(fleet.root / "asset_id=T-001" / f"date={day(3):%Y-%m-%d}" / "part-0.parquet",
                root / "T-001" / f"{day(3):%Y-%m-%d}.parquet")
    config = write_config(tmp_path / "fleet.toml", root, tmp_path / "mlflow.db")
    status = main(["--config", str(config), "run", "--as-of", day(DAYS).isoformat()])
    err = capsys.readouterr().err
    assert status == 2
    assert "asset_id=<ID>/date=<YYYY-MM-DD>/<file>.parquet" in err
    assert "T-001/2026-01-04.parquet" in err


def test_an_empty_telemetry_root_is_an_empty_fleet(harness, tmp_path, capsys):
    from flowtest_config import write_config
    from flows.cli import main

    (tmp_path / "telemetry").mkdir()
    config = write_config(tmp_path / "fleet.toml", tmp_path / "telemetry", tmp_path / "m.db")
    assert main(["--config", str(config), "run", "--as-of", day(DAYS).isoformat()]) == 0
    assert "0 assets: none." in capsys.readouterr().out


def test_fault_invalid_folder_and_links_out_of_the_root_are_skipped_with_why(
        workspace, fleet, tmp_path, capsys):
    """``asset_id=T 007`` (invalid id), ``asset_id=T-009`` (a link to a directory outside
    the root), T-003's last date partition and T-005's last file (links out of the root) are
    not read and are named with why; every other window is analysed as usual."""
    from flows.cli import main

    root = tmp_path / "telemetry"
    outside = tmp_path / "outside"
    shutil.copytree(fleet.root, root)
    outside.mkdir()
    last = f"date={day(DAYS - 1):%Y-%m-%d}"
    shutil.copytree(root / "asset_id=T-001", root / "asset_id=T 007")
    shutil.copytree(root / "asset_id=T-001", outside / "T-009")
    os.symlink(outside / "T-009", root / "asset_id=T-009")
    shutil.move(root / "asset_id=T-003" / last, outside / "T-003-last")
    os.symlink(outside / "T-003-last", root / "asset_id=T-003" / last)
    shutil.move(root / "asset_id=T-005" / last / "part-0.parquet", outside / "T-005.parquet")
    os.symlink(outside / "T-005.parquet", root / "asset_id=T-005" / last / "part-0.parquet")
    workspace.configure(telemetry=root)

    status = main(["--config", str(workspace.config), "run", "--as-of", day(DAYS).isoformat(),
                   "--json"])
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert status == 0
    skipped = {entry["path"]: entry["reason"] for entry in summary["skipped"]}
    assert "invalid asset id 'T 007'" in skipped[str(root / "asset_id=T 007")]
    assert "outside the telemetry root" in skipped[str(root / "asset_id=T-009")]
    assert "outside the telemetry root" in skipped[str(root / "asset_id=T-003" / last)]
    assert len(skipped) == 3
    assert f"skipped {root / 'asset_id=T 007'}: invalid asset id" in captured.err

    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    assert sorted(by_asset) == list(ASSETS)                 # T-009 and 'T 007' not read
    registry = workspace.registry()
    for asset in ("T-003", "T-005"):
        assert by_asset[asset]["status"] == "ok"
        assert [w["window_start"] for w in by_asset[asset]["windows"]] == \
            [day(i).isoformat() for i in range(BASELINE_DAYS, DAYS - 1)]
        assert registry.watermark(asset) == day(DAYS - 1)
    link = str(root / "asset_id=T-005" / last / "part-0.parquet")
    assert f"skipped 1 symbolic link(s) out of the telemetry root: {link}" in \
        by_asset["T-005"]["note"]
    for asset in ("T-001", "T-002", "T-004"):
        assert len(by_asset[asset]["windows"]) == DAYS - BASELINE_DAYS
        assert registry.watermark(asset) == day(DAYS)
