import warnings

import numpy as np
import pytest
from scipy import stats
from scipy.signal import lfilter

from graybox.exceptions import InsufficientDataError
from graybox.noise_tier import describe_noise


def test_moments_match_scipy():
    x = np.random.default_rng(0).standard_t(6, size=5000) * 2 + 1
    noise = describe_noise(x)
    assert noise.mean == pytest.approx(x.mean())
    assert noise.variance == pytest.approx(x.var())
    assert noise.skewness == pytest.approx(stats.skew(x))
    assert noise.excess_kurtosis == pytest.approx(stats.kurtosis(x))
    assert noise.excess_kurtosis > 1  # heavy tails


def test_ljung_box_matches_statsmodels_and_flags_colour():
    from statsmodels.stats.diagnostic import acorr_ljungbox   # the test extra: must be there
    rng = np.random.default_rng(1)
    white = rng.normal(size=4000)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reference = acorr_ljungbox(white, lags=[20])
    noise = describe_noise(white, lags=20)
    assert noise.ljung_box_statistic == pytest.approx(float(reference["lb_stat"].iloc[0]))
    assert noise.ljung_box_pvalue == pytest.approx(float(reference["lb_pvalue"].iloc[0]))
    assert noise.is_white
    assert not describe_noise(lfilter([1], [1, -0.3], white)).is_white


def test_too_few_samples():
    with pytest.raises(InsufficientDataError):
        describe_noise(np.ones(5))
