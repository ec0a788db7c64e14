"""The 10-s output of the fleet simulator is pinned to the numbers it gave before it became
rate-invariant (commit 2a9ddb0), so every test and the published 10-s benchmark stay valid.

The numbers in ``data/simulator_reference.json`` were printed by that commit's
``graybox/simulation/`` for the fleet :data:`VEHICLES` over one day at 10 s, without and
with jitter and drops.
"""
import json
import pathlib

import numpy as np
import pytest

from graybox.simulation import Fault, FleetSpec, VehicleSpec, simulate_fleet_with_truth

VEHICLES = (
    VehicleSpec("H", seed=11),
    VehicleSpec("FR", seed=11, faults=(Fault("friction", 0.5, 0.3, ramp_days=0.1),)),
    VehicleSpec("NL", seed=12, faults=(Fault("nonlinear", 0.4, 0.3),),
                plant_parameters={"inertia": 48.0}),
    VehicleSpec("MX", seed=13, faults=(Fault("noise", 0.6, 0.5), Fault("heavy_tails", 0.7, 1.0),
                                       Fault("bias", 0.8, 2.0)),
                sensor_noise=0.2, moment_std=0.3),
)
INDEX = [0, 1, 7, 1000, 4321, 6000, 7000, 8639]
RTOL = 1e-12

REFERENCE = json.loads((pathlib.Path(__file__).parent / "data" / "simulator_reference.json")
                       .read_text())
PLAIN, JITTER = REFERENCE["plain"], REFERENCE["jitter"]


def _close(actual, expected):
    np.testing.assert_allclose(actual, expected, rtol=RTOL, atol=0)


@pytest.fixture(scope="module")
def plain():
    return simulate_fleet_with_truth(FleetSpec(VEHICLES, days=1))


@pytest.fixture(scope="module")
def jittered():
    spec = FleetSpec(VEHICLES, days=1, jitter=2.0, drop_fraction=0.05)
    return spec, simulate_fleet_with_truth(spec)[0]


@pytest.mark.parametrize("asset", sorted(PLAIN))
def test_ten_second_output_is_unchanged(plain, asset):
    telemetry, truth = plain
    frame, tr, expected = telemetry[asset], truth[asset], PLAIN[asset]
    assert len(frame) == len(tr) == 8640
    _close(tr.omega.to_numpy()[INDEX], expected["omega"])
    _close(tr.moment.to_numpy()[INDEX], expected["moment"])
    _close(frame.shaft_speed.to_numpy()[INDEX], expected["shaft_speed"])
    _close(frame.fuel_rate.to_numpy()[INDEX], expected["fuel_rate"])
    _close([frame.shaft_speed.mean(), frame.shaft_speed.std(), tr.omega.mean(), tr.omega.std(),
            frame.fuel_rate.mean()], expected["summary"])


@pytest.mark.parametrize("asset", sorted(JITTER))
def test_ten_second_output_with_jitter_and_drops_is_unchanged(jittered, asset):
    spec, telemetry = jittered
    frame, expected = telemetry[asset], JITTER[asset]
    assert len(frame) == expected["rows"]
    index = [0, 1, 7, 1000, 4321, 6000, 7000, len(frame) - 1]
    seconds = (frame.timestamp - spec.start_timestamp).dt.total_seconds().to_numpy()
    np.testing.assert_array_equal(seconds[index], expected["seconds"])
    _close(frame.shaft_speed.to_numpy()[index], expected["shaft_speed"])
    _close(frame.fuel_rate.to_numpy()[index], expected["fuel_rate"])
    _close([frame.shaft_speed.mean(), frame.shaft_speed.std(), frame.fuel_rate.mean()],
           expected["summary"])
