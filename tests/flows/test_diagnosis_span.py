"""The diagnosis of a candidate of two nights, end to end through the command line
(``[nightly] candidate_nights = 2``, the product's default): two simulated gas turbines at
30 s with the exact white box, baselined on days 1-3 and checked on days 4-5. T-003's speed
sensor reads 1 rad/s high from day 5 on, so the candidate of day 5 spans a healthy night and
a biased one. Its alerts name the speed sensor's bias first, fitted from day 5 on
(``since``), with the one-night estimate, not half of it; the healthy T-001 has no alert.
"""
from __future__ import annotations

import json

import pandas as pd
import pytest

START = pd.Timestamp("2026-01-01", tz="UTC")
BASELINE_DAYS, ONSET, DAYS = 3, 4, 5
ASSETS = ("T-001", "T-003")
BIAS = 1.0


def day(k: int) -> pd.Timestamp:
    return START + pd.Timedelta(days=k)


@pytest.fixture(scope="module")
def run(harness, tmp_path_factory):
    """The fleet baselined and its two nights run with two-night candidates: the run's
    summary and the likely causes of the run table."""
    import sys
    from io import StringIO

    from flows.cli import main
    from flows.demo import write_simulation
    from flows.run_tables import alert_rows
    from flowtest_config import write_config
    from graybox.simulation import Fault, FleetSpec, VehicleSpec
    from registry import Registry

    directory = tmp_path_factory.mktemp("diagnosis-span")
    faults = {"T-003": (Fault("bias", ONSET, BIAS),)}
    spec = FleetSpec(tuple(VehicleSpec(asset, seed=11 + 2 * i, faults=faults.get(asset, ()))
                           for i, asset in enumerate(ASSETS)),
                     days=DAYS, start=f"{START:%Y-%m-%d}", sample_interval=30.0)
    write_simulation(spec, directory / "telemetry")
    config = write_config(directory / "fleet.toml", directory / "telemetry",
                          directory / "mlflow.db", candidate_nights=2)
    saved = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = StringIO(), StringIO()
    try:
        assert main(["--config", str(config), "baseline", "fit", "--class", "turbine",
                     "--start", day(0).isoformat(), "--end", day(BASELINE_DAYS).isoformat(),
                     "--promote", "--reason", "healthy days 1-3", "--json"]) == 0, \
            sys.stderr.getvalue()
        sys.stdout.seek(0), sys.stdout.truncate(0)
        assert main(["--config", str(config), "run", "--as-of", day(DAYS).isoformat(),
                     "--json"]) == 0, sys.stderr.getvalue()
        summary = json.loads(sys.stdout.getvalue())
    finally:
        sys.stdout, sys.stderr = saved
    rows = alert_rows(Registry(f"sqlite:///{directory / 'mlflow.db'}").alerts())
    return summary, rows


@pytest.mark.slow
def test_the_onset_nights_bias_is_fitted_from_the_night_it_began(run):
    summary, rows = run
    alerts = summary["alerts"]
    assert alerts and {a["asset_id"] for a in alerts} == {"T-003"}
    # the candidate of day 5 spans days 4 and 5 (the first night after the baseline spans
    # day 4 alone, healthy: no alert)
    assert {(a["window_start"], a["window_end"]) for a in alerts} == {
        (day(BASELINE_DAYS).isoformat(), day(DAYS).isoformat())}
    for alert in alerts:
        first = alert["diagnosis"][0]
        low, high = first["interval"]
        assert (first["kind"], first["target"]) == ("bias", "omega")
        assert first["since"] == day(ONSET).isoformat()
        assert low < BIAS < high and first["score"] > 0
    causes = {row["asset"]: row["likely cause"] for row in rows}
    assert causes["T-003"].startswith("omega sensor bias 0 -> 1.0")
    assert causes["T-003"].endswith(f"since {day(ONSET).isoformat()}")
