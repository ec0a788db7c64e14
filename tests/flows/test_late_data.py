"""Issue 13, item 8: a day's telemetry that arrives after the run over the days around it is
analysed by the next run (the look-back), with its alert; nothing is lost or duplicated."""
from __future__ import annotations

import json
import shutil

import pandas as pd

from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, day
from flows.results import run_summary


def _run(config, as_of):
    from flows.nightly import nightly

    state = nightly(config_path=str(config), as_of=as_of.isoformat(), return_state=True)
    return run_summary(state)


def _jsonl(path):
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_fault_late_day_is_analysed_by_the_next_run(workspace, fleet, tmp_path, count):
    """T-004's 2026-01-05 partition (flutter from that day on) is missing when the run over
    01-04..01-06 runs: the watermark moves to 01-07 without it. When the file arrives, the
    next run records its candidate and its alert; a third run adds nothing."""
    root = tmp_path / "telemetry"
    shutil.copytree(fleet.root, root)
    late_day = root / "asset_id=T-004" / f"date={day(BASELINE_DAYS + 1):%Y-%m-%d}"
    parked = tmp_path / "parked"
    shutil.move(late_day, parked)
    workspace.configure(telemetry=root)
    registry = workspace.registry()

    first = _run(workspace.config, day(DAYS))
    by_asset = {a["asset_id"]: a for a in first["assets"]}
    assert [w["window_start"] for w in by_asset["T-004"]["windows"]] == \
        [day(BASELINE_DAYS).isoformat(), day(DAYS - 1).isoformat()]
    assert registry.watermark("T-004") == day(DAYS)
    assert not any(a["window_start"] == day(BASELINE_DAYS + 1).isoformat()
                   for a in first["alerts"] if a["asset_id"] == "T-004")

    shutil.move(parked, late_day)                       # the late file arrives
    second = _run(workspace.config, day(DAYS))
    assert second["exit_status"] == 0
    by_asset = {a["asset_id"]: a for a in second["assets"]}
    late = by_asset["T-004"]
    assert late["status"] == "ok"
    assert [w["window_start"] for w in late["windows"]] == [day(BASELINE_DAYS + 1).isoformat()]
    assert late["windows"][0]["alarm"] is True          # the flutter's first day
    assert "1 late window(s) before the watermark analysed: 2026-01-05 00:00" in late["note"]
    assert late["watermark_after"] == day(DAYS).isoformat()   # the watermark did not move back
    assert registry.watermark("T-004") == day(DAYS)
    late_alerts = [a for a in second["alerts"] if a["asset_id"] == "T-004"]
    assert late_alerts and {a["window_start"] for a in late_alerts} == \
        {day(BASELINE_DAYS + 1).isoformat()}
    for asset in set(ASSETS) - {"T-004"}:
        assert by_asset[asset]["status"] == "up to date"
    # in the alerts file and the registry's record of the night
    assert any(x["asset_id"] == "T-004" and x["window_start"] == day(BASELINE_DAYS + 1).isoformat()
               for x in _jsonl(workspace.alerts))
    history = registry.zeta_history("T-004")
    assert sorted(set(history["window_start"])) == \
        [day(i).isoformat() for i in range(BASELINE_DAYS, DAYS)]

    before, lines = count(registry), len(_jsonl(workspace.alerts))
    third = _run(workspace.config, day(DAYS))
    assert {a["status"] for a in third["assets"]} == {"up to date"}
    assert count(registry) == before and len(_jsonl(workspace.alerts)) == lines


def test_fault_late_day_beyond_the_lookback_is_left_alone(workspace, fleet, tmp_path):
    """With lookback = "0D" the late day is not looked for (documented: reanalyze covers
    it), and nothing else changes."""
    root = tmp_path / "telemetry"
    shutil.copytree(fleet.root, root)
    late_day = root / "asset_id=T-001" / f"date={day(BASELINE_DAYS + 1):%Y-%m-%d}"
    parked = tmp_path / "parked"
    shutil.move(late_day, parked)
    workspace.configure(telemetry=root, extra="")
    text = workspace.config.read_text().replace("[nightly]\n", '[nightly]\nlookback = "0D"\n')
    workspace.config.write_text(text)
    _run(workspace.config, day(DAYS))
    shutil.move(parked, late_day)
    again = _run(workspace.config, day(DAYS))
    assert {a["status"] for a in again["assets"]} == {"up to date"}
    assert set(workspace.registry().zeta_history("T-001")["window_start"]) == \
        {day(BASELINE_DAYS).isoformat(), day(DAYS - 1).isoformat()}


def test_fault_bad_lookback_is_a_config_error(tmp_path):
    import pytest

    from flowtest_config import write_config
    from flows.config import ConfigError, load_config

    config = write_config(tmp_path / "fleet.toml", tmp_path, tmp_path / "m.db")
    assert load_config(config).nightly.lookback_delta == pd.Timedelta(days=7)
    config.write_text(config.read_text().replace("[nightly]\n", '[nightly]\nlookback = "7"\n'))
    with pytest.raises(ConfigError, match="nightly.lookback.*not a duration"):
        load_config(config)
