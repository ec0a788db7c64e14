"""Issue 13, "no silent failures": coverage of every run, and fault scenarios.

Each ``test_fault_<what>`` is one scenario of the fault matrix: it injects the fault into a
real run (real Prefect, MLflow on SQLite, Parquet) and asserts that nothing is lost (runs,
versions, aliases, alerts, watermarks) and that the outcome is reported, never silent.
"""
from __future__ import annotations

import json

from flows.cli import main
from flows.results import (FAILED, NO_BASELINE, NO_TELEMETRY, OK, STALE, UNUSABLE_BASELINE,
                           UP_TO_DATE, AssetResult, RunSummary)
from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, day


def run(capsys, *argv):
    status = main(list(argv))
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def _state(registry) -> dict:
    """Everything a run commits: watermarks, baseline aliases, and the alerts."""
    return {"watermarks": {a: registry.watermark(a) for a in ASSETS},
            "baselines": {a: (registry.baseline(a).version if registry.baseline(a) else None)
                          for a in ASSETS},
            "alerts": sorted((a.asset_id, a.window_start, a.channel, a.tier)
                             for a in registry.alerts())}


# -- coverage ---------------------------------------------------------------------------------

def _summary(flow: str, statuses: list[str]) -> RunSummary:
    return RunSummary(flow, "2026-01-01T00:00:00+00:00", assets=[
        AssetResult(f"A-{i}", "c", status) for i, status in enumerate(statuses)])


def test_coverage_counts_every_status_and_sets_the_exit_status():
    complete = _summary("nightly", [OK, UP_TO_DATE, OK])
    assert complete.coverage.complete and complete.exit_status == 0
    assert complete.coverage.line() == "3 assets: 3 monitored and up to date."
    for missing in (FAILED, STALE, NO_BASELINE, UNUSABLE_BASELINE, NO_TELEMETRY):
        summary = _summary("nightly", [OK, missing])
        assert summary.exit_status == 1, missing
        assert summary.coverage.missed == ("A-1",)
    summary = _summary("nightly", [OK, STALE, NO_BASELINE, UNUSABLE_BASELINE, FAILED,
                                   NO_TELEMETRY, UP_TO_DATE])
    coverage = summary.to_dict()["coverage"]
    assert coverage == {"flow": "nightly", "assets": 7, "up_to_date": 2, "stale": 1,
                        "no_baseline": 1, "unusable_baseline": 1, "failed": 1,
                        "no_telemetry": 1, "missed": ["A-1", "A-2", "A-3", "A-4", "A-5"],
                        "complete": False}
    assert summary.coverage.line() == (
        "7 assets: 2 monitored and up to date; not monitored: 1 failed, 1 stale, "
        "1 without baseline, 1 with an unusable baseline, 1 without telemetry "
        "(A-1, A-2, A-3, A-4, A-5).")
    # the summary's JSON round trip keeps what the coverage is computed from
    assert RunSummary.from_dict(json.loads(json.dumps(summary.to_dict()))).coverage == \
        summary.coverage


def test_baseline_coverage_is_honest_when_every_fit_failed():
    summary = _summary("baseline", [FAILED] * 8)
    assert summary.coverage.line() == (
        "8 assets: 0 fitted; not fitted: 8 failed "
        "(A-0, A-1, A-2, A-3, A-4, A-5, A-6, A-7).")
    assert summary.exit_status == 1


def test_fault_baseline_fit_without_data_reports_every_asset_failed(workspace, capsys):
    """Every fit fails (no telemetry in the range): the summary, its JSON and the exit
    status say so, nothing is recorded and the promoted baselines are untouched."""
    registry = workspace.registry()
    before = _state(registry)
    start, end = day(DAYS + 10), day(DAYS + 14)
    status, out, err = run(capsys, "--config", str(workspace.config), "baseline", "fit",
                           "--all", "--start", f"{start:%Y-%m-%d}", "--end", f"{end:%Y-%m-%d}")
    assert status == 1
    text = " ".join(out.split())
    assert f"Coverage: 5 assets: 0 fitted; not fitted: 5 failed ({', '.join(ASSETS)})." in text
    for asset in ASSETS:
        assert f"fleet-health: {asset} failed:" in err
    status, out, _ = run(capsys, "--config", str(workspace.config), "baseline", "fit",
                         "--all", "--start", f"{start:%Y-%m-%d}", "--end", f"{end:%Y-%m-%d}",
                         "--json")
    data = json.loads(out)
    assert status == 1 and data["coverage"]["failed"] == 5 and data["coverage"]["up_to_date"] == 0
    assert _state(workspace.registry()) == before


def test_fault_alerts_file_unwritable_is_not_retried_and_loses_nothing(workspace, capsys,
                                                                       count):
    """The alerts file cannot be written (a directory is in its place): the batch fails at
    once, says it was not retried, the watermarks stay, and the rerun after the fix commits
    every window once with its alerts."""
    registry = workspace.registry()
    before = _state(registry)
    counts_before = count(registry)
    workspace.alerts.mkdir()
    as_of = day(BASELINE_DAYS + 1).isoformat()
    status, out, err = run(capsys, "--config", str(workspace.config), "run", "--as-of", as_of,
                           "--json")
    assert status == 1
    summary = json.loads(out)
    for asset in summary["assets"]:
        assert asset["status"] == "failed"
        assert "(not retried: not a transient error)" in asset["error"]["message"]
        assert "attempt" not in asset["error"]["message"]
    assert summary["coverage"]["failed"] == len(ASSETS)
    assert _state(workspace.registry())["watermarks"] == before["watermarks"]

    workspace.alerts.rmdir()
    status, out, err = run(capsys, "--config", str(workspace.config), "run", "--as-of", as_of,
                           "--json")
    assert status == 0, err
    after = json.loads(out)
    assert after["coverage"]["complete"]
    registry = workspace.registry()
    for asset in ASSETS:
        assert registry.watermark(asset) == day(BASELINE_DAYS + 1)
    # one candidate per asset and window: the failed run's records are reused, not doubled
    assert count(registry)["versions"] == counts_before["versions"] + len(ASSETS)
    lines = [json.loads(x) for x in workspace.alerts.read_text().splitlines() if x.strip()]
    assert {a["asset_id"] for a in lines} == {"T-002"}
    assert len(lines) == len({(a["asset_id"], a["window_start"], a["channel"], a["tier"])
                              for a in lines})
