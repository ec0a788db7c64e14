"""The three flows' batches on a Dask cluster give what the sequential runner gives.

One LocalCluster (2 worker processes, 1 thread each) serves the module; the flows reach it
through ``[dask] address``. The fleet is the flow tests' small simulated one, cut into
batches of 2 assets so that batches run at once and finish out of order.
"""
from __future__ import annotations

import io
import json
import os
import pathlib
import re
import shutil

import pytest

from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, day
from flows.results import run_summary

pytestmark = pytest.mark.slow

BATCH_SIZE = 2


@pytest.fixture(scope="module")
def cluster():
    from distributed import LocalCluster

    from flows.task_runner import worker_environment

    env = worker_environment()
    # the workers also import this directory's fault injection (dask_faults)
    env["PYTHONPATH"] += os.pathsep + str(pathlib.Path(__file__).resolve().parent)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0", env=env) as local:
        yield local


def _workdir(write_config, root, name, fleet, db=None, dask_address=None):
    """A fleet.toml and a store (a copy of ``db``, or empty) in ``root/name``; on Dask with
    ``dask_address``."""
    directory = root / name
    directory.mkdir()
    store = directory / "mlflow.db"
    if db is not None:
        shutil.copy(db, store)
    extra = "" if dask_address is None else f'[dask]\naddress = "{dask_address}"\n'
    config = write_config(directory / "fleet.toml", fleet.root, store,
                          batch_size=BATCH_SIZE, extra=extra)
    if dask_address is not None:
        text = config.read_text().replace("[nightly]\n", '[nightly]\ntask_runner = "dask"\n')
        config.write_text(text)
    return config


def _registry(config):
    from flows.config import load_config

    return load_config(config).registry()


def _windows(summary):
    """Per asset (in summary order): status, baseline, watermarks and each window's outcome
    (everything but run ids, which MLflow draws at random)."""
    return [(a["asset_id"], a["status"], a["baseline_version"], a["watermark_before"],
             a["watermark_after"],
             [(w["window_start"], w["window_end"], w["version"], w["alarm"], w["max_ratio"],
               w["created"]) for w in a["windows"]])
            for a in summary["assets"]]


def _zetas(config):
    frames = {}
    for asset in ASSETS:
        frame = _registry(config).zeta_history(asset)
        frames[asset] = frame.drop(columns=["run_id"]).sort_values(
            ["window_start", "channel", "tier"]).reset_index(drop=True)
    return frames


def _alert_lines(path):
    lines = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    for line in lines:
        line.pop("run_id")
    # batches append as they finish: the file's order differs, its content must not
    return sorted(lines, key=lambda a: (a["asset_id"], a["window_start"], a["channel"],
                                        a["tier"]))


def _run_flow(flow, **kwargs):
    state = flow(return_state=True, **kwargs)
    return state, run_summary(state)


def test_the_flows_on_dask_equal_the_sequential_runs(tmp_path, harness, fleet, baselined,
                                                    cluster, config_writer):
    from flows import progress
    from flows.baseline import baseline
    from flows.nightly import nightly
    from flows.reanalyze import reanalyze

    # the sequential runs start from the session's store, baselined in process
    sequential = _workdir(config_writer, tmp_path, "sequential", fleet, db=baselined.db)
    on_dask = _workdir(config_writer, tmp_path, "dask", fleet,
                       dask_address=cluster.scheduler_address)

    # baselines fitted on Dask equal the ones fitted in process (same range and settings)
    state, summary = _run_flow(baseline, config_path=str(on_dask), vehicle_class="turbine",
                               start=day(0).isoformat(), end=day(BASELINE_DAYS).isoformat(),
                               promote=True, reason="healthy days 1-3")
    assert state.is_completed(), state.message
    assert [a["asset_id"] for a in summary["assets"]] == list(ASSETS)
    assert {a["status"] for a in summary["assets"]} == {"ok"}
    assert _windows(summary) == _windows(baselined.summary)
    for asset in ASSETS:
        fitted, expected = (_registry(c).baseline(asset) for c in (on_dask, sequential))
        assert fitted.version == expected.version
        assert fitted.calibration == expected.calibration

    results = {}

    # the nightly run: same versions, zetas, alerts, watermarks and statuses
    stream = io.StringIO()
    for config in (sequential, on_dask):
        reporter = progress.LineReporter(stream) if config == on_dask else progress.Reporter()
        with progress.reporting(reporter):
            state, summary = _run_flow(nightly, config_path=str(config),
                                       as_of=day(DAYS).isoformat())
        assert state.is_completed(), state.message
        results[config] = summary
    night, night_dask = results[sequential], results[on_dask]
    assert [a["asset_id"] for a in night_dask["assets"]] == list(ASSETS)  # the fleet's order
    assert _windows(night_dask) == _windows(night)
    assert all(len(a["windows"]) == DAYS - BASELINE_DAYS for a in night_dask["assets"])
    assert night_dask["alerts"] and len(night_dask["alerts"]) == len(night["alerts"])
    assert set(night_dask["extra"]["stages"]) == set(night["extra"]["stages"])
    zetas, zetas_dask = _zetas(sequential), _zetas(on_dask)
    for asset in ASSETS:
        assert len(zetas_dask[asset]) > 0
        assert zetas_dask[asset].equals(zetas[asset]), asset
    assert _alert_lines(on_dask.parent / "alerts.jsonl") == \
        _alert_lines(sequential.parent / "alerts.jsonl")
    for asset in ASSETS:
        assert _registry(on_dask).watermark(asset) == _registry(sequential).watermark(asset) \
            == day(DAYS)
    # progress is advanced in this process, per finished batch: 3 batches of 2, 2 and 1
    done = [0] + [int(c) for c in re.findall(r": (\d+)/5 done", stream.getvalue())]
    assert sorted(b - a for a, b in zip(done, done[1:])) == [1, 2, 2], stream.getvalue()
    assert done[-1] == 5 and "failed" not in stream.getvalue()

    # reanalysis of the last night against the baselines: the same zetas
    for config in (sequential, on_dask):
        state, summary = _run_flow(reanalyze, config_path=str(config),
                                   start=day(DAYS - 1).isoformat(), end=day(DAYS).isoformat())
        assert state.is_completed(), state.message
        results[config] = summary
    assert _windows(results[on_dask]) == _windows(results[sequential])
    assert [a["asset_id"] for a in results[on_dask]["assets"]] == list(ASSETS)

    # every batch task ran on the cluster's workers
    assert {"baseline_batch", "nightly_batch", "reanalysis_batch"} <= \
        set(cluster.scheduler.task_prefixes)


def test_retries_and_failed_batches_on_dask(tmp_path, harness, fleet, baselined, cluster,
                                            config_writer):
    from distributed import Client

    from dask_faults import BrokenWatermarks
    from flows import progress
    from flows.nightly import nightly

    config = _workdir(config_writer, tmp_path, "dask", fleet, db=baselined.db,
                      dask_address=cluster.scheduler_address)
    config.write_text(config.read_text().replace("batch_size = 2", "batch_size = 1")
                      .replace("retries = 2", "retries = 1"))
    stream = io.StringIO()
    with Client(cluster) as client:
        client.register_plugin(BrokenWatermarks(always=("T-001",), once=("T-003",)),
                               name="broken-watermarks")
        try:
            with progress.reporting(progress.LineReporter(stream)):
                state, summary = _run_flow(nightly, config_path=str(config),
                                           as_of=day(BASELINE_DAYS + 1).isoformat(),
                                           assets=["T-001", "T-003"])
        finally:
            client.unregister_worker_plugin("broken-watermarks")
    assert state.is_failed()
    assert [a["asset_id"] for a in summary["assets"]] == ["T-001", "T-003"]
    failed, retried = summary["assets"]
    # T-001 failed its two attempts: reported failed, the other batch went on
    assert failed["status"] == "failed"
    assert "failed after 2 attempt(s)" in failed["error"]["message"]
    assert "registry unreachable" in failed["error"]["message"]
    # T-003's batch was retried in its worker and found its first attempt's record
    assert retried["status"] == "ok"
    assert [w["created"] for w in retried["windows"]] == [False]
    registry = _registry(config)
    assert registry.watermark("T-001") is None
    assert registry.watermark("T-003") == day(BASELINE_DAYS + 1)
    assert "2/2 done, 1 failed" in stream.getvalue(), stream.getvalue()
    assert summary["exit_status"] == 1


def test_a_local_cluster_keeps_the_ordinary_malloc(harness, monkeypatch):
    """The LocalCluster a run starts: its workers have Dask's one BLAS thread but not its
    ``MALLOC_TRIM_THRESHOLD_`` (a fixed trim threshold made every array above 128 kB a fresh
    mmap); Dask's configuration and this process's environment are as they were after the
    run."""
    import dask
    from prefect import flow, task

    from flows.config import DaskSettings
    from flows.task_runner import DaskBatches

    # a nanny started with Dask's defaults in this process (the module's ``cluster``) wrote its
    # pre-spawn variables into os.environ, which every later worker inherits; a run's own
    # process has no such cluster
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)

    @task
    def worker_environment():
        return {name: os.environ.get(name) for name in ("MALLOC_TRIM_THRESHOLD_",
                                                        "OMP_NUM_THREADS")}

    @flow
    def on_a_local_cluster():
        with DaskBatches(DaskSettings(workers=1, threads_per_worker=1)) as runner:
            runner.submit(worker_environment, {})
            return [outcome.result() for _, outcome in runner.completed()]

    before = dict(os.environ)
    assert on_a_local_cluster() == [{"MALLOC_TRIM_THRESHOLD_": None, "OMP_NUM_THREADS": "1"}]
    # and this process's own environment is as it was: the nanny's variables (one BLAS
    # thread, a fixed hash seed) do not reach the processes it starts later
    assert dict(os.environ) == before
    assert dask.config.get("distributed.nanny.pre-spawn-environ")["MALLOC_TRIM_THRESHOLD_"] \
        == 65536
