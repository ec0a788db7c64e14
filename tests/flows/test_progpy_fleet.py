"""A ProgPy centrifugal-pump fleet end to end: telemetry simulated by ProgPy itself, baselines
by the baseline flow, the worn pump alerted by the nightly flow, the healthy one left alone."""
from __future__ import annotations

import pandas as pd
import pytest

pytest.importorskip("progpy")

START = pd.Timestamp("2026-03-01", tz="UTC")
HOUR = 3600.0


@pytest.mark.slow
def test_worn_pump_is_alerted_and_healthy_pump_is_not(tmp_path, harness):
    from flows.baseline import baseline
    from flows.nightly import nightly
    from graybox.models import load_model
    from graybox.models.progpy_simulation import pump_cycle_load, simulate_progpy_fleet
    from graybox.telemetry.writing import write_telemetry
    from registry import Registry

    model = load_model("graybox.models.progpy:CentrifugalPump", columns={"Q": "Qout"})
    # five hourly windows: three healthy for the baselines, then P-002's impeller wears
    # from the start of the fifth at ProgPy's example rate (wA = 0.01)
    frames = simulate_progpy_fleet(
        model, ["P-001", "P-002"], START, 5 * HOUR, pump_cycle_load, sample_interval=1.0, step=0.5,
        process_noise={"w": 0.5, "Q": 1e-4, "Tt": 0.01, "Tr": 0.01, "To": 0.001},
        measurement_noise={"w": 0.05, "Qout": 1e-5, "Tt": 0.01, "Tr": 0.01, "To": 0.01},
        initial={"w": 385.0, "Q": 0.117, "Tt": 336.0, "Tr": 329.0, "To": 318.0},
        changes={"P-002": [(4 * HOUR, {"wA": 0.01})]}, seed=11)
    telemetry = tmp_path / "telemetry"
    for asset, frame in frames.items():
        write_telemetry(telemetry, asset, frame.iloc[:-1])
    config = tmp_path / "fleet.toml"
    config.write_text(f'''
[telemetry]
root = "{telemetry}"
[mlflow]
tracking_uri = "sqlite:///{tmp_path / 'mlflow.db'}"
[alerts]
false_alarm_rate = 0.01
jsonl = "alerts.jsonl"
[nightly]
window = "1h"
plots = "none"
retries = 0
candidate_nights = 1
[classes.pump]
model = "graybox.models.progpy:CentrifugalPump"
assets = ["P-*"]
columns = {{ Q = "Qout" }}
''')

    state = baseline(start=START.isoformat(), end=(START + pd.Timedelta(hours=3)).isoformat(),
                     config_path=str(config), vehicle_class="pump", promote=True,
                     reason="healthy hours 1-3", return_state=True)
    assert state.is_completed(), state.message
    assert {a["status"] for a in state.result()["assets"]} == {"ok"}

    state = nightly(config_path=str(config), as_of=(START + pd.Timedelta(hours=5)).isoformat(),
                    return_state=True)
    assert state.is_completed(), state.message
    summary = state.result()
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    assert sorted(by_asset) == ["P-001", "P-002"]
    assert all(len(a["windows"]) == 2 and a["status"] == "ok" for a in by_asset.values())

    alerts = summary["alerts"]
    worn_hour = (START + pd.Timedelta(hours=4)).isoformat()
    assert {(a["asset_id"], a["window_start"]) for a in alerts} == {("P-002", worn_hour)}
    assert {a["channel"] for a in alerts} == {"Q"}   # the flow: the impeller wore
    assert all(a["zeta"] > a["epsilon"] for a in alerts)
    registry = Registry(f"sqlite:///{tmp_path / 'mlflow.db'}")
    assert {(r.asset_id, r.window_start) for r in registry.alerts()} == {("P-002", worn_hour)}
    for asset in by_asset:
        assert registry.watermark(asset) == START + pd.Timedelta(hours=5)
