"""Reanalysis: any assets and range, against the baseline or a named version; it records
runs only (no version, no alias, no watermark, no nightly alert)."""
from __future__ import annotations

import json

import pandas as pd
import pytest

from flowtest_fleet import BASELINE_DAYS, day


def _state(versions):
    return sorted((v.version, v.aliases) for v in versions)


def test_reanalysis_moves_nothing_and_is_idempotent(workspace, count, capsys):
    from flows.cli import main

    registry = workspace.registry()
    before = count(registry)
    history = {a: _state(registry.history(a)) for a in ("T-001", "T-002")}
    argv = ["--config", str(workspace.config), "reanalyze", "--asset", "T-001", "--asset",
            "T-002", "--start", day(BASELINE_DAYS).isoformat(),
            "--end", day(BASELINE_DAYS + 2).isoformat(), "--json"]
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    assert [len(by_asset[a]["windows"]) for a in ("T-001", "T-002")] == [2, 2]
    assert all(w["version"] is None and w["created"] for a in by_asset.values()
               for w in a["windows"])
    assert by_asset["T-002"]["alerts"] and not by_asset["T-001"]["alerts"]   # noise fault
    assert {a["source"] for a in summary["alerts"]} == {"reanalysis"}

    after = count(registry)
    assert after["runs"] == before["runs"] + 4          # one run per asset-window
    assert after["versions"] == before["versions"]      # no version registered
    assert after["alerts"] == before["alerts"]          # not a nightly alert
    assert {a: _state(registry.history(a)) for a in history} == history   # aliases kept
    assert registry.watermark("T-001") is None and registry.watermark("T-002") is None
    assert not workspace.alerts.exists()                 # the nightly alerts file untouched
    assert registry.zeta_history("T-002").empty          # nightly history untouched

    run = registry.backend.client.get_run(by_asset["T-002"]["windows"][0]["run_id"])
    assert run.data.tags["fleet_health.reanalysis"] == "true"
    assert run.data.tags["fleet_health.baseline_version"] == "1"

    # the same reanalysis again finds the same runs
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    assert all(not w["created"] for a in again["assets"] for w in a["windows"])
    assert count(registry) == after


def test_reanalysis_against_a_named_version(workspace, capsys):
    from flows.cli import main
    from flows.nightly import nightly

    state = nightly(config_path=str(workspace.config), as_of=day(BASELINE_DAYS + 1).isoformat(),
                    assets=["T-002"], return_state=True)
    assert state.is_completed()
    registry = workspace.registry()
    versions = _state(registry.history("T-002"))
    assert versions == [(1, ("baseline",)), (2, ("candidate",))]
    argv = ["--config", str(workspace.config), "reanalyze", "--asset", "T-002",
            "--start", day(BASELINE_DAYS + 1).isoformat(),
            "--end", (day(BASELINE_DAYS + 1) + pd.Timedelta(hours=12)).isoformat(), "--json"]
    # a nightly candidate has no calibration: nothing could alarm against it, so it is refused
    assert main(argv + ["--version", "2"]) == 1
    (asset,) = json.loads(capsys.readouterr().out)["assets"]
    assert asset["status"] == "unusable baseline" and asset["windows"] == []
    assert "version 2 has no calibration" in asset["note"]
    assert "fleet-health baseline promote T-002 --version 1" in asset["note"]
    status = main(argv + ["--version", "1"])
    assert status == 0
    (asset,) = json.loads(capsys.readouterr().out)["assets"]
    assert asset["baseline_version"] == 1 and asset["status"] == "ok"
    (window,) = asset["windows"]                           # half a day: a partial window
    assert window["window_end"].startswith(f"{day(BASELINE_DAYS + 1):%Y-%m-%d}T12:00")
    assert window["alarm"] and window["max_ratio"] > 1     # the noise fault, named version
    assert _state(registry.history("T-002")) == versions


def test_reanalysis_of_an_unknown_version_fails_that_asset(workspace, capsys):
    from flows.cli import main

    status = main(["--config", str(workspace.config), "reanalyze", "--asset", "T-001",
                   "--asset", "T-003", "--start", day(BASELINE_DAYS).isoformat(),
                   "--end", day(BASELINE_DAYS + 1).isoformat(), "--version", "7", "--json"])
    captured = capsys.readouterr()
    assert status == 1
    assert "T-001 failed" in captured.err and "no version 7" in captured.err


def test_record_fit_reanalysis_rules(workspace):
    from graybox.drift import compute_drift

    registry = workspace.registry()
    loaded = registry.baseline("T-001")
    drift = compute_drift(loaded.signature, loaded.signature, loaded.calibration)
    common = dict(window_start=day(4), window_end=day(5), data_hash="h")
    with pytest.raises(ValueError, match="names the version"):
        registry.record_fit("T-001", "turbine", loaded.signature, role="candidate",
                            drift=drift, reanalysis=True, **common)
    with pytest.raises(ValueError, match="candidate"):
        registry.record_fit("T-001", "turbine", loaded.signature, role="baseline",
                            calibration=loaded.calibration, reanalysis=True,
                            baseline_version=1, **common)
    first = registry.record_fit("T-001", "turbine", loaded.signature, role="candidate",
                                drift=drift, reanalysis=True, baseline_version=1, plots=False,
                                **common)
    again = registry.record_fit("T-001", "turbine", loaded.signature, role="candidate",
                                drift=drift, reanalysis=True, baseline_version=1, plots=False,
                                **common)
    other = registry.record_fit("T-001", "turbine", loaded.signature, role="candidate",
                                drift=drift, reanalysis=True, baseline_version=2, plots=False,
                                **common)
    assert first.created and not again.created and other.created
    assert first.run_id == again.run_id != other.run_id
    assert first.version is None and first.model_id == ""
    # a nightly record of the same window is a different record
    nightly = registry.record_fit("T-001", "turbine", loaded.signature, role="candidate",
                                  drift=drift, plots=False, **common)
    assert nightly.created and nightly.version == 2 and nightly.run_id != first.run_id
