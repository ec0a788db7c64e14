"""GridPolicy limits in physical time: the same limits at 1 s, 10 s and 60 s samples."""
from __future__ import annotations

import dataclasses
import datetime

import numpy as np
import pandas as pd
import pytest

from graybox.exceptions import TelemetryError
from graybox.telemetry import GridPolicy, read_window, validate, write_telemetry

T0 = pd.Timestamp("2024-03-01", tz="UTC")
COLUMNS = ["sensor", "setpoint"]


def make_frame(step: float, hours: float = 6.0) -> pd.DataFrame:
    """Rows every ``step`` s: a sensor that never repeats and a setpoint held for an hour."""
    k = np.arange(int(round(hours * 3600 / step)))
    seconds = k * step
    return pd.DataFrame({
        "timestamp": T0 + pd.to_timedelta(seconds, unit="s"),
        "sensor": np.sin(seconds / 300.0) + 1e-6 * seconds,
        "setpoint": 0.5 + 0.1 * (seconds // 3600),
    })


def rows_at(frame: pd.DataFrame, seconds: float) -> int:
    """The row whose timestamp is ``seconds`` after T0."""
    return int(np.flatnonzero(frame["timestamp"] == T0 + pd.Timedelta(seconds=seconds))[0])


def drop_between(frame: pd.DataFrame, after: float, before: float) -> pd.DataFrame:
    """Drop the rows strictly between ``after`` and ``before`` seconds (rows that far apart)."""
    seconds = (frame["timestamp"] - T0).dt.total_seconds()
    return frame[(seconds <= after) | (seconds >= before)].reset_index(drop=True)


def hold(frame: pd.DataFrame, column: str, start: float, duration: float) -> pd.DataFrame:
    """``column`` holds its value at ``start`` for ``duration`` s (samples in [start, +duration))."""
    seconds = (frame["timestamp"] - T0).dt.total_seconds()
    held = (seconds >= start) & (seconds < start + duration)
    frame = frame.copy()
    frame.loc[held, column] = frame.loc[rows_at(frame, start), column]
    return frame


def read(root, frame, **kwargs):
    write_telemetry(root, "A-1", frame)
    return read_window(root, "A-1", COLUMNS, inputs=["setpoint"], **kwargs)


def period_spans(window) -> list[tuple[float, float]]:
    """Each operating period's first and last grid point, in seconds after T0."""
    return [((p.index[0] - T0).total_seconds(), (p.index[-1] - T0).total_seconds())
            for p in window.periods()]


def telemetry_error(kind, root, frame, **kwargs) -> TelemetryError:
    with pytest.raises(TelemetryError) as info:
        read(root, frame, **kwargs)
    assert info.value.kind == kind, str(info.value)
    return info.value


# -- 1 Hz -----------------------------------------------------------------------------------

def test_a_5_second_dropout_at_1hz_is_filled(tmp_path):
    """Rows 5 s apart (a dropout of 4 samples) are bridged under max_gap = "5s", 6 s are not
    (they separate two operating periods); the default (4 minutes) fills either."""
    frame = make_frame(1.0, hours=2)
    five = drop_between(frame, 1000.0, 1005.0)
    window = read(tmp_path, five, policy=GridPolicy(max_gap="5s"))
    assert window.sample_interval == 1.0
    assert window.n_samples == 7200 and window.filled_samples == 4
    np.testing.assert_allclose(window.frame["sensor"].iloc[1001:1005],
                               np.interp([1001, 1002, 1003, 1004], [1000, 1005],
                                         frame["sensor"].iloc[[1000, 1005]]))
    six = drop_between(frame, 1000.0, 1006.0)
    apart = read(tmp_path, six, policy=GridPolicy(max_gap="5s"))
    assert period_spans(apart) == [(0.0, 1000.0), (1006.0, 7199.0)]
    assert apart.filled_samples == 0 and apart.n_samples == 7200 - 5
    assert read(tmp_path, six).filled_samples == 5


def test_a_10_minute_gap_at_1hz_separates_two_operating_periods(tmp_path):
    # a logger's outage is not bad data: the rows on either side are two periods, each on
    # its own grid, nothing interpolated across the 10 minutes
    frame = make_frame(1.0, hours=2)
    window = read(tmp_path, drop_between(frame, 1800.0, 2400.0))
    assert window.n_periods == 2 and window.sample_interval == 1.0
    assert period_spans(window) == [(0.0, 1800.0), (2400.0, 7199.0)]
    assert window.filled_samples == 0 and window.n_samples == 7200 - 599
    np.testing.assert_array_equal(window.periods()[1]["sensor"].to_numpy(),
                                  frame["sensor"].iloc[2400:].to_numpy())


def test_a_held_setpoint_is_fine_a_stuck_sensor_is_not(tmp_path):
    frame = make_frame(1.0, hours=2)
    assert (frame["setpoint"].iloc[:3600] == 0.5).all()  # an input holding for an hour
    read(tmp_path, frame)
    stuck = hold(frame, "sensor", 1200.0, 601.0)  # a state held 10 min 1 s
    error = telemetry_error("stuck_channel", tmp_path, stuck)
    assert error.row == 1200 and "'sensor'" in error.message
    assert "for 601 consecutive samples" in error.message and "stuck_after=10min" in error.message
    # without inputs every column is checked: the setpoint is the first stuck run
    with pytest.raises(TelemetryError) as info:
        read_window(tmp_path, "A-1", COLUMNS)
    assert info.value.kind == "stuck_channel" and info.value.row == 0
    assert "'setpoint'" in info.value.message


def test_a_stuck_message_names_the_channels_own_limit_and_that_limit_reads_it(tmp_path):
    # a fixed-speed pump's power logged to 0.5 kW holds for hours while running: the message
    # gives the line that lets this channel hold, and that line reads the window
    stuck = hold(make_frame(1.0, hours=2), "sensor", 1200.0, 601.0)
    error = telemetry_error("stuck_channel", tmp_path, stuck)
    assert "give it a longer limit in the class's grid" in error.message
    assert 'stuck_after = { sensor = "6h" }' in error.message
    read(tmp_path / "again", stuck, policy=GridPolicy(stuck_after={"sensor": "6h"}))


def test_a_state_stuck_just_under_stuck_after_is_fine(tmp_path):
    frame = hold(make_frame(1.0, hours=2), "sensor", 1200.0, 599.0)
    read(tmp_path, frame)


def test_per_channel_stuck_limits(tmp_path):
    frame = make_frame(1.0, hours=2).assign(pdisch=lambda f: np.cos(f.index / 50.0))
    frame = hold(frame, "pdisch", 600.0, 20 * 60.0)
    policy = GridPolicy(stuck_after={"pdisch": "30min"})
    write_telemetry(tmp_path, "A-1", frame)
    columns = [*COLUMNS, "pdisch"]
    read_window(tmp_path, "A-1", columns, policy=policy, inputs=["setpoint"])
    with pytest.raises(TelemetryError) as info:
        read_window(tmp_path, "A-1", columns, inputs=["setpoint"],
                    policy=GridPolicy(stuck_after={"*": "1h", "pdisch": "15min"}))
    assert "'pdisch'" in info.value.message and info.value.row == 600


# -- the same limits at every rate ------------------------------------------------------------

RATES = [1.0, 10.0, 60.0]


@pytest.mark.parametrize("step", RATES)
def test_a_few_missing_samples_are_filled_at_every_rate(tmp_path, step):
    frame = drop_between(make_frame(step), 3600.0, 3600.0 + 240.0)  # rows 4 min apart
    window = read(tmp_path, frame)
    assert window.sample_interval == step
    assert window.filled_samples == 240 / step - 1
    assert window.n_samples == 6 * 3600 / step


@pytest.mark.parametrize("step", RATES)
def test_a_10_minute_gap_separates_two_periods_at_every_rate(tmp_path, step):
    frame = make_frame(step)
    end = 6 * 3600.0 - step
    window = read(tmp_path, drop_between(frame, 3600.0, 4200.0))
    assert period_spans(window) == [(0.0, 3600.0), (4200.0, end)]
    # just over max_gap (one interval more) separates them too, max_gap itself is bridged
    over = read(tmp_path, drop_between(frame, 3600.0, 3600.0 + 240.0 + step))
    assert period_spans(over) == [(0.0, 3600.0), (3840.0 + step, end)]
    assert read(tmp_path, drop_between(frame, 3600.0, 3600.0 + 240.0)).n_periods == 1


@pytest.mark.parametrize("step", RATES)
def test_stuck_after_is_the_same_time_at_every_rate(tmp_path, step):
    frame = make_frame(step)
    read(tmp_path, hold(frame, "sensor", 1800.0, 600.0 - step))  # 10 min minus one sample
    error = telemetry_error("stuck_channel", tmp_path, hold(frame, "sensor", 1800.0, 600.0))
    assert error.row == rows_at(frame, 1800.0)
    assert f"for {int(600 / step)} consecutive samples (10min" in error.message
    # a setpoint held for hours is never stuck
    read(tmp_path, hold(frame, "setpoint", 0.0, 5 * 3600.0))


@pytest.mark.parametrize("step", RATES)
def test_min_duration_is_the_same_time_at_every_rate(tmp_path, step):
    frame = make_frame(step)
    one_hour = frame[frame["timestamp"] < T0 + pd.Timedelta(hours=1)]
    assert read(tmp_path, one_hour).n_samples == 3600 / step
    error = telemetry_error("too_few_samples", tmp_path, one_hour.iloc[:-1])
    assert error.row is None and "min_duration=1h" in error.message


@pytest.mark.parametrize("step", RATES)
def test_jitter_below_half_an_interval_is_no_gap_and_no_fill(tmp_path, step):
    frame = make_frame(step, hours=2)
    rng = np.random.default_rng(int(step))
    # two rows' jitter adds up: below half an interval in all, a step still rounds right
    jitter = rng.uniform(-0.2, 0.2, len(frame)) * step
    jitter[[0, -1]] = 0.0
    frame["timestamp"] += pd.to_timedelta(jitter, unit="s")
    # rows 4 min apart give or take the jitter: still bridged
    first = int(3600 / step)
    frame = frame.drop(index=range(first + 1, first + int(240 / step))).reset_index(drop=True)
    window = read(tmp_path, frame, policy=GridPolicy(sample_interval=step))
    assert window.n_samples == 2 * 3600 / step
    assert window.filled_samples == 240 / step - 1
    assert read(tmp_path, make_frame(step, hours=2)).filled_samples == 0


# -- the policy -------------------------------------------------------------------------------

def test_durations_as_seconds_strings_or_timedeltas():
    policy = GridPolicy(sample_interval="10s", max_gap="40s", stuck_after="10min",
                        min_duration="2h")
    assert policy == GridPolicy(sample_interval=10, max_gap=40.0, stuck_after=600,
                                min_duration=pd.Timedelta(hours=2))
    assert policy == GridPolicy(10.0, datetime.timedelta(seconds=40), 600.0, 7200.0)
    assert (policy.max_gap, policy.stuck_after, policy.min_duration) == (40.0, 600.0, 7200.0)
    assert len({policy, GridPolicy(sample_interval=10.0, max_gap=40, min_duration="2h")}) == 1
    with pytest.raises(dataclasses.FrozenInstanceError):
        policy.max_gap = 5.0


def test_the_defaults():
    policy = GridPolicy()
    assert policy.sample_interval is None
    assert (policy.max_gap, policy.stuck_after, policy.min_duration) == (240.0, 600.0, 3600.0)


def test_per_channel_limits_are_hashable_and_survive_replace():
    policy = GridPolicy(stuck_after={"pdisch": "30min", "flow": 0})
    assert policy.stuck_limit("pdisch") == 1800.0
    assert policy.stuck_limit("flow") == 0.0
    assert policy.stuck_limit("other") == 600.0  # the default for channels not listed
    assert GridPolicy(stuck_after={"*": "1h"}).stuck_limit("other") == 3600.0
    again = dataclasses.replace(policy, sample_interval=1.0)
    assert again.stuck_after == policy.stuck_after and hash(again)
    assert GridPolicy(stuck_after={"flow": 0, "pdisch": 1800}) == policy


@pytest.mark.parametrize("kwargs", [{"max_fill": 3}, {"stuck_samples": 60}, {"min_samples": 500}])
def test_old_sample_count_fields_are_gone(kwargs):
    with pytest.raises(TypeError):
        GridPolicy(**kwargs)


def test_max_gap_shorter_than_the_interval_fills_nothing(tmp_path):
    frame = make_frame(60.0)
    validate(frame, "A-1", GridPolicy(max_gap="5s"), inputs=["setpoint"])
    # one missing sample at 60 s: two periods, not one filled sample
    window = read(tmp_path, drop_between(frame, 3600.0, 3720.0), policy=GridPolicy(max_gap="5s"))
    assert period_spans(window) == [(0.0, 3600.0), (3720.0, 6 * 3600.0 - 60.0)]
    assert window.filled_samples == 0


def test_validate_takes_inputs_too():
    frame = make_frame(10.0)
    validate(frame, "A-1", inputs=["setpoint"])
    with pytest.raises(TelemetryError, match="'setpoint'"):
        validate(frame, "A-1")


@pytest.mark.parametrize("seed", [3, 4])
def test_limits_hold_when_the_inferred_interval_is_a_little_off(tmp_path, seed):
    """A logger whose clock runs 1 % slow (a step of 1.01 s, jittered); limits count in
    rounded intervals, so a dropout of rows 4 steps apart is still within max_gap = "4s" and
    5 steps apart is not."""
    frame = make_frame(1.0, hours=2)
    rng = np.random.default_rng(seed)
    jitter = rng.uniform(-0.2, 0.2, len(frame))
    jitter[[0, -1]] = 0.0
    frame["timestamp"] = T0 + pd.to_timedelta(np.arange(len(frame)) * 1.01 + jitter, unit="s")
    first = 3600
    four = frame.drop(index=range(first + 1, first + 4)).reset_index(drop=True)
    window = read(tmp_path, four, policy=GridPolicy(max_gap="4s"))
    assert window.sample_interval == 1.01
    assert window.n_periods == 1
    five = frame.drop(index=range(first + 1, first + 5)).reset_index(drop=True)
    apart = read(tmp_path, five, policy=GridPolicy(max_gap="4s"))
    assert apart.n_periods == 2 and len(apart.periods()[0]) == first + 1


def test_a_logger_slower_than_a_minute_needs_ten_equal_samples_for_a_stuck_sensor(tmp_path):
    # a 0.1-degree reading every 5 minutes holds for two samples (10 min) as a matter of
    # course: as at 1-minute samples, ten equal readings are the evidence of a stuck sensor
    frame = make_frame(300.0, hours=12)
    read(tmp_path, hold(frame, "sensor", 3600.0, 9 * 300.0))      # 9 samples, 45 min: fine
    error = telemetry_error("stuck_channel", tmp_path, hold(frame, "sensor", 3600.0, 3000.0))
    assert error.row == rows_at(frame, 3600.0)
    assert ("for 10 consecutive samples (50min; stuck_after=10min, and at least 10 samples)"
            in error.message)
    assert (error.channel, error.excess) == ("sensor", (3000.0, 3000.0))


@pytest.mark.parametrize("step", [1.0, 60.0, 300.0])
def test_a_jittering_logger_with_missing_rows_gives_every_day_its_nominal_step(tmp_path, step):
    # timestamps ±20 % of a step off, 2 % of the rows missing: the median step was 1.003 s
    # one day and 1.004 s the next, and days gridded at different steps cannot be fitted
    # together
    frame = make_frame(step, hours=24)
    rng = np.random.default_rng(int(step))
    kept = frame[rng.random(len(frame)) >= 0.02].reset_index(drop=True)
    kept["timestamp"] += pd.to_timedelta(rng.uniform(-0.2, 0.2, len(kept)) * step, unit="s")
    kept["timestamp"] = kept["timestamp"].dt.round("ms")
    for hours in ((0, 8), (8, 16), (16, 24)):
        part = kept[(kept["timestamp"] >= T0 + pd.Timedelta(hours=hours[0]))
                    & (kept["timestamp"] < T0 + pd.Timedelta(hours=hours[1]))]
        write_telemetry(tmp_path, "A-1", part.reset_index(drop=True))
        window = read_window(tmp_path, "A-1", COLUMNS, inputs=["setpoint"],
                             policy=GridPolicy(max_gap=f"{4 * step}s", min_duration="1h"))
        assert window.sample_interval == step
