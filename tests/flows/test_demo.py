"""`fleet-health demo` on a smaller fleet (the full demo is `make demo`)."""
from __future__ import annotations

import pytest

from flows.cli import main


@pytest.mark.slow
def test_small_demo_end_to_end(tmp_path, harness, capsys):
    workdir = tmp_path / "demo"
    status = main(["demo", "--workdir", str(workdir), "--vehicles", "4", "--days", "6",
                   "--baseline-days", "3", "--sample-interval", "10"])
    out = capsys.readouterr().out
    assert status == 0, out
    # demo_fleet(4) injects friction into T-001 and flutter into T-004 (seed 0)
    assert "Alerts (" in out and "Against the simulator's ground truth" in out
    for asset, verdict in (("T-001", "detected"), ("T-002", "quiet"), ("T-003", "quiet"),
                           ("T-004", "detected")):
        line = next(line for line in out.splitlines() if line.startswith(f"│ {asset}")
                    and ("detected" in line or "quiet" in line or "FALSE" in line
                         or "MISSED" in line))
        assert verdict in line, line
    assert f"mlflow ui --backend-store-uri sqlite:///{workdir / 'mlflow.db'}" in out
    assert f"PREFECT_HOME={workdir / '.prefect'} prefect server start" in out
    for name in ("fleet.toml", "mlflow.db", "alerts.jsonl", "telemetry/fleet_truth.json",
                 ".fleet-health-demo"):
        assert (workdir / name).exists(), name


def test_demo_refuses_a_directory_that_is_not_a_demo(tmp_path, capsys):
    (tmp_path / "precious.txt").write_text("keep me")
    status = main(["demo", "--workdir", str(tmp_path)])
    assert status == 2 and "not empty" in capsys.readouterr().err
    assert (tmp_path / "precious.txt").read_text() == "keep me"


def test_demo_replaces_only_its_own_files(tmp_path):
    from flows.demo import MARKER, prepare_workdir

    (tmp_path / MARKER).write_text("")
    (tmp_path / "telemetry").mkdir()
    (tmp_path / "mlflow.db").write_text("old")
    (tmp_path / "notes.txt").write_text("mine")
    prepare_workdir(tmp_path)
    assert not (tmp_path / "telemetry").exists() and not (tmp_path / "mlflow.db").exists()
    assert (tmp_path / "notes.txt").read_text() == "mine"
