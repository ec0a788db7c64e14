"""A night that ran too little is not monitored, named, and never holds up the nights after
it. A pump at 5 s, baselined on three days; on the fourth day it ran 4 minutes (read, too
short to fit), on the fifth 2 minutes (shorter than the grid's min_duration: not read), the
sixth and seventh normally. Before, the nightly run stopped the asset at the fourth night on
every run: the nights after it were never analysed."""
from __future__ import annotations

import json

import pandas as pd
import pytest

from plant_telemetry import pump_config, pump_days

START = pd.Timestamp("2026-03-01", tz="UTC")
RAN = {3: 240.0, 4: 120.0}      # day -> seconds of operation, the others 3 h


def _night(k: int) -> tuple[pd.Timestamp, pd.Timestamp]:
    return START + pd.Timedelta(days=k), START + pd.Timedelta(days=k + 1)


def _pending(watermark: int, recorded: int | None, calm: list[int], idle: str = "up to date"):
    from flows.discovery import AssetRef
    from flows.pipeline import PendingAsset
    from flows.results import AssetResult

    result = AssetResult("P-1", "pumps", "ok", watermark_before=_night(watermark)[0].isoformat())
    return PendingAsset(AssetRef("P-1", "pumps"), result, model=None,
                        committed_end=None if recorded is None else _night(recorded)[1],
                        calm=[_night(k) for k in calm], idle_status=idle)


def test_the_watermark_moves_past_calm_nights_but_never_past_a_failure():
    from flows.pipeline import settle_calm

    # a night recorded, then two calm ones: past the last calm night
    assert _pending(3, 3, [4, 5]).watermark_end == _night(5)[1]
    # calm nights read again before the watermark (late windows) do not move it
    assert _pending(6, None, [4, 5]).watermark_end is None
    assert _pending(6, 6, [4]).watermark_end == _night(6)[1]
    failed = _pending(3, 3, [4, 5])
    failed.fail(ValueError("the fit diverged"), _night(6)[0])
    assert failed.watermark_end == _night(3)[1]
    # all calm: not operating when a calm night is new, else the idle status
    for watermark, calm, idle, status in ((3, [3, 4], "up to date", "not operating"),
                                          (6, [4, 5], "up to date", "up to date"),
                                          (3, [3, 4], "stale", "stale")):
        asset = _pending(watermark, None, calm, idle)
        settle_calm(asset)
        assert asset.result.status == status, (watermark, calm, idle)


def _baselined_pump(tmp_path, days: int):
    """The pump's ``days`` days written and its baseline on the first three promoted; the
    fleet.toml's path."""
    from flows.cli import main
    from graybox.telemetry import write_telemetry

    root = tmp_path / "telemetry"
    write_telemetry(root, "P-001", pump_days(START, days, RAN))
    config = tmp_path / "fleet.toml"
    config.write_text(pump_config(root, tmp_path / "mlflow.db",
                                  "grid = { intermittent = true, min_duration = \"3min\" }"))
    assert main(["--config", str(config), "baseline", "fit", "--all", "--start",
                 START.isoformat(), "--end", (START + pd.Timedelta(days=3)).isoformat(),
                 "--promote", "--reason", "healthy days", "--json"]) == 0
    return config


@pytest.mark.slow
def test_calm_nights_are_named_and_the_nights_after_them_analysed(harness, tmp_path, capsys):
    from flows.cli import main

    config = _baselined_pump(tmp_path, 7)
    capsys.readouterr()
    as_of = (START + pd.Timedelta(days=7)).isoformat()
    status = main(["--config", str(config), "run", "--as-of", as_of, "--json"])
    out = capsys.readouterr()
    assert status == 0, out.err
    [asset] = json.loads(out.out)["assets"]
    assert asset["status"] == "ok"
    analysed = [w["window_start"] for w in asset["windows"]]
    assert analysed == [(START + pd.Timedelta(days=k)).isoformat() for k in (5, 6)]
    assert ("not monitored 1 window(s) with too little operation to read (shorter than the "
            "grid's min_duration): 2026-03-05T00:00:00+00:00") in asset["note"]
    assert ("not monitored 1 window(s) with too little operation to fit: "
            "2026-03-04T00:00:00+00:00") in asset["note"]
    # the next run has nothing left to do
    status = main(["--config", str(config), "run", "--as-of", as_of, "--json"])
    out = capsys.readouterr()
    assert status == 0, out.err
    assert json.loads(out.out)["assets"][0]["windows"] == []


@pytest.mark.slow
def test_an_asset_whose_new_nights_all_ran_too_little_is_not_operating(harness, tmp_path,
                                                                      capsys):
    """Both new nights calm (one too short to fit, one too short to read): the asset is
    ``not operating``, not ``up to date``; the coverage line names it as not monitored, the
    exit status stays 0, and its watermark moves past the calm nights. Read again later as
    late windows, the same calm nights are old news (``up to date``); the next night that
    ran is analysed."""
    from flows.cli import main

    config = _baselined_pump(tmp_path, 6)
    capsys.readouterr()

    def run(days: int) -> dict:
        status = main(["--config", str(config), "run", "--as-of",
                       (START + pd.Timedelta(days=days)).isoformat(), "--json"])
        out = capsys.readouterr()
        summary = json.loads(out.out)
        assert status == summary["exit_status"] == 0, out.err
        return summary

    summary = run(5)
    [asset] = summary["assets"]
    assert asset["status"] == "not operating" and asset["windows"] == []
    assert asset["watermark_after"] == (START + pd.Timedelta(days=5)).isoformat()
    assert "too little operation to fit: 2026-03-04T00:00:00+00:00" in asset["note"]
    assert "(shorter than the grid's min_duration): 2026-03-05T00:00:00+00:00" in asset["note"]
    coverage = summary["coverage"]
    assert (coverage["not_operating"], coverage["up_to_date"], coverage["missed"]) == (
        1, 0, ["P-001"])
    assert not coverage["complete"]

    [asset] = run(5)["assets"]          # the calm nights again, within the look-back
    assert asset["status"] == "up to date" and asset["windows"] == []

    [asset] = run(6)["assets"]
    assert asset["status"] == "ok"
    assert [w["window_start"] for w in asset["windows"]] == [
        (START + pd.Timedelta(days=5)).isoformat()]
