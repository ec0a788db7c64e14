"""Known answers of the extended white-box contract: a hidden state, an output map with a
table and feed-through, a stiff state, a diverging model."""
from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
from scipy.signal import cont2discrete, dlsim

from graybox.integration import Integration, IntegrationError, advance, choose_integration
from graybox.models.base import WhiteBoxModel
from graybox.residual import residual_frame
from graybox.state_estimation import check_prediction, estimate_states, window_arrays

from contract_models import Armature, HiddenCharge, WrongSign

DT = 1.0


def _current(n: int, rng) -> np.ndarray:
    """A drive-like current: slow random steps and a wander, A."""
    steps = np.repeat(rng.uniform(-20, 25, n // 120 + 1), 120)[:n]
    return steps + np.cumsum(rng.normal(0, 0.3, n)) * 0.1


def _simulate_hidden(n: int, seed: int, q0: float, temp0: float):
    """The model's own trajectory (fine RK4, no process noise) and its noisy outputs."""
    model = HiddenCharge()
    rng = np.random.default_rng(seed)
    current = _current(n, rng)[:, None]
    x = np.empty((n, 2))
    x[0] = q0, temp0
    fine = Integration("rk4", 16)
    for t in range(1, n):
        x[t] = advance(model.derivatives, x[t - 1:t], current[t - 1:t], current[t:t + 1], DT,
                       fine)[0]
    clean = model.output(x, current)
    noise = np.array([0.002, 0.05])
    index = pd.date_range("2026-01-01", periods=n, freq="1s", tz="UTC")
    frame = pd.DataFrame({"voltage": clean[:, 0] + rng.normal(0, noise[0], n),
                          "temp": clean[:, 1] + rng.normal(0, noise[1], n),
                          "current": current[:, 0]}, index=index)
    return model, frame, x, noise


def test_a_hidden_state_is_estimated_and_the_output_residual_is_the_measurement_noise():
    model, frame, truth, noise = _simulate_hidden(4000, 1, q0=0.62, temp0=40.0)
    assert model.hidden_states == ("q",)
    window = estimate_states(model, *window_arrays(model, frame), DT, Integration("rosenbrock"))
    # the least-squares start over the first 15 minutes, then the model's own run
    assert window.initial_hidden["q"] == pytest.approx(0.62, abs=0.005)
    np.testing.assert_allclose(window.states[:, 0], truth[:, 0], atol=0.005)
    residual = residual_frame(model, frame, integration=Integration("rosenbrock"), window=window)
    assert list(residual.columns) == ["voltage", "temp"]
    # differenced white noise: variance 2 sigma^2 and lag-1 correlation -1/2, to the
    # precision of 4,000 samples (the standard deviation's relative error ~ 1.1 %)
    for name, sigma in zip(residual.columns, noise):
        r = residual[name].to_numpy()
        assert r.std() == pytest.approx(np.sqrt(2) * sigma, rel=0.05), name
        assert np.corrcoef(r[1:], r[:-1])[0, 1] == pytest.approx(-0.5, abs=0.05), name


def test_the_feed_through_is_what_the_residual_explains():
    # without its ohmic term, the voltage residual is dominated by r * delta current
    model, frame, _, noise = _simulate_hidden(2000, 2, q0=0.4, temp0=30.0)
    right = residual_frame(model, frame, integration=Integration("rosenbrock"))["voltage"]
    wrong = residual_frame(HiddenCharge({"r": 0.0}), frame,
                           integration=Integration("rosenbrock"))["voltage"]
    assert right.std() < 1.1 * np.sqrt(2) * noise[0] < 0.1 * wrong.std()


def test_a_table_parameter_is_overridden_and_round_trips():
    from graybox.models.spec import ModelSpec
    from graybox.models.table import Table

    model = HiddenCharge({"curve": {"breakpoints": [0, 1], "values": [3.0, 4.0]}})
    assert model.parameters["curve"] == Table((0.0, 1.0), (3.0, 4.0))
    assert float(model.output(np.array([[0.25, 20.0]]), np.array([[0.0]]))[0, 0]) == 3.25
    spec = ModelSpec.from_model(model)
    assert ModelSpec.from_dict(spec.to_dict()) == spec
    assert spec.load().parameters["curve"] == model.parameters["curve"]
    with pytest.raises(Exception, match="breakpoints must increase"):
        HiddenCharge({"curve": {"breakpoints": [1, 0], "values": [3.0, 4.0]}})
    with pytest.raises(Exception, match="is a table"):
        HiddenCharge({"curve": 3.0})


def _armature_frame(n: int, seed: int, noise=(0.5, 0.01)):
    """The armature's exact response (first-order-hold discretisation) to a random voltage."""
    model = Armature()
    a, b = model.matrices()
    discrete = cont2discrete((a, b, np.eye(2), np.zeros((2, 1))), DT, method="foh")
    rng = np.random.default_rng(seed)
    v = 100 + np.cumsum(rng.normal(0, 1.0, n))
    _, y, _ = dlsim(discrete, v[:, None], x0=[0.0, 190.0])
    index = pd.date_range("2026-01-01", periods=n, freq="1s", tz="UTC")
    return model, pd.DataFrame({"i": y[:, 0] + rng.normal(0, noise[0], n),
                                "w": y[:, 1] + rng.normal(0, noise[1], n), "v": v}, index=index)


def test_a_stiff_armature_at_1_hz_is_integrated_by_rosenbrock_to_its_sensor_noise():
    model, frame = _armature_frame(3000, 3)
    window = estimate_states(model, *window_arrays(model, frame), DT, Integration())
    change = np.sqrt(np.mean(np.diff(window.states, axis=0) ** 2, axis=0))
    chosen = choose_integration(model, window.states, window.u, DT, change)
    assert chosen.method == "rosenbrock_w"
    residual = residual_frame(model, frame, integration=chosen)
    # i relaxes within the sample (6 ms): its residual is its own noise plus the speed noise
    # through the back-EMF, k / R * 0.01 = 0.1 A. With i quasi-static the speed settles at
    # (k^2 / R + b) / J = 2.7 /s, so its prediction forgets the noise of its start (e^-2.7):
    # its residual is its own sensor noise, 0.01 rad/s
    assert residual["i"].std() == pytest.approx(np.hypot(0.5, 0.1), rel=0.06)
    assert residual["w"].std() == pytest.approx(0.01 * np.sqrt(1 + np.exp(-5.4)), rel=0.1)
    # fixed-step RK4 with 2 steps a second diverges on it, and says so
    with pytest.raises(IntegrationError, match="diverges"):
        residual_frame(model, frame, integration=Integration("rk4", 2))


def test_a_wrong_sign_fails_loudly_naming_the_model_and_the_state():
    rng = np.random.default_rng(4)
    index = pd.date_range("2026-01-01", periods=600, freq="1s", tz="UTC")
    u = 10 + rng.normal(0, 1, 600)
    frame = pd.DataFrame({"x": u + rng.normal(0, 0.1, 600), "u": u}, index=index)
    model = WrongSign()
    window = estimate_states(model, *window_arrays(model, frame), DT, Integration())
    change = np.sqrt(np.mean(np.diff(window.states, axis=0) ** 2, axis=0))
    with pytest.raises(IntegrationError, match=r"WrongSign: state 'x'.*signs"):
        choose_integration(model, window.states, window.u, DT, change)


def test_a_wrong_constant_is_a_bias_and_a_blow_up_is_divergence():
    # a quiet channel near 0.027 (range 0.002), predicted 0.212 by a level parameter tuned
    # elsewhere: 7 magnitudes off, a bias for the tiers and the estimation, not divergence
    rng = np.random.default_rng(2)
    measured = 0.027 + rng.uniform(-0.001, 0.001, (300, 1))
    check_prediction(WrongSign(), measured, np.full_like(measured, 0.212), "prediction")
    blown = np.full_like(measured, 0.212)
    blown[-5:] = 50.0                     # > 100 times the magnitude: a blow-up
    with pytest.raises(IntegrationError, match="diverges"):
        check_prediction(WrongSign(), measured, blown, "prediction")


def test_a_channel_at_zero_throughout_has_no_scale_and_only_infinity_diverges():
    # a stopped pump's flow (exactly 0) over a short operating period, predicted 2 m^3/h by
    # an interpolated pump count: no scale to call that a blow-up; an infinity still is one
    measured = np.zeros((9, 1))
    predicted = np.full_like(measured, 2.0)
    check_prediction(WrongSign(), measured, predicted, "prediction")
    predicted[-1] = np.inf
    with pytest.raises(IntegrationError, match="diverges"):
        check_prediction(WrongSign(), measured, predicted, "prediction")


def test_a_stiff_baseline_is_decomposed_with_its_own_integrator():
    # the baseline's plots run a window through the signature (graybox.decompose): with the
    # default RK4 the armature diverged there and the plots failed
    from graybox import FitRequest, decompose, fit_signatures

    model, frame = _armature_frame(3 * 3600, 5)
    days = [frame.iloc[k * 3600:(k + 1) * 3600] for k in range(3)]
    signature = fit_signatures([FitRequest(model, days, asset_id="M-1")])[0]
    assert signature.integration_used.method == "rosenbrock_w"
    parts = decompose(signature, model, days[0])
    assert [p.channel for p in parts] == ["i", "w"]
    assert all(np.isfinite(p.residual).all() for p in parts)


class RingingServo(WhiteBoxModel):
    """A valve-controlled cylinder as a user first writes it: position, velocity and chamber
    pressure (bar), the oil column a 12-Hz spring on the load barely damped, the orifice's
    flow the square root of the pressure drop (an infinite slope at zero drop)."""

    states = ("x", "v", "p")
    inputs = ("spool", "ps")
    integrator = "rosenbrock"
    default_parameters = {"area": 5e-3, "mass": 1700.0, "friction": 3600.0, "k_valve": 3e-7,
                          "stiffness": 3.9e11, "load": 30000.0}

    def derivatives(self, x, u):
        p = self.parameters
        v, pressure = x[..., 1], x[..., 2] * 1e5
        drop = u[..., 1] * 1e5 - pressure
        q = p["k_valve"] * u[..., 0] * np.sign(drop) * np.sqrt(np.abs(drop))
        force = p["area"] * pressure - p["friction"] * v - p["load"]
        return np.stack([v, force / p["mass"],
                         p["stiffness"] * (q - p["area"] * v) / 1e5], axis=-1)


def test_a_model_the_implicit_method_cannot_follow_is_told_why_not_to_declare_it():
    """At 10 Hz the servo's oil column rings 1.2 times within a sample and its orifice has an
    infinite slope where the chamber reaches the supply pressure: no sub-steps reach the
    bound. The error says the implicit method was already chosen, names the ringing mode and
    the non-smooth slope, and what to write instead (not "declare rosenbrock")."""
    rng = np.random.default_rng(0)
    n = 400
    x = np.stack([np.cumsum(rng.normal(0, 0.002, n)) + 0.3, rng.normal(0, 0.02, n),
                  60 + rng.normal(0, 30, n)], axis=1)
    x[::7, 2] = 150.0                                     # the chamber at the supply pressure
    u = np.stack([rng.uniform(-0.3, 0.3, n), np.full(n, 150.0)], axis=1)
    change = np.sqrt(np.mean(np.diff(x, axis=0) ** 2, axis=0))
    with pytest.raises(IntegrationError) as info:
        choose_integration(RingingServo(), x, u, 0.1, change)
    message = str(info.value)
    assert "RingingServo: state 'v'" in message and '"rosenbrock", chosen' in message
    assert re.search(r"rings at 12\.\d Hz \(damping ratio 0\.0\d+\), 1\.2 periods", message)
    assert "not smooth" in message and "quasi-static" in message
    assert "declares integrator" not in message


def test_a_white_box_no_integrator_follows_fails_on_its_first_segment(monkeypatch):
    """The baseline fit judges the integrator on the first segment's states before it
    estimates the others: the ringing servo's baseline of three windows stops after one."""
    import graybox.segment_cache
    import graybox.signature_fit
    from graybox.signature_fit import FitRequest, fit_signatures

    rng = np.random.default_rng(0)
    windows = []
    for day in range(3):
        n = 3000
        x = np.stack([np.cumsum(rng.normal(0, 0.002, n)) + 0.3, rng.normal(0, 0.02, n),
                      60 + rng.normal(0, 30, n)], axis=1)
        x[::7, 2] = 150.0
        index = pd.date_range(pd.Timestamp("2026-01-01", tz="UTC") + pd.Timedelta(days=day),
                              periods=n, freq="100ms")
        windows.append(pd.DataFrame({"x": x[:, 0], "v": x[:, 1], "p": x[:, 2],
                                     "spool": rng.uniform(-0.3, 0.3, n), "ps": 150.0},
                                    index=index))
    estimated = []
    for module in (graybox.signature_fit, graybox.segment_cache):
        original = module.estimate_states
        monkeypatch.setattr(module, "estimate_states",
                            lambda *args, _original=original, **kwargs:
                            estimated.append(len(args[1])) or _original(*args, **kwargs))
    [result] = fit_signatures([FitRequest(RingingServo(), windows)])
    assert isinstance(result, IntegrationError) and "cannot be integrated" in str(result)
    assert estimated == [3000]
