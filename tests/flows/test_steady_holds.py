"""A coarse reading of a steady plant holds one value for longer than ``stuck_after`` with
nothing in the plant to explain it (a 1-kPa tyre pressure on the highway). The baseline flow
reads such holds (``GridPolicy.for_baseline``) and records the longest per channel with the
baseline (``Signature.holds``); the nightly flow then lets that channel hold a value twice as
long (``GridPolicy.with_holds``), and a longer hold is still a stuck sensor, with its alert.

A pump at 5 s (90 minutes from 06:00 and from 13:00 a day) whose temperature reading holds
its value for 15 minutes each baseline day (default ``stuck_after`` 10 minutes: before,
every baseline day was a stuck sensor and the baseline failed), 25 minutes on the first
night (read: the limit is now 30) and 45 on the second (stuck)."""
from __future__ import annotations

import json

import pandas as pd
import pytest

from plant_telemetry import pump_config, pump_days

START = pd.Timestamp("2026-03-01", tz="UTC")
BASELINE_DAYS, DAYS = 3, 5
#: day -> minutes the temperature reading holds from 06:30
HOLDS = {**{k: 15 for k in range(BASELINE_DAYS)}, BASELINE_DAYS: 25, BASELINE_DAYS + 1: 45}


def _day(k: int) -> pd.Timestamp:
    return START + pd.Timedelta(days=k)


def _holding(frame: pd.DataFrame) -> pd.DataFrame:
    stamps = pd.DatetimeIndex(frame["timestamp"])
    for k, minutes in HOLDS.items():
        begin = _day(k) + pd.Timedelta("6h30min")
        held = (stamps >= begin) & (stamps < begin + pd.Timedelta(minutes=minutes))
        frame.loc[held, "temperature"] = frame.loc[held, "temperature"].iloc[0]
    return frame


@pytest.mark.slow
def test_a_baseline_learns_how_long_a_reading_holds_and_the_nights_allow_for_it(
        harness, tmp_path, capsys):
    from flows.cli import main
    from graybox.telemetry import write_telemetry
    from registry import Registry

    root = tmp_path / "telemetry"
    write_telemetry(root, "P-001", _holding(pump_days(START, DAYS, {})))
    config = tmp_path / "fleet.toml"
    config.write_text(pump_config(root, tmp_path / "mlflow.db",
                                  "grid = { intermittent = true }"))
    status = main(["--config", str(config), "baseline", "fit", "--all", "--start",
                   START.isoformat(), "--end", _day(BASELINE_DAYS).isoformat(), "--promote",
                   "--reason", "first baseline", "--json"])
    out = capsys.readouterr()
    assert status == 0, out.err
    [asset] = json.loads(out.out)["assets"]
    assert asset["status"] == "ok", asset
    assert asset["note"].endswith("; held one value with nothing to explain it: temperature "
                                  "15min (nights may hold 30min)")
    signature = Registry(f"sqlite:///{tmp_path / 'mlflow.db'}").baseline("P-001").signature
    assert dict(signature.holds) == {"temperature": 15 * 60.0}

    status = main(["--config", str(config), "run", "--as-of", _day(DAYS).isoformat(), "--json"])
    out = capsys.readouterr()
    [asset] = json.loads(out.out)["assets"]
    assert status == 1 and asset["status"] == "failed", out.err
    # the first night (a 25-minute hold) was analysed; the second stops at its stuck sensor
    assert [w["window_start"] for w in asset["windows"]] == [_day(BASELINE_DAYS).isoformat()]
    assert asset["error"]["kind"] == "stuck_channel"
    assert "'temperature' stuck at" in asset["error"]["message"]
    assert "(45min; stuck_after=30min)" in asset["error"]["message"]
    assert [(a["window_start"], a["channel"], a["tier"]) for a in asset["alerts"]
            if a["kind"] == "sensor"] == [
        (_day(BASELINE_DAYS + 1).isoformat(), "temperature", "stuck_channel")]
