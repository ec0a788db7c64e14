"""A logger's held rows, a plant part at rest and a steady coarse reading are not stuck
sensors; a frozen sensor still is (graybox/telemetry/holds.py, validation._check_stuck)."""
import numpy as np
import pandas as pd
import pytest

from graybox.exceptions import TelemetryError
from graybox.telemetry import GridPolicy, to_grid, validate
from graybox.telemetry.holds import drop_held_rows, held_rows
from graybox.telemetry.rows import Rows

T0 = pd.Timestamp("2026-03-01", tz="UTC")
STEP = 900.0  # a SCADA export every 15 minutes
DAY = 96


def scada_day(seed: int = 0) -> pd.DataFrame:
    """A tank level and a district outflow that move every row, a pump count (an input)."""
    rng = np.random.default_rng(seed)
    k = np.arange(DAY)
    return pd.DataFrame({
        "timestamp": T0 + pd.to_timedelta(k * STEP, unit="s"),
        "level": np.round(4.0 + np.sin(k / 10.0) + rng.normal(0, 0.005, DAY), 2),
        "outflow": np.round(150.0 + 40.0 * np.sin(k / 7.0) + rng.normal(0, 1.5, DAY)) + 0.5,
        "pumps": np.where((k // 12) % 2 == 0, 1.0, 0.0),
    })


def hold(frame: pd.DataFrame, first: int, rows: int) -> pd.DataFrame:
    """The historian repeats row ``first - 1`` over rows ``first .. first + rows - 1``."""
    held = frame.copy()
    channels = [c for c in frame.columns if c != "timestamp"]
    held.loc[first:first + rows - 1, channels] = frame.loc[first - 1, channels].to_numpy()
    return held


def stuck_error(frame: pd.DataFrame, **kwargs) -> TelemetryError:
    with pytest.raises(TelemetryError) as info:
        validate(frame, "A-1", **kwargs)
    assert info.value.kind == "stuck_channel"
    return info.value


def test_rows_repeating_every_moving_channel_are_held_and_dropped():
    frame = hold(scada_day(), 40, 12)   # a 3-hour outage of the link
    rows = Rows.from_frame(frame)
    held = held_rows(rows)
    assert np.flatnonzero(held).tolist() == list(range(40, 52))
    kept = drop_held_rows(rows)
    assert len(kept) == DAY - 12
    assert np.flatnonzero(kept.after_hold).tolist() == [40]   # the first row after the hold
    plain = Rows.from_frame(scada_day())
    assert not held_rows(plain).any() and drop_held_rows(plain) is plain


def test_a_long_hold_splits_the_day_and_a_short_one_is_bridged():
    frame = hold(scada_day(), 40, 12)
    validate(frame, "A-1", inputs=["pumps"])   # 12 equal rows of every channel: not stuck
    window = to_grid(frame, "A-1")
    assert [len(p) for p in window.periods()] == [40, DAY - 52]
    # one held row at 1-minute rows is a missing sample inside max_gap: interpolated
    minute = scada_day().assign(timestamp=T0 + pd.to_timedelta(np.arange(DAY) * 60.0, unit="s"))
    window = to_grid(hold(minute, 30, 1), "A-1")
    assert window.n_periods == 1 and window.filled_samples == 1 and window.n_samples == DAY


def test_one_frozen_sensor_among_moving_ones_is_still_stuck():
    frame = scada_day()
    frame.loc[20:35, "level"] = frame.loc[19, "level"]   # the level alone freezes
    error = stuck_error(frame, inputs=["pumps"])
    assert error.channel == "level" and error.row == 19


def test_a_hold_of_one_moving_channel_and_a_setpoint_is_that_channels():
    frame = scada_day().drop(columns="outflow")
    frame["setpoint"] = 4.0
    frame.loc[20:35, "level"] = frame.loc[19, "level"]   # whole rows repeat, one sensor moves
    assert not held_rows(Rows.from_frame(frame)).any()
    assert stuck_error(frame, inputs=["pumps", "setpoint"]).channel == "level"


def test_a_pump_at_rest_reads_zero_while_the_tank_moves_but_not_when_all_stop():
    frame = scada_day()
    frame["flow"] = np.where(frame["pumps"] > 0, 230.0 + np.arange(DAY) % 7, 0.0)
    validate(frame, "A-1", inputs=["pumps", "outflow"])   # 12 zeros at a time: at rest
    stopped = frame.copy()
    stopped.loc[:, ["level", "flow"]] = 0.0     # every measured channel at 0: a stopped machine
    assert not held_rows(Rows.from_frame(stopped)).any()
    error = stuck_error(stopped, inputs=["pumps", "outflow"])
    assert error.row == 0 and "at 0.0" in error.message


def test_a_closed_valve_whose_meter_reads_its_zero_offset_is_at_rest_but_not_a_sensor_frozen_elsewhere():
    frame = scada_day()
    closed = (np.arange(DAY) >= 40) & (np.arange(DAY) < 56)   # 4 hours, the pumps switch inside
    # the valve's meter reads its leak, 0.01 (not exactly 0), while the tank moves
    frame["flow"] = np.where(closed, 0.01, 5.0 + 0.1 * (np.arange(DAY) % 7))
    validate(frame, "A-1", inputs=["pumps", "outflow"])   # 16 rows at 0.01 of 5.6: at rest
    # the same hold at a quarter of the range is a frozen sensor
    frozen = frame.assign(flow=np.where(closed, 1.4, frame["flow"]))
    assert stuck_error(frozen, inputs=["pumps", "outflow"]).row == 40
    # and a signed reading (a position about 0) is at rest only at exactly 0
    signed = frame.assign(flow=np.where(closed, 0.01, frame["flow"] - 5.3))
    assert stuck_error(signed, inputs=["pumps", "outflow"]).channel == "flow"


def power_day(run: slice) -> pd.DataFrame:
    """A pump's power logged to 0.5 kW: 50.5 kW while the pump runs (rows ``run``), 0 when
    not, a moving level and outflow."""
    frame = scada_day()
    frame["pumps"] = 0.0
    frame.loc[run, "pumps"] = 1.0
    frame["power"] = np.where(frame["pumps"] > 0, 50.5, 0.0)
    return frame


def test_a_steady_coarse_reading_between_the_switching_of_an_input_is_not_stuck():
    frame = power_day(slice(20, 59))            # on for 10 hours at one 0.5-kW step
    validate(frame, "A-1", inputs=["pumps"])
    # the same hold while the pump's switching says nothing (a switch before and after)
    frozen = frame.copy()
    frozen["pumps"] = np.where((np.arange(DAY) >= 10) & (np.arange(DAY) < 70), 1.0, 0.0)
    frozen.loc[:9, "power"] = 0.0
    frozen.loc[10:19, "power"] = 48.0 + np.arange(10)
    frozen.loc[60:69, "power"] = 60.0 + np.arange(10)
    error = stuck_error(frozen, inputs=["pumps"])
    assert error.channel == "power" and error.row == 20


def test_a_coarse_reading_that_moves_by_its_resolution_is_not_stuck():
    rng = np.random.default_rng(1)
    frame = scada_day()
    steps = rng.choice([-0.5, 0.0, 0.0, 0.5], DAY)      # dithers by one 0.5-kW step
    steps[29] = 0.5                                      # a 21-row hold reached by one step
    steps[30:50] = 0.0
    steps[50] = -0.5                                     # and left by one
    frame["power"] = 50.0 + np.cumsum(steps)
    validate(frame, "A-1", inputs=["pumps"])
    steps[29], steps[50] = -3.0, 3.5                     # reached and left by jumps: frozen
    frame["power"] = 50.0 + np.cumsum(steps)
    error = stuck_error(frame, inputs=["pumps"])
    assert error.channel == "power" and error.row == 29
    steps[29] = 0.5                                      # one end by a step is not enough
    frame["power"] = 50.0 + np.cumsum(steps)
    assert stuck_error(frame, inputs=["pumps"]).row == 29


def test_a_coarse_reading_left_by_a_jump_as_an_input_kicks_the_plant_is_not_stuck():
    # a clipping inverter's heat sink: a coarse reading held while the sun wanders by a few
    # W/m2 a row, left by three steps at once as a cloud cuts the sun by 400 W/m2
    rng = np.random.default_rng(1)
    frame = scada_day()
    steps = rng.choice([-0.5, 0.0, 0.0, 0.5], DAY)
    steps[29] = 0.5                                      # a 21-row hold reached by one step
    steps[30:50] = 0.0
    steps[50] = -1.5                                     # and left by three
    frame["power"] = 50.0 + np.cumsum(steps)
    sun = 1000.0 + np.cumsum(rng.normal(0.0, 5.0, DAY))
    frame["sun"] = sun
    assert stuck_error(frame, inputs=["pumps", "sun"]).row == 29     # nothing kicked it
    frame["sun"] = sun - np.where(np.arange(DAY) >= 50, 400.0, 0.0)  # the cloud, then
    validate(frame, "A-1", inputs=["pumps", "sun"])
    # a cloud up to three rows before the reading leaves (the plant's lag) explains it too;
    # ten rows later it says nothing of the hold
    frame["sun"] = sun - np.where(np.arange(DAY) >= 48, 400.0, 0.0)
    validate(frame, "A-1", inputs=["pumps", "sun"])
    frame["sun"] = sun - np.where(np.arange(DAY) >= 60, 400.0, 0.0)
    assert stuck_error(frame, inputs=["pumps", "sun"]).row == 29


def test_a_slow_coarse_reading_that_moves_by_its_resolution_is_not_stuck():
    # a room logged to 0.1 C every 30 s for 5 hours: it changes by one step every 20-40
    # samples (3 % of its steps), each hold 10-20 minutes (stuck_after 10 min)
    rng = np.random.default_rng(2)
    n = 600
    holds = rng.integers(20, 41, size=30)
    at = np.cumsum(holds)[np.cumsum(holds) < n]
    steps = np.zeros(n)
    steps[at] = rng.choice([-0.1, 0.1], size=len(at))
    frame = pd.DataFrame({"timestamp": T0 + pd.to_timedelta(np.arange(n) * 30.0, unit="s"),
                          "level": 4.0 + rng.normal(0, 0.01, n),
                          "room": np.round(20.0 + np.cumsum(steps), 1)})
    assert np.count_nonzero(np.diff(frame["room"])) < 0.1 * (n - 1)
    validate(frame, "A-1")
    # the same reading frozen: reached and left by jumps of half a degree
    steps[at[10]], steps[at[11]] = 0.5, -0.6
    frozen = frame.assign(room=np.round(20.0 + np.cumsum(steps), 1))
    # the first hold a jump ends is the one before the frozen reading
    assert stuck_error(frozen).row == at[9]


def test_an_operating_period_s_edge_explains_the_end_of_a_steady_reading():
    # the link drops for 2 hours while the pump runs: the steady power before the outage ends
    # at the period's edge, the one after it starts there, each explained at its other end
    # by the pump's switching
    frame = hold(power_day(slice(20, 59)), 40, 8)
    validate(frame, "A-1", inputs=["pumps"])
    assert [len(p) for p in to_grid(frame, "A-1").periods()] == [40, DAY - 48]


def test_a_single_held_row_is_bridged_at_any_rate_and_two_are_not():
    # at 15-minute rows a 4-minute max_gap bridges no missing row; one held row is bridged
    # all the same (its neighbours are two samples apart), two held rows split the day
    window = to_grid(hold(scada_day(), 30, 1), "A-1")
    assert window.n_periods == 1 and window.filled_samples == 1 and window.n_samples == DAY
    window = to_grid(hold(scada_day(), 30, 2), "A-1")
    assert [len(p) for p in window.periods()] == [30, DAY - 32]
    intermittent = to_grid(hold(scada_day(), 30, 1), "A-1", GridPolicy(intermittent=True))
    assert intermittent.n_periods == 1


def room_day(resolution: float | None) -> pd.DataFrame:
    """A room's temperature every 30 s with 0.05 C of sensor noise, rounded to
    ``resolution`` (None: logged at full precision), beside a moving supply temperature; the
    room warms from 20.6 to 21.6 C over samples 300 to 350 and stands still after."""
    rng = np.random.default_rng(3)
    n = 2880
    k = np.arange(n)
    room = 20.6 + np.clip((k - 300) / 50.0, 0.0, 1.0) + rng.normal(0.0, 0.05, n)
    if resolution is not None:
        room = np.round(room / resolution) * resolution
    return pd.DataFrame({"timestamp": T0 + pd.to_timedelta(k * 30.0, unit="s"),
                         "room": room,
                         "supply": 35.0 + 5.0 * np.sin(k / 50.0) + rng.normal(0, 0.05, n)})


def test_a_reading_on_a_grid_that_holds_by_chance_where_the_process_stands_still_is_not_stuck():
    # the heat pump of the zoo's seventh blind family: a room logged to 0.1 C holds one
    # value for 10 minutes (20 samples) once in a few hundred days while it stands still,
    # entered and left by readings its neighbours also take (here 21.5 and 21.8)
    frame = room_day(0.1)
    frame.loc[1040:1059, "room"] = 21.6
    frame.loc[1039, "room"], frame.loc[1060, "room"] = 21.5, 21.8
    frame.loc[1020, "room"], frame.loc[1075, "room"] = 21.8, 21.5
    validate(frame, "A-1")
    # the air-handling unit of the eighth: a start-up's jumps elsewhere in the day (here the
    # sensor reading 3 C apart, twenty times in the first hour) do not make a chance hold
    # hours later stuck (the hold is judged on the readings beside it), nor does a process
    # that stood one step above the hold just after it (21.7 to 21.8 after a hold at 21.6)
    started = frame.copy()
    started.loc[20:59:2, "room"] = started.loc[20:59:2, "room"] - 3.0
    started.loc[1061:1079, "room"] = np.where(np.arange(19) % 3 == 0, 21.8, 21.7)
    validate(started, "A-1")
    # the same sensor frozen while the room warms: the hold (20.6 C) is a value the room's
    # later readings have left
    warming = room_day(0.1)
    warming.loc[300:319, "room"] = 20.6
    error = stuck_error(warming)   # from 300, or from 299 where the noise read 20.6 too
    assert error.channel == "room" and error.row == 300 - (warming.loc[299, "room"] == 20.6)
    # logged to 0.01 C its noise spans five steps: 20 equal readings are a frozen sensor
    fine = room_day(0.01)
    fine.loc[1040:1059, "room"] = 21.6
    assert stuck_error(fine).row == 1040
    # at full precision an exact repeat is a frozen sensor even where the room stands still
    precise = room_day(None)
    precise.loc[1040:1059, "room"] = precise.loc[1039, "room"]
    error = stuck_error(precise)
    assert error.channel == "room" and error.row == 1039   # row 1039's reading, held


def test_a_coarse_reading_left_by_one_noisy_sample_two_steps_away_is_not_stuck():
    # the ninth blind family's tyre: a pressure logged to 1 kPa every minute with 0.4 kPa of
    # noise holds 859 for 12 minutes, left by one reading two steps up (861) while the
    # readings after it (861, 860, 859) stay within a step of the hold
    k = np.arange(120)
    rng = np.random.default_rng(4)
    pressure = np.round(858.2 + 0.02 * (k - 60) + rng.normal(0.0, 0.4, k.size))
    pressure[60:72] = 859.0
    pressure[59], pressure[72:75] = 858.0, [861.0, 860.0, 859.0]
    frame = pd.DataFrame({"timestamp": T0 + pd.to_timedelta(k * 60.0, unit="s"),
                          "pressure": pressure,
                          "speed": 80.0 + rng.normal(0.0, 1.0, k.size)})
    validate(frame, "A-1")
    # frozen: the readings after the hold are where the process went, three steps up
    frozen = frame.assign(pressure=np.where(k >= 72, pressure + 3.0, pressure))
    assert stuck_error(frozen).row == 60
