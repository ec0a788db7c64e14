"""A night computed by a compute pool (``[nightly] processes = 2``) against the same night in
the flow's process alone (``processes = 1``): the same results, records and alerts; an
asset's failure in a worker, and a worker that dies, fail that asset alone, by name."""
from __future__ import annotations

import json
import shutil

import pytest

from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, assert_the_others_ran_every_night, day
from flowtest_store import committed_state
from flows.results import run_summary


def _night(config):
    from flows.nightly import nightly

    state = nightly(config_path=str(config), as_of=day(DAYS).isoformat(), return_state=True)
    return run_summary(state)


def _store(tmp_path, baselined, fleet, config_writer, name, processes, telemetry=None):
    directory = tmp_path / name
    directory.mkdir()
    shutil.copy(baselined.db, directory / "mlflow.db")
    config = config_writer(directory / "fleet.toml", telemetry or fleet.root,
                           directory / "mlflow.db", batch_size=3, processes=processes)
    from registry import Registry

    return config, Registry(f"sqlite:///{directory / 'mlflow.db'}")


def _without_ids(summary: dict) -> list:
    """The assets' results without what differs between two runs of the same night (run ids,
    times)."""
    out = []
    for asset in summary["assets"]:
        asset = dict(asset)
        asset["windows"] = [{k: v for k, v in w.items() if k != "run_id"}
                            for w in asset["windows"]]
        asset["alerts"] = [{k: v for k, v in a.items() if k not in ("run_id", "created")}
                           for a in asset["alerts"]]
        out.append(asset)
    return out


def _candidates(registry) -> list:
    """Every candidate run's identity, metrics and parameters, in a stable order."""
    client = registry.backend.client
    runs = registry.backend.paged(client.search_runs, registry.backend.experiment_ids(), "")
    found = []
    for run in runs:
        tags = run.data.tags
        if tags.get("fleet_health.role") != "candidate":
            continue
        found.append((tags["fleet_health.asset_id"], tags["fleet_health.window_start"],
                      tags["fleet_health.data_hash"], tags["fleet_health.fit_key"],
                      tags.get("fleet_health.alarm"), sorted(run.data.metrics.items()),
                      sorted(run.data.params.items())))
    return sorted(found)


def test_a_pooled_night_records_what_the_sequential_night_records(tmp_path, baselined, fleet,
                                                                    config_writer, harness):
    import io

    from flows import progress

    alone, alone_registry = _store(tmp_path, baselined, fleet, config_writer, "alone", 1)
    pooled, pooled_registry = _store(tmp_path, baselined, fleet, config_writer, "pooled", 2)
    lines = {}
    for name, config in (("alone", alone), ("pooled", pooled)):
        stream = io.StringIO()
        with progress.reporting(progress.LineReporter(stream)):
            lines[name] = (_night(config), stream.getvalue())
    (expected, said_alone), (got, said) = lines["alone"], lines["pooled"]
    # the progress lines say who computes: the pool's workers, or nothing extra
    assert "2 worker processes compute the candidates, this one records them " \
           "([nightly] processes = 2)" in said
    assert "worker processes" not in said_alone

    assert got["exit_status"] == expected["exit_status"] == 0
    assert [a["asset_id"] for a in got["assets"]] == list(ASSETS)
    assert _without_ids(got) == _without_ids(expected)
    # the pool did the compute, and its workers' stages are in the summary
    assert (got["extra"]["processes"], expected["extra"]["processes"]) == (2, 1)
    assert set(got["extra"]["stages"]) - {"pool_wait"} == set(expected["extra"]["stages"])
    nights = DAYS - BASELINE_DAYS
    assert all(len(a["windows"]) == nights for a in got["assets"])
    assert any(a["alerts"] for a in got["assets"])       # the faulty assets alarmed
    assert committed_state(pooled_registry) == committed_state(alone_registry)
    candidates = _candidates(pooled_registry)
    assert len(candidates) == len(ASSETS) * nights
    assert candidates == _candidates(alone_registry)


def test_bad_telemetry_in_a_worker_fails_that_asset_alone(tmp_path, baselined, fleet,
                                                          config_writer, corrupt, harness):
    root, bad_file = corrupt("T-003", BASELINE_DAYS, "inf")          # its first night
    config, registry = _store(tmp_path, baselined, fleet, config_writer, "pooled", 2,
                              telemetry=root)
    summary = _night(config)
    by_asset = {a["asset_id"]: a for a in summary["assets"]}

    bad = by_asset["T-003"]
    assert bad["status"] == "failed" and bad["windows"] == []
    assert bad["error"]["kind"] == "non_finite" and "'T-003'" in bad["error"]["message"]
    assert bad["error"]["file"] == str(bad_file) and bad["error"]["row"] == 100
    assert registry.watermark("T-003") is None
    for asset in ("T-001", "T-002", "T-004", "T-005"):
        assert by_asset[asset]["status"] == "ok"
        assert len(by_asset[asset]["windows"]) == DAYS - BASELINE_DAYS
        assert registry.watermark(asset) == day(DAYS)
    assert summary["exit_status"] == 1


def test_a_worker_that_dies_fails_its_asset_alone(tmp_path, baselined, fleet, config_writer,
                                                  harness, monkeypatch):
    import pool_faults
    from flows import pooled_execute

    monkeypatch.setattr(pooled_execute, "compute_chunk", pool_faults.chunk_or_die)
    config, registry = _store(tmp_path, baselined, fleet, config_writer, "pooled", 2)
    summary = _night(config)
    by_asset = {a["asset_id"]: a for a in summary["assets"]}

    doomed = by_asset[pool_faults.DOOMED]
    assert doomed["status"] == "failed" and doomed["windows"] == []
    assert f"asset '{pool_faults.DOOMED}'" in doomed["error"]["message"]
    assert "worker died" in doomed["error"]["message"]
    assert registry.watermark(pool_faults.DOOMED) is None
    assert_the_others_ran_every_night(by_asset, registry, pool_faults.DOOMED)
    assert summary["exit_status"] == 1


@pytest.mark.parametrize("setting, cores, assets, expected", [
    ("auto", 1, None, 1), ("auto", 2, None, 2), ("auto", 64, None, 4), (1, 8, None, 1),
    (3, 1, None, 3),
    # "auto" (the default) only for a run of 64 assets or more; a number as it is
    ("auto", 2, 64, 2), ("auto", 2, 63, 1), ("auto", 8, 1000, 4), (2, 2, 3, 2)])
def test_processes_setting(setting, cores, assets, expected):
    from flows.config import NightlySettings

    assert NightlySettings(processes=setting).process_count(cores, assets) == expected
    assert NightlySettings().processes == "auto"
