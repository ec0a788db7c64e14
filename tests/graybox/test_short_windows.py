"""Known answer: a new baseline leaves out a window that held too little operation to fit
(a calm day of a wind turbine, a machine idle most of the day) where enough others remain,
and says which (``Signature.left_out``); with too few left it fails as before, naming them."""
from __future__ import annotations

import numpy as np

import graybox as gb
from graybox.calibration import Calibration
from graybox.exceptions import InsufficientDataError, ShortWindowsError
from graybox.record_json import from_dict, to_dict
from graybox.signature import Signature
from test_units import HeatedTank, _days


def test_a_window_too_short_to_fit_is_left_out_of_a_baseline_and_named():
    days = _days(1.0, 0.0, 1.0)[:5]
    short = days[2].iloc[:40]                 # 20 minutes of the third day: too little
    windows = days[:2] + [short] + days[3:]
    [(signature, calibration)] = gb.fit_baselines(
        [gb.FitRequest(HeatedTank(), windows, asset_id="T-1", seed=0)])
    assert signature.left_out == (short.index[0].isoformat(),)
    # the baseline is the one fitted on the other four days
    [(alone, alone_calibration)] = gb.fit_baselines(
        [gb.FitRequest(HeatedTank(), days[:2] + days[3:], asset_id="T-1", seed=0)])
    assert alone.left_out is None
    assert to_dict(signature) == {**to_dict(alone), "left_out": [short.index[0].isoformat()]}
    assert calibration == alone_calibration
    assert from_dict(Signature, to_dict(signature)) == signature


def test_a_baseline_left_with_too_few_windows_fails_naming_them():
    days = _days(1.0, 0.0, 1.0)[:4]
    windows = [days[0], days[1].iloc[:40], days[2].iloc[:40], days[3]]
    [error] = gb.fit_baselines([gb.FitRequest(HeatedTank(), windows, asset_id="T-1", seed=0)])
    assert isinstance(error, ShortWindowsError)
    assert error.windows == (1, 2) and "asset 'T-1'" in str(error)


def test_a_candidate_fitted_without_its_earlier_night_that_ran_too_little():
    """A two-night candidate whose first night ran 20 minutes is the candidate of its second
    night alone, and says so; one whose own night ran too little keeps its error."""
    days = _days(1.0, 0.0, 1.0)
    [(baseline, _)] = gb.fit_baselines([gb.FitRequest(HeatedTank(), days[:4], asset_id="T-1",
                                                      seed=0)])
    short, night = days[4].iloc[:40], days[5]
    [both] = gb.fit_signatures([gb.FitRequest(HeatedTank(), [short, night], baseline=baseline,
                                              asset_id="T-1")])
    [alone] = gb.fit_signatures([gb.FitRequest(HeatedTank(), [night], baseline=baseline,
                                               asset_id="T-1")])
    assert both.left_out == (short.index[0].isoformat(),)
    assert to_dict(both) == {**to_dict(alone), "left_out": [short.index[0].isoformat()]}
    [error] = gb.fit_signatures([gb.FitRequest(HeatedTank(), [night, short], baseline=baseline,
                                               asset_id="T-1")])
    assert isinstance(error, ShortWindowsError) and error.windows == (1,)


def test_a_calibration_piece_where_the_machine_stood_still_is_left_out():
    """Six hours of one baseline day in which the tank stands still at the ambient temperature
    with the heater off (its residual constant: nothing to describe) hold no healthy change;
    the calibration uses the day's other pieces and every threshold is a number. (It failed
    the baseline with "the residual is constant", and a residual constant only to rounding
    gave a NaN threshold, refused when the baseline was promoted.)"""
    days = _days(1.0, 0.0, 1.0)[:5]
    still = days[2].copy()
    quiet = slice(len(still) // 4, len(still) // 2)
    still.iloc[quiet, still.columns.get_indexer(["temp", "ambient", "heater"])] = [15.0, 15.0, 0.0]
    windows = days[:2] + [still] + days[3:]
    [result] = gb.fit_baselines([gb.FitRequest(HeatedTank(), windows, asset_id="T-1", seed=0)])
    signature, calibration = result
    [(_, whole)] = gb.fit_baselines([gb.FitRequest(HeatedTank(), days, asset_id="T-1", seed=0)])
    assert calibration.n_windows < whole.n_windows          # the still pieces left out
    assert all(np.isfinite([t.epsilon, t.mean_zeta, t.dof]).all()
               for t in calibration.thresholds)
    assert Calibration.from_dict(calibration.to_dict()) == calibration


def test_a_night_where_the_machine_stood_still_is_an_error_naming_the_channel():
    days = _days(1.0, 0.0, 1.0)
    [(baseline, _)] = gb.fit_baselines([gb.FitRequest(HeatedTank(), days[:4], asset_id="T-1",
                                                      seed=0)])
    still = days[4].copy()
    still[["temp", "ambient", "heater"]] = [15.0, 15.0, 0.0]
    [error] = gb.fit_signatures([gb.FitRequest(HeatedTank(), [still], baseline=baseline,
                                               asset_id="T-1")])
    assert isinstance(error, InsufficientDataError)
    assert "channel 'temp'" in str(error) and "running" in str(error)
