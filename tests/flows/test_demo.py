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


def test_verdicts_name_the_night_a_multi_night_window_is_for():
    from flows.demo import verdicts
    from graybox.simulation import Fault, FleetSpec, VehicleSpec
    from graybox.alert import Alert

    spec = FleetSpec((VehicleSpec("T-001", seed=1),
                      VehicleSpec("T-002", seed=2, faults=(Fault("friction", 6.5, 0.5),))),
                     days=9, sample_interval=10.0, start="2026-01-01")

    def alert(asset, start, end):
        return Alert(asset_id=asset, vehicle_class="turbine", window_start=f"{start}T00:00:00+00:00",
                     window_end=f"{end}T00:00:00+00:00", channel="omega", tier="noise",
                     zeta=2.0, epsilon=1.0, ratio=2.0, severity="major")

    # two-night candidates of the nights 01-07 and 01-08 (onset 01-07 12:00)
    alerts = [alert("T-002", "2026-01-06", "2026-01-08"), alert("T-002", "2026-01-07", "2026-01-09")]
    healthy, faulty = verdicts(spec, alerts)
    assert (healthy.alert_nights, healthy.verdict, healthy.ok) == ([], "quiet", True)
    assert faulty.alert_nights == ["2026-01-07", "2026-01-08"]
    assert faulty.ok and faulty.verdict == "detected: first alert in the window ending 12 h after onset"
    # a window that ends before the onset is an alert before it, whatever its start
    early, = verdicts(spec, [alert("T-002", "2026-01-05", "2026-01-07")])[1:]
    assert not early.ok and early.alert_nights == ["2026-01-06"]
