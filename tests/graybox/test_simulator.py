"""Known-answer tests of the fleet simulator (graybox/simulation/)."""
import json
import math

import numpy as np
import pandas as pd
import pytest

from graybox.exceptions import InvalidAssetIdError, ModelSpecError
from graybox.models import GasTurbineShaft, LangevinShaft
from graybox.residual import one_step_residual
from graybox.simulation.draws import draw
from graybox.simulation.plant import Plant, integrate
from graybox.simulation import (FAULT_KINDS, Fault, FleetSpec, VehicleSpec, demo_fleet,
                               moment_ar_coefficients, simulate_fleet, simulate_fleet_with_truth,
                               simulate_langevin, white_box_parameters, write_fleet)
from graybox.telemetry import list_assets, list_dates, read_raw

DT = 10.0
DAY = 8640  # samples per day at DT
SEED = 11
ONSET = 1.0


def _residual(model, speed, fuel):
    return one_step_residual(model, np.asarray(speed)[:, None], np.asarray(fuel)[:, None], DT,
                             substeps=4)[:, 0]


def _acf(x, lag):
    x = x - x.mean()
    return float(np.dot(x[lag:], x[:-lag]) / np.dot(x, x))


@pytest.fixture(scope="module")
def counterfactual():
    """Vehicles that share one seed: each differs from "H" by one fault from day 1 on."""
    vehicles = (
        VehicleSpec("H", seed=SEED),
        VehicleSpec("FR", seed=SEED, faults=(Fault("friction", ONSET, 0.5),)),
        VehicleSpec("NL", seed=SEED, faults=(Fault("nonlinear", ONSET, 0.3),)),
        VehicleSpec("NO", seed=SEED, faults=(Fault("noise", ONSET, 1.0),)),
        VehicleSpec("BI", seed=SEED, faults=(Fault("bias", 1.5, 5.0),)),
        VehicleSpec("HT", seed=SEED, faults=(Fault("heavy_tails", ONSET, 1.0),)),
    )
    return simulate_fleet_with_truth(FleetSpec(vehicles, days=3))


# -- specs ----------------------------------------------------------------------------------------
def test_fault_validation():
    assert FAULT_KINDS == ("friction", "nonlinear", "noise", "bias", "heavy_tails")
    with pytest.raises(ValueError, match="fault kind"):
        Fault("wear", 1.0, 0.1)
    for kind, magnitude in (("friction", -1.0), ("noise", -1.5), ("heavy_tails", 0.0)):
        with pytest.raises(ValueError, match="magnitude"):
            Fault(kind, 1.0, magnitude)
    with pytest.raises(ValueError):
        Fault("bias", -1.0, 1.0)
    with pytest.raises(ValueError):
        Fault("bias", 1.0, float("nan"))
    ramp = Fault("bias", 2.0, 4.0, ramp_days=2.0)
    np.testing.assert_allclose(ramp.level(np.array([0.0, 2.0, 3.0, 4.0, 9.0])), [0, 0, 2, 4, 4])
    np.testing.assert_array_equal(Fault("bias", 2.0, 4.0).level(np.array([1.9, 2.0])), [0, 4])


def test_spec_validation():
    with pytest.raises(InvalidAssetIdError):
        VehicleSpec("bad/id", seed=1)
    with pytest.raises(ModelSpecError):
        VehicleSpec("T-1", seed=1, plant_parameters={"no_such": 1.0})
    with pytest.raises(ModelSpecError):
        VehicleSpec("T-1", seed=1, plant_parameters={"turbine_slope": -1.0})
    with pytest.raises(ValueError):
        VehicleSpec("T-1", seed=-1)
    with pytest.raises(ValueError, match="repeated"):
        FleetSpec((VehicleSpec("T-1", seed=1), VehicleSpec("T-1", seed=2)))
    with pytest.raises(ValueError):
        FleetSpec((VehicleSpec("T-1", seed=1),), drop_fraction=0.6)
    with pytest.raises(ValueError):
        FleetSpec((VehicleSpec("T-1", seed=1),), start="not a date")


def test_spec_json_round_trip():
    spec = FleetSpec(
        (VehicleSpec("T-001", seed=3, faults=(Fault("friction", 6.5, 0.5, ramp_days=1.25),
                                               Fault("bias", 7, 2))),
         VehicleSpec("T-002", seed=4, plant_parameters={"inertia": 51.3, "turbine_gain": 2249.1},
                     sensor_noise=0.25, moment_std=0.1 + 0.2)),
        days=3, start="2026-02-03T04:05:06Z", sample_interval=5, jitter=0.7, drop_fraction=0.01)
    text = json.dumps(spec.to_dict())
    back = FleetSpec.from_dict(json.loads(text))
    assert back == spec
    assert hash(back) == hash(spec)
    assert json.dumps(back.to_dict()) == text
    demo = demo_fleet()
    assert FleetSpec.from_dict(json.loads(json.dumps(demo.to_dict()))) == demo
    stamped = FleetSpec(spec.vehicles, start=pd.Timestamp("2026-03-01T06:00", tz="UTC"))
    assert stamped.start == "2026-03-01T06:00:00+00:00"
    assert stamped.start_timestamp == pd.Timestamp("2026-03-01T06:00Z")
    with pytest.raises(ValueError, match="unknown"):
        VehicleSpec.from_dict({**spec.vehicles[0].to_dict(), "colour": "red"})


def test_white_box_parameters():
    turbine = white_box_parameters(0.2)
    defaults = GasTurbineShaft.default_parameters
    for name in ("turbine_slope", "compressor_linear", "compressor_quadratic"):
        assert turbine[name] == pytest.approx(1.2 * defaults[name])
    assert turbine["inertia"] == defaults["inertia"]
    assert turbine["turbine_gain"] == defaults["turbine_gain"]
    langevin = white_box_parameters(-0.1, model="langevin")
    assert langevin["gamma"] == pytest.approx(0.9 * LangevinShaft.default_parameters["gamma"])
    assert langevin["fuel_gain"] == pytest.approx(
        0.9 * LangevinShaft.default_parameters["fuel_gain"])
    assert langevin["omega_ref"] == LangevinShaft.default_parameters["omega_ref"]
    assert white_box_parameters(0.0) == dict(defaults)
    GasTurbineShaft(turbine), LangevinShaft(langevin)  # valid models
    with pytest.raises(ValueError):
        white_box_parameters(0.1, model="pump")


def test_demo_fleet():
    spec = demo_fleet()
    assert spec == demo_fleet() and spec != demo_fleet(seed=1)
    assert [v.asset_id for v in spec.vehicles] == [f"T-{i:03d}" for i in range(1, 9)]
    assert spec.days == 10 and len({v.seed for v in spec.vehicles}) == 8
    faults = sorted((f.kind, f.magnitude) for v in spec.vehicles for f in v.faults)
    assert faults == [("friction", 0.5), ("noise", 1.0), ("nonlinear", 0.3)]
    assert all(6 <= f.onset_day <= 7 and len(v.faults) <= 1
               for v in spec.vehicles for f in v.faults)
    for v in spec.vehicles:
        for name, value in v.plant_parameters.items():
            assert abs(value / GasTurbineShaft.default_parameters[name] - 1) <= 0.03 + 1e-12
    assert sum(bool(v.faults) for v in demo_fleet(2, days=4).vehicles) == 1


# -- the healthy plant ----------------------------------------------------------------------------
def test_grid_columns_and_load_cycle():
    spec = FleetSpec((VehicleSpec("T-1", seed=5),), days=2)
    frame = simulate_fleet(spec)["T-1"]
    assert list(frame.columns) == ["timestamp", "shaft_speed", "fuel_rate"]
    assert len(frame) == 2 * DAY
    assert frame.timestamp.iloc[0] == pd.Timestamp("2026-01-01T00:00Z")
    assert str(frame.timestamp.dt.tz) == "UTC"
    assert (frame.timestamp.diff().dropna() == pd.Timedelta(seconds=10)).all()
    fuel = frame.fuel_rate.to_numpy()
    assert 0.95 < fuel.mean() < 1.05 and 0.12 < fuel.std() < 0.25  # 0.25 / sqrt(2) cycle
    assert np.diff(fuel).std() > 5e-5                              # never exactly constant
    speed = frame.shaft_speed.to_numpy()
    assert 900 < speed.mean() < 1100 and np.isfinite(speed).all()


def test_moment_std_and_ar2_poles(counterfactual):
    _, truth = counterfactual
    gamma = truth["H"].moment.to_numpy()
    assert gamma.std() == pytest.approx(0.2, rel=0.05)
    # least squares AR(2) on the simulated moment recovers the poles 0.9 exp(+-i pi/4)
    design = np.column_stack([gamma[1:-1], gamma[:-2]])
    (a1, a2), *_ = np.linalg.lstsq(design, gamma[2:], rcond=None)
    np.testing.assert_allclose((a1, a2), moment_ar_coefficients(), atol=0.01)
    poles = np.roots([1.0, -a1, -a2])
    np.testing.assert_allclose(np.abs(poles), 0.9, atol=0.01)
    np.testing.assert_allclose(np.sort(np.abs(np.angle(poles))), math.pi / 4, atol=0.02)
    innovation = truth["H"].innovation.to_numpy()
    assert abs(_acf(innovation, 1)) < 0.03 and innovation.std() == pytest.approx(1.0, rel=0.03)


def test_healthy_residual_is_the_injected_moment(counterfactual):
    telemetry, truth = counterfactual
    model = GasTurbineShaft()  # the true plant of "H"
    tr = truth["H"]
    omega, gamma, nu = tr.omega.to_numpy(), tr.moment.to_numpy(), tr.sensor_noise.to_numpy()
    rate = model.damping_rate(omega[:-1])
    decay = np.exp(-rate * DT)
    gain = (1 - decay) / rate  # response to a moment held over one sample
    # noise-free: the one-step residual is the held moment's contribution
    exact = _residual(model, omega, tr.fuel_rate)
    assert np.std(exact - gain * gamma[:-1]) < 1e-3 * np.std(exact)
    # measured: plus the sensor noise filtered by the one-step map (and the tiny fuel noise)
    frame = telemetry["H"]
    measured = _residual(model, frame.shaft_speed, frame.fuel_rate)
    expected = gain * gamma[:-1] + nu[1:] - decay * nu[:-1]
    assert np.std(measured - expected) < 0.05
    assert abs(measured.mean()) < 0.1
    # lag structure: AR(2) moment plus MA(1) noise
    a1, a2 = moment_ar_coefficients()
    rho = [1.0, a1 / (1 - a2)]
    rho += [a1 * rho[1] + a2, a1 * (a1 * rho[1] + a2) + a2 * rho[1]]
    g2, d, s2 = np.mean(gain ** 2) * 0.2 ** 2, np.mean(decay), 0.3 ** 2
    variance = g2 + (1 + d ** 2) * s2
    assert measured.std() == pytest.approx(math.sqrt(variance), rel=0.05)
    for lag in (1, 2, 3):
        theory = (g2 * rho[lag] - (d * s2 if lag == 1 else 0.0)) / variance
        assert _acf(measured, lag) == pytest.approx(theory, abs=0.04)


# -- faults ---------------------------------------------------------------------------------------
def test_friction_changes_dynamics_not_level(counterfactual):
    telemetry, truth = counterfactual
    model = GasTurbineShaft()
    after = slice(DAY + 1, None)  # residual samples whose whole interval is after onset
    before = slice(0, DAY - 1)
    tr = truth["FR"]
    omega, fuel, gamma = tr.omega.to_numpy(), tr.fuel_rate.to_numpy(), tr.moment.to_numpy()
    # known answer: damping (1 + m) gamma0 around the equilibrium of the mid-sample fuel rate
    rate = model.damping_rate(model.equilibrium_speed(fuel[:-1]))
    decay, decay_f = np.exp(-rate * DT), np.exp(-1.5 * rate * DT)
    equilibrium = model.equilibrium_speed(0.5 * (fuel[:-1] + fuel[1:]))
    gain_f = (1 - decay_f) / (1.5 * rate)
    expected = (decay_f - decay) * (omega[:-1] - equilibrium) + gain_f * gamma[:-1]
    exact = _residual(model, omega, fuel)
    assert np.std((exact - expected)[after]) < 0.05
    healthy = _residual(model, telemetry["H"].shaft_speed, telemetry["H"].fuel_rate)
    faulty = _residual(model, telemetry["FR"].shaft_speed, telemetry["FR"].fuel_rate)
    np.testing.assert_array_equal(faulty[before], healthy[before])
    # the lag structure changes; the level does not (the equilibrium does not move)
    assert _acf(faulty[after], 1) < _acf(healthy[after], 1) - 0.03
    assert _acf(faulty[after], 2) < _acf(healthy[after], 2) - 0.03
    assert abs(faulty[after].mean() - healthy[after].mean()) < 0.05
    # more damping also shrinks the response to the moment: the std drops ~17 % at m = 0.5
    assert 0.75 < faulty[after].std() / healthy[after].std() < 0.9


def test_noise_fault_scales_sensor_noise(counterfactual):
    telemetry, truth = counterfactual
    diff = telemetry["NO"].shaft_speed.to_numpy() - telemetry["H"].shaft_speed.to_numpy()
    nu = truth["H"].sensor_noise.to_numpy()
    np.testing.assert_array_equal(diff[:DAY], 0.0)
    np.testing.assert_allclose(diff[DAY:], 1.0 * nu[DAY:], atol=1e-9)
    noise = truth["NO"].sensor_noise.to_numpy()
    assert noise[:DAY].std() == pytest.approx(0.3, rel=0.05)
    assert noise[DAY:].std() == pytest.approx(0.6, rel=0.05)


def test_heavy_tails_keep_std(counterfactual):
    _, truth = counterfactual
    healthy, tails = truth["H"].sensor_noise.to_numpy(), truth["HT"].sensor_noise.to_numpy()
    np.testing.assert_array_equal(tails[:DAY], healthy[:DAY])
    after = tails[DAY:]
    assert after.std() == pytest.approx(0.3, rel=0.1)
    kurtosis = np.mean(after ** 4) / np.mean(after ** 2) ** 2
    assert kurtosis > 4.5  # Student-t df = 6: 6; Gaussian: 3


def test_bias_shifts_measured_speed_exactly_after_onset(counterfactual):
    telemetry, truth = counterfactual
    onset = int(1.5 * DAY)
    diff = telemetry["BI"].shaft_speed.to_numpy() - telemetry["H"].shaft_speed.to_numpy()
    np.testing.assert_array_equal(diff[:onset], 0.0)
    np.testing.assert_allclose(diff[onset:], 5.0, atol=1e-9)
    pd.testing.assert_series_equal(telemetry["BI"].fuel_rate, telemetry["H"].fuel_rate)
    np.testing.assert_array_equal(truth["BI"].omega, truth["H"].omega)


def test_nonlinear_fault_is_invisible_to_linear_models(counterfactual):
    _, truth = counterfactual
    tr = truth["NL"]
    u, e = tr.innovation.to_numpy(), tr.shock.to_numpy()
    he3 = e[:-1] ** 3 - 3 * e[:-1]
    before, after = slice(0, DAY - 1), slice(DAY, None)
    assert np.mean((u[1:] * he3)[before]) == pytest.approx(0.0, abs=0.15)
    assert np.mean((u[1:] * he3)[after]) == pytest.approx(6 * 0.3, abs=0.25)
    assert abs(_acf(u[DAY:], 1)) < 0.03
    assert abs(_acf(u[DAY:], 2)) < 0.03
    np.testing.assert_array_equal(tr.moment[:DAY], truth["H"].moment[:DAY])
    # not renormalised: var(u) = 1 + 6 kappa^2
    assert u[DAY:].std() == pytest.approx(math.sqrt(1 + 6 * 0.09), rel=0.05)


# -- determinism and vectorisation ----------------------------------------------------------------
def test_deterministic_and_vehicles_differ():
    spec = FleetSpec((VehicleSpec("A", seed=1), VehicleSpec("B", seed=2)), days=1)
    first, second = simulate_fleet(spec), simulate_fleet(spec)
    for asset in ("A", "B"):
        pd.testing.assert_frame_equal(first[asset], second[asset], check_exact=True)
    assert not np.allclose(first["A"].shaft_speed, first["B"].shaft_speed)


def test_fleet_equals_vehicles_simulated_alone():
    a = VehicleSpec("A", seed=21, faults=(Fault("friction", 0.5, 0.4, ramp_days=0.2),),
                    plant_parameters={"inertia": 48.0})
    b = VehicleSpec("B", seed=22, faults=(Fault("nonlinear", 0.3, 0.3),), sensor_noise=0.2)
    together = simulate_fleet(FleetSpec((a, b), days=1))
    for vehicle in (a, b):
        alone = simulate_fleet(FleetSpec((vehicle,), days=1))[vehicle.asset_id]
        pd.testing.assert_frame_equal(together[vehicle.asset_id], alone, check_exact=True)


def _integration_inputs(vehicles, days=1):
    spec = FleetSpec(tuple(vehicles), days=days)
    draws = [draw(v, spec) for v in spec.vehicles]
    models = [v.plant() for v in spec.vehicles]
    stack = [np.stack([getattr(d, name) for d in draws], axis=1)
             for name in ("fuel", "moment", "friction")]
    omega0 = np.array([m.equilibrium_speed(d.fuel[0]) for m, d in zip(models, draws)])
    return Plant(models), omega0, stack


def test_time_chunks_match_serial_integration():
    vehicles = [VehicleSpec("A", seed=3),
                VehicleSpec("B", seed=4, faults=(Fault("friction", 0.3, 1.0),))]
    plant, omega0, (fuel, moment, friction) = _integration_inputs(vehicles)
    chunked, mismatch = integrate(plant, omega0, fuel, moment, friction, DT, 4)
    serial, _ = integrate(plant, omega0, fuel, moment, friction, DT, 4, serial=True)
    assert (mismatch < 1e-9).all()
    np.testing.assert_allclose(chunked, serial, rtol=0, atol=1e-9)


def test_weakly_damped_plant_falls_back_to_serial():
    # inertia 100x: gamma ~ 0.0006 1/s, the chunk warm-up cannot forget its start
    slow = VehicleSpec("S", seed=9, plant_parameters={"inertia": 5000.0})
    plant, omega0, (fuel, moment, friction) = _integration_inputs([slow])
    _, mismatch = integrate(plant, omega0, fuel, moment, friction, DT, 4)
    assert mismatch[0] > 1e-6
    serial, _ = integrate(plant, omega0, fuel, moment, friction, DT, 4, serial=True)
    _, truth = simulate_fleet_with_truth(FleetSpec((slow,), days=1))
    np.testing.assert_array_equal(truth["S"].omega.to_numpy(), serial[:, 0])


# -- uneven sampling and gaps ---------------------------------------------------------------------
def test_jitter_and_drops():
    spec = FleetSpec((VehicleSpec("J", seed=8),), days=1, jitter=2.0, drop_fraction=0.05)
    telemetry, truth = simulate_fleet_with_truth(spec)
    frame, tr = telemetry["J"], truth["J"]
    seconds = (frame.timestamp - spec.start_timestamp).dt.total_seconds().to_numpy()
    index = np.round(seconds / DT).astype(int)
    offset = seconds - index * DT
    assert np.all(np.diff(seconds) > 0)
    assert np.abs(offset).max() <= 0.4 * DT + 1e-9 and offset.std() == pytest.approx(2.0, rel=0.1)
    assert np.diff(index).max() <= 3  # never more than 2 consecutive samples dropped
    assert 1 - len(frame) / DAY == pytest.approx(0.05, abs=0.01)
    # the values are those at the jittered instants: close to the interpolated truth
    grid = np.arange(DAY) * DT
    clean = frame.shaft_speed.to_numpy() - tr.sensor_noise.to_numpy()[index]
    assert np.abs(clean - np.interp(seconds, grid, tr.omega)).max() < 0.5
    assert np.abs(frame.fuel_rate - np.interp(seconds, grid, tr.fuel_rate)).max() < 1e-3


def test_write_fleet(tmp_path):
    vehicles = (VehicleSpec("T-001", seed=1),
                VehicleSpec("T-002", seed=2, faults=(Fault("bias", 1.0, 3.0),)))
    spec = FleetSpec(vehicles, days=2)
    frames = write_fleet(spec, tmp_path / "telemetry")
    root = tmp_path / "telemetry"
    assert list_assets(root) == ["T-001", "T-002"]
    assert [str(d) for d in list_dates(root, "T-002")] == ["2026-01-01", "2026-01-02"]
    assert (root / "asset_id=T-001" / "date=2026-01-02" / "part-0.parquet").is_file()
    truth = json.loads((root / "fleet_truth.json").read_text())
    assert FleetSpec.from_dict(truth) == spec
    raw = read_raw(root, "T-002", ["shaft_speed", "fuel_rate"])
    assert len(raw) == 2 * DAY
    np.testing.assert_allclose(raw.shaft_speed.to_numpy(), frames["T-002"].shaft_speed.to_numpy())


# -- the Langevin equation ------------------------------------------------------------------------
def test_simulate_langevin_constant_force_exact():
    n, dt, gamma, force, omega0 = 500, 0.5, 0.3, 2.0, -1.0
    omega = simulate_langevin(n, dt, gamma, np.full(n, force), omega0=omega0)
    t = np.arange(n) * dt
    exact = force / gamma + (omega0 - force / gamma) * np.exp(-gamma * t)
    np.testing.assert_allclose(omega, exact, rtol=0, atol=1e-10)
    np.testing.assert_allclose(simulate_langevin(n, dt, gamma, lambda s: force, omega0=omega0),
                               exact, rtol=0, atol=1e-10)


def test_simulate_langevin_force_forms():
    n, dt, gamma = 200, 1.0, 0.1
    t = np.arange(n) * dt
    ramp = simulate_langevin(n, dt, gamma, 0.01 * t, substeps=8)
    by_callable = simulate_langevin(n, dt, gamma, lambda s: 0.01 * s, substeps=8)
    np.testing.assert_allclose(ramp, by_callable)
    # domega/dt = -gamma omega + q t, omega(0) = 0
    q = 0.01
    exact = q * t / gamma - q / gamma ** 2 * (1 - np.exp(-gamma * t))
    np.testing.assert_allclose(ramp, exact, atol=1e-9)
    noisy = simulate_langevin(n, dt, gamma, None, seed=4)
    np.testing.assert_array_equal(noisy, simulate_langevin(n, dt, gamma, None, seed=4))
    assert not np.allclose(noisy, simulate_langevin(n, dt, gamma, None, seed=5))
    with pytest.raises(ValueError):
        simulate_langevin(n, dt, gamma, np.zeros(n + 1))


def test_plant_is_driven_by_the_models_own_derivatives():
    # without moment and fault terms the plant's drift is GasTurbineShaft.derivatives
    models = [GasTurbineShaft(), GasTurbineShaft({"inertia": 45.0})]
    plant = Plant(models)
    omega = np.array([[950.0, 1020.0], [1000.0, 990.0]])
    fuel = np.array([[1.0, 0.95], [1.05, 1.0]])
    forcing, damping = plant.forcing(fuel, np.zeros_like(fuel), np.zeros_like(fuel), False)
    drift = plant.drift(omega, fuel, forcing, damping)
    for i, model in enumerate(models):
        np.testing.assert_array_equal(
            drift[:, i], model.derivatives(omega[:, i, None], fuel[:, i, None])[:, 0])
    # the friction fault adds m * gamma(omega_eq) * (omega_eq - omega)
    friction = np.full_like(fuel, 0.3)
    forcing, damping = plant.forcing(fuel, np.zeros_like(fuel), friction, True)
    extra = plant.drift(omega, fuel, forcing, damping) - drift
    eq = np.stack([m.equilibrium_speed(fuel[:, i]) for i, m in enumerate(models)], axis=1)
    rate = np.stack([m.damping_rate(eq[:, i]) for i, m in enumerate(models)], axis=1)
    np.testing.assert_allclose(extra, 0.3 * rate * (eq - omega), rtol=1e-9)
