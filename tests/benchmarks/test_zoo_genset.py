"""The genset family (written blind) simulates the physics its docstring sizes the faults by
(the generic family checks are in test_zoo.py)."""
import functools

import numpy as np
import pandas as pd

from benchmarks.zoo.families.genset import FAMILY

START = pd.Timestamp("2026-03-01", tz="UTC")


@functools.cache
def _day() -> dict[str, pd.DataFrame]:
    """Day 1 of one set (seed 11) healthy and with each fault at each magnitude from its start:
    one batch, about 3 s."""
    return FAMILY.fault_days(START)


def test_the_governor_holds_the_speed_and_load_steps_move_it():
    frame = _day()["healthy"]
    speed = frame["engine_speed"]
    assert abs(speed.median() - 1500.0) <= 1.0
    assert 0.8 < speed.std() < 3.0                      # the healthy wander, about 1.5 rpm
    assert (abs(speed - 1500.0) > 10.0).mean() < 0.02
    # a motor start of 10-45 kW between two samples dips the speed (and the end of its 3-s
    # inrush lifts it) while the governor recovers in about 3 s: a snapshot catches either
    change = frame["load_kw"].diff().abs()
    step, steady = change > 20.0, change < 2.0
    assert step.sum() > 10
    assert (speed[step] - 1500.0).abs().mean() > 5.0
    assert (speed[steady] - 1500.0).abs().mean() < 2.0
    assert speed[step].min() < 1485.0


def test_the_fuel_follows_the_load_on_a_willans_like_line_and_the_coolant_is_held():
    frame = _day()["healthy"]
    slope, idle = np.polyfit(frame["load_kw"], frame["fuel_rate"], 1)
    assert 0.22 < slope < 0.27 and 3.0 < idle < 15.0
    assert np.corrcoef(frame["load_kw"], frame["fuel_rate"])[0, 1] > 0.97
    assert 250.0 < frame["exhaust_temp"].mean() < 450.0
    # the thermostat holds the coolant in its band whatever the load and the ambient
    assert 82.0 <= frame["coolant_temp"].quantile(0.01) and frame["coolant_temp"].max() <= 95.0


def test_the_large_faults_change_what_they_should_physically():
    frames = _day()
    healthy = frames["healthy"]

    def change(fault, column):
        return frames[fault][column].mean() - healthy[column].mean()

    # the same site load (a counterfactual pair): only the plant differs
    pd.testing.assert_series_equal(frames["injector_fouling/large"]["load_kw"],
                                   healthy["load_kw"])
    fuel_ratio = frames["injector_fouling/large"]["fuel_rate"].sum() / healthy["fuel_rate"].sum()
    assert abs(fuel_ratio - 1.08) < 0.01
    assert 25.0 < change("injector_fouling/large", "exhaust_temp") < 45.0
    assert 35.0 < change("turbo_degradation/large", "exhaust_temp") < 60.0
    assert 0.005 < change("turbo_degradation/large", "fuel_rate") / healthy["fuel_rate"].mean() < 0.04
    assert 1.5 < change("radiator_fouling/large", "coolant_temp") < 6.0
    assert 0 < change("radiator_fouling/small", "coolant_temp") < change("radiator_fouling/large",
                                                                         "coolant_temp")
    for column in ("fuel_rate", "exhaust_temp"):
        pd.testing.assert_series_equal(frames["radiator_fouling/large"][column], healthy[column])
    hunting = frames["governor_hunting/large"]["engine_speed"].std()
    assert hunting > 3 * healthy["engine_speed"].std()
    assert frames["governor_hunting/small"]["engine_speed"].std() > 1.4 * healthy["engine_speed"].std()
