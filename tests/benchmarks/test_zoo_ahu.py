"""The office air-handling unit (written blind) simulates the physics its docstring sizes the
faults by: the white box's known answers, the building's schedule as the product reads it, the
loops holding their setpoints, the faults' effects (the generic family checks are in
test_zoo.py)."""
import functools
import tempfile

import numpy as np
import pandas as pd
import pytest

import graybox as gb
from benchmarks.zoo.families.air_handler import FAMILY, RHO_CP, AirHandlerWhiteBox
from benchmarks.zoo.family import AssetPlan
from graybox.telemetry.writing import write_telemetry

#: a Monday (the family's days count from one)
START = pd.Timestamp("2026-03-02", tz="UTC")
TUESDAY = START + pd.Timedelta(days=1)


@functools.cache
def _frames() -> tuple[dict[str, pd.DataFrame], pd.DataFrame]:
    """Tuesday of one unit (seed 11, a mild day: the economizer at work, the chilled water
    in the afternoon) healthy and with each fault at each magnitude from midnight, and the
    same unit's Saturday and Sunday: one batch, about 1 s of CPU."""
    plans = [AssetPlan("healthy", 11)] + [
        AssetPlan(f"{kind.name}/{size}", 11, kind, kind.magnitudes[i], TUESDAY)
        for kind in FAMILY.faults for i, size in enumerate(("small", "large"))]
    tuesday, weekend = FAMILY.simulate_together(
        [(plans, START, 2, 1), ([AssetPlan("healthy", 11)], START, 7, 5)])
    return tuesday, weekend["healthy"]


def _running(frame: pd.DataFrame) -> pd.DataFrame:
    low, high = FAMILY.grid["running"]["fan_speed"]
    return frame[(frame["fan_speed"] >= low) & (frame["fan_speed"] <= high)]


def test_the_white_box_mixes_by_the_damper_and_follows_the_fan_laws():
    model = AirHandlerWhiteBox()
    p = model.parameters
    # outdoor 10 C, return 22 C, damper 25 %, no preheat, valve 30 %, speed 50 %
    u = np.array([[10.0, 22.0, 25.0, 0.0, 30.0, 50.0]])
    x = np.array([[15.0]])
    mixed, supply, airflow, power = model.output(x, u)[0]
    assert mixed == pytest.approx(19.0) and supply == 15.0
    assert airflow == pytest.approx(p["design_airflow"] / 2)
    assert power == pytest.approx(p["fan_power_full"] / 8)
    # the supply air relaxes toward the mixed air less the coil's cooling plus the fan's heat
    capacity = RHO_CP * airflow
    cooled = 19.0 - 0.3 * p["ua_coil"] * (19.0 - p["chilled_water"]) / capacity + p["fan_heat"]
    assert model.derivatives(x, u)[0, 0] == pytest.approx((cooled - 15.0) / p["lag"])
    # the coil cools the air at most to the chilled water (its conductance capped by the
    # air's own capacity)
    u[0, 4] = 100.0
    target = p["chilled_water"] + p["fan_heat"]
    assert model.derivatives(x, u)[0, 0] == pytest.approx((target - 15.0) / p["lag"])


def test_the_unit_runs_on_the_office_schedule_and_the_product_reads_the_stops_as_pauses():
    frames, weekend = _frames()
    tuesday = frames["healthy"]
    on = _running(tuesday)
    assert 5.3 <= on.index[0].hour + on.index[0].minute / 60 <= 6.7
    assert 18.3 <= on.index[-1].hour + on.index[-1].minute / 60 <= 19.7
    assert len(on) > 0.95 * (on.index[-1] - on.index[0]) / pd.Timedelta(minutes=1)
    # stopped (the drive's ramps aside; the airflow station sees the air coast down for the
    # minute after a stop), the BMS logs zeros
    still = (tuesday["fan_speed"] == 0) & (tuesday["fan_speed"].shift(1) == 0)
    stopped = tuesday[still]
    assert len(stopped) > len(tuesday) - len(on) - 5
    assert (stopped[["supply_airflow", "fan_power", "cooling_valve", "preheat_valve"]]
            == 0).all().all()
    saturday, sunday = (weekend[START + pd.Timedelta(days=d): START + pd.Timedelta(days=d + 1)
                                - pd.Timedelta(seconds=1)] for d in (5, 6))
    assert len(_running(saturday)) == pytest.approx(360, abs=3)   # 7-13 h
    assert (sunday["fan_speed"] == 0).all()
    model = gb.load_model(FAMILY.spec, dict(FAMILY.parameters), dict(FAMILY.columns))
    with tempfile.TemporaryDirectory() as root:
        write_telemetry(root, "AHU-1", weekend)

        def read(day):
            begin = START + pd.Timedelta(days=day)
            return gb.read_window(root, "AHU-1", model.required_columns, begin,
                                  begin + pd.Timedelta(days=1),
                                  policy=gb.GridPolicy(**dict(FAMILY.grid)),
                                  inputs=model.input_columns)

        window = read(5)
        assert window.n_periods == 1 and abs(len(window.frame) - 360) <= 3
        with pytest.raises(gb.GrayBoxError, match=r"did not run.*\[no_data\]"):
            read(6)


def test_the_loops_hold_their_setpoints():
    frame = _running(_frames()[0]["healthy"])
    true = FAMILY.true_parameters(np.random.default_rng([11, 7919]))
    # the fan holds the duct's static pressure (4 Pa of noise, the drive's 1-% steps)
    assert abs(frame["static_pressure"].median() - true["static_setpoint"]) < 5.0
    # the chilled-water valve holds the supply air at the reset setpoint while it modulates
    setpoint = 13.0 + 3.0 * np.clip((20.0 - frame["outdoor_temp"]) / 10.0, 0.0, 1.0)
    modulating = (frame["cooling_valve"] > 5) & (frame["cooling_valve"] < 95)
    assert modulating.sum() > 120
    assert abs((frame["supply_temp"] - setpoint)[modulating].median()) < 0.3
    # the mixed air lies between the outdoor and return air (sensor noise, stratification)
    low = np.minimum(frame["outdoor_temp"], frame["return_temp"]) - 1.0
    high = np.maximum(frame["outdoor_temp"], frame["return_temp"]) + 1.0
    assert ((frame["mixed_temp"] > low) & (frame["mixed_temp"] < high)).all()
    # the economizer opens past the minimum on a mild morning, to full in the afternoon
    assert frame["outdoor_damper"].min() >= true["minimum_air"] - 1
    assert frame["outdoor_damper"].max() == 100.0


def test_the_faults_change_what_they_should_physically():
    frames = {name: _running(frame) for name, frame in _frames()[0].items()}
    healthy = frames["healthy"]

    def change(fault, column):
        return frames[fault][column].mean() - healthy[column].mean()

    def ratio(fault, column):
        return frames[fault][column].mean() / healthy[column].mean()

    # the weather and the zones do not depend on the plant's faults
    for name, frame in frames.items():
        assert frame.index.equals(healthy.index), name
        pd.testing.assert_series_equal(frame["outdoor_temp"], healthy["outdoor_temp"])
    # a fouled coil: the valve opens more for the same supply air (a mild day)
    assert 0.5 < change("coil_fouling/small", "cooling_valve") < 3.0
    assert 3.0 < change("coil_fouling/large", "cooling_valve") < 8.0
    assert abs(change("coil_fouling/large", "supply_temp")) < 0.05
    # a leaking valve cools the air the economizer holds; the preheat opens against it
    assert -0.7 < change("valve_leak/small", "supply_temp") < -0.2
    assert -1.5 < change("valve_leak/large", "supply_temp") < -0.6
    assert change("valve_leak/large", "preheat_valve") > 3.0
    # a biased supply sensor: the log looks held, the valve works harder
    for size, low, high in (("small", 4.0, 12.0), ("large", 20.0, 40.0)):
        assert abs(change(f"supply_sensor_bias/{size}", "supply_temp")) < 0.3
        assert low < change(f"supply_sensor_bias/{size}", "cooling_valve") < high
    # a slipping belt: more speed and power for the same air and pressure
    assert 2.0 < change("belt_slip/small", "fan_speed") < 5.0
    assert 8.0 < change("belt_slip/large", "fan_speed") < 15.0
    for size in ("small", "large"):
        assert abs(ratio(f"belt_slip/{size}", "supply_airflow") - 1.0) < 0.01
        assert ratio(f"belt_slip/{size}", "fan_power") > 1.03
    # a clogged filter: a little more speed, more power
    assert 0.5 < change("filter_clogging/small", "fan_speed") < 2.0
    assert 1.5 < change("filter_clogging/large", "fan_speed") < 5.0
    assert 1.02 < ratio("filter_clogging/small", "fan_power") < ratio(
        "filter_clogging/large", "fan_power") < 1.3
    # a slipped damper linkage: the economizer opens its command further; warmer mixed air
    for size, low in (("small", 1.0), ("large", 5.0)):
        assert change(f"damper_linkage/{size}", "outdoor_damper") > low
        assert change(f"damper_linkage/{size}", "mixed_temp") > 0.1
