"""Unusable baselines in the flows: the asset is refused loudly ("unusable baseline", exit
status 1, the version and the fix named), its watermark stays, and the rest of the fleet
goes on (issue 13's fault matrix: ``test_fault_*``)."""
from __future__ import annotations

import importlib.util
import json
import math
import pathlib
import sys

import pandas as pd

from flowtest_fleet import BASELINE_DAYS, day
from flows.results import run_summary

ZEN = "Beautiful is better than ugly"


def _tampering():
    """The registry tests' tampering helpers (tests/registry/tampering.py)."""
    if "tampering" in sys.modules:
        return sys.modules["tampering"]
    path = pathlib.Path(__file__).parents[1] / "registry" / "tampering.py"
    spec = importlib.util.spec_from_file_location("tampering", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["tampering"] = module
    spec.loader.exec_module(module)
    return module


def _jsonl(path):
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _versions(registry, asset):
    return [(v.version, v.aliases) for v in registry.history(asset)]


def _signature_edited_baseline(registry, asset, tmp_path, edit) -> int:
    """A copy of the asset's version 1 whose signature.json ``edit`` changed (manifest and
    digest tag consistent), moved to the ``baseline`` alias; its version."""
    tampering = _tampering()
    version = tampering.tampered_version(registry, asset, 1, tmp_path,
                                         tampering.edit_json("signature.json", edit))
    tampering.move_alias(registry, asset, "baseline", version)
    return version


def _nightly(workspace, as_of, assets):
    from flows.nightly import nightly

    state = nightly(config_path=str(workspace.config), as_of=as_of.isoformat(), assets=assets,
                    return_state=True)
    return state, run_summary(state)


def test_fault_baseline_alias_moved_to_an_uncalibrated_candidate(workspace, capsys):
    from flows.cli import main

    tampering = _tampering()
    registry = workspace.registry()
    first = main(["--config", str(workspace.config), "run", "--as-of",
                  day(BASELINE_DAYS + 1).isoformat(), "--asset", "T-001", "--asset", "T-002",
                  "--json"])
    assert first == 0
    capsys.readouterr()
    lines_before = _jsonl(workspace.alerts)
    # someone moves T-001's baseline alias to its nightly candidate (v2) in the MLflow UI
    tampering.move_alias(registry, "T-001", "baseline", 2)
    versions = _versions(registry, "T-001")

    status = main(["--config", str(workspace.config), "run", "--as-of",
                   day(BASELINE_DAYS + 2).isoformat(), "--asset", "T-001", "--asset", "T-002",
                   "--json"])
    captured = capsys.readouterr()
    assert status == 1
    summary = json.loads(captured.out)
    assert summary["exit_status"] == 1
    assert summary["counts"]["unusable baseline"] == 1 and summary["counts"]["ok"] == 1
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    refused = by_asset["T-001"]
    assert refused["status"] == "unusable baseline" and refused["windows"] == []
    assert "asset 'T-001' version 2 has no calibration (a candidate fit)" in refused["note"]
    assert "fleet-health baseline promote T-001 --version 1" in refused["note"]
    assert "T-001 not monitored (unusable baseline): asset 'T-001' version 2" in captured.err
    # nothing of T-001 moved: its watermark, versions and aliases are as they were
    assert registry.watermark("T-001") == day(BASELINE_DAYS + 1)
    assert refused["watermark_after"] == day(BASELINE_DAYS + 1).isoformat()
    assert _versions(registry, "T-001") == versions
    # T-002 went on: its night recorded, its alerts written, its watermark advanced
    assert by_asset["T-002"]["status"] == "ok" and len(by_asset["T-002"]["windows"]) == 1
    assert registry.watermark("T-002") == day(BASELINE_DAYS + 2)
    new_lines = _jsonl(workspace.alerts)[len(lines_before):]
    assert new_lines and {a["asset_id"] for a in new_lines} == {"T-002"}   # noise fault
    assert _jsonl(workspace.alerts)[:len(lines_before)] == lines_before


def test_fault_one_tampered_asset_does_not_stop_the_fleet(workspace, tmp_path, count):
    tampering = _tampering()
    registry = workspace.registry()

    def nan_epsilon(data):
        data["thresholds"][0]["epsilon"] = math.nan
    # a copy of T-003's baseline whose epsilon is NaN, manifest and digest tag consistent
    version = tampering.tampered_version(registry, "T-003", 1, tmp_path,
                                         tampering.edit_json("calibration.json", nan_epsilon))
    tampering.move_alias(registry, "T-003", "baseline", version)
    before = count(registry)

    state, summary = _nightly(workspace, day(BASELINE_DAYS + 1), ["T-001", "T-002", "T-003"])
    assert state.is_failed() and "1 with an unusable baseline (T-003)" in state.message
    assert summary["exit_status"] == 1
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    refused = by_asset["T-003"]
    assert refused["status"] == "unusable baseline" and refused["windows"] == []
    assert (f"asset 'T-003' version {version}: calibration.json: TierThreshold.epsilon must "
            f"be a finite number, got nan") in refused["note"]
    assert registry.watermark("T-003") is None
    assert _versions(registry, "T-003") == [(1, ("candidate",)), (version, ("baseline",))]
    for asset in ("T-001", "T-002"):
        assert by_asset[asset]["status"] == "ok" and len(by_asset[asset]["windows"]) == 1
        assert registry.watermark(asset) == day(BASELINE_DAYS + 1)
    assert count(registry)["versions"] == before["versions"] + 2      # T-001 and T-002 only
    lines = _jsonl(workspace.alerts)
    assert lines and {a["asset_id"] for a in lines} == {"T-002"}


def _night_refusing_t001(workspace, tmp_path, edit):
    """T-001's baseline moved to a copy whose signature.json ``edit`` changed, then a nightly
    over T-001 and T-005: the run fails (exit status 1) with T-001 an unusable baseline whose
    watermark stays, and T-005 compared as ever. Returns the copy's version and T-001's
    result."""
    registry = workspace.registry()
    version = _signature_edited_baseline(registry, "T-001", tmp_path, edit)
    state, summary = _nightly(workspace, day(BASELINE_DAYS + 1), ["T-001", "T-005"])
    assert state.is_failed() and summary["exit_status"] == 1
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    assert by_asset["T-001"]["status"] == "unusable baseline"
    assert registry.watermark("T-001") is None
    assert by_asset["T-005"]["status"] == "ok" and len(by_asset["T-005"]["windows"]) == 1
    return version, by_asset["T-001"]


def test_fault_stored_spec_naming_another_module_is_not_imported(workspace, tmp_path, capfd):
    assert "this" not in sys.modules

    def zen(data):
        data["model"]["spec"] = "this:Zen"
    version, refused = _night_refusing_t001(workspace, tmp_path, zen)

    assert (f"asset 'T-001' version {version}: signature.json: model 'this:Zen' is not the "
            f"asset's configured model ('graybox.models.gas_turbine:GasTurbineShaft' or "
            f"'graybox.models:GasTurbineShaft'); refusing to import it") in refused["note"]
    assert workspace.registry().watermark("T-005") == day(BASELINE_DAYS + 1)
    assert "this" not in sys.modules
    assert ZEN not in capfd.readouterr().out


def test_fault_a_baseline_fitted_on_another_model_file_is_refused(workspace, tmp_path):
    """The stored record's fingerprint (an FMU's GUID) is not the configured model's now
    (the file was replaced): the asset is an unusable baseline, named with both, not
    compared with a model its parameters and calibration do not belong to."""
    def replaced(data):
        data["model"]["fingerprint"] = "fmi2 guid {0000e810-0000-4a00-8276-176fa3c9128f}"
    version, refused = _night_refusing_t001(workspace, tmp_path, replaced)

    assert refused["windows"] == []
    assert (f"version {version}: model 'graybox.models.gas_turbine:GasTurbineShaft' was fitted "
            f"as 'fmi2 guid {{0000e810-0000-4a00-8276-176fa3c9128f}}' and is now None") \
        in refused["note"]
    assert "fleet-health baseline fit T-001 --start DATE --end DATE --promote" in refused["note"]


def test_fault_reanalysis_against_an_uncalibrated_baseline(workspace, tmp_path, capsys, count):
    from flows.cli import main
    from registry.store import naming

    tampering = _tampering()
    registry = workspace.registry()

    def drop_calibration(bundle):
        (bundle / "calibration.json").unlink()
        manifest = json.loads((bundle / "manifest.json").read_text())
        del manifest["files"]["calibration.json"]
        (bundle / "manifest.json").write_text(json.dumps(manifest))
    version = tampering.tampered_version(registry, "T-001", 1, tmp_path, drop_calibration)
    name = naming.model_name("T-001")
    registry.backend.client.set_model_version_tag(name, str(version), naming.TAG_CALIBRATED,
                                                  "false")
    tampering.move_alias(registry, "T-001", "baseline", version)
    before = count(registry)

    status = main(["--config", str(workspace.config), "reanalyze", "--asset", "T-001",
                   "--asset", "T-002", "--start", day(BASELINE_DAYS).isoformat(),
                   "--end", (day(BASELINE_DAYS) + pd.Timedelta(hours=12)).isoformat(),
                   "--json"])
    captured = capsys.readouterr()
    assert status == 1
    by_asset = {a["asset_id"]: a for a in json.loads(captured.out)["assets"]}
    assert by_asset["T-001"]["status"] == "unusable baseline"
    assert f"asset 'T-001' version {version} has no calibration" in by_asset["T-001"]["note"]
    assert "fleet-health baseline promote T-001 --version 1" in by_asset["T-001"]["note"]
    assert by_asset["T-002"]["status"] == "ok" and len(by_asset["T-002"]["windows"]) == 1
    after = count(registry)
    assert after["runs"] == before["runs"] + 1          # T-002's reanalysis run only
    assert after["versions"] == before["versions"]
