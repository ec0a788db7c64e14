"""A new baseline says which conditions its nights are judged against: the inputs its days
were driven at differently beyond chance, each with its days' range
(graybox.operating_conditions.covered). A night beyond them is judged by extrapolation, and
its alert says so; the engineer reads the range when the baseline is fitted, not first in an
alert. A pump whose inlet is 3 degC warmer each day than the day before."""
from __future__ import annotations

import pandas as pd
import pytest

from plant_telemetry import fit_pump_baseline, pump_days

START = pd.Timestamp("2026-03-01", tz="UTC")
DAYS = 4


@pytest.mark.slow
def test_a_baseline_names_the_conditions_of_its_days(harness, tmp_path, capsys):
    frame = pump_days(START, DAYS, {}, inlet_offsets=[0.0, 3.0, 6.0, 9.0])
    asset = fit_pump_baseline(tmp_path, frame, START, DAYS, capsys)
    assert asset["status"] == "ok"
    # the first and the warmest day's mean inlet, over the pump's operating samples
    days = frame.groupby(pd.to_datetime(frame["timestamp"]).dt.date)["inlet_temperature"].mean()
    expected = f"inlet_temperature mean {days.iloc[0]:.4g} to {days.iloc[-1]:.4g}"
    # right after the windows it was fitted on
    assert asset["note"].startswith("v1 is the candidate; ")
    assert ("(windows 2026-03-01, 2026-03-02, 2026-03-03, 2026-03-04); its days' conditions: "
            in asset["note"]) and expected in asset["note"]
    assert "(a night beyond them is judged by extrapolation, and its alert says so)" in \
        asset["note"]
