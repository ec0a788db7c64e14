"""A sensor's fault found by the telemetry checks is an alert of its night: the channel, and
how far it went against its limit (known answers on 10-s telemetry)."""
from __future__ import annotations

import numpy as np
import pytest

from graybox.alert import SENSOR, sensor_alert
from graybox.exceptions import TelemetryError
from graybox.severity import SeverityScale
from graybox.telemetry import GridPolicy, validate
from tests.graybox.conftest import raw_frame

NIGHT = dict(vehicle_class="pump", window_start="2026-01-04T00:00:00+00:00",
             window_end="2026-01-05T00:00:00+00:00")


def _error(frame, policy=GridPolicy()) -> TelemetryError:
    with pytest.raises(TelemetryError) as caught:
        validate(frame, "P-1", policy)
    return caught.value


def _speed():
    return 1000 + np.random.default_rng(0).normal(0, 5, 720)


def test_a_stuck_sensor_is_an_alert_of_its_channel_graded_by_how_long_it_held():
    speed = _speed()
    speed[100:190] = speed[100]            # 90 samples of 10 s hold one value: 900 s
    error = _error(raw_frame(speed=speed, flow=_speed()))
    assert (error.kind, error.channel, error.row) == ("stuck_channel", "speed", 100)
    assert error.excess == (900.0, 600.0)  # held 15 min, stuck_after 10 min
    alert = sensor_alert(error, **NIGHT)
    assert (alert.kind, alert.asset_id, alert.channel, alert.tier) == \
        (SENSOR, "P-1", "speed", "stuck_channel")
    assert (alert.zeta, alert.epsilon, alert.ratio, alert.severity) == (900.0, 600.0, 1.5, "minor")
    assert alert.hint() == "sensor speed stuck for 900 s (stuck_after 600 s)"
    assert alert.likely_cause() == "speed sensor stuck"
    assert sensor_alert(error, scale=SeverityScale(1.2, 1.4), **NIGHT).severity == "critical"
    assert alert.key == ("P-1", NIGHT["window_start"], NIGHT["window_end"], "speed",
                         "stuck_channel")


def test_an_impossible_reading_is_an_alert_graded_by_its_distance_from_the_range():
    speed = _speed()
    speed[50] = 1150.0
    error = _error(raw_frame(speed=speed), GridPolicy(ranges={"speed": [900, 1100]}))
    assert (error.kind, error.channel, error.row) == ("out_of_range", "speed", 50)
    assert error.excess == (150.0, 100.0)  # 150 from the range's centre 1000, 100 allowed
    alert = sensor_alert(error, **NIGHT)
    assert (alert.tier, alert.ratio, alert.severity) == ("out_of_range", 1.5, "minor")
    assert alert.hint() == "sensor speed out of range: 150 from its centre, 100 allowed"
    assert alert.likely_cause() == "speed sensor out of range"


def test_a_sensor_without_a_reading_all_night_is_an_alert_of_its_channel():
    # two hours of 10-s rows (720), the flow's readings all missing: a dead sensor
    error = _error(raw_frame(speed=_speed(), flow=np.full(720, np.nan)))
    assert (error.kind, error.channel, error.row) == ("silent_channel", "flow", 0)
    assert error.excess == (7200.0, 240.0)  # 2 h without a reading, max_gap 4 min
    alert = sensor_alert(error, **NIGHT)
    assert (alert.kind, alert.channel, alert.tier, alert.ratio, alert.severity) == \
        (SENSOR, "flow", "silent_channel", 30.0, "critical")
    assert alert.hint() == "sensor flow gave no reading for 7200 s (max_gap 240 s)"
    assert alert.likely_cause() == "flow sensor silent"


def test_the_data_s_faults_are_not_a_sensor_s():
    frame = raw_frame(speed=_speed())
    frame.loc[frame.index[300], "timestamp"] = frame["timestamp"].iloc[299]
    error = _error(frame)
    assert error.kind == "duplicate_timestamp" and error.channel is None
    assert sensor_alert(error, **NIGHT) is None
    assert sensor_alert(TelemetryError("P-1", "schema", "no column 'speed'"), **NIGHT) is None
