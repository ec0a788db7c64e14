"""A fleet whose white box is an FMU named in fleet.toml alone (``model = "fmu:models/
plant.fmu"``), end to end: the test FMU (tests/graybox/models/plant_fmu.py, built from C),
two heated probes simulated exactly by its Python twin, baselines by the baseline flow, the
probe whose heater slowed (``tau`` 20 -> 40 s) alerted by the nightly flow and diagnosed as
that change, the healthy one left alone; the FMU moved with its GUID: the same model; then
the FMU re-exported under another GUID to the same path: both assets ``unusable baseline``,
naming both GUIDs."""
from __future__ import annotations

import shutil

import pandas as pd
import pytest

from flowtest_fmu import plant_fmu

PLANT = plant_fmu()
START = pd.Timestamp("2026-03-01", tz="UTC")
WINDOW = 300                      # samples (1 s) of a 5-minute window
OTHER_GUID = "{0000e810-0000-4a00-8276-176fa3c9128f}"


def _write_fleet(telemetry):
    from graybox.telemetry.writing import write_telemetry

    # five windows: three healthy for the baselines, F-002's heater slows from the fourth;
    # the fifth is for the night after the FMU is replaced
    for asset, seed, changed in (("F-001", 1, None), ("F-002", 2, (3 * WINDOW, 40.0))):
        frame, _ = PLANT.simulate(5 * WINDOW, seed, [4.0, 3.0], 0.01, changed=changed)
        frame.index = START + pd.to_timedelta(range(len(frame)), unit="s")
        frame.index.name = "timestamp"
        write_telemetry(telemetry, asset, frame.rename(columns={"reading": "probe_temp"}))


@PLANT.needs_compiler
@pytest.mark.slow
def test_an_fmu_named_in_fleet_toml_is_baselined_alerted_and_refused_once_replaced(tmp_path,
                                                                                 harness):
    from flows.baseline import baseline
    from flows.nightly import nightly
    from flows.results import run_summary
    from registry import Registry
    from registry.exceptions import UnusableBaselineError

    site = tmp_path / "site"
    fmu = PLANT.build_fmu(site / "models")                      # site/models/plant.fmu
    _write_fleet(site / "telemetry")
    config = site / "fleet.toml"
    config.write_text('''
[alerts]
false_alarm_rate = 0.01
[nightly]
window = "5min"
plots = "none"
retries = 0
candidate_nights = 1
processes = 1
[classes.probe]
model = "fmu:models/plant.fmu"
assets = ["F-*"]
parameters = { lag = 5.0 }
columns = { reading = "probe_temp" }
grid = { min_duration = "4min" }
''')
    window = pd.Timedelta(seconds=WINDOW)

    state = baseline(start=START.isoformat(), end=(START + 3 * window).isoformat(),
                     config_path=str(config), vehicle_class="probe", promote=True,
                     reason="healthy windows 1-3", return_state=True)
    assert state.is_completed(), state.message
    assert {a["asset_id"]: a["status"] for a in state.result()["assets"]} == \
        {"F-001": "ok", "F-002": "ok"}
    registry = Registry(f"sqlite:///{site / 'mlflow.db'}")
    recorded = registry.reference("F-001").signature.model
    assert recorded.spec == f"fmu:{fmu}" and recorded.fingerprint == f"fmi2 guid {PLANT.GUID}"
    assert dict(recorded.columns) == {"reading": "probe_temp", "power": "power"}
    assert dict(recorded.parameters) == {"tau": 20.0, "lag": 5.0}

    state = nightly(config_path=str(config), as_of=(START + 4 * window).isoformat(),
                    return_state=True)
    assert state.is_completed(), state.message
    summary = state.result()
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    assert all(a["status"] == "ok" and len(a["windows"]) == 1 for a in by_asset.values())
    # far from the threshold either way (measured: 0.09 and 129 times epsilon)
    assert by_asset["F-001"]["windows"][0]["max_ratio"] < 0.5
    assert by_asset["F-002"]["windows"][0]["max_ratio"] > 10.0
    # each window names the channel and tier of its largest ratio: F-002's largest alert's
    top = max(summary["alerts"], key=lambda a: a["ratio"])
    assert by_asset["F-002"]["windows"][0]["max_ratio_at"] == f"{top['channel']} {top['tier']}"
    assert by_asset["F-001"]["windows"][0]["max_ratio_at"].split()[0] == "reading"
    slowed = (START + 3 * window).isoformat()
    assert {(a["asset_id"], a["window_start"]) for a in summary["alerts"]} == {("F-002", slowed)}
    assert {a["channel"] for a in summary["alerts"]} == {"reading"}   # the FMU's output
    # the diagnosis, through the FMU: the heater's time constant, at its simulated value
    best = summary["alerts"][0]["diagnosis"][0]
    assert (best["hypothesis"], best["baseline"]) == ("parameter tau", 20.0)
    assert best["interval"][0] < 40.0 < best["interval"][1]

    # the configuration names a file that is not there: not the configured model, nothing
    # loaded
    with pytest.raises(UnusableBaselineError, match=f"model 'fmu:{fmu}' is not the asset's "
                                                    f"configured model"):
        registry.reference("F-001", models={f"fmu:{site / 'elsewhere.fmu'}"})
    # the FMU moved (the site copied to another server): the same GUID, the same model; the
    # baseline names it where it is now
    moved = tmp_path / "moved" / "plant.fmu"
    moved.parent.mkdir()
    shutil.copy(fmu, moved)
    reference = registry.reference("F-001", models={f"fmu:{moved}"})
    assert reference.signature.model.spec == f"fmu:{moved}"
    assert reference.signature.model.load({f"fmu:{moved}"}).spec() == f"fmu:{moved}"
    # another FMU (another GUID) at that path is another model
    PLANT.build_fmu(tmp_path / "other", guid=OTHER_GUID).replace(moved)
    with pytest.raises(UnusableBaselineError, match="is not the asset's configured model"):
        registry.reference("F-001", models={f"fmu:{moved}"})
    # re-exported under another GUID to the same path: the fingerprint check refuses it
    PLANT.build_fmu(tmp_path / "export", guid=OTHER_GUID).replace(fmu)
    state = nightly(config_path=str(config), as_of=(START + 5 * window).isoformat(),
                    return_state=True)
    assert state.is_failed() and "2 with an unusable baseline" in state.message
    for asset in run_summary(state)["assets"]:
        assert asset["status"] == "unusable baseline" and asset["windows"] == []
        assert (f"was fitted as 'fmi2 guid {PLANT.GUID}' and is now 'fmi2 guid {OTHER_GUID}'"
                in asset["note"])
    for asset in ("F-001", "F-002"):
        assert registry.watermark(asset) == START + 4 * window       # kept
