"""The simulator's process does not depend on the sampling interval (1 s, 10 s, 60 s)."""
import numpy as np
import pytest

from graybox.simulation.draws import draw
from graybox.simulation.plant import Plant, chunk_layout, integrate
from graybox.simulation import (MOMENT_STEP, Fault, FleetSpec, VehicleSpec, moment_steps_ratio,
                               simulate_fleet_with_truth)

VEHICLES = (
    VehicleSpec("H", seed=5),
    VehicleSpec("NL", seed=5, faults=(Fault("nonlinear", 0.3, 0.3),)),
    VehicleSpec("FR", seed=5, faults=(Fault("friction", 0.3, 0.4, ramp_days=0.1),),
                plant_parameters={"inertia": 48.0}),
)
RATES = (1.0, 10.0, 60.0)


@pytest.fixture(scope="module")
def by_rate():
    """``{dt: (telemetry, truth)}`` of :data:`VEHICLES` over one day."""
    return {dt: simulate_fleet_with_truth(FleetSpec(VEHICLES, days=1, sample_interval=dt))
            for dt in RATES}


def _common(frame, dt, every=60.0):
    """Rows of ``frame`` (sampled at ``dt``) at the instants ``k * every``."""
    return frame.iloc[::int(round(every / dt))].reset_index(drop=True)


def test_sample_interval_must_meet_the_moment_clock():
    assert MOMENT_STEP == 10.0
    for dt, ratio in ((1, (10, 1)), (2.5, (4, 1)), (5, (2, 1)), (10, (1, 1)), (20, (1, 2)),
                      (60, (1, 6)), (10 / 3, (3, 1))):
        assert moment_steps_ratio(dt) == ratio
        FleetSpec(VEHICLES[:1], days=1, sample_interval=dt)
    for dt in (7, 15, 0.3, 45.5):
        with pytest.raises(ValueError, match=r"1, 2, 2\.5, 5, 10 s.*20, 30, 60 s"):
            moment_steps_ratio(dt)
        with pytest.raises(ValueError, match="FleetSpec.sample_interval must divide"):
            FleetSpec(VEHICLES[:1], days=1, sample_interval=dt)


def test_grid_sizes(by_rate):
    for dt in RATES:
        telemetry, truth = by_rate[dt]
        assert len(telemetry["H"]) == len(truth["H"]) == 86_400 / dt
        step = np.diff(truth["H"].timestamp.to_numpy()).astype("timedelta64[ns]").astype(float)
        np.testing.assert_array_equal(step, dt * 1e9)


def test_moment_and_fuel_are_one_path_at_every_rate(by_rate):
    for asset in ("H", "NL"):
        reference = _common(by_rate[10.0][1][asset], 10.0)
        for dt in (1.0, 60.0):
            frame = _common(by_rate[dt][1][asset], dt)
            for column in ("moment", "innovation", "shock", "fuel_rate"):
                np.testing.assert_array_equal(frame[column], reference[column])
    # at 1 s the moment (and its flutter) is constant over each 10-s moment step
    fine = by_rate[1.0][1]["NL"]
    for column in ("moment", "innovation", "shock"):
        steps = fine[column].to_numpy().reshape(-1, 10)
        np.testing.assert_array_equal(steps, np.repeat(steps[:, :1], 10, axis=1))
        np.testing.assert_array_equal(steps[:, 0], by_rate[10.0][1]["NL"][column])
    # flutter acts after onset only, at the same moment steps at every rate
    u, e = fine.innovation.to_numpy()[::10], fine.shock.to_numpy()[::10]
    he3 = e[:-1] ** 3 - 3 * e[:-1]
    onset = int(0.3 * 8640)
    assert np.mean((u[1:] * he3)[onset:]) == pytest.approx(6 * 0.3, abs=0.3)


def test_true_shaft_speed_agrees_across_rates_up_to_integration_error(by_rate):
    for vehicle in VEHICLES:
        asset = vehicle.asset_id
        coarse = _common(by_rate[10.0][1][asset], 10.0).omega.to_numpy()
        fine = _common(by_rate[1.0][1][asset], 1.0).omega.to_numpy()
        slow = by_rate[60.0][1][asset].omega.to_numpy()
        # above 10 s the plant is integrated on the 10-s moment clock itself
        np.testing.assert_array_equal(slow, coarse)
        # RK4 at 2.5 s (10 s / 4 substeps) against 0.25 s: about 1e-4 rad/s, sensor noise 0.3
        np.testing.assert_allclose(fine, coarse, rtol=0, atol=5e-4)
    # and the gap is integration error: it shrinks with finer RK4 steps
    vehicle = VEHICLES[2]
    gaps = []
    for substeps in (4, 16):
        truths = [simulate_fleet_with_truth(FleetSpec((vehicle,), days=1, sample_interval=dt,
                                                      substeps=substeps))[1]["FR"]
                  for dt in (1.0, 10.0)]
        gaps.append(np.abs(_common(truths[0], 1.0).omega - _common(truths[1], 10.0).omega).max())
    assert gaps[1] < gaps[0] / 5 and gaps[1] < 3e-5


def test_sensor_noise_is_white_per_sample_at_every_rate(by_rate):
    noises = {}
    for dt in RATES:
        telemetry, truth = by_rate[dt]
        frame, tr = telemetry["H"], truth["H"]
        nu = tr.sensor_noise.to_numpy()
        np.testing.assert_allclose(frame.shaft_speed - tr.omega, nu, rtol=0, atol=1e-9)
        assert nu.std() == pytest.approx(0.3, rel=0.1 if dt == 60.0 else 0.03)
        lag1 = np.dot(nu[1:], nu[:-1]) / np.dot(nu, nu)
        assert abs(lag1) < 4 / np.sqrt(len(nu))
        assert (frame.fuel_rate - tr.fuel_rate).std() == pytest.approx(1e-4, rel=0.1)
        noises[dt] = _common(tr, dt).sensor_noise.to_numpy()
    # drawn per sample: not shared between rates
    assert abs(np.corrcoef(noises[1.0], noises[10.0])[0, 1]) < 0.1


@pytest.mark.parametrize("dt", [1.0, 60.0])
def test_jitter_and_drops_at_other_rates(dt, by_rate):
    spec = FleetSpec(VEHICLES[:1], days=1, sample_interval=dt, jitter=0.2 * dt,
                     drop_fraction=0.05)
    telemetry, truth = simulate_fleet_with_truth(spec)
    frame, tr = telemetry["H"], truth["H"]
    n = int(86_400 / dt)
    seconds = (frame.timestamp - spec.start_timestamp).dt.total_seconds().to_numpy()
    index = np.round(seconds / dt).astype(int)
    offset = seconds - index * dt
    assert np.all(np.diff(seconds) > 0)
    assert np.abs(offset).max() <= 0.4 * dt + 1e-9
    assert offset.std() == pytest.approx(0.2 * dt, rel=0.1)
    assert np.diff(index).max() <= 3
    assert 1 - len(frame) / n == pytest.approx(0.05, abs=0.01 if dt == 1.0 else 0.02)
    # the values are those of the same process at the jittered instants: compare with the
    # 1-s truth interpolated there (the same shaft speed, see the test above)
    reference = by_rate[1.0][1]["H"]
    grid = np.arange(len(reference)) * 1.0
    clean = frame.shaft_speed.to_numpy() - tr.sensor_noise.to_numpy()[index]
    assert np.abs(clean - np.interp(seconds, grid, reference.omega)).max() < 0.02
    fuel = frame.fuel_rate.to_numpy() - np.interp(seconds, grid, reference.fuel_rate)
    assert np.abs(fuel).max() < 6e-4 and fuel.std() == pytest.approx(1e-4, rel=0.1)


def test_one_second_chunks_keep_the_loop_short():
    # 6 days at 1 s: the time loop runs warm-up + chunk steps, not 518,400
    n_chunks, chunk, warmup, steps = chunk_layout(6 * 86_400, 1.0, serial=False)
    assert warmup == 1_500 and steps == warmup + chunk <= 5_000
    assert (n_chunks - 1) * chunk + steps >= 6 * 86_400 - 1


def test_one_second_chunks_match_serial_integration():
    vehicles = (VehicleSpec("A", seed=3),
                VehicleSpec("B", seed=4, faults=(Fault("friction", 0.0, 1.0),)))
    spec = FleetSpec(vehicles, days=1, sample_interval=1.0)
    draws = [draw(v, spec) for v in vehicles]
    n = 15_000  # a few chunks, and a serial run that stays short
    fuel, moment, friction = (np.stack([getattr(d, name)[:n] for d in draws], axis=1)
                              for name in ("fuel", "moment", "friction"))
    models = [v.plant() for v in vehicles]
    omega0 = np.array([m.equilibrium_speed(f) for m, f in zip(models, fuel[0])])
    chunked, mismatch = integrate(Plant(models), omega0, fuel, moment, friction, 1.0, 4)
    serial, _ = integrate(Plant(models), omega0, fuel, moment, friction, 1.0, 4, serial=True)
    assert (mismatch < 1e-9).all()
    np.testing.assert_allclose(chunked, serial, rtol=0, atol=1e-9)
