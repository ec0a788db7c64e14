"""Intermittent operation and channel roles: a window is its operating periods (segments);
gaps between them are not errors; residuals, differences, delays and calibration pieces
never span a pause; inputs (setpoints) may hold a value, sensors may not."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from graybox.calibration import _split
from graybox.exceptions import InsufficientDataError, TelemetryError
from graybox.signature_fit import FitRequest, fit_signatures
from graybox.models import PumpLoop
from graybox.settings import GrayBoxSettings
from graybox.telemetry import GridPolicy, read_window, to_grid, write_telemetry

T0 = pd.Timestamp("2026-03-01", tz="UTC")
COLUMNS = list(PumpLoop().required_columns)
INPUTS = PumpLoop().input_columns
INTERMITTENT = GridPolicy(intermittent=True)
NATIVE = GrayBoxSettings(analysis_interval="native")


def period(start: pd.Timestamp, seconds: int, rng, level: float = 0.0,
           hold: float = 300.0) -> pd.DataFrame:
    """1-Hz rows of a pump: states AR(1) noise around ``level``, a setpoint holding ``hold``
    seconds at a time and a constant inlet temperature."""
    n = int(seconds)
    states = np.empty((n, 4))
    states[0] = rng.standard_normal(4)
    shocks = rng.standard_normal((n, 4))
    for k in range(1, n):
        states[k] = 0.8 * states[k - 1] + shocks[k]
    frame = pd.DataFrame(states + level, columns=list(PumpLoop.states))
    frame["pdisch_setpoint"] = 5.0 + (np.arange(n) // int(hold)) % 3
    frame["inlet_temperature"] = 18.0
    frame.insert(0, "timestamp", start + pd.to_timedelta(np.arange(n), unit="s"))
    return frame


def day_of_periods(rng, spans=((6, 3600), (13, 3600)), level_step: float = 0.0):
    """Periods starting at the given hours of day 1, each ``level_step`` above the last."""
    return pd.concat([period(T0 + pd.Timedelta(hours=h), s, rng, level=i * level_step)
                      for i, (h, s) in enumerate(spans)], ignore_index=True)


# -- telemetry: periods, pauses, stuck, duration ---------------------------------------------

def test_a_pause_separates_operating_periods_instead_of_failing(tmp_path):
    rng = np.random.default_rng(1)
    write_telemetry(tmp_path, "P-1", day_of_periods(rng))
    # a continuous asset's gap separates the same periods (a logger's outage)
    continuous = read_window(tmp_path, "P-1", COLUMNS, inputs=INPUTS)
    window = read_window(tmp_path, "P-1", COLUMNS, policy=INTERMITTENT, inputs=INPUTS)
    pd.testing.assert_frame_equal(continuous.frame, window.frame)
    assert continuous.n_periods == 2
    assert window.n_periods == 2 and window.n_samples == 7200 and window.filled_samples == 0
    first, second = window.periods()
    assert first.index[0] == T0 + pd.Timedelta(hours=6) and len(first) == 3600
    assert second.index[0] == T0 + pd.Timedelta(hours=13) and len(second) == 3600
    for frame in (first, second):  # each on its own uniform 1-s grid
        assert (np.diff(frame.index.asi8) == 10**9).all()
    assert window.end == T0 + pd.Timedelta(hours=14)


def test_short_gaps_inside_a_period_are_still_filled(tmp_path):
    rng = np.random.default_rng(2)
    frame = day_of_periods(rng).drop(index=range(100, 130))  # 30 s missing in period 1
    window = to_grid(frame, "P-1", INTERMITTENT)
    assert window.n_periods == 2 and window.filled_samples == 30
    assert [len(p) for p in window.periods()] == [3600, 3600]


def test_min_duration_counts_operating_time_only(tmp_path):
    rng = np.random.default_rng(3)
    frame = day_of_periods(rng, spans=((6, 1500), (13, 1500)))  # 50 min over 7.4 h
    with pytest.raises(TelemetryError) as info:
        to_grid(frame, "P-1", INTERMITTENT)
    assert info.value.kind == "too_few_samples" and "50min" in info.value.message
    assert to_grid(frame, "P-1", GridPolicy(intermittent=True, min_duration="45min")
                   ).n_samples == 3000


def test_a_value_held_across_a_pause_is_not_stuck_but_within_a_period_is(tmp_path):
    rng = np.random.default_rng(4)
    frame = day_of_periods(rng)
    # the flow sensor reads 1.5 for the last 6 min before the pause and the first 6 min
    # after it: 12 min of one value, but split by a pause of 5 h 20 min
    frame.loc[3600 - 360:3600 + 359, "flow"] = 1.5
    write_telemetry(tmp_path, "P-1", frame)
    window = read_window(tmp_path, "P-1", COLUMNS, policy=INTERMITTENT, inputs=INPUTS)
    assert window.n_periods == 2
    frame.loc[3600 + 360:3600 + 659, "flow"] = 1.5  # now 11 min inside period 2
    write_telemetry(tmp_path, "P-1", frame)
    with pytest.raises(TelemetryError) as info:
        read_window(tmp_path, "P-1", COLUMNS, policy=INTERMITTENT, inputs=INPUTS)
    error = info.value
    assert error.kind == "stuck_channel" and error.row == 3600
    assert error.file.endswith("part-0.parquet") and "'flow'" in error.message


def test_split_by_day_keeps_the_periods():
    rng = np.random.default_rng(5)
    two_days = pd.concat([day_of_periods(rng),
                          day_of_periods(rng).assign(timestamp=lambda f: f.timestamp
                                                     + pd.Timedelta(days=1))],
                         ignore_index=True)
    days = to_grid(two_days, "P-1", INTERMITTENT).split("1D")
    assert [d.n_periods for d in days] == [2, 2]
    assert [[len(p) for p in d.periods()] for d in days] == [[3600, 3600], [3600, 3600]]


# -- channel roles -----------------------------------------------------------------------------

def test_a_setpoint_input_may_hold_for_ten_minutes_a_stuck_sensor_may_not(tmp_path):
    """A pump's discharge-pressure setpoint (an input) holds 10 minutes at a time and passes;
    the same data with the setpoint read as a sensor, or with a stuck pressure sensor, fails
    naming the channel, file and row. Limits can differ per channel, in time units."""
    rng = np.random.default_rng(6)
    frame = period(T0 + pd.Timedelta(hours=6), 7200, rng, hold=600.0)
    write_telemetry(tmp_path, "P-1", frame)
    read_window(tmp_path, "P-1", COLUMNS, inputs=INPUTS)  # the model's inputs are exempt
    with pytest.raises(TelemetryError) as info:
        read_window(tmp_path, "P-1", COLUMNS)  # every channel read as a sensor
    assert info.value.kind == "stuck_channel" and "'pdisch_setpoint'" in info.value.message
    assert info.value.row == 0 and "10min" in info.value.message

    frame.loc[1000:1599, "pdisch"] = 5.2  # the pressure sensor itself holds 10 minutes
    write_telemetry(tmp_path, "P-1", frame)
    with pytest.raises(TelemetryError) as info:
        read_window(tmp_path, "P-1", COLUMNS, inputs=INPUTS)
    assert info.value.kind == "stuck_channel" and "'pdisch'" in info.value.message
    assert info.value.row == 1000 and info.value.asset_id == "P-1"
    # a slower sensor may be given a longer limit, per channel
    read_window(tmp_path, "P-1", COLUMNS, inputs=INPUTS,
                policy=GridPolicy(stuck_after={"pdisch": "15min"}))


# -- fits: segments ------------------------------------------------------------------------------

def test_the_residual_and_the_tiers_never_span_a_pause():
    """Period 2 restarts 50 units away: a residual across the pause would hold one huge
    value. The fit of the window equals the fit of its periods given as segments, and
    counts one residual sample less per period (the one-step residual drops each period's
    first sample)."""
    rng = np.random.default_rng(7)
    window = to_grid(day_of_periods(rng, level_step=50.0), "P-1", INTERMITTENT)
    model = PumpLoop()
    by_window, by_periods = fit_signatures(
        [FitRequest(model, [window], asset_id="P-1"),
         FitRequest(model, [tuple(window.periods())], asset_id="P-1")], NATIVE)
    assert by_window.to_dict() == by_periods.to_dict()
    for channel in by_window.channels:
        lost = channel.structure.differencing.lost
        assert channel.n_samples == 2 * (3600 - 1 - lost)
        # an AR(1) of 0.8 plus the model's own part: no outlier in the noise
        assert abs(channel.noise.excess_kurtosis) < 0.5
        assert channel.noise.variance < 2.0


def test_a_continuous_window_is_one_period_fitted_as_its_frame():
    rng = np.random.default_rng(8)
    frame = period(T0, 7200, rng)
    window = to_grid(frame, "P-1")
    assert window.n_periods == 1
    a, b = fit_signatures([FitRequest(PumpLoop(), [window], asset_id="P-1"),
                           FitRequest(PumpLoop(), [window.frame], asset_id="P-1")], NATIVE)
    assert a.to_dict() == b.to_dict()


def test_periods_too_short_to_fit_are_left_out_and_none_long_enough_is_an_error():
    rng = np.random.default_rng(9)
    # 460 s (ar_span + delay_span + derivative_span) is the shortest period fitted
    with_blip = to_grid(day_of_periods(rng, spans=((6, 3600), (10, 300), (13, 3600))), "P-1",
                        GridPolicy(intermittent=True))
    without = to_grid(pd.concat([p.reset_index() for i, p in enumerate(with_blip.periods())
                                 if i != 1]), "P-1", INTERMITTENT)
    a, b = fit_signatures([FitRequest(PumpLoop(), [with_blip], asset_id="P-1"),
                           FitRequest(PumpLoop(), [without], asset_id="P-1")], NATIVE)
    assert a.to_dict() == b.to_dict()

    blips = to_grid(day_of_periods(rng, spans=((6, 400), (10, 400), (13, 400))), "P-1",
                    GridPolicy(intermittent=True, min_duration="10min"))
    (error,) = fit_signatures([FitRequest(PumpLoop(), [blips], asset_id="P-1")], NATIVE)
    assert isinstance(error, InsufficientDataError)
    assert "none of its 3 operating periods" in str(error) and "460 s" in str(error)


def test_calibration_pieces_are_cut_from_the_operating_periods():
    rng = np.random.default_rng(10)
    window = to_grid(day_of_periods(rng, spans=((6, 3000), (12, 2000), (15, 300), (18, 2500))),
                     "P-1", INTERMITTENT)
    pieces = _split(window, 8, shortest=460)
    fragments = [f for piece in pieces for f in piece]
    # the 300-s period is left out; every fragment lies inside one period, none is short
    assert sum(len(f) for f in fragments) == 3000 + 2000 + 2500
    assert all(len(f) >= 460 for f in fragments)
    for f in fragments:
        assert (np.diff(f.index.asi8) == 10**9).all()
    assert len(pieces) == 8 and {len(p) for p in pieces} <= {1, 2}
    # fragments tile the kept periods in time order
    starts = [f.index[0] for f in fragments]
    assert starts == sorted(starts)


def test_rows_of_a_stopped_machine_are_pauses_when_running_is_set(tmp_path):
    """The pump writes rows all day; from 07:00 to 13:00 it stands still (speed 0, every
    sensor frozen). Read as data that is a stuck sensor; with ``running`` those rows are
    pauses, and the window is its two operating periods. ``running`` may name a channel
    outside the model (here a ``motor_on`` flag)."""
    rng = np.random.default_rng(11)
    frame = period(T0 + pd.Timedelta(hours=6), 8 * 3600, rng, level=10.0)
    off = (frame.timestamp >= T0 + pd.Timedelta(hours=7)) & \
        (frame.timestamp < T0 + pd.Timedelta(hours=13))
    frame.loc[off, list(PumpLoop.states)] = 0.0
    frame["motor_on"] = np.where(off, 0.0, 1.0)
    write_telemetry(tmp_path, "P-1", frame)
    with pytest.raises(TelemetryError) as info:
        read_window(tmp_path, "P-1", COLUMNS, policy=INTERMITTENT, inputs=INPUTS)
    assert info.value.kind == "stuck_channel" and info.value.row == 3600
    for running in ({"speed": [1.0, 100.0]}, {"motor_on": [0.5, 1.5]}):
        window = read_window(tmp_path, "P-1", COLUMNS, inputs=INPUTS,
                             policy=GridPolicy(intermittent=True, running=running))
        assert [len(p) for p in window.periods()] == [3600, 3600]
        assert list(window.frame.columns) == COLUMNS
        assert window.periods()[1].index[0] == T0 + pd.Timedelta(hours=13)
    # a whole window stopped is a night without data, not an error
    with pytest.raises(TelemetryError) as info:
        read_window(tmp_path, "P-1", COLUMNS, inputs=INPUTS, start=T0 + pd.Timedelta(hours=8),
                    end=T0 + pd.Timedelta(hours=12),
                    policy=GridPolicy(intermittent=True, running={"motor_on": [0.5, 1.5]}))
    assert info.value.kind == "no_data"
    assert GridPolicy(running={"speed": [1.0, 100.0]}).intermittent  # implied
    # a missing running value leaves its row out, as a missing row (whether the pump ran
    # then is unknown), counted; the row is filled like any missed reading
    motor = GridPolicy(intermittent=True, running={"motor_on": [0.5, 1.5]})
    frame.loc[5, "motor_on"] = np.nan
    write_telemetry(tmp_path, "P-1", frame)
    window = read_window(tmp_path, "P-1", COLUMNS, inputs=INPUTS, policy=motor)
    assert [len(p) for p in window.periods()] == [3600, 3600] and window.filled_samples == 1
    assert window.unread == (("motor_on", 1),)
    # silent all day while the pump's sensors read: a dead sensor, not a stopped pump
    frame["motor_on"] = np.nan
    write_telemetry(tmp_path, "P-1", frame)
    with pytest.raises(TelemetryError) as info:
        read_window(tmp_path, "P-1", COLUMNS, inputs=INPUTS, policy=motor)
    assert (info.value.kind, info.value.channel, info.value.row) == ("silent_channel",
                                                                    "motor_on", 0)
    # an Inf is still bad data at its row
    frame["motor_on"] = np.where(off, 0.0, 1.0)
    frame.loc[5, "motor_on"] = np.inf
    write_telemetry(tmp_path, "P-1", frame)
    with pytest.raises(TelemetryError) as info:
        read_window(tmp_path, "P-1", COLUMNS, inputs=INPUTS, policy=motor)
    assert info.value.kind == "non_finite" and info.value.row == 5
