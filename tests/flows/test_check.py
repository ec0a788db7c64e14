"""``fleet-health check``: a healthy fleet passes; each problem is reported with its fix."""
from __future__ import annotations

import json
import sqlite3

from flows.cli import main
from flowtest_fleet import ASSETS


def check(capsys, *argv):
    status = main(["--config", *argv[:1], "check", *argv[1:]])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def _findings(out: str) -> dict:
    return {(f["area"], f["subject"]): f for f in json.loads(out)["findings"]}


def test_healthy_fleet_passes(workspace, fleet, capsys, count):
    before = count(workspace.registry())
    status, out, err = check(capsys, str(workspace.config), "--json")
    assert status == 0, out + err
    report = json.loads(out)
    assert report["ok"] and report["problems"] == 0
    findings = _findings(out)
    assert findings[("telemetry", str(fleet.root))]["detail"] == \
        f"{len(ASSETS)} asset(s) found ({len(ASSETS)} turbine)"
    for asset in ASSETS:
        assert findings[("baseline", asset)]["level"] == "ok"
        assert "calibrated, loads and verifies" in findings[("baseline", asset)]["detail"]
    assert findings[("store", "artifacts")]["level"] == "ok"
    assert next(f for k, f in findings.items() if k[0] == "prefect")["level"] == "ok"
    assert findings[("runs", "orphans")]["level"] == "ok"
    # the probe run is deleted: the fleet's runs and versions are as before
    assert count(workspace.registry()) == before

    status, out, _ = check(capsys, str(workspace.config))
    assert status == 0 and "All good." in out


def test_missing_baseline_is_reported_with_the_fix(workspace, fleet, tmp_path, capsys):
    import shutil

    root = tmp_path / "telemetry"
    shutil.copytree(fleet.root, root)
    shutil.copytree(root / "asset_id=T-001", root / "asset_id=T-009")
    (root / "notes").mkdir()
    workspace.configure(telemetry=root)
    status, out, err = check(capsys, str(workspace.config), "--json")
    assert status == 1
    findings = _findings(out)
    missing = findings[("baseline", "T-009")]
    assert missing["level"] == "problem" and missing["detail"].startswith("no baseline")
    assert "fleet-health baseline fit T-009" in missing["fix"] and "--promote" in missing["fix"]
    assert findings[("telemetry", "skipped")]["level"] == "note"
    assert "notes" in findings[("telemetry", "skipped")]["detail"]
    status, out, err = check(capsys, str(workspace.config))
    assert status == 1 and "1 problem(s) found." in out
    assert "baseline T-009: no baseline" in err and "fleet-health baseline fit T-009" in err


def test_unreadable_tracking_store_is_reported_with_the_fix(workspace, capsys):
    workspace.db.write_bytes(b"this is not a database" * 100)
    for suffix in ("-wal", "-shm"):
        workspace.db.with_name(workspace.db.name + suffix).unlink(missing_ok=True)
    status, out, err = check(capsys, str(workspace.config), "--json")
    assert status == 1
    (store,) = [f for f in json.loads(out)["findings"] if f["area"] == "store"]
    assert store["level"] == "problem" and "cannot be read" in store["detail"]
    assert "not a database" in store["detail"]
    assert "restore the store from a backup" in store["fix"]


def test_missing_store_is_reported_with_the_fix(workspace, capsys):
    workspace.db.unlink()
    status, out, _ = check(capsys, str(workspace.config), "--json")
    assert status == 1
    (store,) = [f for f in json.loads(out)["findings"] if f["area"] == "store"]
    assert "does not exist" in store["detail"] and "baseline fit" in store["fix"]
    assert not workspace.db.exists()       # check never creates a store


def test_broken_config_exits_2_naming_the_key(tmp_path, capsys):
    config = tmp_path / "fleet.toml"
    config.write_text('[telemetry]\nroot = "x"\n[nightly]\nbatch_sise = 3\n')
    status, out, err = check(capsys, str(config), "--json")
    assert status == 2
    (finding,) = json.loads(out)["findings"]
    assert finding["area"] == "config" and "nightly.batch_sise" in finding["detail"]
    assert finding["fix"]
    status, out, err = check(capsys, str(config))
    assert status == 2 and "nightly.batch_sise" in err


def test_check_marks_orphaned_flow_runs_crashed(workspace, capsys, monkeypatch):
    """A Running nightly flow run named by the lock's holder file although the lock is free
    (its process died), and one Running longer than $FLEET_HEALTH_ORPHAN_AFTER: check marks
    both Crashed, says so, and is otherwise all good."""
    from prefect.client.orchestration import get_client
    from prefect.client.schemas.objects import StateType
    from prefect.states import Running

    from flows.nightly import nightly
    from flows.orphans import ORPHAN_AFTER_ENV
    from flows.run_lock import Holder, RunLock

    with get_client(sync_client=True) as client:
        dead, old = (client.create_flow_run(nightly, parameters={
            "config_path": str(workspace.config)}, state=Running()) for _ in range(2))
    lock = RunLock.of(workspace.uri)
    lock.directory.mkdir(parents=True, exist_ok=True)
    lock._write_holder(Holder("nightly", str(dead.id), 999999, "gone-host",
                              "2026-01-07T02:30:00+00:00"))
    monkeypatch.setenv(ORPHAN_AFTER_ENV, "0")
    status, out, err = check(capsys, str(workspace.config), "--json")
    assert status == 0, out + err
    findings = _findings(out)
    assert "pid 999999 on gone-host" in findings[("runs", dead.name)]["detail"]
    assert "Running since" in findings[("runs", old.name)]["detail"]
    with get_client(sync_client=True) as client:
        for run in (dead, old):
            state = client.read_flow_run(run.id).state
            assert state.type == StateType.CRASHED and "orphaned" in state.message
    assert not lock.holder_path.exists()
    # nothing is left to mark
    status, out, _ = check(capsys, str(workspace.config), "--json")
    assert status == 0 and _findings(out)[("runs", "orphans")]["level"] == "ok"


def test_unusable_baseline_is_reported_with_the_fix(workspace, capsys):
    """T-003's baseline no longer verifies (its recorded manifest digest differs from its
    artifacts): check names it unusable, with the error and the fix."""
    from registry.store import naming

    connection = sqlite3.connect(workspace.db)
    changed = connection.execute(
        "UPDATE model_version_tags SET value = ? WHERE key = ? AND name = ?",
        ("0" * 64, naming.TAG_MANIFEST_SHA256, naming.model_name("T-003"))).rowcount
    connection.commit()
    connection.close()
    assert changed >= 1
    status, out, _ = check(capsys, str(workspace.config), "--json")
    assert status == 1
    findings = _findings(out)
    unusable = findings[("baseline", "T-003")]
    assert unusable["level"] == "problem" and unusable["detail"].startswith("unusable baseline")
    assert "baseline rollback T-003" in unusable["fix"]
    assert [a for a in ASSETS if findings[("baseline", a)]["level"] != "ok"] == ["T-003"]


def test_help_says_what_is_checked_and_the_exit_statuses(capsys):
    assert main(["check", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    for what in ("configuration", "telemetry layout", "MLflow store", "Prefect's API",
                 "baseline", "Orphaned flow runs", "Exit status: 0 all good; 1 problems "
                 "found; 2 usage or configuration error."):
        assert what in out, what
    assert main(["--help"]) == 0 and "check" in capsys.readouterr().out
