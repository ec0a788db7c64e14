"""A new baseline leaves out a day that held too little operation to fit and says which, in
the command's result (graybox.calibration.fit_baselines, ``Signature.left_out``). A pump runs
three hours a day at 5 s; on its third baseline day only 4 minutes (a calm day of a wind
turbine, a machine idle most of the day), on its fifth 2 minutes, less than the grid's
``min_duration``. Before, the whole baseline failed on either day."""
from __future__ import annotations

import pandas as pd
import pytest

from plant_telemetry import fit_pump_baseline, pump_days

START = pd.Timestamp("2026-03-01", tz="UTC")
DAYS = 5
SHORT_DAY = 2          # 4 minutes: read, too short to fit
UNREAD_DAY = 4         # 2 minutes: shorter than the grid's min_duration, not read


@pytest.mark.slow
def test_a_day_with_too_little_operation_is_left_out_of_the_baseline_and_named(
        harness, tmp_path, capsys):
    asset = fit_pump_baseline(
        tmp_path, pump_days(START, DAYS, {SHORT_DAY: 240.0, UNREAD_DAY: 120.0}), START, DAYS,
        capsys, "grid = { intermittent = true, min_duration = \"3min\" }")
    assert asset["status"] == "ok"
    assert "(windows 2026-03-01, 2026-03-02, 2026-03-04); " in asset["note"]
    assert ("left out 1 window(s) with too little operation to read (shorter than the grid's "
            "min_duration): 2026-03-05T00:00:00+00:00" in asset["note"])
    assert asset["note"].endswith("left out, too little operation to fit: 2026-03-03 09:00")
