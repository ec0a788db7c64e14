"""The two families written blind for issue 18 (cold_room, pump_station) simulate the physics
their docstrings size the faults by (the generic family checks are in test_zoo.py)."""
import functools

import numpy as np
import pandas as pd

from benchmarks.zoo.families import discover

FAMILIES = discover()
START = pd.Timestamp("2026-03-01", tz="UTC")


@functools.cache
def _days(name: str) -> dict[str, pd.DataFrame]:
    """Days 1-2 of one vehicle (seed 11) healthy and with each fault at each magnitude from
    the start of day 1."""
    family = FAMILIES[name]
    return family.fault_days(START, 2)


def test_the_cold_rooms_thermostat_holds_the_room_between_defrosts():
    frame = _days("cold_room")["healthy"]
    quiet = (frame["defrost"] == 0) & (frame["door_open"] == 0)
    assert abs(frame.loc[quiet, "room_temp"].median() - 2.0) < 0.7
    on = frame["compressor_power"] > 0.05
    starts = int((on.astype(int).diff() == 1).sum())
    assert 0.25 < on.mean() < 0.75 and 40 < starts / 2 < 150        # per day


def test_the_cold_rooms_large_capacity_faults_lengthen_the_compressors_run_time():
    frames = _days("cold_room")
    energy = {name: frame["compressor_power"].sum() for name, frame in frames.items()}
    for kind in ("refrigerant_leak", "condenser_fouling", "door_seal"):
        small, large = energy[f"{kind}/small"], energy[f"{kind}/large"]
        assert energy["healthy"] < small < large, kind
        assert large > 1.2 * energy["healthy"], kind          # sized as "worth a visit"


def test_the_pump_stations_fresh_rows_close_the_tanks_mass_balance():
    family = FAMILIES["pump_station"]
    frame = _days("pump_station")["healthy"]
    area = family.true_parameters(np.random.default_rng([11, 7919]))["area"]
    values = frame.to_numpy()
    stale = np.r_[False, (values[1:] == values[:-1]).all(axis=1)]
    assert 0.01 < stale.mean() < 0.3                      # the historian holds some rows
    fresh = ~stale[1:] & ~stale[:-1]
    fresh &= frame.index[1:].normalize() == frame.index[:-1].normalize()   # days apart
    volume = np.diff(frame["tank_level"].to_numpy()) * area              # m^3
    pumped = (frame["pump_flow"] - frame["district_outflow"]).to_numpy()[1:] * 0.25
    error = (volume - pumped)[fresh]
    assert np.median(np.abs(error)) < 5.0
    assert np.corrcoef(volume[fresh], pumped[fresh])[0, 1] > 0.95


def test_the_pump_stations_tank_leak_and_worn_impellers_lengthen_the_pumps_run_time():
    frames = _days("pump_station")
    hours = {name: frame["pumps_running"].sum() * 0.25 for name, frame in frames.items()}
    for kind in ("impeller_wear", "tank_leak"):
        assert hours["healthy"] < hours[f"{kind}/large"], kind
    # the meter reading low: the same water, 8 % less of it on the meter
    healthy, low = frames["healthy"], frames["outflow_meter/large"]
    ratio = low["district_outflow"].sum() / healthy["district_outflow"].sum()
    assert abs(ratio - 0.92) < 0.01
