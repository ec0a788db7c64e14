"""The drum boiler family (written blind) simulates the physics its docstring sizes the faults
by (the generic family checks are in test_zoo.py)."""
import functools

import numpy as np
import pandas as pd

from benchmarks.zoo.families.drum_boiler import FAMILY

START = pd.Timestamp("2026-03-01", tz="UTC")


@functools.cache
def _day() -> dict[str, pd.DataFrame]:
    """Day 1 of one boiler (seed 11) healthy and with each fault at each magnitude from its
    start: one batch of 9 asset-days, about 15 s (a 1-s loop over the day)."""
    return FAMILY.fault_days(START)


def test_the_loops_hold_the_level_and_the_pressure_and_a_load_step_swells_then_shrinks():
    frame = _day()["healthy"]
    level, pressure = frame["drum_level"], frame["drum_pressure"]
    assert abs(level.median()) < 3.0 and 5.0 < level.std() < 25.0
    assert level.abs().quantile(0.99) < 60.0
    assert (pressure - pressure.median()).abs().quantile(0.99) < 0.5
    # steps up of the steam drawn (over 2.5 t/h within a minute): the level first rises
    # (flashing in the risers: swell), then falls below where it was (shrink)
    steam = frame["steam_flow"].rolling(12).mean().to_numpy()
    rise = np.flatnonzero(steam[12:] - steam[:-12] > 2.5) + 12
    starts = [i for k, i in enumerate(rise) if (k == 0 or i - rise[k - 1] > 60)
              and 24 < i < len(frame) - 100]
    assert len(starts) > 10
    smooth = level.rolling(6, center=True).mean().to_numpy()
    response = np.mean([smooth[i - 12: i + 60] - smooth[i - 12] for i in starts], axis=0)
    assert response[:30].max() > 10.0                   # swell within 2.5 minutes
    assert response[36:].min() < -5.0                    # then shrink, 4-6 minutes after


def test_the_large_faults_change_what_they_should_physically():
    frames = _day()
    healthy = frames["healthy"]

    def change(fault, column):
        return frames[fault][column].mean() - healthy[column].mean()

    # the same process demand (a counterfactual pair): the steam drawn barely moves
    for fault in frames:
        assert abs(change(fault, "steam_flow")) < 0.02, fault
    # water lost from the circuit: fed on top of the steam (t/h)
    assert abs(change("tube_leak/large", "feedwater_flow") - 0.3 * 3.6) < 0.1
    assert abs(change("safety_valve_passing/large", "feedwater_flow") - 0.25 * 3.6) < 0.1
    fuel = healthy["fuel_flow"].mean()
    assert 0.02 < change("safety_valve_passing/large", "fuel_flow") / fuel < 0.04
    # fouling: more gas, a hotter stack and feedwater, the same water
    assert 0.015 < change("fireside_fouling/large", "fuel_flow") / fuel < 0.04
    assert 25.0 < change("fireside_fouling/large", "flue_gas_temp") < 50.0
    assert 0 < change("fireside_fouling/small", "flue_gas_temp") < change(
        "fireside_fouling/large", "flue_gas_temp")
    assert abs(change("fireside_fouling/large", "feedwater_flow")) < 0.05
    # a meter reading 4 % high: the same water, 4 % more of it on the meter
    ratio = frames["feedwater_meter/large"]["feedwater_flow"].sum() / healthy[
        "feedwater_flow"].sum()
    assert abs(ratio - 1.04) < 0.005
    assert abs(change("feedwater_meter/large", "fuel_flow")) / fuel < 0.002
