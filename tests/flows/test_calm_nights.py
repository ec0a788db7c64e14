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
#: and calm again after a night that ran (day 5): parked from day 6 on
PARKED = {**RAN, 6: 240.0, 7: 120.0, 8: 240.0}


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


class _Recorded:
    """A registry whose asset has recorded candidates ending at ``ends`` (newest version
    first), or whose look-up fails with ``error``."""

    def __init__(self, ends=(), error: Exception | None = None):
        self.ends, self.error, self.asked = list(ends), error, []

    def recorded_windows(self, asset_id: str, last: int) -> list[tuple[str, str]]:
        self.asked.append(last)
        if self.error is not None:
            raise self.error
        return [((end - pd.Timedelta(days=1)).isoformat(), end.isoformat())
                for end in self.ends]


def test_an_asset_last_operated_at_its_latest_recorded_night_or_its_baseline():
    from flows.dormancy import LastOperated, is_dormant, last_operated

    baseline_end = _night(2)[1]
    # a late night recorded after a later one: the latest end counts, not the newest version
    registry = _Recorded([_night(4)[1], _night(6)[1]])
    assert last_operated(registry, "P-1", 1, baseline_end, 16) == LastOperated(_night(6)[1])
    assert registry.asked == [16]
    # nothing recorded since the baseline (or a baseline refitted since): the baseline's end
    for ends in ([], [_night(1)[1]]):
        assert last_operated(_Recorded(ends), "P-1", 1, baseline_end, 16) == \
            LastOperated(baseline_end, 1)
    limit = pd.Timedelta("7D")
    last = LastOperated(_night(6)[1])
    assert not is_dormant(last, last.end + limit, limit)        # the limit itself: not yet
    assert is_dormant(last, last.end + limit + pd.Timedelta("1s"), limit)
    assert not is_dormant(last, last.end + 10 * limit, None)     # "off"


def test_a_dormant_asset_is_named_with_its_baseline_and_a_failed_look_up_keeps_its_watermark():
    from types import SimpleNamespace

    from flows.config.settings import AlertSettings, NightlySettings
    from flows.dormancy import settle_dormant
    from registry import RegistryError

    config = SimpleNamespace(alerts=AlertSettings(not_operating_after="36h"),
                             nightly=NightlySettings(), classes={})
    baseline = SimpleNamespace(version=3, info=SimpleNamespace(window_end=_night(2)[1]))

    def calm(night: int):
        asset = _pending(night, None, [night])
        asset.reference, asset.result.status = baseline, "not operating"
        return asset

    near, far, lost = calm(3), calm(4), calm(4)
    settle_dormant(config, _Recorded(), [near], as_of=_night(4)[0])
    settle_dormant(config, _Recorded(), [far], as_of=_night(5)[0])
    assert near.result.status == "not operating" and near.result.note is None
    assert far.result.status == "dormant"
    assert far.result.note.startswith(
        "dormant: not operating for 2.0 days (no night monitored since its baseline v3, whose "
        "window ended 2026-03-04 00:00 UTC), longer than [alerts] not_operating_after = 36h")
    assert far.watermark_end == _night(4)[1]              # it still moves past the calm night
    # and it is in the alert feed: one dormant alert, keyed by the night it last operated
    assert near.result.alerts == []
    (alert,) = far.result.alerts
    assert (alert.kind, alert.tier, alert.channel) == ("dormant", "dormant", "*")
    assert alert.window_start == alert.window_end == _night(2)[1].isoformat()
    assert (alert.zeta, alert.epsilon, alert.ratio) == (2.0, 1.5, 2.0 / 1.5)
    assert alert.hint() == (f"not operating since {_night(2)[1].isoformat()} (2.0 days; "
                            "not_operating_after 1.5 days)")
    # a class with its own limit (pumps parked for days) keeps to it, and names it
    patient, lazy = calm(4), calm(4)
    for limit, asset in (("5D", patient), ("1D", lazy)):
        own = SimpleNamespace(alerts=config.alerts, nightly=config.nightly,
                              classes={"pumps": SimpleNamespace(not_operating_after=limit)})
        settle_dormant(own, _Recorded(), [asset], as_of=_night(5)[0])
    assert patient.result.status == "not operating" and patient.result.note is None
    assert lazy.result.status == "dormant" and "longer than [classes.pumps] " \
        "not_operating_after = 1D" in lazy.result.note
    settle_dormant(config, _Recorded(error=RegistryError("the store said no")), [lost],
                   as_of=_night(5)[0])
    assert lost.result.status == "failed" and lost.watermark_end is None
    assert lost.result.error.message == "the store said no"


def _baselined_pump(tmp_path, days: int, ran: dict[int, float] = RAN):
    """The pump's ``days`` days written (those of ``ran`` calm) and its baseline on the
    first three promoted; the fleet.toml's path."""
    from flows.cli import main
    from graybox.telemetry import write_telemetry

    root = tmp_path / "telemetry"
    write_telemetry(root, "P-001", pump_days(START, days, ran))
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
    ran is analysed.

    Issue 18: parked after that night, it is ``not operating`` for as long as its last
    monitored night ended within ``[alerts] not_operating_after`` (default 7 days) of the
    as-of time, and ``dormant`` beyond it: not settled (exit status 1), counted and named in
    the coverage, its note saying since when (the last recorded night, not the baseline's
    end) and the limit; its watermark still moves. ``"off"`` keeps ``not operating``."""
    from flows.cli import main

    config = _baselined_pump(tmp_path, 9, PARKED)
    capsys.readouterr()
    stderr = []
    written = config.read_text()

    def run(days: int, exit_status: int = 0) -> dict:
        status = main(["--config", str(config), "run", "--as-of",
                       (START + pd.Timedelta(days=days)).isoformat(), "--json"])
        out = capsys.readouterr()
        summary = json.loads(out.out)
        assert status == summary["exit_status"] == exit_status, out.err
        stderr.append(out.err)
        return summary

    def limit(value: str) -> None:
        config.write_text(written.replace("[alerts]\n", f"[alerts]\nnot_operating_after = "
                                                        f"{value}\n", 1))

    summary = run(5)        # 2 days since the baseline's end: within the default 7 days
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

    limit('"36h"')          # parked since the end of day 5: 2 days before day 8
    summary = run(8, exit_status=1)
    [asset] = summary["assets"]
    assert asset["status"] == "dormant" and asset["windows"] == []
    assert asset["watermark_after"] == (START + pd.Timedelta(days=8)).isoformat()
    assert ("dormant: not operating for 2.0 days (its last monitored night ended 2026-03-07 "
            "00:00 UTC), longer than [alerts] not_operating_after = 36h") in asset["note"]
    assert "`running` bounds too strict" in asset["note"]
    coverage = summary["coverage"]
    assert (coverage["dormant"], coverage["not_operating"], coverage["missed"]) == (
        1, 0, ["P-001"])
    assert "fleet-health: P-001 not monitored (dormant): " in stderr[-1]
    # in the alert feed too (the run's alerts and the JSON-lines file), once: a rerun of the
    # same night (its calm nights old news by then: up to date) adds no second line
    [alert] = asset["alerts"]
    assert (alert["kind"], alert["window_end"]) == ("dormant", "2026-03-07T00:00:00+00:00")
    feed = tmp_path / "alerts.jsonl"
    assert [json.loads(line)["kind"] for line in feed.read_text().splitlines()] == ["dormant"]
    assert run(8)["assets"][0]["status"] == "up to date"
    assert len(feed.read_text().splitlines()) == 1

    limit('"off"')
    [asset] = run(9)["assets"]
    assert asset["status"] == "not operating" and "dormant" not in asset["note"]
    assert asset["watermark_after"] == (START + pd.Timedelta(days=9)).isoformat()
