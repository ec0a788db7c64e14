"""A multichannel white box end to end through the command line: three pumps
(``graybox.models:PumpLoop``, four states and two inputs) running continuously at 5 s are
baselined on days 1-3 (``baseline fit``) and checked on days 4-5 (``run``). From day 4 P-003's
coolant cools 25 % faster (``A_temperature_temperature`` -0.02 -> -0.025): its temperature
channel alarms, and no healthy pump alarms.
"""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from plant_telemetry import pump_config, pump_period

START = pd.Timestamp("2026-05-01", tz="UTC")
ASSETS = ["P-001", "P-002", "P-003"]
BASELINE_DAYS, DAYS = 3, 5
FAULTY = {"P-003": {"A_temperature_temperature": -0.025}}


def day(k: int) -> pd.Timestamp:
    return START + pd.Timedelta(days=k)


@pytest.mark.slow
def test_four_state_two_input_pumps_baseline_and_alarm_in_the_faulty_channel(harness,
                                                                             tmp_path, capsys):
    from flows.cli import main
    from graybox.models import PumpLoop
    from graybox.telemetry import write_telemetry

    root = tmp_path / "telemetry"
    for seed, asset in enumerate(ASSETS):
        rng = np.random.default_rng(200 + seed)
        frames = [pump_period(PumpLoop(FAULTY[asset]) if asset in FAULTY and k >= BASELINE_DAYS
                              else PumpLoop(), day(k), 86_400.0, 5.0, rng)
                  for k in range(DAYS)]
        write_telemetry(root, asset, pd.concat(frames, ignore_index=True))
    config = tmp_path / "fleet.toml"
    config.write_text(pump_config(root, tmp_path / "mlflow.db"))

    status = main(["--config", str(config), "baseline", "fit", "--class", "pump", "--start",
                   day(0).isoformat(), "--end", day(BASELINE_DAYS).isoformat(), "--promote",
                   "--reason", "healthy days", "--json"])
    out = capsys.readouterr()
    assert status == 0, out.err
    assert {a["asset_id"]: a["status"] for a in json.loads(out.out)["assets"]} == \
        {asset: "ok" for asset in ASSETS}

    status = main(["--config", str(config), "run", "--as-of", day(DAYS).isoformat(), "--json"])
    out = capsys.readouterr()
    assert status == 0, out.err
    summary = json.loads(out.out)
    assert {a["asset_id"]: a["status"] for a in summary["assets"]} == \
        {asset: "ok" for asset in ASSETS}
    alerts = summary["alerts"]
    assert {a["asset_id"] for a in alerts} == {"P-003"}
    nights = {a["window_start"] for a in alerts if a["channel"] == "temperature"}
    assert nights == {day(k).isoformat() for k in range(BASELINE_DAYS, DAYS)}

    status = main(["--config", str(config), "alerts", "--json"])
    out = capsys.readouterr()
    assert status == 0
    assert {(a["asset_id"], a["channel"], a["tier"]) for a in json.loads(out.out)} == \
        {(a["asset_id"], a["channel"], a["tier"]) for a in alerts}
