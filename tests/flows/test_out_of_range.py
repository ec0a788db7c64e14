"""Issue 13, item 11: one finite but huge sample in one asset's telemetry fails that asset,
named with file and row, and never the others (nightly run and baseline fit)."""
from __future__ import annotations

import json
import shutil

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, assert_the_others_ran_every_night, day


def _spike(root, asset, day_index, row=500, value=1e10):
    path = root / f"asset_id={asset}" / f"date={day(day_index):%Y-%m-%d}" / "part-0.parquet"
    frame = pq.read_table(path).to_pandas()
    frame.loc[row, "shaft_speed"] = value
    pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), path)
    return path


def _run(main, capsys, *argv):
    status = main([*argv, "--json"])
    out = capsys.readouterr()
    return status, json.loads(out.out), out.err


def test_fault_huge_sample_in_one_night_fails_only_that_asset(workspace, fleet, tmp_path,
                                                              capsys):
    from flows.cli import main

    root = tmp_path / "telemetry"
    shutil.copytree(fleet.root, root)
    bad_file = _spike(root, "T-003", BASELINE_DAYS + 1)
    workspace.configure(telemetry=root)
    status, summary, err = _run(main, capsys, "--config", str(workspace.config), "run",
                                "--as-of", day(DAYS).isoformat())
    assert status == 1
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    bad = by_asset["T-003"]
    assert bad["status"] == "failed" and bad["error"]["kind"] == "out_of_range"
    assert bad["error"]["file"] == str(bad_file) and bad["error"]["row"] == 500
    assert "1e+10" in bad["error"]["message"] or "10000000000.0" in bad["error"]["message"]
    assert len(bad["windows"]) == 1                            # the night before is committed
    registry = workspace.registry()
    assert registry.watermark("T-003") == day(BASELINE_DAYS + 1)   # not past the bad night
    assert "T-003 failed" in err and "row 500" in err
    assert_the_others_ran_every_night(by_asset, registry, "T-003")
    # the drift alerts as before; the impossible reading is T-003's sensor alert of its night
    assert {a["asset_id"] for a in summary["alerts"] if a["kind"] == "drift"} == {"T-002", "T-004"}
    assert [(a["asset_id"], a["channel"], a["tier"]) for a in summary["alerts"]
            if a["kind"] == "sensor"] == [("T-003", "shaft_speed", "out_of_range")]


def test_fault_huge_sample_past_the_checks_is_isolated_in_the_batched_fit(workspace, fleet,
                                                                        tmp_path, capsys):
    """With the plausibility check off, the batched fit meets the 1e10: T-003 fails with its
    name in the error, and the others' windows, versions and watermarks are committed."""
    from flows.cli import main

    root = tmp_path / "telemetry"
    shutil.copytree(fleet.root, root)
    _spike(root, "T-003", BASELINE_DAYS + 1)
    workspace.configure(telemetry=root, extra="grid = { plausible_spread = 0 }")
    status, summary, err = _run(main, capsys, "--config", str(workspace.config), "run",
                                "--as-of", day(DAYS).isoformat())
    assert status == 1
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    bad = by_asset["T-003"]
    assert bad["status"] == "failed" and "asset 'T-003'" in bad["error"]["message"]
    assert bad["error"]["window_start"] == day(BASELINE_DAYS + 1).isoformat()
    registry = workspace.registry()
    assert registry.watermark("T-003") == day(BASELINE_DAYS + 1)
    assert_the_others_ran_every_night(by_asset, registry, "T-003")


@pytest.mark.slow
def test_fault_huge_sample_in_baseline_days_fails_only_that_asset(harness, fleet, tmp_path,
                                                                  capsys):
    """`baseline fit --all`: T-002's second healthy day holds a 1e10; T-002 fails naming the
    file and row, the other four are fitted and promoted."""
    from flowtest_config import write_config
    from flows.cli import main
    from registry import Registry

    root = tmp_path / "telemetry"
    shutil.copytree(fleet.root, root)
    bad_file = _spike(root, "T-002", 1, row=123)
    config = write_config(tmp_path / "fleet.toml", root, tmp_path / "mlflow.db")
    status, summary, err = _run(main, capsys, "--config", str(config), "baseline", "fit",
                                "--all", "--start", day(0).isoformat(), "--end",
                                day(BASELINE_DAYS).isoformat(), "--promote", "--reason",
                                "healthy days")
    assert status == 1
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    bad = by_asset["T-002"]
    assert bad["status"] == "failed" and bad["error"]["kind"] == "out_of_range"
    assert bad["error"]["file"] == str(bad_file) and bad["error"]["row"] == 123
    registry = Registry(f"sqlite:///{tmp_path / 'mlflow.db'}")
    assert registry.baseline("T-002") is None
    for asset in set(ASSETS) - {"T-002"}:
        assert by_asset[asset]["status"] == "ok"
        assert registry.baseline(asset) is not None


def test_ranges_per_vehicle_class_load_from_fleet_toml(tmp_path):
    from flowtest_config import write_config
    from flows.config import ConfigError, load_config

    config = write_config(tmp_path / "fleet.toml", tmp_path, tmp_path / "m.db",
                          extra="grid = { ranges = { shaft_speed = [0, 5000] } }")
    assert load_config(config).classes["turbine"].grid.value_range("shaft_speed") == (0, 5000)
    write_config(tmp_path / "fleet.toml", tmp_path, tmp_path / "m.db",
                 extra="grid = { ranges = { shaft_speed = [5000, 0] } }")
    with pytest.raises(ConfigError, match="classes.turbine.grid.ranges"):
        load_config(config)
