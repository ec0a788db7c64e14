"""Issue 13, "no silent failures": coverage of every run, and fault scenarios.

Each ``test_fault_<what>`` is one scenario of the fault matrix: it injects the fault into a
real run (real Prefect, MLflow on SQLite, Parquet) and asserts that nothing is lost (runs,
versions, aliases, alerts, watermarks) and that the outcome is reported, never silent.
"""
from __future__ import annotations

import json
import os
import pathlib
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import threading
import time
import uuid
from types import SimpleNamespace

import pytest

from flows.cli import main
from flows.results import (DORMANT, FAILED, NO_BASELINE, NO_TELEMETRY, NOT_OPERATING, OK,
                           STALE, UNUSABLE_BASELINE, UP_TO_DATE, AssetResult, RunSummary,
                           run_summary)
from flowtest_config import write_config
from flows.run_lock import LOCK_WAIT_ENV, RunLock
from flows.errors import RunLockTimeout
from registry.exceptions import RegistryError
from flows.store_probe import MLFLOW_HTTP_DEFAULTS, STORE_TIMEOUT_ENV, bound_mlflow_requests
from flowtest_store import committed_state
from flowtest_fleet import ASSETS, BASELINE_DAYS, DAYS, day


def run(capsys, *argv):
    status = main(list(argv))
    captured = capsys.readouterr()
    return status, captured.out, captured.err




# -- coverage ---------------------------------------------------------------------------------

def _summary(flow: str, statuses: list[str]) -> RunSummary:
    return RunSummary(flow, "2026-01-01T00:00:00+00:00", assets=[
        AssetResult(f"A-{i}", "c", status) for i, status in enumerate(statuses)])


def test_coverage_counts_every_status_and_sets_the_exit_status():
    complete = _summary("nightly", [OK, UP_TO_DATE, OK])
    assert complete.coverage.complete and complete.exit_status == 0
    assert complete.coverage.line() == "3 assets: 3 monitored and up to date."
    for missing in (FAILED, STALE, NO_BASELINE, UNUSABLE_BASELINE, NO_TELEMETRY, DORMANT):
        summary = _summary("nightly", [OK, missing])
        assert summary.exit_status == 1, missing
        assert summary.coverage.missed == ("A-1",)
    summary = _summary("nightly", [OK, STALE, NO_BASELINE, UNUSABLE_BASELINE, FAILED,
                                   NO_TELEMETRY, UP_TO_DATE])
    coverage = summary.to_dict()["coverage"]
    assert coverage == {"flow": "nightly", "assets": 7, "up_to_date": 2, "stale": 1,
                        "no_baseline": 1, "unusable_baseline": 1, "failed": 1,
                        "no_telemetry": 1, "not_operating": 0, "dormant": 0,
                        "missed": ["A-1", "A-2", "A-3", "A-4", "A-5"],
                        "complete": False}
    assert summary.coverage.line() == (
        "7 assets: 2 monitored and up to date; not monitored: 1 failed, 1 stale, "
        "1 without baseline, 1 with an unusable baseline, 1 without telemetry "
        "(A-1, A-2, A-3, A-4, A-5).")
    # an asset that ran too little to monitor is named, and alone leaves the exit status 0
    summary = _summary("nightly", [OK, NOT_OPERATING, UP_TO_DATE])
    assert summary.exit_status == 0 and not summary.coverage.complete
    assert summary.coverage.line() == (
        "3 assets: 2 monitored and up to date; not monitored: 1 not operating (A-1).")
    assert _summary("nightly", [NOT_OPERATING, STALE]).exit_status == 1
    # not operating for longer than [alerts] not_operating_after: dormant, not settled
    summary = _summary("nightly", [OK, NOT_OPERATING, DORMANT])
    assert summary.exit_status == 1 and summary.coverage.dormant == 1
    assert summary.coverage.line() == (
        "3 assets: 1 monitored and up to date; not monitored: 1 not operating, 1 dormant "
        "(A-1, A-2).")
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
    before = committed_state(registry)
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
    assert committed_state(workspace.registry()) == before


def test_fault_alerts_file_unwritable_loses_nothing(workspace, capsys, count):
    """The alerts file cannot be written (a directory is in its place). The registry is the
    alerts' system of record: the night is committed there (candidates with their alerts,
    watermarks), the run fails naming the file and the command that writes it, and the next
    run after the fix writes the missed alerts once."""
    registry = workspace.registry()
    counts_before = count(registry)
    workspace.alerts.mkdir()
    as_of = day(BASELINE_DAYS + 1).isoformat()
    status, out, err = run(capsys, "--config", str(workspace.config), "run", "--as-of", as_of,
                           "--json")
    assert status == 1
    assert str(workspace.alerts) in err and "fleet-health alerts --export" in err
    registry = workspace.registry()
    for asset in ASSETS:
        assert registry.watermark(asset) == day(BASELINE_DAYS + 1)
    assert count(registry)["versions"] == counts_before["versions"] + len(ASSETS)
    recorded = {a.key for a in registry.alerts()}
    assert recorded and {key[0] for key in recorded} == {"T-002"}

    workspace.alerts.rmdir()
    status, out, err = run(capsys, "--config", str(workspace.config), "run", "--as-of", as_of,
                           "--json")
    assert status == 0, err
    after = json.loads(out)
    assert after["coverage"]["complete"]
    assert {a["status"] for a in after["assets"]} == {"up to date"}
    # one candidate per asset and window: nothing fitted or recorded again
    assert count(workspace.registry())["versions"] == counts_before["versions"] + len(ASSETS)
    lines = [json.loads(x) for x in workspace.alerts.read_text().splitlines() if x.strip()]
    keys = [(a["asset_id"], a["window_start"], a["window_end"], a["channel"], a["tier"])
            for a in lines]
    assert len(keys) == len(set(keys)) and set(keys) == recorded


# -- the store ------------------------------------------------------------------------------

def _closed_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def test_mlflow_request_bounds_are_set_unless_the_user_set_them():
    environ = {"MLFLOW_HTTP_REQUEST_TIMEOUT": "7"}
    bound_mlflow_requests(environ)
    assert environ == {**MLFLOW_HTTP_DEFAULTS, "MLFLOW_HTTP_REQUEST_TIMEOUT": "7"}


def test_fault_store_unreachable_fails_fast_naming_the_uri(workspace, capsys, monkeypatch,
                                                            count):
    """A dead MLflow server (a closed port): the run stops within the bound with one line
    naming the URI; nothing is done and the real store is untouched."""
    before = committed_state(workspace.registry()), count(workspace.registry())
    uri = f"http://127.0.0.1:{_closed_port()}"
    monkeypatch.setenv(STORE_TIMEOUT_ENV, "2")
    started = time.monotonic()
    status, out, err = run(capsys, "--config", str(workspace.config), "--tracking-uri", uri,
                           "run", "--as-of", day(DAYS).isoformat())
    elapsed = time.monotonic() - started
    assert status == 1 and elapsed < 60, (status, elapsed)
    (line,) = err.splitlines()
    assert line == (f"fleet-health: error: the MLflow tracking server {uri} did not answer "
                     f"within 2 s (ConnectionRefusedError: [Errno 111] Connection refused): "
                     f"nothing was run. Start it, or fix [mlflow] tracking_uri / "
                     f"--tracking-uri (${STORE_TIMEOUT_ENV} sets the wait)")
    # a deployed (scheduled) run has no command line around it: the flow itself stops
    from flows.nightly import nightly

    started = time.monotonic()
    state = nightly(config_path=str(workspace.config), tracking_uri=uri,
                    as_of=day(DAYS).isoformat(), return_state=True)
    assert state.is_failed() and time.monotonic() - started < 60
    assert f"the MLflow tracking server {uri} did not answer within 2 s" in state.message
    assert (committed_state(workspace.registry()), count(workspace.registry())) == before
    assert not workspace.alerts.exists()


def test_fault_store_locked_by_another_writer_waits_and_loses_nothing(workspace, count):
    """Another connection takes SQLite's exclusive lock for 5 s in the middle of the run
    (once its first candidate is recorded): the registry retries, the run completes and
    every window is committed once."""
    from flows.nightly import nightly

    before = count(workspace.registry())
    held = threading.Event()
    done = threading.Event()

    def hold_when_recording():
        connection = sqlite3.connect(workspace.db, isolation_level=None, timeout=30)
        while not done.is_set():
            (versions,) = connection.execute("SELECT count(*) FROM model_versions").fetchone()
            if versions > before["versions"]:
                connection.execute("BEGIN EXCLUSIVE")
                held.set()
                time.sleep(5)
                connection.execute("ROLLBACK")
                break
            time.sleep(0.02)
        connection.close()

    holder = threading.Thread(target=hold_when_recording)
    holder.start()
    try:
        state = nightly(config_path=str(workspace.config), as_of=day(DAYS).isoformat(),
                        return_state=True)
    finally:
        done.set()
        holder.join()
    assert held.is_set(), "the store was never locked during the run"
    summary = run_summary(state)
    assert state.is_completed(), state.message
    assert summary["coverage"]["complete"]
    registry = workspace.registry()
    nights = DAYS - BASELINE_DAYS
    assert count(registry)["versions"] == before["versions"] + nights * len(ASSETS)
    assert count(registry)["runs"] == before["runs"] + nights * len(ASSETS)
    assert {registry.watermark(a) for a in ASSETS} == {day(DAYS)}


def test_fault_store_read_only_fails_every_asset_and_the_rerun_commits_once(workspace, count):
    """The store refuses writes (SQLite's "attempt to write a readonly database", raised by
    a trigger): every asset is reported failed with the reason, no watermark moves; once
    writable, the rerun commits every window once."""
    from flows.nightly import nightly

    registry = workspace.registry()
    before, counts = committed_state(registry), count(registry)
    connection = sqlite3.connect(workspace.db)
    connection.execute("CREATE TRIGGER read_only BEFORE INSERT ON runs BEGIN "
                       "SELECT RAISE(ABORT, 'attempt to write a readonly database'); END")
    connection.commit()
    as_of = day(BASELINE_DAYS + 1).isoformat()
    state = nightly(config_path=str(workspace.config), as_of=as_of, return_state=True)
    summary = run_summary(state)
    assert state.is_failed()
    assert summary["coverage"]["failed"] == len(ASSETS) and summary["exit_status"] == 1
    for asset in summary["assets"]:
        assert "readonly database" in asset["error"]["message"], asset
    assert committed_state(workspace.registry()) == before
    assert count(workspace.registry()) == counts
    connection.execute("DROP TRIGGER read_only")
    connection.commit()
    connection.close()
    state = nightly(config_path=str(workspace.config), as_of=as_of, return_state=True)
    assert state.is_completed(), state.message
    assert count(workspace.registry())["versions"] == counts["versions"] + len(ASSETS)


# -- concurrent runs, killed runs -------------------------------------------------------------

REPO = pathlib.Path(__file__).resolve().parents[2]


def _start_cli(workspace, *argv) -> subprocess.Popen:
    """``python -m flows --config <workspace> ARGV`` in its own process, on the session's
    Prefect server."""
    from prefect.settings import PREFECT_API_URL

    env = dict(os.environ, PREFECT_API_URL=PREFECT_API_URL.value(),
               PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    env[LOCK_WAIT_ENV] = "600"
    return subprocess.Popen([sys.executable, "-m", "flows", "--config", str(workspace.config),
                             *argv], cwd=workspace.path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _wait_for_versions(process, db: pathlib.Path, versions_before: int) -> None:
    """Poll the running ``process``'s SQLite store until it holds more model versions than
    ``versions_before`` (the run recorded a candidate)."""
    deadline = time.monotonic() + 600
    while True:
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline
        connection = sqlite3.connect(db)
        (versions,) = connection.execute("SELECT count(*) FROM model_versions").fetchone()
        connection.close()
        if versions > versions_before:
            return
        time.sleep(0.02)


def _alert_lines(path: pathlib.Path) -> list[tuple]:
    lines = [json.loads(x) for x in path.read_text().splitlines() if x.strip()]
    return sorted((a["asset_id"], a["window_start"], a["channel"], a["tier"]) for a in lines)


@pytest.mark.slow
def test_fault_concurrent_runs_fit_each_window_once(workspace, count):
    """Two ``run``s of the same fleet at once: one fits every window, the other waits for
    the run lock and finds them done; both exit 0 with honest summaries."""
    before = count(workspace.registry())
    as_of = day(DAYS).isoformat()
    processes = [_start_cli(workspace, "run", "--as-of", as_of, "--json") for _ in range(2)]
    outputs = [p.communicate(timeout=900) for p in processes]
    for process, (out, err) in zip(processes, outputs):
        assert process.returncode == 0, err
    summaries = [json.loads(out) for out, _ in outputs]
    created = [sum(w["created"] for a in s["assets"] for w in a["windows"]) for s in summaries]
    nights = DAYS - BASELINE_DAYS
    worker, waiter = (0, 1) if created[0] else (1, 0)
    assert sorted(created) == [0, nights * len(ASSETS)]
    assert {a["status"] for a in summaries[worker]["assets"]} == {"ok"}
    assert {a["status"] for a in summaries[waiter]["assets"]} == {"up to date"}
    for summary in summaries:
        assert summary["coverage"]["complete"] and summary["exit_status"] == 0
    lock = summaries[waiter]["extra"]["run_lock"]
    if lock["waited_seconds"] >= 1:       # they overlapped (the usual case): it says whom
        assert lock["waited_for"]["flow_run_id"] == summaries[worker]["flow_run_id"]
        assert "waited" in outputs[waiter][1]
    registry = workspace.registry()
    assert count(registry)["versions"] == before["versions"] + nights * len(ASSETS)
    assert count(registry)["runs"] == before["runs"] + nights * len(ASSETS)
    assert {registry.watermark(a) for a in ASSETS} == {day(DAYS)}
    alerts = _alert_lines(workspace.alerts)
    assert alerts and len(alerts) == len(set(alerts))
    assert not (workspace.db.parent / ".fleet-health-locks" / "fleet-run.json").exists()


@pytest.mark.slow
def test_fault_kill_9_then_rerun_equals_uninterrupted_run(workspace, baselined, fleet,
                                                          count, capsys):
    """A run killed with SIGKILL while it records its candidates: its Prefect flow run
    stays Running until the next run marks it Crashed; that rerun leaves the store and the
    alerts exactly as one uninterrupted run does."""
    from prefect.client.orchestration import get_client
    from prefect.client.schemas.objects import StateType

    from flows.nightly import nightly

    as_of = day(DAYS).isoformat()
    reference = workspace.path / "reference"
    reference.mkdir()
    shutil.copy(baselined.db, reference / "mlflow.db")
    reference_config = write_config(reference / "fleet.toml", fleet.root,
                                    reference / "mlflow.db")
    state = nightly(config_path=str(reference_config), as_of=as_of, return_state=True)
    assert state.is_completed(), state.message
    from registry import Registry
    expected = Registry(f"sqlite:///{reference / 'mlflow.db'}")

    versions_before = count(workspace.registry())["versions"]
    holder_file = workspace.db.parent / ".fleet-health-locks" / "fleet-run.json"
    process = _start_cli(workspace, "run", "--as-of", as_of)
    _wait_for_versions(process, workspace.db, versions_before)   # a first candidate
    os.kill(process.pid, signal.SIGKILL)
    process.communicate()
    killed = json.loads(holder_file.read_text())["flow_run_id"]
    with get_client(sync_client=True) as client:
        assert client.read_flow_run(uuid.UUID(killed)).state.type == StateType.RUNNING

    status, out, err = run(capsys, "--config", str(workspace.config), "run", "--as-of", as_of,
                           "--json")
    assert status == 0, err
    summary = json.loads(out)
    assert [o["flow_run_id"] for o in summary["extra"]["orphans_crashed"]] == [killed]
    assert "marked the orphaned fleet-health-nightly flow run" in err
    with get_client(sync_client=True) as client:
        crashed = client.read_flow_run(uuid.UUID(killed)).state
    assert crashed.type == StateType.CRASHED and "orphaned" in crashed.message

    registry = workspace.registry()
    assert count(registry) == count(expected)
    assert committed_state(registry) == committed_state(expected)
    assert _alert_lines(workspace.alerts) == _alert_lines(reference / "alerts.jsonl")
    assert not holder_file.exists()


def test_coverage_is_in_the_flow_runs_prefect_artifact(workspace):
    from prefect.client.orchestration import get_client
    from prefect.client.schemas.filters import (ArtifactFilter, ArtifactFilterFlowRunId,
                                                ArtifactFilterKey)

    from flows.nightly import nightly

    state = nightly(config_path=str(workspace.config), as_of=day(BASELINE_DAYS + 1).isoformat(),
                    assets=["T-001", "T-003"], return_state=True)
    summary = state.result()
    with get_client(sync_client=True) as client:
        (artifact,) = client.read_artifacts(artifact_filter=ArtifactFilter(
            key=ArtifactFilterKey(any_=["fleet-health-nightly"]),
            flow_run_id=ArtifactFilterFlowRunId(any_=[uuid.UUID(summary["flow_run_id"])])))
    assert artifact.description.endswith("Coverage: 2 assets: 2 monitored and up to date.")


def test_fault_artifacts_unwritable_fail_the_assets_and_the_rerun_commits_once(workspace,
                                                                               count):
    """The experiment's artifact location cannot be created (a file stands where its
    directory should be): every asset fails with the reason, no watermark moves and no
    version is made; once fixed, the rerun commits every window once."""
    from flows.nightly import nightly

    registry = workspace.registry()
    before, counts = committed_state(registry), count(registry)
    blocked = workspace.path / "artifacts-blocked"
    blocked.write_text("a file where the artifact directory should be")
    connection = sqlite3.connect(workspace.db)
    connection.execute("UPDATE experiments SET artifact_location = ?",
                       (f"file://{blocked}/inside",))
    connection.commit()
    connection.close()
    as_of = day(BASELINE_DAYS + 1).isoformat()
    state = nightly(config_path=str(workspace.config), as_of=as_of, return_state=True)
    summary = run_summary(state)
    assert state.is_failed()
    assert summary["coverage"]["failed"] == len(ASSETS)
    for asset in summary["assets"]:
        assert asset["error"]["message"], asset
    registry = workspace.registry()
    assert committed_state(registry) == before
    assert count(registry)["versions"] == counts["versions"]
    assert not workspace.alerts.exists()
    blocked.unlink()
    state = nightly(config_path=str(workspace.config), as_of=as_of, return_state=True)
    assert state.is_completed(), state.message
    registry = workspace.registry()
    assert count(registry)["versions"] == counts["versions"] + len(ASSETS)
    assert count(registry)["runs"] == counts["runs"] + len(ASSETS)
    assert {registry.watermark(a) for a in ASSETS} == {day(BASELINE_DAYS + 1)}


def test_run_lock_names_its_holder_and_never_swallows_the_runs_errors(tmp_path):
    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    first = RunLock.of(uri)
    with first.hold("nightly", "run-1", wait=0):
        assert first.is_held()
        with pytest.raises(RunLockTimeout, match=r"the nightly run \(flow run run-1, pid "):
            with RunLock.of(uri).hold("baseline", "run-2", wait=0.2):
                raise AssertionError("must not be reached")
    assert not first.is_held() and first.holder() is None
    with pytest.raises(RegistryError, match="the run's own"):
        with RunLock.of(uri).hold("nightly", "run-3", wait=0):
            raise RegistryError("the run's own error")
    assert RunLock.of(uri).holder() is None


# -- kill -9 at more points ---------------------------------------------------------------------

def _watermarks_committed(db: pathlib.Path) -> int:
    connection = sqlite3.connect(db)
    try:
        (n,) = connection.execute("SELECT count(*) FROM registered_model_tags "
                                  "WHERE key = 'fleet_health.watermark'").fetchone()
    finally:
        connection.close()
    return n


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory, baselined, fleet, harness):
    """The nightly run over days 4-6 once, uninterrupted, on a copy of the baselined store."""
    from flows.nightly import nightly
    from registry import Registry

    directory = tmp_path_factory.mktemp("uninterrupted")
    shutil.copy(baselined.db, directory / "mlflow.db")
    config = write_config(directory / "fleet.toml", fleet.root, directory / "mlflow.db")
    state = nightly(config_path=str(config), as_of=day(DAYS).isoformat(), return_state=True)
    assert state.is_completed(), state.message
    return SimpleNamespace(registry=Registry(f"sqlite:///{directory / 'mlflow.db'}"),
                           alerts=directory / "alerts.jsonl")


@pytest.mark.slow
@pytest.mark.parametrize("committed", [1, len(ASSETS)],
                         ids=["one_watermark_committed", "every_watermark_committed"])
def test_fault_kill_9_after_watermarks_then_rerun_equals_uninterrupted_run(
        committed, workspace, uninterrupted, count, capsys):
    """A run killed with SIGKILL once ``committed`` assets' watermarks are committed
    (mid-fleet, or after the last one, before its alerts are exported): the rerun leaves the
    store and the alerts file exactly as one uninterrupted run does (the registry is the
    alerts' system of record: the rerun exports what the killed run did not).

    The moment is made exact: the test holds the alerts file's lock (so the killed run
    cannot have exported) and, once enough watermarks are seen, SQLite's exclusive lock (so
    no further watermark is committed between looking and killing)."""
    from registry.store.tracking_store import file_lock

    assert _watermarks_committed(workspace.db) == 0
    if committed < len(ASSETS):
        # a memory group's watermarks are committed in one transaction: a kill between two
        # assets' commits needs them in different groups (a batch of one asset each)
        workspace.configure(batch_size=1)
    holder_file = workspace.db.parent / ".fleet-health-locks" / "fleet-run.json"
    alerts_lock = workspace.alerts.with_name(workspace.alerts.name + ".lock")
    connection = sqlite3.connect(workspace.db, isolation_level=None, timeout=60)
    try:
        with file_lock(alerts_lock, timeout=5):
            process = _start_cli(workspace, "run", "--as-of", day(DAYS).isoformat())
            deadline = time.monotonic() + 600
            while True:
                assert process.poll() is None, process.communicate()
                assert time.monotonic() < deadline
                # looked at under SQLite's lock, so none is committed between looking and
                # killing (a watermark's commit takes a few ms: polling without the lock
                # could see all of them at once)
                connection.execute("BEGIN EXCLUSIVE")
                at_kill = _watermarks_committed(workspace.db)
                if at_kill >= committed:
                    break
                connection.execute("ROLLBACK")
                time.sleep(0.001)
            os.kill(process.pid, signal.SIGKILL)
            process.communicate()
            connection.execute("ROLLBACK")
    finally:
        connection.close()
    assert process.returncode == -signal.SIGKILL
    if committed < len(ASSETS):
        assert committed <= at_kill < len(ASSETS), at_kill      # killed mid-fleet
    else:
        assert at_kill == len(ASSETS)
    assert not workspace.alerts.exists()                  # the killed run exported nothing
    killed = json.loads(holder_file.read_text())["flow_run_id"]
    watermarks = committed_state(workspace.registry())["watermarks"]
    assert sum(w == day(DAYS) for w in watermarks.values()) == at_kill

    status, out, err = run(capsys, "--config", str(workspace.config), "run", "--as-of",
                           day(DAYS).isoformat(), "--json")
    assert status == 0, err
    summary = json.loads(out)
    assert [o["flow_run_id"] for o in summary["extra"]["orphans_crashed"]] == [killed]
    assert summary["coverage"]["complete"]
    registry = workspace.registry()
    assert count(registry) == count(uninterrupted.registry)
    assert committed_state(registry) == committed_state(uninterrupted.registry)
    assert _alert_lines(workspace.alerts) == _alert_lines(uninterrupted.alerts)
    assert not holder_file.exists()


# -- promotion during a run -----------------------------------------------------------------------

def _zetas(registry, asset: str) -> dict:
    """(window start, channel, tier) -> (zeta, baseline version) of the asset's candidates."""
    frame = registry.zeta_history(asset)
    keys = list(zip(frame["window_start"].astype(str), frame["channel"], frame["tier"]))
    assert len(keys) == len(set(keys)), "a window is recorded twice"
    return dict(zip(keys, zip(frame["zeta"], frame["baseline_version"].astype(int))))


@pytest.mark.slow
def test_fault_promotion_during_a_run_is_not_torn(workspace, uninterrupted, count, capsys):
    """``baseline promote`` of another calibrated version of T-001 while a nightly run records
    its candidates: each window is compared with exactly one baseline version, recorded with
    it (those against the old one give the uninterrupted run's zetas), the alias ends where
    the promotion put it, nothing is recorded twice, the watermarks are those of a clean run,
    and the next run compares against the new baseline."""
    from registry.store.tracking_store import file_lock

    asset, nights = "T-001", DAYS - BASELINE_DAYS
    old = workspace.registry().baseline(asset).version
    status, out, err = run(capsys, "--config", str(workspace.config), "baseline", "fit", asset,
                           "--start", day(0).isoformat(),
                           "--end", day(BASELINE_DAYS + 1).isoformat())
    assert status == 0, err
    registry = workspace.registry()
    (summary,) = [s for s in registry.list_baselines() if s.asset_id == asset]
    new = summary.candidate.version
    assert new != old and summary.candidate.calibrated and summary.baseline.version == old
    before = count(registry)

    # the run cannot end before the promotion: its alerts export waits for this lock
    with file_lock(workspace.alerts.with_name(workspace.alerts.name + ".lock"), timeout=5):
        process = _start_cli(workspace, "run", "--as-of", day(DAYS - 1).isoformat(), "--json")
        _wait_for_versions(process, workspace.db, before["versions"])   # a first candidate
        status, out, err = run(capsys, "--config", str(workspace.config), "baseline",
                               "promote", asset, "--version", str(new), "--reason",
                               "refit on days 1-4")
        assert status == 0, err
        assert process.poll() is None
    out, err = process.communicate(timeout=900)
    assert process.returncode == 0, err
    during = json.loads(out)
    assert during["coverage"]["complete"]

    registry = workspace.registry()
    assert registry.baseline(asset).version == new
    assert count(registry)["versions"] == before["versions"] + (nights - 1) * len(ASSETS)
    assert {registry.watermark(a) for a in ASSETS} == {day(DAYS - 1)}
    zetas, expected = _zetas(registry, asset), _zetas(uninterrupted.registry, asset)
    by_window: dict = {}
    for (start, channel, tier), (zeta, version) in zetas.items():
        by_window.setdefault(start, set()).add(version)
        if version == old:
            assert zeta == pytest.approx(expected[start, channel, tier][0]), (start, channel)
    assert len(by_window) == nights - 1
    assert all(len(v) == 1 and v <= {old, new} for v in by_window.values()), by_window

    status, out, err = run(capsys, "--config", str(workspace.config), "run", "--as-of",
                           day(DAYS).isoformat(), "--json")
    assert status == 0, err
    registry = workspace.registry()
    last = day(DAYS - 1).isoformat()
    latest = {v for (start, _, _), (_, v) in _zetas(registry, asset).items()
              if start.startswith(last[:10])}
    assert latest == {new}
    assert registry.baseline(asset).version == new
    assert count(registry)["versions"] == before["versions"] + nights * len(ASSETS)
    assert {registry.watermark(a) for a in ASSETS} == {day(DAYS)}
    lines = _alert_lines(workspace.alerts)
    assert lines == sorted(set(lines))
    # the other assets' alerts are those of a run without any promotion
    assert [a for a in lines if a[0] != asset] == \
        [a for a in _alert_lines(uninterrupted.alerts) if a[0] != asset]
