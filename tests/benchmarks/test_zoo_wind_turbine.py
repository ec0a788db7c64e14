"""The wind-turbine family (written blind) simulates the physics its docstring sizes the faults
by (the generic family checks are in test_zoo.py)."""
import functools

import numpy as np
import pandas as pd

from benchmarks.zoo.families.wind_turbine import (AREA, CURVE_KW, CURVE_WIND, FAMILY,
                                                  power_coefficient)
from benchmarks.zoo.family import AssetPlan

START = pd.Timestamp("2026-01-05", tz="UTC")
ONSET = START + pd.Timedelta(days=1)
#: seeds of a windy turbine-day (a mean wind near 9 m/s, producing all day)
WINDY = 11


@functools.cache
def _days() -> dict[str, pd.DataFrame]:
    """Days 1-2 of eight healthy turbines and of the windy one with each fault at each
    magnitude from day 1's start: one batch, under a second."""
    plans = [AssetPlan(f"T-{seed}", seed) for seed in range(11, 19)] + [
        AssetPlan(f"{kind.name}/{size}", WINDY, kind, kind.magnitudes[i], ONSET)
        for kind in FAMILY.faults for i, size in enumerate(("small", "large"))]
    return FAMILY.simulate(plans, START, 3, first_day=1)


def _healthy_rows() -> pd.DataFrame:
    frames = _days()
    rows = pd.concat([frames[f"T-{seed}"] for seed in range(11, 19)])
    return rows[rows["production_time"] >= 599.0]


def test_the_surface_peaks_at_the_optimal_tip_speed_ratio():
    ratios = np.linspace(4.0, 12.0, 161)
    cp = power_coefficient(ratios, np.zeros_like(ratios))
    assert abs(ratios[cp.argmax()] - 8.1) < 0.1 and 0.47 < cp.max() < 0.49
    # pitching out sheds power at the ratios above rated wind
    assert (np.diff(power_coefficient(np.full(20, 6.0), np.linspace(0, 25, 20))) < 0).all()
    # the datasheet at 9 m/s: 0.5 rho A Cp U^3 less about 6 % of losses
    shaft = 0.5 * 1.225 * AREA * 0.48 * 1.02 * 9.0 ** 3 / 1000.0
    assert abs(np.interp(9.0, CURVE_WIND, CURVE_KW) / shaft - 0.93) < 0.03


def test_the_power_curve_has_its_regions_and_the_turbine_stops():
    rows = _healthy_rows()
    binned = rows.groupby(pd.cut(rows["wind_speed"], np.arange(3.0, 21.0, 1.0)),
                          observed=True).mean()
    power, speed, pitch = binned["active_power"], binned["generator_speed"], binned["pitch_angle"]
    # region 2: the power rises about as the cube of the wind, the pitch at 0
    low = binned.index.get_loc(pd.Interval(5.0, 6.0))
    high = binned.index.get_loc(pd.Interval(8.0, 9.0))
    cube = power.iloc[high] / power.iloc[low]
    assert 2.5 < cube < 5.0 and (pitch.iloc[:high + 1] < 0.5).all()
    # the speed from its minimum (1020 rpm) to its rated 1800
    assert abs(speed.iloc[0] - 1020.0) < 30.0 and abs(speed.iloc[-1] - 1800.0) < 5.0
    # region 3: rated power (curtailment aside), the pitch rising with the wind
    at_rated = rows[(rows["wind_speed"] > 14.0) & (rows["power_setpoint"] >= 2500.0)]
    assert abs(at_rated["active_power"].median() - 2500.0) < 15.0
    assert pitch.iloc[-1] > 15.0 and (np.diff(pitch.iloc[high:].to_numpy()) > -0.5).all()
    # curtailed rows hold their setpoint
    curtailed = rows[(rows["power_setpoint"] < 2400.0) & (rows["wind_speed"] > 14.0)]
    assert len(curtailed) and (abs(curtailed["active_power"] - curtailed["power_setpoint"])
                               < 0.05 * curtailed["power_setpoint"]).all()
    # stopped rows: feathered, drawing a few kW, below cut-in or stopped for maintenance
    frames = _days()
    every = pd.concat([frames[f"T-{seed}"] for seed in range(11, 19)])
    stopped = every[every["production_time"] == 0.0]
    assert len(stopped) > 10
    assert (stopped["pitch_angle"] == 88.0).all() and (stopped["active_power"] < 0.0).all()


def test_the_temperatures_lag_and_rise_with_the_losses():
    rows = _healthy_rows()
    at_rated = rows[(rows["active_power"] > 2400.0)]
    # the bearing about 12 K over the oil at rated, the winding about 35 K over the nacelle
    assert 9.0 < (at_rated["gearbox_bearing_temp"] - at_rated["gearbox_oil_temp"]).mean() < 15.0
    assert 28.0 < (at_rated["generator_winding_temp"] - at_rated["nacelle_temp"]).mean() < 42.0
    # the oil held by its thermostatic cooler below about 57 C
    assert rows["gearbox_oil_temp"].max() < 58.0
    # the winding follows a step of load with a lag of tens of minutes: the 10-min rows of a
    # turbine-day correlate with the power best a few rows late
    frame = _days()["T-11"]
    lags = [frame["generator_winding_temp"].corr(frame["active_power"].shift(k))
            for k in range(0, 8)]
    assert 1 <= int(np.argmax(lags)) <= 5


def test_the_faults_are_the_sizes_the_docstring_gives():
    frames = _days()
    healthy = frames[f"T-{WINDY}"]
    both = healthy["production_time"] >= 599.0

    def change(fault, column, where=both):
        return (frames[fault][column][where] - healthy[column][where]).mean()

    rated = both & (healthy["active_power"] > 2400.0)
    # the bearing: 3 K (small) and 12 K (large) over the oil at rated
    assert 2.0 < change("bearing_degradation/small", "gearbox_bearing_temp", rated) < 4.0
    assert 9.0 < change("bearing_degradation/large", "gearbox_bearing_temp", rated) < 15.0
    # the generator's fan: +8 K and +21 K at rated
    assert 5.0 < change("generator_fan/small", "generator_winding_temp", rated) < 11.0
    assert 15.0 < change("generator_fan/large", "generator_winding_temp", rated) < 27.0
    # fouling: the power down by m in region 2, none at rated
    region2 = both & (healthy["pitch_angle"] < 0.1) & (healthy["active_power"] < 1500.0)
    for size, m in (("small", 0.03), ("large", 0.08)):
        ratio = (frames[f"blade_fouling/{size}"]["active_power"][region2].sum()
                 / healthy["active_power"][region2].sum())
        assert abs(ratio - (1 - m)) < 0.01
    pitched = both & (healthy["pitch_angle"] > 5.0) & (healthy["power_setpoint"] >= 2500.0)
    assert abs(change("blade_fouling/large", "active_power", pitched)) < 10.0
    # the anemometer: the wind read low by m, the power the same where it produced
    for size, m in (("small", 0.03), ("large", 0.08)):
        faulty = frames[f"anemometer_low/{size}"]
        ratio = faulty["wind_speed"][both].sum() / healthy["wind_speed"][both].sum()
        assert abs(ratio - (1 - m)) < 0.005
    # the same weather (a counterfactual pair): only the plant differs
    pd.testing.assert_series_equal(frames["generator_fan/large"]["wind_speed"],
                                   healthy["wind_speed"])
