"""Plausible values per channel: configured ranges and the default spread check."""
from __future__ import annotations

import numpy as np
import pytest

from graybox.exceptions import TelemetryError
from graybox.telemetry import GridPolicy, validate
from tests.graybox.conftest import raw_frame


RNG = np.random.default_rng(0)
SPEED = 1000 + RNG.normal(0, 5, 720)


def test_healthy_channels_pass():
    step = np.where(np.arange(720) < 700, 100.0, 120.0)     # a setpoint step, 3 % of samples
    validate(raw_frame(speed=SPEED, setpoint=step), "A-1", GridPolicy(stuck_after=0))


def test_fault_huge_sample_is_out_of_range_at_its_row():
    speed = SPEED.copy()
    speed[321] = 1e10
    with pytest.raises(TelemetryError) as caught:
        validate(raw_frame(speed=speed), "A-1")
    error = caught.value
    assert (error.kind, error.file, error.row, error.asset_id) == \
        ("out_of_range", "/t/part-0.parquet", 321, "A-1")
    assert "1e+10" in str(error) or "10000000000.0" in str(error)


def test_a_channel_at_rest_most_of_the_day_is_judged_by_how_far_it_moves():
    # a lift on a quiet day: its speed 0 at 98.3 % of the samples, the rest trips up and
    # down at up to 1.6 m/s, fewer than 1 % each way: the 1st and 99th percentiles are 0
    # and a creeping 1 mm/s
    speed = np.zeros(36000)
    trips = np.arange(36000) % 600 < 10                     # 600 samples of travel
    trip = np.r_[np.linspace(0.001, 1.6, 5), np.linspace(1.6, 0.001, 5)]
    speed[trips] = np.concatenate([trip * (1 if k % 2 else -1) for k in range(60)])
    assert np.ptp(np.percentile(speed, [1, 99])) <= 0.01
    assert 0.98 <= (speed == 0).mean() < 0.99
    validate(raw_frame(speed=speed), "A-1", GridPolicy(stuck_after=0))
    speed[1234] = 1e6                                       # a corrupt sample still is not
    with pytest.raises(TelemetryError, match="implausibly far") as caught:
        validate(raw_frame(speed=speed), "A-1", GridPolicy(stuck_after=0))
    assert caught.value.row == 1234


def test_fault_value_outside_the_configured_range():
    speed = SPEED.copy()
    speed[50] = 1100.0                                      # plausible by spread, not by range
    policy = GridPolicy(ranges={"speed": [900, 1090]})
    with pytest.raises(TelemetryError, match=r"outside its range \[900, 1090\]") as caught:
        validate(raw_frame(speed=speed), "A-1", policy)
    assert caught.value.row == 50
    validate(raw_frame(speed=speed), "A-1", GridPolicy())         # the default spread accepts it


def test_spread_check_off_and_bad_ranges():
    speed = SPEED.copy()
    speed[321] = 1e10
    validate(raw_frame(speed=speed), "A-1", GridPolicy(plausible_spread=0))
    for ranges in ({"speed": [2, 1]}, {"speed": [0]}, {"speed": [0, float("inf")]}):
        with pytest.raises(ValueError, match="ranges"):
            GridPolicy(ranges=ranges)
    with pytest.raises(ValueError, match="plausible_spread"):
        GridPolicy(plausible_spread=-1)
    assert GridPolicy(ranges={"b": [0, 1], "a": (2, 3)}).ranges == (("a", 2.0, 3.0),
                                                                   ("b", 0.0, 1.0))
