"""The air-to-water heat pump (written blind) simulates the physics its docstring sizes the
faults by: the degree-minute controller's minimum run and off times, the defrost taking heat
from the water, the faults' effects (the generic family checks are in test_zoo.py)."""
import functools

import numpy as np
import pandas as pd

from benchmarks.zoo.families.heat_pump import FAMILY, MIN_OFF, MIN_RUN

START = pd.Timestamp("2026-01-05", tz="UTC")


@functools.cache
def _day() -> dict[str, pd.DataFrame]:
    """Day 1 of one heat pump (seed 11) healthy and with each fault at each magnitude from
    its start: one batch, about 1 s of CPU."""
    return FAMILY.fault_days(START)


def _runs(flags: np.ndarray) -> np.ndarray:
    """The lengths (samples) of the runs of True in ``flags`` that neither start nor end the
    day."""
    edges = np.diff(np.r_[0, flags.astype(np.int8), 0])
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    inside = (starts > 0) & (ends < len(flags))
    return (ends - starts)[inside]


def test_the_controller_cycles_the_compressor_within_its_minimum_run_and_off_times():
    frame = _day()["healthy"]
    power = frame["compressor_power"].to_numpy()
    on = power > 0.0
    # exactly 0 when off (the logger's 0.01 kW with nothing to read); 1-5 kW while it runs
    assert 0.2 < on.mean() < 0.8 and 1.0 < np.median(power[on]) < 5.0
    assert _runs(on).size >= 10
    assert _runs(on).min() >= MIN_RUN / FAMILY.sample_interval
    assert _runs(~on).min() >= MIN_OFF / FAMILY.sample_interval
    # the house holds its setpoint within a kelvin
    assert 20.0 < frame["room_temp"].min() and frame["room_temp"].max() < 22.0


def test_heating_lifts_the_supply_above_the_return_and_a_defrost_takes_heat_from_the_water():
    frame = _day()["healthy"]
    on = frame["compressor_power"] > 0.0
    defrost = frame["defrost"] > 0.0
    lift = frame["supply_temp"] - frame["return_temp"]
    heating = on & ~defrost
    assert 4.0 < lift[heating].median() < 10.0 and abs(lift[~on].median()) < 0.5
    assert defrost.any() and on[defrost].all()          # a defrost runs the compressor
    assert frame["supply_temp"][defrost].mean() < frame["supply_temp"][heating].mean() - 5.0


def test_the_faults_change_what_they_should_physically():
    frames = _day()
    healthy = frames["healthy"]

    def on_share(fault):
        return (frames[fault]["compressor_power"] > 0.0).mean()

    def lift(fault):
        frame = frames[fault]
        heating = (frame["compressor_power"] > 0.0) & (frame["defrost"] == 0.0)
        return (frame["supply_temp"] - frame["return_temp"])[heating].median()

    healthy_on = (healthy["compressor_power"] > 0.0).mean()
    # less heat per run (undercharge, a leaking valve, a weak fan): the compressor runs longer
    for fault in ("refrigerant_undercharge/large", "valve_leak/large", "fan_degradation/large"):
        assert on_share(fault) > 1.1 * healthy_on, fault
    assert on_share("refrigerant_undercharge/large") > on_share("refrigerant_undercharge/small")
    # the weak fan ices the coil faster: more time defrosting
    assert frames["fan_degradation/large"]["defrost"].mean() > 2.0 * healthy["defrost"].mean()
    # less flow: a wider supply-return difference for the same heat
    assert lift("pump_flow_loss/small") > 1.15 * lift("healthy")
    assert lift("pump_flow_loss/large") > 1.5 * lift("healthy")
    # the drifting supply sensor reads low, so the controller heats the water hotter: the
    # return (read true) rises while the supply reading falls
    drift = frames["supply_sensor_drift/large"]
    assert drift["return_temp"].mean() > healthy["return_temp"].mean() + 0.15
    assert drift["supply_temp"].mean() < healthy["supply_temp"].mean()
