"""Issue 10 item 4, must show: an asset that runs a few hours a day at 1 Hz, whose
pressure setpoint (an input) holds for minutes at a time, is baselined and its fault
detected through the command line; its healthy twins do not alarm.

Three pumps (``graybox.models:PumpLoop``, four states, two inputs) run each day from 06:00
to 07:30 and from 13:00 to 14:30, plus a 5-minute start at 20:00 too short to fit (left
out): 3 h of operation a day and hours without a sample between. Days 1-3 are the
baseline; from day 4 on P-002's flow damping is 10 % lower (``A_flow_flow`` -0.5 -> -0.45).
"""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from plant_telemetry import pump_config, pump_period

START = pd.Timestamp("2026-03-01", tz="UTC")
PERIODS = [(pd.Timedelta("6h"), 5_400.0), (pd.Timedelta("13h"), 5_400.0),
           (pd.Timedelta("20h"), 300.0)]
BASELINE_DAYS, DAYS = 3, 5
FAULTY = {"P-002": {"A_flow_flow": -0.45}}
INTERMITTENT = "grid = { intermittent = true }"


def day(k: int) -> pd.Timestamp:
    return START + pd.Timedelta(days=k)


def write_pumps(root) -> dict[str, pd.DataFrame]:
    """Each pump's telemetry (one file per day), as written."""
    from graybox.models import PumpLoop
    from graybox.telemetry import write_telemetry

    written = {}
    for seed, asset in enumerate(["P-001", "P-002", "P-003"]):
        rng = np.random.default_rng(100 + seed)
        frames = []
        for k in range(DAYS):
            faulty = asset in FAULTY and k >= BASELINE_DAYS
            model = PumpLoop(FAULTY[asset]) if faulty else PumpLoop()
            frames += [pump_period(model, day(k) + offset, seconds, 1.0, rng)
                       for offset, seconds in PERIODS]
        written[asset] = pd.concat(frames, ignore_index=True)
        write_telemetry(root, asset, written[asset])
    return written


def longest_hold(values: np.ndarray, timestamps: pd.Series) -> float:
    """Seconds the longest run of one value lasts (without crossing a pause)."""
    t = pd.DatetimeIndex(timestamps).as_unit("ns").asi8 / 1e9
    best, first = 0.0, 0
    for i in range(1, len(values) + 1):
        if i == len(values) or values[i] != values[first] or t[i] - t[i - 1] > 1.5:
            best = max(best, t[i - 1] - t[first] + 1.0)
            first = i
    return best


@pytest.mark.slow
def test_intermittent_pumps_baseline_and_detect_through_the_command_line(harness, tmp_path,
                                                                         capsys):
    from flows.cli import main

    root = tmp_path / "telemetry"
    written = write_pumps(root)
    # the setpoint input holds longer than stuck_after (10 min), which a sensor may not
    assert longest_hold(written["P-001"]["pdisch_setpoint"].to_numpy(),
                        written["P-001"]["timestamp"]) >= 600
    config = tmp_path / "fleet.toml"
    # without intermittent = true the pauses read as a logger's outages: the baseline fits
    # on the same periods, and its result says that every day was read in parts (one pump:
    # the three fit alike, and the rest of the test fits them with intermittent = true)
    config.write_text(pump_config(root, tmp_path / "mlflow.db"))
    status = main(["--config", str(config), "baseline", "fit", "P-001", "--start",
                   day(0).isoformat(), "--end", day(BASELINE_DAYS).isoformat(), "--json"])
    out = capsys.readouterr()
    assert status == 0, out.err
    fitted = json.loads(out.out)["assets"]
    assert [a["asset_id"] for a in fitted] == ["P-001"]
    for asset in fitted:
        assert asset["status"] == "ok"
        assert (f"read {BASELINE_DAYS} window(s) in parts, split where rows were missing for "
                f"longer than the grid's max_gap: {day(0).isoformat()} (2 gaps)") in asset["note"]

    config.write_text(pump_config(root, tmp_path / "mlflow.db", INTERMITTENT))
    status = main(["--config", str(config), "baseline", "fit", "--all", "--start",
                   day(0).isoformat(), "--end", day(BASELINE_DAYS).isoformat(), "--promote",
                   "--reason", "healthy days", "--json"])
    out = capsys.readouterr()
    assert status == 0, out.err
    fitted = {a["asset_id"]: a["status"] for a in json.loads(out.out)["assets"]}
    assert fitted == {"P-001": "ok", "P-002": "ok", "P-003": "ok"}
    # an intermittent machine's pauses are its way of running: nothing to say
    assert not any("in parts" in (a["note"] or "") for a in json.loads(out.out)["assets"])

    status = main(["--config", str(config), "run", "--as-of", day(DAYS).isoformat(), "--json"])
    out = capsys.readouterr()
    assert status == 0, out.err
    summary = json.loads(out.out)
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    for asset in ("P-001", "P-002", "P-003"):
        assert by_asset[asset]["status"] == "ok"
        assert len(by_asset[asset]["windows"]) == DAYS - BASELINE_DAYS
    alerts = summary["alerts"]
    assert {a["asset_id"] for a in alerts} == {"P-002"}
    # the fault is in the flow channel's dynamics: both faulty nights alarm there
    flow_nights = {a["window_start"] for a in alerts if a["channel"] == "flow"}
    assert flow_nights == {day(k).isoformat() for k in range(BASELINE_DAYS, DAYS)}


def test_intermittent_and_running_load_from_fleet_toml(tmp_path):
    from flows.config import ConfigError, load_config
    from flows.config.template import _grid_text

    config = tmp_path / "fleet.toml"
    text = pump_config(tmp_path, tmp_path / "m.db", INTERMITTENT)
    config.write_text(text.replace("{ intermittent = true }",
                                   "{ intermittent = true, running = { speed = [1, 100] } }"))
    grid = load_config(config).classes["pump"].grid
    assert grid.intermittent and grid.running == (("speed", 1.0, 100.0),)
    assert "intermittent = true" in _grid_text({"intermittent": True})
    config.write_text(text.replace("{ intermittent = true }", "{ running = { speed = [1] } }"))
    with pytest.raises(ConfigError, match=r"classes.pump.grid.running: running\['speed'\]"):
        load_config(config)
    config.write_text(text.replace("{ intermittent = true }", '{ intermittent = "yes" }'))
    with pytest.raises(ConfigError, match="classes.pump.grid.intermittent"):
        load_config(config)
