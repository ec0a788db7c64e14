"""The nightly flow end to end under the Prefect test harness, on the small simulated fleet."""
from __future__ import annotations

import json
from types import SimpleNamespace

import pandas as pd
import pytest

from flowtest_fleet import (ASSETS, BASELINE_DAYS, DAYS, FAULTY, assert_the_others_ran_every_night,
                            day)
from flows.results import run_summary


def _run(config, **kwargs):
    from flows.nightly import nightly

    state = nightly(config_path=str(config), return_state=True, **kwargs)
    return state, run_summary(state)


def _jsonl(path):
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_alerts_exactly_for_the_faulty_assets_after_onset(workspace, count):
    registry = workspace.registry()
    state, summary = _run(workspace.config, as_of=day(DAYS).isoformat())
    assert state.is_completed(), state.message
    assert summary["exit_status"] == 0
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    assert sorted(by_asset) == list(ASSETS)
    nights = DAYS - BASELINE_DAYS
    for asset in ASSETS:
        assert by_asset[asset]["status"] == "ok"
        assert len(by_asset[asset]["windows"]) == nights
        # every asset succeeded, so every watermark moved to the end of the last night
        assert registry.watermark(asset) == day(DAYS)

    alerts = summary["alerts"]
    assert {a["asset_id"] for a in alerts} == set(FAULTY)
    for alert in alerts:
        _, onset_day, _ = FAULTY[alert["asset_id"]]
        assert pd.Timestamp(alert["window_start"]) >= day(0) + pd.Timedelta(days=onset_day)
        assert alert["zeta"] > alert["epsilon"] and alert["ratio"] > 1
        assert alert["severity"] in ("minor", "major", "critical")
        assert alert["top_changes"] and {"name", "baseline", "candidate", "contribution"} \
            <= set(alert["top_changes"][0])
        assert alert["version"] is not None and alert["run_id"]
    # each faulty asset alerts on its last night (the fault is there all night)
    for asset in FAULTY:
        assert any(a["asset_id"] == asset and a["window_start"] == day(DAYS - 1).isoformat()
                   for a in alerts)

    # stored in the JSON-lines file and in the registry
    lines = _jsonl(workspace.alerts)
    assert len(lines) == len(alerts)
    assert {(a["asset_id"], a["window_start"], a["channel"], a["tier"]) for a in lines} == \
        {(a["asset_id"], a["window_start"], a["channel"], a["tier"]) for a in alerts}
    recorded = registry.alerts()
    assert {(r.asset_id, r.window_start) for r in recorded} == \
        {(a["asset_id"], a["window_start"]) for a in alerts}

    # the night's fleet table is a Prefect artifact
    from prefect.client.orchestration import get_client

    with get_client(sync_client=True) as client:
        # the raw endpoint: this client's read_artifacts sends None for omitted filters
        response = client.request("POST", "/artifacts/filter", json={
            "artifacts": {"key": {"any_": ["fleet-health-nightly"]},
                          "flow_run_id": {"any_": [summary["flow_run_id"]]}},
            "limit": 5, "offset": 0, "sort": "UPDATED_DESC"})
    artifacts = response.json()
    assert len(artifacts) == 1
    artifact = SimpleNamespace(**artifacts[0])
    assert artifact is not None and artifact.type == "table"
    rows = json.loads(artifact.data) if isinstance(artifact.data, str) else artifact.data
    assert {row["asset"] for row in rows} == set(ASSETS)

    # the same night again: nothing new anywhere
    before = count(registry)
    state, again = _run(workspace.config, as_of=day(DAYS).isoformat())
    assert state.is_completed()
    assert {a["status"] for a in again["assets"]} == {"up to date"}
    assert count(registry) == before
    assert len(_jsonl(workspace.alerts)) == len(alerts)


def test_registry_and_alerts_file_hold_equal_records(workspace):
    """One alert type: the night's alerts read back from the registry are the records the
    JSON-lines file and the run summary hold, equal field for field."""
    from flows.alerts import AlertLog
    from flows.config import load_config
    from graybox.alert import Alert

    state, summary = _run(workspace.config, as_of=day(BASELINE_DAYS + 1).isoformat())
    assert state.is_completed(), state.message
    logged = AlertLog(workspace.alerts).read()
    assert logged and {a.asset_id for a in logged} <= set(FAULTY)
    config = load_config(workspace.config)
    recorded = workspace.registry().alerts(scale=config.alerts.scale)
    assert all(isinstance(a, Alert) for a in recorded)
    assert recorded == logged
    assert sorted((Alert.from_dict(a) for a in summary["alerts"]), key=lambda a: a.key) == \
        sorted(logged, key=lambda a: a.key)


def test_corrupt_telemetry_fails_only_that_asset(workspace, corrupt, capsys):
    from flows.cli import main

    root, nan_file = corrupt("T-003", BASELINE_DAYS, "inf")          # its first night
    _, backward_file = corrupt("T-001", BASELINE_DAYS + 1, "backward")  # its second night
    workspace.configure(telemetry=root)
    status = main(["--config", str(workspace.config), "run", "--as-of", day(DAYS).isoformat(),
                   "--json"])
    out, err = capsys.readouterr()
    assert status == 1
    summary = json.loads(out)
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    registry = workspace.registry()

    bad = by_asset["T-003"]
    assert bad["status"] == "failed" and bad["windows"] == []
    assert bad["error"]["kind"] == "non_finite"
    assert bad["error"]["file"] == str(nan_file) and bad["error"]["row"] == 100
    assert registry.watermark("T-003") is None                     # unchanged
    assert "T-003 failed" in err and str(nan_file) in err and "row 100" in err

    # stops at its first bad night: the night before it is committed, the rest wait
    stopped = by_asset["T-001"]
    assert stopped["status"] == "failed" and len(stopped["windows"]) == 1
    assert stopped["error"]["kind"] == "backward_timestamp"
    assert stopped["error"]["file"] == str(backward_file) and stopped["error"]["row"] == 200
    assert registry.watermark("T-001") == day(BASELINE_DAYS + 1)
    assert "T-001 failed" in err

    for asset in ("T-002", "T-004", "T-005"):
        assert by_asset[asset]["status"] == "ok"
        assert len(by_asset[asset]["windows"]) == DAYS - BASELINE_DAYS
        assert registry.watermark(asset) == day(DAYS)
    assert summary["exit_status"] == 1


class Interrupt(BaseException):
    """Stands for the process being killed."""


def test_interrupted_run_rerun_has_no_duplicates(workspace, monkeypatch, count):
    from registry.registry import Registry

    workspace.configure(batch_size=2)           # batches T-001..2, T-003..4, T-005
    original = Registry.record_group
    calls = {"n": 0}
    nights = DAYS - BASELINE_DAYS

    def record_then_die(self, submissions, **kwargs):
        # the flow records a group's fits together; killed after the first 2 * nights + 2
        # (second batch, after two of its fits: a group whose fits were being written one
        # transaction each, after its own transaction failed)
        left = 2 * nights + 2 - calls["n"]
        if len(submissions) < left:
            calls["n"] += len(submissions)
            return original(self, submissions, **kwargs)
        original(self, submissions[:left], **kwargs)
        raise Interrupt("killed")

    monkeypatch.setattr(Registry, "record_group", record_then_die)
    with pytest.raises(BaseException) as stopped:
        state, _ = _run(workspace.config, as_of=day(DAYS).isoformat())
        if not state.is_completed():
            raise RuntimeError(state.message)
    assert not isinstance(stopped.value, AssertionError)
    registry = workspace.registry()
    # the first batch is committed; nothing after the interruption moved a watermark
    assert registry.watermark("T-001") == day(DAYS)
    assert registry.watermark("T-002") == day(DAYS)
    for asset in ("T-003", "T-004", "T-005"):
        assert registry.watermark(asset) is None
    partial = count(registry)
    assert partial["versions"] == len(ASSETS) + 2 * nights + 2

    monkeypatch.setattr(Registry, "record_group", original)
    state, summary = _run(workspace.config, as_of=day(DAYS).isoformat())
    assert state.is_completed(), state.message
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    assert by_asset["T-001"]["status"] == by_asset["T-002"]["status"] == "up to date"
    created = [w["created"] for w in by_asset["T-003"]["windows"]]
    assert created == [False, False, True]      # found again, not recorded twice
    final = count(registry)
    assert final["versions"] == len(ASSETS) + len(ASSETS) * nights   # baselines + candidates
    assert final["runs"] == final["versions"]
    recorded = registry.alerts()
    alarmed = {(r.asset_id, r.window_start) for r in recorded}
    assert final["alerts"] == len({r.key for r in recorded})   # each window read back once
    lines = [json.loads(l) for l in workspace.alerts.read_text().splitlines()]
    keys = [(a["asset_id"], a["window_start"], a["channel"], a["tier"]) for a in lines]
    assert len(keys) == len(set(keys))
    assert {(a["asset_id"], a["window_start"]) for a in lines} == alarmed
    for asset in ASSETS:
        assert registry.watermark(asset) == day(DAYS)


def test_transient_error_is_retried(workspace, monkeypatch):
    from registry.registry import Registry

    original = Registry.commit_watermarks
    calls = {"n": 0}

    def flaky(self, ends):
        calls["n"] += 1
        if calls["n"] == 1:
            raise OSError("network file system hiccup")
        return original(self, ends)

    monkeypatch.setattr(Registry, "commit_watermarks", flaky)
    state, summary = _run(workspace.config, as_of=day(BASELINE_DAYS + 1).isoformat(),
                          assets=["T-001"])
    assert state.is_completed(), state.message
    (asset,) = summary["assets"]
    assert asset["status"] == "ok" and calls["n"] == 2
    assert [w["created"] for w in asset["windows"]] == [False]   # the retry found its record
    assert workspace.registry().watermark("T-001") == day(BASELINE_DAYS + 1)


def test_a_store_briefly_away_is_a_transient_error_and_is_retried(workspace, monkeypatch):
    """A genuine store failure, not a mock of MLflow: while the batch reads its assets'
    watermarks (planning reads them for the whole batch at once) the store's directory is
    away (an unmounted share). The registry raises its TransientStoreError, the flows treat
    it as transient as they treated MLflow's error, and the batch's retry finds the store
    back."""
    from registry.exceptions import TransientStoreError
    from registry.registry import Registry

    monkeypatch.setenv("MLFLOW_SQLALCHEMYSTORE_POOLCLASS", "NullPool")  # a connection a call
    original = Registry.watermarks
    store, away = workspace.db.parent, workspace.path / "store-away"
    failures = []

    def away_once(self, asset_ids):
        if failures:
            return original(self, asset_ids)
        store.rename(away)
        try:
            return original(self, asset_ids)
        except Exception as error:
            failures.append(error)
            raise
        finally:
            away.rename(store)

    monkeypatch.setattr(Registry, "watermarks", away_once)
    state, summary = _run(workspace.config, as_of=day(BASELINE_DAYS + 1).isoformat(),
                          assets=["T-001"])
    assert [type(error) for error in failures] == [TransientStoreError]
    assert state.is_completed(), state.message
    (asset,) = summary["assets"]
    assert asset["status"] == "ok"
    assert workspace.registry().watermark("T-001") == day(BASELINE_DAYS + 1)

def test_batch_failing_after_its_retries_does_not_stop_the_others(workspace, monkeypatch):
    from registry.registry import Registry

    workspace.configure(batch_size=1, retries=1)
    original = Registry.commit_watermarks

    def broken_for_one(self, ends):
        if "T-001" in ends:         # a batch of one asset: its group is T-001 alone
            raise ConnectionError("registry unreachable")
        return original(self, ends)

    monkeypatch.setattr(Registry, "commit_watermarks", broken_for_one)
    state, summary = _run(workspace.config, as_of=day(BASELINE_DAYS + 1).isoformat(),
                          assets=["T-001", "T-003"])
    assert state.is_failed()
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    assert by_asset["T-001"]["status"] == "failed"
    assert "failed after 2 attempt(s)" in by_asset["T-001"]["error"]["message"]
    assert "registry unreachable" in by_asset["T-001"]["error"]["message"]
    assert by_asset["T-003"]["status"] == "ok"
    assert summary["exit_status"] == 1


def test_a_fit_the_store_refuses_fails_its_asset_alone(workspace, monkeypatch):
    """The group's candidates are recorded in one transaction; when the store refuses one
    fit's rows, the others land, its asset keeps the nights before it and is reported
    failed with that window, and the next run records what is left."""
    from mlflow.exceptions import MlflowException
    from mlflow.protos.databricks_pb2 import INVALID_PARAMETER_VALUE

    from registry.store import naming
    from registry.store.sql_writes import SqlWriter

    write_many = SqlWriter.write_many
    refused_end = day(BASELINE_DAYS + 2)

    def refusing(self, items):
        for run, _ in items:
            if run.tags[naming.TAG_ASSET_ID] == "T-002" and \
                    pd.Timestamp(run.tags[naming.TAG_WINDOW_END]) == refused_end:
                raise MlflowException("the store refused a row", INVALID_PARAMETER_VALUE)
        return write_many(self, items)

    monkeypatch.setattr(SqlWriter, "write_many", refusing)
    state, summary = _run(workspace.config, as_of=day(DAYS).isoformat())
    assert state.is_failed()
    by_asset = {a["asset_id"]: a for a in summary["assets"]}
    refused = by_asset["T-002"]
    assert refused["status"] == "failed" and len(refused["windows"]) == 1
    assert "refused a row" in refused["error"]["message"]
    registry = workspace.registry()
    assert registry.watermark("T-002") == day(BASELINE_DAYS + 1)
    assert_the_others_ran_every_night(by_asset, registry, "T-002")

    monkeypatch.setattr(SqlWriter, "write_many", write_many)
    state, summary = _run(workspace.config, as_of=day(DAYS).isoformat())
    assert state.is_completed(), state.message
    (again,) = [a for a in summary["assets"] if a["asset_id"] == "T-002"]
    assert again["status"] == "ok"
    assert [w["created"] for w in again["windows"]] == [True] * (DAYS - BASELINE_DAYS - 1)
    assert registry.watermark("T-002") == day(DAYS)
