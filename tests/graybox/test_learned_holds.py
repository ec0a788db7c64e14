"""Known answers: a coarse reading of a steady plant (a 1-kPa tyre pressure on the highway)
holds one value for longer than ``stuck_after`` with nothing in the plant to explain it. A
new baseline reads such holds (``read_window(..., holds=True)``), records the longest per
channel (``TelemetryWindow.holds``, ``Signature.holds``), and its candidates may hold twice
as long (:meth:`GridPolicy.with_holds`); a sensor frozen for longer is still stuck."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import graybox as gb
from graybox.record_json import from_dict, to_dict
from graybox.signature import Signature
from graybox.signature_fit import holds_over
from graybox.telemetry.policy import HOLD_CAP, HOLD_FACTOR
from graybox.telemetry.writing import write_telemetry
from conftest import make_signature

START = pd.Timestamp("2026-03-01", tz="UTC")


def _day(holds: list[int], seed: int, day: int = 0) -> pd.DataFrame:
    """A day at 60 s of a pressure on a 2-kPa grid that moves by 2 or 4 kPa a sample (its
    noise spans steps, so an exact repeat is not chance) but for holds of the given lengths
    (samples), each left by 6 kPa; and a speed at full precision, which never repeats."""
    rng = np.random.default_rng(seed)
    values, level = [], 850.0

    def wander(count):
        nonlocal level
        for _ in range(count):
            step = rng.choice([2.0, 4.0])
            level += step if level < 850.0 - rng.uniform(-15.0, 15.0) else -step
            values.append(level)

    for hold in holds:
        wander(30)
        level += 6.0 if level < 850.0 else -6.0
        values.extend([level] * hold)
    wander(1440 - len(values))
    index = pd.date_range(START + pd.Timedelta(days=day), periods=1440, freq="60s",
                          name="timestamp")
    return pd.DataFrame({"pressure": values, "speed": 20.0 + rng.normal(0.0, 1.0, 1440)},
                        index=index)


def _read(root, day: int, policy: gb.GridPolicy, **kwargs) -> gb.TelemetryWindow:
    begin = START + pd.Timedelta(days=day)
    return gb.read_window(root, "TRUCK-1", ["pressure", "speed"], begin,
                          begin + pd.Timedelta(days=1), policy=policy, **kwargs)


def test_a_baseline_reads_and_records_the_holds_its_candidates_then_allow(tmp_path):
    write_telemetry(tmp_path, "TRUCK-1", pd.concat([
        _day([15, 25, 18], seed=1, day=0), _day([45], seed=2, day=1),
        _day([120], seed=3, day=2), _day([4, 4], seed=4, day=3)]))
    policy = gb.GridPolicy()
    # with the default limit a 15-minute hold is a stuck sensor
    with pytest.raises(gb.GrayBoxError, match=r"'pressure' stuck at .* for 15 consecutive"):
        _read(tmp_path, 0, policy)
    baseline = _read(tmp_path, 0, policy, holds=True)
    assert baseline.holds == (("pressure", 25 * 60.0),)      # the longest, 25 minutes
    assert _read(tmp_path, 0, policy.for_baseline()).holds == ()   # found only when asked
    # holds of 4 samples are not learned (twice 4 stays under the 10 samples a hold needs)
    assert _read(tmp_path, 3, policy, holds=True).holds == ()

    learned = policy.with_holds(dict(baseline.holds))
    assert learned.stuck_limit("pressure") == HOLD_FACTOR * 25 * 60.0 == 3000.0
    assert learned.stuck_limit("speed") == 600.0
    assert _read(tmp_path, 1, learned).frame["pressure"].notna().all()   # 45 minutes: read
    with pytest.raises(gb.GrayBoxError, match=r"'pressure' stuck at .* for 120 consecutive "
                                              r"samples \(2h; stuck_after=50min\)"):
        _read(tmp_path, 2, learned)


def test_learned_limits_only_widen_up_to_the_cap_and_keep_a_channel_off():
    policy = gb.GridPolicy(stuck_after={"pressure": "20min", "temperature": 0})
    assert policy.with_holds(None) is policy and policy.with_holds({}) is policy
    assert policy.with_holds({"pressure": 300.0}) is policy          # 10 min < its 20
    widened = policy.with_holds({"pressure": 1800.0, "speed": 20 * 3600.0,
                                 "temperature": 3600.0})
    assert widened.stuck_limit("pressure") == 3600.0
    assert widened.stuck_limit("speed") == HOLD_CAP                  # capped at 6 h
    assert widened.stuck_limit("temperature") == 0                   # still not checked
    assert widened.stuck_limit("other") == 600.0
    baseline = policy.for_baseline()
    assert (baseline.stuck_limit("pressure"), baseline.stuck_limit("other"),
            baseline.stuck_limit("temperature")) == (HOLD_CAP, HOLD_CAP, 0)


def test_a_signature_keeps_the_longest_hold_of_its_windows_through_json():
    index = pd.date_range(START, periods=3, freq="60s", name="timestamp")
    windows = [gb.TelemetryWindow("T-001", pd.DataFrame({"omega": [1.0, 2.0, 3.0]}, index),
                                  60.0, 0, (), holds=holds)
               for holds in [(("omega", 600.0),), (("omega", 900.0), ("theta", 300.0)), ()]]
    holds = holds_over(windows + [windows[0].frame])
    assert dict(holds) == {"omega": 900.0, "theta": 300.0}
    assert holds_over(windows[2:]) is None
    signature = make_signature(holds=holds)
    assert to_dict(signature)["holds"] == {"omega": 900.0, "theta": 300.0}
    assert from_dict(Signature, to_dict(signature)) == signature
    assert "holds" not in to_dict(make_signature())          # stored as before without them
    assert "Longest holds" in signature.summary() and "omega 900 s, theta 300 s" in signature.summary()


def test_a_hold_longer_than_the_cap_fails_a_baseline_and_the_message_suggests_more(tmp_path):
    write_telemetry(tmp_path, "TRUCK-1", _day([7 * 60], seed=5))
    with pytest.raises(gb.GrayBoxError, match=r"for 420 consecutive samples \(7h; "
                                              r"stuck_after=6h\).*pressure = \"14h\""):
        _read(tmp_path, 0, gb.GridPolicy(), holds=True)


def test_only_holds_that_could_widen_the_limit_are_sought():
    """At 1 s ``stuck_after`` (10 minutes) needs 600 samples: a hold is learned from 300 on
    (twice it reaches the limit), so the many short runs of a coarse 1-Hz reading are not
    judged one by one (a second of CPU per day when they were)."""
    from graybox.telemetry.rows import Rows
    from graybox.telemetry.validation import longest_holds

    index = pd.date_range(START, periods=3600, freq="1s", name="timestamp")

    def holds_with_one_of(samples: int):
        values = 850.0 + np.tile(np.repeat([0.0, 3.0], 20), 90)    # holds of 20 samples
        values[1000:1000 + samples] = 900.0                        # one more, left by 50
        rows = Rows.from_frame(pd.DataFrame({"pressure": values}, index=index).reset_index())
        return longest_holds(rows, gb.GridPolicy(), 10 ** 9)

    assert holds_with_one_of(400) == (("pressure", 400.0),)
    assert holds_with_one_of(299) == ()
    assert holds_with_one_of(300) == (("pressure", 300.0),)


def test_a_hold_an_inputs_kick_explains_at_night_is_still_learned_by_a_baseline():
    """A reading held 400 samples, reached by one step and left by 50 as an input (wandering
    by 1 a sample) steps by 30: the night's check takes the kick for the plant's, and a
    baseline still
    learns the hold as how long the reading holds on this plant (so that its limits are
    those it learned before kicks counted)."""
    from graybox.telemetry.rows import Rows
    from graybox.telemetry.validation import longest_holds, validate

    index = pd.date_range(START, periods=3600, freq="1s", name="timestamp")
    values = 850.0 + np.tile(np.repeat([0.0, 3.0], 20), 90)
    values[990:1000] = 897.0
    values[1000:1400] = 900.0
    drive = 50.0 + np.cumsum(np.random.default_rng(3).choice([-1.0, 1.0], 3600))
    drive[1400:] += 30.0
    frame = pd.DataFrame({"pressure": values, "drive": drive}, index=index).reset_index()
    rows = Rows.from_frame(frame)
    assert longest_holds(rows, gb.GridPolicy(), 10 ** 9, inputs=("drive",)) == (
        ("pressure", 400.0),)
    validate(frame, "A-1", gb.GridPolicy(stuck_after="5min"), inputs=("drive",))
    frame["drive"] = drive - np.where(np.arange(3600) >= 1400, 30.0, 0.0)   # no kick
    with pytest.raises(gb.TelemetryError, match="stuck"):
        validate(frame, "A-1", gb.GridPolicy(stuck_after="5min"), inputs=("drive",))


def test_readings_on_a_grid_share_their_longest_hold(tmp_path):
    """A truck on the highway holds every coarse reading at once: the day's longest hold of
    one tyre's pressure is what its other coarse readings may hold too; the speed, logged at
    full precision, never repeats by chance and learns nothing."""
    day = _day([25], seed=1)
    other = _day([4], seed=2)["pressure"].to_numpy()               # never holds 5 samples
    day.insert(1, "pressure_rear", other)
    write_telemetry(tmp_path, "TRUCK-1", day)
    window = gb.read_window(tmp_path, "TRUCK-1", ["pressure", "pressure_rear", "speed"],
                            START, START + pd.Timedelta(days=1), holds=True)
    assert window.holds == (("pressure", 1500.0), ("pressure_rear", 1500.0))
