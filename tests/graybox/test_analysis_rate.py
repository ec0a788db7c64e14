import numpy as np
import pandas as pd
import pytest

from graybox import GrayBoxSettings, load_model
from graybox.analysis_rate import (choose_analysis_interval, decimate, decimation_factor,
                                   fastest_rate, integrates, linearised_eigenvalues)
from graybox.models.base import WhiteBoxModel
from graybox.models.linear import DriveTrain, LinearStateSpace, linear_parameters


def frame(model, n=500, dt=1.0, seed=0):
    rng = np.random.default_rng(seed)
    index = pd.date_range("2026-01-01", periods=n, freq=pd.Timedelta(seconds=dt), tz="UTC")
    columns = {c: 1000 + rng.normal(0, 50, n) for c in model.state_columns}
    columns.update({c: 1 + rng.normal(0, 0.1, n) for c in model.input_columns})
    return pd.DataFrame(columns, index=index)


def test_fastest_rate_of_a_linear_model_is_its_largest_eigenvalue():
    model = DriveTrain()
    expected = np.abs(np.linalg.eigvals(model.A)).max()
    assert fastest_rate(model, [frame(model)]) == pytest.approx(expected, rel=1e-6)


def test_gas_turbine_rate_is_its_damping_rate_at_the_operating_points():
    model = load_model("graybox.models:GasTurbineShaft")
    data = frame(model, n=64)      # every row is an operating point
    # gamma = (b + c + 2 d omega) / J is linear in omega: its 90th percentile is gamma's
    expected = np.quantile(model.damping_rate(data["omega"].to_numpy()), 0.9)
    assert fastest_rate(model, [data]) == pytest.approx(expected, rel=1e-6)


@pytest.mark.parametrize("dt, expected", [(1.0, 8.0), (2.0, 8.0), (3.0, 6.0), (10.0, 10.0),
                                          (60.0, 60.0)])
def test_analysis_interval_is_the_largest_multiple_below_half_the_time_constant(dt, expected):
    model = load_model("graybox.models:GasTurbineShaft")
    data = frame(model, dt=dt)
    data["omega"] = 1000.0         # gamma = (b + c + 2 d omega) / J = 0.06: 0.5 / gamma = 8.3 s
    assert fastest_rate(model, [data]) == pytest.approx(0.06, rel=1e-6)
    assert choose_analysis_interval(model, [data], dt) == expected


class SlowRoom(LinearStateSpace):
    """A room whose air settles in two hours: 0.5 / rate asks for an hour's blocks."""

    states = ("air",)
    inputs = ("heater",)
    default_parameters = linear_parameters(states, inputs, A=[[-1 / 7200]], B=[[1e-4]])


class TankAndHeater(WhiteBoxModel):
    """A tank's volume counted from its flows (never decays) beside a relaxing temperature."""

    states = ("volume", "temp")
    inputs = ("flow",)
    default_parameters = {"area": 2.0, "rate": 1e-3}

    def derivatives(self, x, u):
        p = self.parameters
        return np.column_stack([u[:, 0] / p["area"], -p["rate"] * (x[:, 1] - 20.0)])


def test_a_mode_that_never_decays_integrates():
    def eigenvalues(model):
        return linearised_eigenvalues(model, [frame(model)])

    assert integrates(eigenvalues(TankAndHeater()))
    assert not integrates(eigenvalues(SlowRoom()))
    assert not integrates(eigenvalues(DriveTrain()))


@pytest.mark.parametrize("dt, day, expected", [
    (60.0, 1440, 60.0),         # a day at 60 s cannot pay for any decimation: native
    (10.0, 8640, 50.0),         # 8640 // 1600 = 5 blocks of 10 s
    (1.0, 86400, 54.0),         # 86400 // 1600 = 54 s, not the dynamics' 3600 s
])
def test_a_slow_plant_keeps_the_samples_its_tiers_need(dt, day, expected):
    model = SlowRoom()
    data = frame(model, n=64, dt=dt)
    assert choose_analysis_interval(model, [data], dt) >= 3600.0 - dt   # uncapped: 24 a day
    settings = GrayBoxSettings()
    chosen = choose_analysis_interval(model, [data], dt, shortest_window=day,
                                      samples_needed=settings.samples_per_window)
    assert chosen == expected
    assert day * dt / chosen >= min(day, settings.samples_per_window)


def test_the_cap_leaves_a_fast_plant_alone():
    model = load_model("graybox.models:GasTurbineShaft")
    data = frame(model, dt=1.0)
    data["omega"] = 1000.0
    assert choose_analysis_interval(model, [data], 1.0, shortest_window=86400,
                                    samples_needed=GrayBoxSettings().samples_per_window) == 8.0


def test_block_means_and_dropped_tail():
    x = np.arange(10.0)
    np.testing.assert_array_equal(decimate(x, 3), [1.0, 4.0, 7.0])
    np.testing.assert_array_equal(decimate(x, 1), x)
    two = np.column_stack([x, -x])
    np.testing.assert_array_equal(decimate(two, 5), [[2.0, -2.0], [7.0, -7.0]])


def test_decimation_factor_must_be_whole():
    assert decimation_factor(7.0, 1.0) == 7
    with pytest.raises(ValueError, match="whole multiple"):
        decimation_factor(7.5, 2.0)


def test_time_settings_in_samples_at_every_rate():
    settings = GrayBoxSettings()
    # the defaults give today's counts at 10 s
    assert settings.max_ar_order(10.0) == 20 and settings.max_delay(10.0) == 20
    assert settings.derivative_window(10.0) == 7
    assert settings.max_ar_order(1.0) == 200 and settings.max_ar_order(60.0) == 3
    assert settings.derivative_window(1.0) == 61 and settings.derivative_window(60.0) == 5


def test_legacy_settings_load_at_the_native_rate():
    stored = GrayBoxSettings().to_dict()
    for key in ("analysis_interval", "ar_span", "delay_span", "derivative_span"):
        stored.pop(key)
    stored.update(max_ar_order=20, max_delay=20)
    loaded = GrayBoxSettings.from_dict(stored)
    assert loaded.analysis_interval == "native"
    with pytest.raises(ValueError, match="analysis_interval"):
        GrayBoxSettings(analysis_interval="fast")
