"""``fleet-health baseline ...``: tables, JSON, exit statuses."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from flows.cli import main


def run(capsys, store_uri, *argv):
    status = main(["--tracking-uri", store_uri, *argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_list_history_promote_reject_rollback(rec, registry, store_uri, capsys):
    rec.baseline(shift_days=0)
    rec.baseline(shift_days=10)
    rec.candidate(night=15, alarmed=True)

    status, out, _ = run(capsys, store_uri, "baseline", "list")
    assert status == 0
    assert "T-01" in out and "turbine" in out and "none" in out and "ALARM" in out

    status, out, err = run(capsys, store_uri, "baseline", "promote", "T-01", "--reason", "x")
    assert status == 1 and "no calibration" in err and "newest promotable version is 2" in err

    status, out, _ = run(capsys, store_uri, "baseline", "promote", "T-01", "--version", "1",
                         "--reason", "initial")
    assert status == 0 and "baseline is now v1" in out
    status, out, _ = run(capsys, store_uri, "baseline", "promote", "T-01", "--version", "2",
                         "--reason", "after overhaul", "--json")
    assert status == 0 and json.loads(out)["previous_baseline"] == 1

    status, out, _ = run(capsys, store_uri, "baseline", "reject", "T-01", "--version", "3",
                         "--reason", "glitch")
    assert status == 0 and "v3 rejected" in out
    status, out, _ = run(capsys, store_uri, "baseline", "rollback", "T-01", "--reason", "noisy")
    assert status == 0 and "rolled back to v1" in out

    status, out, _ = run(capsys, store_uri, "baseline", "history", "T-01")
    assert status == 0
    for text in ("v1", "v2", "v3", "baseline", "rejected", "glitch", "initial", "noisy"):
        assert text in out
    status, out, _ = run(capsys, store_uri, "baseline", "history", "T-01", "--json")
    versions = json.loads(out)
    assert [(v["version"], v["status"]) for v in versions] == [
        (1, "baseline"), (2, "former baseline"), (3, "rejected")]

    status, out, _ = run(capsys, store_uri, "baseline", "list", "--json", "--class", "turbine")
    (summary,) = json.loads(out)
    assert summary["baseline"]["version"] == 1 and summary["candidate"] is None


def test_exit_statuses(registry, store_uri, capsys, tmp_path):
    assert run(capsys, store_uri, "baseline", "promote", "T-01", "--reason", "x")[0] == 1
    status, _, err = run(capsys, store_uri, "baseline", "promote", "../x", "--reason", "x")
    assert status == 2 and "invalid asset id" in err
    assert run(capsys, store_uri, "baseline", "promote", "T-01")[0] == 2        # no --reason
    assert run(capsys, store_uri, "baseline", "reject", "T-01", "--version", "0",
               "--reason", "x")[0] == 2
    assert run(capsys, store_uri, "baseline", "list", "--class", "a/b")[0] == 2
    assert run(capsys, store_uri, "baseline")[0] == 2
    status, out, _ = run(capsys, store_uri, "baseline", "list")
    assert status == 0 and "No assets recorded" in out
    missing = f"sqlite:///{tmp_path}/none/mlflow.db"
    status, _, err = run(capsys, missing, "baseline", "list")
    assert status == 1 and "no registry at" in err
    assert not (tmp_path / "none").exists()
    assert main(["--help"]) == 0


@pytest.mark.slow
def test_python_dash_m_flows(store_uri, registry, monkeypatch):
    monkeypatch.setenv("FLEET_HEALTH_TRACKING_URI", store_uri)
    done = subprocess.run([sys.executable, "-m", "flows", "baseline", "list", "--json"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == []
