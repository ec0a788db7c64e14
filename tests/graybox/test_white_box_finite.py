"""Known answers: a white box that is not finite at the data's states ends the asset with an
error that says so and where (graybox.integration.check_finite_derivatives and
check_finite_prediction), instead of its samples dropping out as if the telemetry had gaps
there; a real gap (a missing input) stays a gap."""
from __future__ import annotations

import numpy as np
import pytest

import graybox as gb
from graybox.integration import Integration, IntegrationError
from graybox.models.base import WhiteBoxModel
from graybox.residual import output_residual
from graybox.state_estimation import WindowStates, predict_one_step
from test_units import BASELINE_DAYS, HeatedTank, _days


class RootTank(HeatedTank):
    """The heater's effect falls with the square root of the margin to a ``limit``: a
    white box undefined above it (its temperatures reach 14.5-51 C)."""

    default_parameters = {**HeatedTank.default_parameters, "limit": 100.0}

    def derivatives(self, x, u):
        p = self.parameters
        margin = np.sqrt((p["limit"] - x) / p["limit"])
        return p["loss"] * (u[..., :1] - x) + p["gain"] * u[..., 1:2] * margin


def test_a_baseline_of_a_white_box_undefined_at_the_data_names_it_and_the_state():
    days = _days(1.0, 0.0, 1.0)[:BASELINE_DAYS]
    [fitted] = gb.fit_baselines([gb.FitRequest(RootTank({"limit": 40.0}), days,
                                               asset_id="T-1", seed=0)])
    assert isinstance(fitted, IntegrationError)
    assert "RootTank: derivatives(x, u) is not finite at" in str(fitted)
    assert "square roots" in str(fitted)
    # defined everywhere the data goes, the same white box fits
    [(signature, _)] = gb.fit_baselines([gb.FitRequest(RootTank({"limit": 100.0}), days,
                                                       asset_id="T-1", seed=0)])
    assert signature.asset_id == "T-1"


@pytest.mark.filterwarnings("ignore:invalid value encountered in sqrt")
def test_a_prediction_missing_from_a_finite_start_is_an_error_and_a_gap_is_not():
    model = RootTank({"limit": 40.0})
    states = np.array([[20.0], [30.0], [41.0], [30.0], [25.0]])
    u = np.array([[10.0, 50.0]] * 5)
    with pytest.raises(IntegrationError, match=r"not finite at 1 of the data's states \(the "
                       r"first: states \{'temp': 41.0\}"):
        predict_one_step(model, states, u, 30.0, Integration("rk4", 2))
    # from just below the limit with the heater high, RK4's second stage (half a 600-s
    # sub-step on, about 35 K higher) lies above it: finite at the data, not within the sample
    with pytest.raises(IntegrationError, match="not finite within the sample"):
        predict_one_step(model, np.array([[38.0], [39.0]]), np.array([[40.0, 500.0]] * 2),
                         600.0, Integration("rk4", 1))
    # a missing input leaves the predictions it enters missing: a gap, no error
    fine = np.array([[20.0], [30.0], [35.0], [30.0]])
    missing = np.array([[10.0, 50.0], [np.nan, 50.0], [10.0, 50.0], [10.0, 50.0]])
    predicted = predict_one_step(model, fine, missing, 30.0, Integration("rk4", 2))
    assert np.isnan(predicted[:2]).all() and np.isfinite(predicted[2:]).all()


class LogReading(WhiteBoxModel):
    """A level (hidden) read through a logarithmic transmitter: the output map is undefined
    at a level of 0 or below."""

    states = ("level",)
    outputs = ("reading",)
    inputs = ("inflow",)

    def derivatives(self, x, u):
        return (u[..., 0] - x[..., 0]) / 10.0

    def output(self, x, u):
        return np.log(x[..., 0])


@pytest.mark.filterwarnings("ignore:invalid value encountered in log")
def test_an_output_map_undefined_at_the_states_is_an_error():
    level = np.array([[2.0], [1.5], [-0.5], [1.0], [1.2]])
    inflow = np.ones((5, 1))
    window = WindowStates(np.log(np.abs(level)), inflow, level, {})
    with pytest.raises(IntegrationError, match=r"LogReading: output\(x, u\) is not finite at "
                       r"1 of the predicted states \(the first: states \{'level': -0.5\}"):
        output_residual(LogReading(), window, 1.0, Integration("rk4", 2))
    fine = WindowStates(np.log(level[[0, 1, 3, 4]]), inflow[:4], level[[0, 1, 3, 4]], {})
    assert np.isfinite(output_residual(LogReading(), fine, 1.0, Integration("rk4", 2))).all()
