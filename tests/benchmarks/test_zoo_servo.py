"""The lift-cylinder servo family (servo_hydraulic, 10 Hz, written blind) simulates the physics
its docstring sizes the faults by (the generic family checks are in test_zoo.py)."""
import functools

import numpy as np
import pandas as pd

from benchmarks.zoo.families import discover
from benchmarks.zoo.family import AssetPlan

FAMILY = discover()["servo_hydraulic"]
START = pd.Timestamp("2026-03-01", tz="UTC")


@functools.cache
def _day() -> dict[str, pd.DataFrame]:
    """Day 1 of one machine (seed 11) healthy and with each fault, large, from the start of the
    day: one batch (a batch costs about 3 s, and 1-1.5 s per asset-day more)."""
    plans = [AssetPlan("healthy", 11)] + [
        AssetPlan(kind.name, 11, kind, kind.magnitudes[1], START + pd.Timedelta(days=1))
        for kind in FAMILY.faults]
    return FAMILY.simulate(plans, START, 2, first_day=1)


def _running(frame: pd.DataFrame) -> pd.DataFrame:
    return frame[frame["supply_pressure"] > 20.0]


def _following_error(frame: pd.DataFrame) -> float:
    """Mean |command - position| (m) while the command moves."""
    running = _running(frame)
    moving = running["position_command"].diff().abs() > 1e-4
    return float((running["position_command"] - running["position"])[moving].abs().mean())


def test_the_servo_follows_its_command_through_one_shift_and_parks_depressurised():
    frame = _day()["healthy"]
    running = _running(frame)
    hours = len(running) * FAMILY.sample_interval / 3600
    assert 5.0 <= hours <= 9.5
    error = (running["position_command"] - running["position"]).abs()
    assert error.median() < 0.002 and error.quantile(0.95) < 0.03
    assert 0.005 < _following_error(frame) < 0.03           # a P loop lags its ramps
    # the relief holds the supply at 175-187 bar; the load on the cylinder is carried by A
    assert 175.0 < running["supply_pressure"].median() < 187.0
    force = (5.03e-3 * running["pressure_a"] - 3.44e-3 * running["pressure_b"]) * 1e5
    assert 0.7 * 900 * 9.81 < force.median() < 2100 * 9.81
    parked = frame[frame["supply_pressure"] <= 20.0]
    assert parked["pressure_a"].abs().median() < 2.0
    assert (parked["spool_command"] == 0).all()
    # the pump's power warms the oil over the shift
    assert running["oil_temp"].iloc[-1] > parked["oil_temp"].iloc[0] + 10.0


def test_the_large_faults_change_what_the_docstring_says():
    frames = _day()
    healthy = frames["healthy"]
    # a worn valve: slower for the same command, a larger following error
    assert _following_error(frames["valve_wear"]) > 1.2 * _following_error(healthy)
    # a worn pump: the supply sags on the fastest lifts
    assert _running(frames["pump_wear"])["supply_pressure"].min() < 150.0
    assert _running(healthy)["supply_pressure"].min() > 165.0
    # the transducer's offset is on its telemetry only
    offset = frames["pressure_offset"]
    shift = (offset["pressure_a"] - healthy["pressure_a"]).mean()
    assert abs(shift - 10.0) < 0.05
    others = [c for c in FAMILY.channels if c != "pressure_a"]
    # (arrays: pandas compares a 10-Hz day's datetime index a Timestamp at a time, seconds)
    np.testing.assert_array_equal(offset[others].to_numpy(), healthy[others].to_numpy())
    # a leaking piston seal: the loop meters the leak away, the spool works more
    spool = {name: _running(f)["spool_command"].abs().mean() for name, f in frames.items()}
    assert spool["piston_seal_leak"] > 1.05 * spool["healthy"]
    assert np.isclose(_running(frames["piston_seal_leak"])["position"].mean(),
                      _running(healthy)["position"].mean(), atol=0.002)
