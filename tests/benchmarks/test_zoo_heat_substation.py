"""The district-heating substation (written blind) simulates the physics its docstring sizes
the faults by: the service pipe's plug-flow delay, the loop holding its supply, the faults'
effects (the generic family checks are in test_zoo.py)."""
import functools

import numpy as np
import pandas as pd

from benchmarks.zoo.families.heat_substation import FAMILY, PlugFlow

START = pd.Timestamp("2026-03-01", tz="UTC")


@functools.cache
def _day() -> dict[str, pd.DataFrame]:
    """Day 1 of one substation (seed 11) healthy and with each fault at each magnitude from
    its start: one batch, about 2 s of CPU."""
    return FAMILY.fault_days(START)


def test_the_plug_flow_delays_by_its_volume_over_the_flow_whatever_the_flow_does():
    # two pipes of 60 l: one at a steady 1 l per 5-s step, one at 2 l per step for the first
    # 20 steps and 0.5 l after; a step of the inlet from 70 to 80 C at step 10
    pipe = PlugFlow(np.array([0.060, 0.060]), 200, np.array([70.0, 70.0]))
    flows = np.array([[0.001] * 200, [0.002] * 20 + [0.0005] * 180]).T
    out = np.array([pipe.step(flow, np.full(2, 70.0 if k < 10 else 80.0))
                    for k, flow in enumerate(flows)])
    # the steady pipe: the new water's front leaves 60 steps after it entered (300 s = 60 l
    # at 0.2 l/s)
    expected = np.where(np.arange(200) < 70, 70.0, 80.0)
    np.testing.assert_allclose(out[:, 0], expected, atol=1e-6)
    # the other: the front, 80 l entered, leaves at 140 l (20 l by step 19, 0.5 l a step
    # after: step 99), spread over the 2 l that entered with it (a 5-s step's volume)
    expected = np.r_[np.full(100, 70.0), 72.5, 75.0, 77.5, np.full(97, 80.0)]
    np.testing.assert_allclose(out[:, 1], expected, atol=1e-6)


def test_the_loop_holds_its_supply_and_the_exchanger_obeys_the_second_law():
    frame = _day()["healthy"]
    assert 35.0 < frame["secondary_supply_temp"].median() < 75.0
    assert 5.0 < frame["valve_command"].quantile(0.05) and frame["valve_command"].quantile(0.95) < 99.0
    # counter-flow: the primary return stays above the secondary return (an approach of a
    # few tenths of a kelvin at least, the sensors' noise aside), the supply far above
    approach = frame["primary_return_temp"] - frame["secondary_return_temp"]
    assert approach.quantile(0.01) > 0.0 and 0.3 < approach.median() < 4.0
    assert (frame["primary_supply_temp"] - frame["secondary_supply_temp"]).min() > 15.0
    # the network's quick swings reach the meter (0.7 K, 4-min correlation)
    assert frame["primary_supply_temp"].diff().std() > 0.1


def test_the_faults_change_what_they_should_physically():
    frames = _day()
    healthy = frames["healthy"]

    def change(fault, column):
        return frames[fault][column].mean() - healthy[column].mean()

    def heat(frame):
        return (frame["primary_flow"] * (frame["primary_supply_temp"]
                                         - frame["primary_return_temp"])).sum()

    # fouling: the loop holds the supply; the primary return rises, more flow for the heat
    for size, low, high in (("small", 0.2, 1.2), ("large", 1.8, 4.0)):
        assert abs(change(f"exchanger_fouling/{size}", "secondary_supply_temp")) < 0.05
        assert low < change(f"exchanger_fouling/{size}", "primary_return_temp") < high
    assert frames["exchanger_fouling/large"]["primary_flow"].mean() > 1.04 * healthy[
        "primary_flow"].mean()
    # stiction: the loop hunts, the supply and the flow move more minute to minute
    def wander(frame, column):
        return (frame[column] - frame[column].rolling(40, center=True).mean()).std()
    for column in ("secondary_supply_temp", "primary_flow"):
        assert wander(frames["valve_stiction/large"], column) > 1.3 * wander(healthy, column)
    # the worn pump: a colder building return, less heat delivered
    assert -3.0 < change("pump_wear/large", "secondary_return_temp") < -1.0
    assert 0.85 < heat(frames["pump_wear/large"]) / heat(healthy) < 0.95
    # the meter's supply sensor reads low by exactly m; nothing else changes
    for size, m in (("small", 1.0), ("large", 3.0)):
        biased = frames[f"supply_sensor_bias/{size}"]
        assert abs(change(f"supply_sensor_bias/{size}", "primary_supply_temp") + m) < 0.005
        pd.testing.assert_frame_equal(biased.drop(columns="primary_supply_temp"),
                                      healthy.drop(columns="primary_supply_temp"))
    # the noisy sensor: the logged supply's steps and the valve's chatter
    steps = {name: frames[name]["secondary_supply_temp"].diff().std()
             for name in ("healthy", "sensor_noise/small", "sensor_noise/large")}
    assert steps["healthy"] < 0.2 and 2.5 * steps["healthy"] < steps["sensor_noise/small"]
    assert steps["sensor_noise/large"] > 1.2
    assert frames["sensor_noise/large"]["valve_command"].diff().std() > 5 * healthy[
        "valve_command"].diff().std()
