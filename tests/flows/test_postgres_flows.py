"""The flows against a real PostgreSQL-backed MLflow (tests/postgres_server.py): baseline fit
and promotion, nightly, reanalysis, the alerts export, and nightly workers in several
processes at once.

Two assets of the small fleet: T-001 (healthy) and T-002 (sensor noise x4 from day 4).
"""
from __future__ import annotations

import json
import pathlib
import subprocess
import sys
from types import SimpleNamespace

import pytest

from flowtest_config import write_config
from flowtest_fleet import BASELINE_DAYS, DAYS, day
from postgres_server import subprocess_env

WORKER = pathlib.Path(__file__).with_name("nightly_worker.py")
PAIR = ["T-001", "T-002"]
BASELINED_DB = "flows_baselined"


def postgres_config(path: pathlib.Path, telemetry: pathlib.Path, uri: str) -> pathlib.Path:
    """A fleet.toml like the other flow tests' (see conftest.write_config), on ``uri``."""
    write_config(path, telemetry, pathlib.Path("PLACEHOLDER.db"))
    text = path.read_text().replace('"sqlite:///PLACEHOLDER.db"', json.dumps(uri))
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def pg_baselined(tmp_path_factory, postgres_server, harness, fleet):
    """A PostgreSQL store whose two assets have a promoted baseline of days 1-3, fitted and
    promoted by the baseline flow (the template of each test's database)."""
    from flows.baseline import baseline

    directory = tmp_path_factory.mktemp("pg-baselined")
    uri = postgres_server.create_database(BASELINED_DB, template="mlflow_template")
    config = postgres_config(directory / "fleet.toml", fleet.root, uri)
    state = baseline(start=day(0).isoformat(), end=day(BASELINE_DAYS).isoformat(),
                     config_path=str(config), assets=PAIR, promote=True,
                     reason="healthy days 1-3", return_state=True)
    assert state.is_completed(), state.message
    summary = state.result()
    assert [a["status"] for a in summary["assets"]] == ["ok", "ok"]
    return SimpleNamespace(uri=uri, directory=directory)


@pytest.fixture
def pg_site(tmp_path, postgres_server, pg_baselined, fleet, request):
    """A copy of the baselined PostgreSQL store (a new database) and its fleet.toml."""
    from registry import Registry

    name = "flows_" + request.node.name.lower().replace("-", "_")[:40]
    uri = postgres_server.create_database(name, template=BASELINED_DB)
    config = postgres_config(tmp_path / "fleet.toml", fleet.root, uri)
    return SimpleNamespace(uri=uri, config=config, alerts=tmp_path / "alerts.jsonl",
                           registry=lambda: Registry(uri, workdir=tmp_path))


def _lines(path: pathlib.Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


@pytest.mark.slow
def test_nightly_reanalysis_and_export_on_postgres(pg_site, count, capsys):
    from flows.cli import main
    from flows.nightly import nightly

    registry = pg_site.registry()
    assert registry.tracking_uri.startswith("postgresql+psycopg://")
    assert {a: registry.baseline(a).version for a in PAIR} == {"T-001": 1, "T-002": 1}
    state = nightly(config_path=str(pg_site.config), as_of=day(DAYS).isoformat(), assets=PAIR,
                    return_state=True)
    assert state.is_completed(), state.message
    summary = state.result()
    nights = DAYS - BASELINE_DAYS
    assert [len(a["windows"]) for a in summary["assets"]] == [nights, nights]
    assert {a["asset_id"] for a in summary["alerts"]} == {"T-002"}
    for asset in PAIR:
        assert registry.watermark(asset) == day(DAYS)

    # the registry holds the alerts; the file is their export, equal record for record
    recorded = registry.alerts()
    lines = _lines(pg_site.alerts)
    assert len(lines) == len(summary["alerts"]) == len(recorded)
    assert {(r.asset_id, r.window_start, r.channel, r.tier) for r in recorded} == \
        {(a["asset_id"], a["window_start"], a["channel"], a["tier"]) for a in lines}

    # the same night again: nothing new in the registry or the file
    before = count(registry)
    assert before["versions"] == len(PAIR) * (1 + nights) and before["runs"] == before["versions"]
    state = nightly(config_path=str(pg_site.config), as_of=day(DAYS).isoformat(), assets=PAIR,
                    return_state=True)
    assert state.is_completed(), state.message
    assert count(registry) == before
    assert len(_lines(pg_site.alerts)) == len(lines)

    # a lost file is rebuilt from the registry, and rebuilding again adds nothing
    pg_site.alerts.unlink()
    assert main(["--config", str(pg_site.config), "alerts", "--export"]) == 0
    assert f"{len(recorded)} alert(s) written" in capsys.readouterr().out
    assert sorted(map(json.dumps, _lines(pg_site.alerts))) == sorted(map(json.dumps, lines))
    assert main(["--config", str(pg_site.config), "alerts", "--export"]) == 0
    assert "0 alert(s) written" in capsys.readouterr().out
    assert len(_lines(pg_site.alerts)) == len(lines)

    # a reanalysis records runs only: no version, no watermark, no line in the file
    assert main(["--config", str(pg_site.config), "reanalyze", "--asset", "T-002", "--start",
                 day(BASELINE_DAYS).isoformat(), "--end", day(BASELINE_DAYS + 1).isoformat(),
                 "--json"]) == 0
    reanalysis = json.loads(capsys.readouterr().out)
    assert [len(a["windows"]) for a in reanalysis["assets"]] == [1]
    assert {a["source"] for a in reanalysis["alerts"]} == {"reanalysis"}
    after = count(registry)
    assert after["runs"] == before["runs"] + 1
    assert (after["versions"], after["alerts"]) == (before["versions"], before["alerts"])
    assert registry.watermark("T-002") == day(DAYS)
    assert len(_lines(pg_site.alerts)) == len(lines)


@pytest.mark.slow
def test_nightly_workers_in_several_processes_at_once(pg_site, count):
    """Three processes (standing for workers on three hosts) run the same nightly batch at
    the same instant: every window is recorded once, the watermarks end at the last night,
    and the flow's export writes each alert once."""
    from flows.config import load_config
    from flows.nightly import export_night_alerts
    from flows.results import AssetResult, RunSummary

    as_of = day(BASELINE_DAYS + 1).isoformat()          # one night
    go = pg_site.config.parent / "go"
    workers = [subprocess.Popen([sys.executable, str(WORKER), str(pg_site.config), as_of,
                                 str(go), *PAIR], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, env=subprocess_env(),
                                cwd=pg_site.config.parent)
               for _ in range(3)]
    try:
        for worker in workers:             # every worker imported and ready: start together
            assert worker.stdout.readline().strip() == "ready", worker.stderr.read()[-5000:]
    finally:
        go.touch()
    outputs = []
    for worker in workers:
        out, err = worker.communicate(timeout=600)
        assert worker.returncode == 0, err[-5000:]
        outputs.append(json.loads(out.strip().splitlines()[-1]))
    registry = pg_site.registry()
    counts = count(registry)
    assert counts["versions"] == len(PAIR) * 2 and counts["runs"] == counts["versions"]
    for asset in PAIR:
        assert [v.version for v in registry.history(asset)] == [1, 2]
        assert registry.watermark(asset) == day(BASELINE_DAYS + 1)
    # each window was created by exactly one worker; the others found it
    created = {}
    for output in outputs:
        for asset in output["assets"]:
            assert asset["status"] in ("ok", "up to date"), asset
            for window in asset["windows"]:
                key = (asset["asset_id"], window["window_start"])
                created[key] = created.get(key, 0) + window["created"]
    assert len(created) == len(PAIR) and set(created.values()) == {1}

    # the parent's export, from each worker's results, writes each alert once
    config = load_config(pg_site.config)
    for output in outputs:
        summary = RunSummary("nightly", "now", assets=[AssetResult.from_dict(a)
                                                        for a in output["assets"]])
        export_night_alerts(config, summary)
    lines = _lines(pg_site.alerts)
    keys = [(a["asset_id"], a["window_start"], a["channel"], a["tier"]) for a in lines]
    assert lines and len(keys) == len(set(keys)) == counts["alerts"]
    assert {a["asset_id"] for a in lines} == {"T-002"}


@pytest.mark.slow
def test_nightly_on_two_dask_workers_on_postgres_equals_the_sequential_run(
        pg_site, postgres_server, fleet, tmp_path, count):
    """Both assets' batches on a LocalCluster of 2 worker processes, writing to PostgreSQL at
    once: the same windows, versions, alarms and watermarks as the sequential run of the
    same store, nothing recorded twice, each alert exported once."""
    from distributed import LocalCluster

    from flows.nightly import nightly
    from flows.task_runner import worker_environment
    from registry import Registry

    as_of = day(DAYS).isoformat()
    sequential_dir = tmp_path / "sequential"
    sequential_dir.mkdir()
    sequential_uri = postgres_server.create_database("flows_dask_sequential",
                                                     template=BASELINED_DB)
    sequential = postgres_config(sequential_dir / "fleet.toml", fleet.root, sequential_uri)
    state = nightly(config_path=str(sequential), as_of=as_of, assets=PAIR, return_state=True)
    assert state.is_completed(), state.message
    expected = state.result()

    text = pg_site.config.read_text().replace("batch_size = 64",
                                              'batch_size = 1\ntask_runner = "dask"')
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0", env=worker_environment()) as cluster:
        pg_site.config.write_text(text + f'\n[dask]\naddress = "{cluster.scheduler_address}"\n')
        state = nightly(config_path=str(pg_site.config), as_of=as_of, assets=PAIR,
                        return_state=True)
        assert len(cluster.scheduler_info["workers"]) == 2
    assert state.is_completed(), state.message
    summary = state.result()

    def outcome(result):
        return [(a["asset_id"], a["status"], a["watermark_after"],
                 [(w["window_start"], w["version"], w["alarm"], w["max_ratio"])
                  for w in a["windows"]]) for a in result["assets"]]

    assert outcome(summary) == outcome(expected)
    nights = DAYS - BASELINE_DAYS
    registry, reference = pg_site.registry(), Registry(sequential_uri, workdir=sequential_dir)
    assert count(registry) == count(reference)
    assert count(registry)["versions"] == len(PAIR) * (1 + nights)
    assert count(registry)["runs"] == count(registry)["versions"]
    for asset in PAIR:
        assert registry.watermark(asset) == reference.watermark(asset) == day(DAYS)

    def alert_keys(path):
        return sorted((a["asset_id"], a["window_start"], a["channel"], a["tier"], a["ratio"])
                      for a in _lines(path))

    assert alert_keys(pg_site.alerts) == alert_keys(sequential_dir / "alerts.jsonl")
    assert len(set(alert_keys(pg_site.alerts))) == len(alert_keys(pg_site.alerts)) > 0


@pytest.mark.slow
def test_a_pooled_night_with_plots_on_postgres_records_what_one_process_records(
        pg_site, postgres_server, fleet, tmp_path, count, capsys):
    """``fleet-health run`` with a compute pool of two workers (``[nightly] processes = 2``)
    and the alarms' plots drawn, on PostgreSQL: the same windows, alarms, records, plots and
    watermarks as the same night in the flow's process alone."""
    from flows.cli import main
    from registry import Registry

    def night(config: pathlib.Path, processes: int) -> dict:
        text = config.read_text().replace('plots = "none"', 'plots = "alarms"')
        config.write_text(text.replace("processes = 1", f"processes = {processes}"))
        status = main(["--config", str(config), "run", "--as-of", day(DAYS).isoformat(),
                       "--asset", PAIR[0], "--asset", PAIR[1], "--json"])
        summary = json.loads(capsys.readouterr().out)
        assert status == 0, summary
        assert summary["extra"]["processes"] == processes
        return summary

    alone_dir = tmp_path / "alone"
    alone_dir.mkdir()
    alone_uri = postgres_server.create_database("flows_pool_alone", template=BASELINED_DB)
    alone = night(postgres_config(alone_dir / "fleet.toml", fleet.root, alone_uri), 1)
    pooled = night(pg_site.config, 2)

    def outcome(result):
        return [(a["asset_id"], a["status"], a["watermark_after"],
                 [(w["window_start"], w["version"], w["alarm"], w["max_ratio"])
                  for w in a["windows"]]) for a in result["assets"]]

    assert outcome(pooled) == outcome(alone)
    registry, reference = pg_site.registry(), Registry(alone_uri, workdir=alone_dir)
    assert count(registry) == count(reference)

    def plots(store: Registry, result: dict) -> dict:
        client = store.backend.client
        return {(a["asset_id"], w["window_start"]):
                sorted(f.path for f in client.list_artifacts(w["run_id"], "plots"))
                for a in result["assets"] for w in a["windows"]}

    drawn = plots(registry, pooled)
    assert drawn == plots(reference, alone)
    alarmed = {(a["asset_id"], w["window_start"]) for a in pooled["assets"]
               for w in a["windows"] if w["alarm"]}
    assert alarmed and all(drawn[key] for key in alarmed)            # T-002's nights
    assert not any(paths for key, paths in drawn.items() if key not in alarmed)
