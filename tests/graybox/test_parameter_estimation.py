"""White-box parameter estimation: a shaft 20 % off comes back within 2 % and within its
intervals; the intervals count the errors' autocorrelation; the record round-trips JSON."""
import numpy as np
import pandas as pd
import pytest

from graybox import record_json
from graybox.effective_samples import effective_sample_size
from graybox.exceptions import ModelSpecError
from graybox.integration import Integration, advance
from graybox.models.gas_turbine import GasTurbineShaft
from graybox.parameter_estimation import ParameterEstimate, estimate_parameters, with_parameters

DT = 10.0
# J, a, b + c and d scale together without changing the dynamics: one of them stays fixed
NAMES = ("turbine_gain", "compressor_linear", "compressor_quadratic")


def simulate(model, u, x0, dt, process, sensor, rng):
    """The model's own trajectory (RK4, 2 sub-steps a sample) with a random push of
    ``process`` per sample and sensor noise of ``sensor``."""
    x = np.empty((len(u), len(x0)))
    x[0] = x0
    state = np.array([x0], float)
    for t in range(1, len(u)):
        state = advance(model.derivatives, state, u[t - 1:t], u[t:t + 1], dt, Integration())
        state = state + process * rng.standard_normal(state.shape)
        x[t] = state[0]
    return x + sensor * rng.standard_normal(x.shape)


def shaft_frame(model, n=2160, seed=0):
    """Six hours at 10 s: fuel steps every 10 minutes over 0.6-1.4 kg/s."""
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    fuel = np.repeat(rng.uniform(0.6, 1.4, n // 60 + 1), 60)[:n] + 0.05 * np.sin(2 * np.pi * t / 97)
    x = simulate(model, fuel[:, None], [model.equilibrium_speed(fuel[0])], DT, 1.0, 0.5, rng)
    index = pd.date_range("2026-01-01", periods=n, freq="10s", tz="UTC")
    return pd.DataFrame({"omega": x[:, 0], "fuel_rate": fuel}, index=index)


def test_a_shaft_twenty_percent_off_comes_back_within_two_percent_and_its_intervals():
    truth = GasTurbineShaft()
    frame = shaft_frame(truth)
    start = dict(zip(NAMES, (1.2 * 2250.0, 0.8 * 0.5, 1.2 * 0.00075)))
    estimate = estimate_parameters(with_parameters(truth, start), [frame], NAMES)
    assert estimate.initial == tuple(start[n] for n in NAMES) and estimate.converged
    assert estimate.positive == (True, True, True)      # the shaft's defaults are all > 0
    for name, value, (low, high) in zip(NAMES, estimate.values, estimate.interval()):
        assert value == pytest.approx(truth.parameters[name], rel=0.02)
        assert low < truth.parameters[name] < high
    # the errors are the sensor noise and the pushes accumulated over k = 12 samples
    assert estimate.horizon == 12 and estimate.error_std[0] == pytest.approx(1.3, rel=0.2)
    assert estimate.n_obs == len(frame) - 12
    # overlapping 12-step predictions: far fewer independent errors than errors
    assert estimate.effective_samples < 0.5 * estimate.n_obs


def test_operating_periods_are_segments_and_the_estimate_still_holds():
    truth = GasTurbineShaft()
    frame = shaft_frame(truth, seed=1)
    # two periods of one window (a pause between them): no prediction crosses the pause
    periods = [frame.iloc[:1000], frame.iloc[1100:]]
    estimate = estimate_parameters(truth, [periods], NAMES,
                                   initial={n: 1.2 * truth.parameters[n] for n in NAMES})
    assert estimate.n_obs == (1000 - 12) + (1060 - 12)
    for name, value, (low, high) in zip(NAMES, estimate.values, estimate.interval()):
        assert value == pytest.approx(truth.parameters[name], rel=0.02)
        assert low < truth.parameters[name] < high


def test_the_effective_sample_size_of_an_ar1_series_is_its_known_value():
    rng = np.random.default_rng(3)
    n, rho = 200_000, 0.8
    noise = rng.standard_normal(n)
    x = np.empty(n)
    x[0] = noise[0]
    for t in range(1, n):
        x[t] = rho * x[t - 1] + noise[t]
    # tau = (1 + rho) / (1 - rho) = 9 for the mean of an AR(1)
    assert effective_sample_size(x - x.mean()) == pytest.approx(n / 9, rel=0.05)
    white = rng.standard_normal(5000)
    assert effective_sample_size(white) == pytest.approx(5000, rel=0.1)


def test_the_estimate_round_trips_json_and_names_are_checked():
    estimate = ParameterEstimate(("inertia",), (51.0,), (0.5,), ((0.25,),), (60.0,),
                                 ("omega",), (1.2,), 12, 2000, 400.5, True)
    again = record_json.from_dict(ParameterEstimate, record_json.parse_json(record_json.to_json(estimate), "x"))
    assert again == estimate
    assert estimate.interval(0.95)[0] == pytest.approx((51.0 - 1.96 * 0.5, 51.0 + 1.96 * 0.5),
                                                       abs=1e-3)
    assert estimate.parameters() == {"inertia": 51.0}
    with pytest.raises(ModelSpecError, match="cannot estimate"):
        estimate_parameters(GasTurbineShaft(), [shaft_frame(GasTurbineShaft(), n=100)],
                            ["friction"])


def test_a_positive_parameters_interval_is_normal_in_its_log():
    # an inertia of 1 with a standard error of 0.8: value * exp(+- 1.96 * 0.8), never below 0;
    # a record stored before `positive` keeps the interval normal in the value
    estimate = ParameterEstimate(("inertia", "offset"), (1.0, 1.0), (0.8, 0.8),
                                 ((0.64, 0.0), (0.0, 0.64)), (1.0, 1.0), ("omega",), (1.2,), 12,
                                 2000, 400.5, True, (True, False))
    (low, high), normal = estimate.interval(0.95)
    assert (low, high) == pytest.approx((np.exp(-1.96 * 0.8), np.exp(1.96 * 0.8)), rel=1e-3)
    assert normal == pytest.approx((1.0 - 1.96 * 0.8, 1.0 + 1.96 * 0.8), rel=1e-3)
    again = record_json.from_dict(ParameterEstimate, record_json.parse_json(
        record_json.to_json(estimate), "x"))
    assert again == estimate
    stored = ParameterEstimate(*[getattr(estimate, f) for f in (
        "names", "values", "standard_errors", "covariance", "initial", "channels", "error_std",
        "horizon", "n_obs", "effective_samples", "converged")])
    assert "positive" not in record_json.to_dict(stored)
    assert stored.interval(0.95)[0] == pytest.approx(normal, rel=1e-3)
