"""Known answer: the grid step of a window whose operating rows are scattered is the logger's
(graybox.telemetry.validation.logged_interval_ns). A wind turbine's 10-minute SCADA rows on a
calm day: it produced in three separate rows. Inferred from the running rows alone, the step
came out 40 minutes, and the night could not be compared with its 10-minute baseline."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from graybox.telemetry.gridding import to_grid
from graybox.telemetry.policy import GridPolicy

POLICY = GridPolicy(running={"producing": (599, 601)}, min_duration="10min")


def _day(producing_rows) -> pd.DataFrame:
    index = pd.date_range("2026-03-01", periods=144, freq="10min", tz="UTC")
    producing = np.zeros(144)
    producing[list(producing_rows)] = 600.0
    power = np.where(producing > 0, 900.0, 0.0) + np.arange(144) % 7
    return pd.DataFrame({"timestamp": index, "power": power, "producing": producing})


@pytest.mark.parametrize("rows", [(30, 34, 38), (30, 31, 32, 90, 91, 92, 93)],
                         ids=["three scattered rows", "two short periods"])
def test_a_calm_days_window_is_gridded_at_the_loggers_step(rows):
    window = to_grid(_day(rows), "WT-1", POLICY)
    assert window.sample_interval == 600.0
    assert len(window.frame) == len(rows)


def test_a_machine_that_runs_in_long_periods_keeps_its_step():
    # an intermittent machine whose rows while stopped are sparser (logged on change): the
    # running rows' own step is used, as before
    index = pd.date_range("2026-03-01", periods=120, freq="10s", tz="UTC")
    stopped = pd.date_range("2026-03-01 00:20", periods=6, freq="10min", tz="UTC")
    frame = pd.DataFrame({"timestamp": index, "power": np.arange(120.0), "producing": 600.0})
    idle = pd.DataFrame({"timestamp": stopped, "power": 0.0, "producing": 0.0})
    window = to_grid(pd.concat([frame, idle]).sort_values("timestamp"), "WT-1",
                     GridPolicy(running={"producing": (599, 601)}, min_duration="10min"))
    assert window.sample_interval == 10.0
