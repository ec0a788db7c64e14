"""The PV inverter family (written blind) simulates the physics its docstring sizes the faults
by (the generic family checks are in test_zoo.py)."""
import functools

import numpy as np
import pandas as pd

from benchmarks.zoo.families.pv_inverter import FAMILY, RATED_KW

START = pd.Timestamp("2026-01-05", tz="UTC")


@functools.cache
def _days() -> dict[str, pd.DataFrame]:
    """Days 1-3 of one site (seed 1001: a highveld roof of 8 strings; two bright days and an
    overcast one) healthy and with each fault at each magnitude from the start of day 1: one
    batch, about 1.5 s."""
    return FAMILY.fault_days(START, 3, seed=1001)


def _day(frame: pd.DataFrame, i: int) -> pd.DataFrame:
    return frame.iloc[i * 1440:(i + 1) * 1440]


def test_the_inverter_is_off_at_night_and_clips_at_its_rating_on_a_bright_day():
    frame = _days()["healthy"]
    hours = frame.index.hour
    night = (hours >= 19) | (hours < 2)                       # UTC: 21-04 h local
    for column in ("dc_power", "ac_power", "dc_voltage"):
        assert (frame.loc[night, column] == 0.0).all(), column
    assert frame.loc[night, "irradiance"].abs().max() <= 6.0
    bright = _day(frame, 0)
    running = bright["ac_power"] > 0.1
    assert 11.0 < running.sum() / 60 < 15.0                    # a summer day's production
    # clipping: the AC holds the rating for more than an hour while the irradiance keeps
    # rising, and the tracker leaves the MPP (the DC voltage rises while clipped)
    clipped = bright["ac_power"] > 0.99 * RATED_KW
    assert clipped.sum() > 60 and bright["ac_power"].max() < 1.01 * RATED_KW
    tracking = running & ~clipped & (bright["irradiance"] > 700)
    voltage = bright["dc_voltage"]
    assert voltage[clipped].median() > voltage[tracking].median() + 20
    # the AC follows the irradiance while not clipped (the plant's efficiency 96-98 %)
    ratio = bright.loc[running & ~clipped, "ac_power"] / bright.loc[running & ~clipped, "dc_power"]
    assert 0.95 < ratio[bright["dc_power"] > 10].median() < 0.985


def test_the_large_faults_change_what_they_should_physically():
    frames = _days()
    healthy = frames["healthy"]

    def energy(name, day):
        return _day(frames[name], day)["ac_power"].sum() / _day(healthy, day)["ac_power"].sum()

    # the same sky and site (a counterfactual pair): only the plant differs
    pd.testing.assert_series_equal(frames["string_outage/large"]["ambient_temp"],
                                   healthy["ambient_temp"])
    # 3 of 8 strings open: the DC power down by 3/8 wherever the inverter does not clip
    unclipped = (healthy["ac_power"] > 1.0) & (healthy["ac_power"] < 40.0)
    share = (frames["string_outage/large"]["dc_power"][unclipped].sum()
             / healthy["dc_power"][unclipped].sum())
    assert abs(share - 5.0 / 8.0) < 0.02
    assert 0.85 < energy("string_outage/small", 0) < 0.95
    # soiling grows over two days: 12 % reached by the third
    assert energy("soiling/large", 2) < energy("soiling/large", 0) < 1.0
    assert 0.85 < energy("soiling/large", 2) < 0.91
    # a dead fan derates the inverter on a bright afternoon; half its air only heats the sink
    bright = _day(healthy, 0)
    assert _day(frames["fan_failure/large"], 0)["heatsink_temp"].max() > 78
    assert energy("fan_failure/large", 0) < 0.85
    hotter = _day(frames["fan_failure/small"], 0)["heatsink_temp"].max()
    assert hotter > bright["heatsink_temp"].max() + 5
    assert energy("fan_failure/small", 0) > 0.995
    # the pyranometer reads 10 % low from a day after its onset; the plant is unchanged
    sensor = frames["irradiance_sensor_drift/large"]
    pd.testing.assert_series_equal(sensor["ac_power"], healthy["ac_power"])
    lit = healthy["irradiance"] > 100
    later = lit & (healthy.index >= START + pd.Timedelta(days=2))
    assert abs(sensor["irradiance"][later].sum() / healthy["irradiance"][later].sum() - 0.9) < 0.005
    assert np.all(frames["irradiance_sensor_drift/small"]["irradiance"][lit]
                  <= healthy["irradiance"][lit] + 2)
