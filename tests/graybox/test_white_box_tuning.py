"""A baseline that asks for it fits chosen white-box parameters to its own windows first
(``FitRequest.estimate``): the tuned values come back near the truth, are recorded with the
baseline (``Signature.tuning``) and its model, and its candidates use them."""
import pandas as pd
import pytest

from graybox import FitRequest, Signature, fit_baselines, fit_signatures
from graybox.models.gas_turbine import GasTurbineShaft
from graybox.parameter_estimation import with_parameters
from tests.graybox.test_parameter_estimation import NAMES, shaft_frame


def _days(model, seeds):
    frames = []
    for day, seed in enumerate(seeds):
        frame = shaft_frame(model, seed=seed)
        frames.append(frame.set_index(frame.index + pd.Timedelta(days=day)))
    return frames


def test_a_baseline_tunes_its_white_box_and_its_candidates_use_the_tuned_values():
    truth = GasTurbineShaft()
    off = with_parameters(truth, {"turbine_gain": 1.2 * 2250.0, "compressor_linear": 0.8 * 0.5,
                                  "compressor_quadratic": 1.2 * 0.00075})
    days = _days(truth, (3, 4, 5, 6))
    [(tuned, _)] = fit_baselines([FitRequest(off, days[:3], asset_id="T-1", estimate=NAMES)])
    [(untuned, _)] = fit_baselines([FitRequest(off, days[:3], asset_id="T-1")])
    assert tuned.tuning.names == NAMES and untuned.tuning is None
    for name, value, (low, high) in zip(NAMES, tuned.tuning.values, tuned.tuning.interval()):
        assert value == pytest.approx(truth.parameters[name], rel=0.02)
        assert low < truth.parameters[name] < high
        assert tuned.model.parameters[name] == value
    # the tuned white box explains the speed: its k-step errors shrink to the noise's
    assert (tuned.channel("omega").level.residual_std
            < 0.5 * untuned.channel("omega").level.residual_std)
    assert Signature.from_json(tuned.to_json()) == tuned
    assert '"tuning"' not in untuned.to_json()
    # a candidate is fitted with its baseline's tuned values, whatever model it is given
    [candidate] = fit_signatures([FitRequest(off, [days[3]], baseline=tuned, asset_id="T-1")])
    assert dict(candidate.model.parameters) == dict(tuned.model.parameters)
    assert candidate.tuning is None


def test_a_parameter_that_cannot_be_estimated_fails_its_asset_only():
    truth = GasTurbineShaft()
    days = _days(truth, (3, 4, 5))
    bad, good = fit_baselines([FitRequest(truth, days, asset_id="T-1", estimate=("nonsense",)),
                               FitRequest(truth, days, asset_id="T-2")])
    assert "asset 'T-1'" in str(bad) and "tuning the white box's nonsense" in str(bad)
    assert "number parameters: inertia" in str(bad)
    assert isinstance(good[0], Signature)
